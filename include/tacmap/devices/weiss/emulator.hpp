// tacmap: an emulated Weiss tactile sensor (WTS module or DSACON32m) on a pseudo-terminal.
//
// The emulator owns the master side of a pty and speaks the protocol of
// /work/shared/reference/weiss-tactile-protocols.md on a background thread, so the real device
// classes (and the real serial_port) can be tested end-to-end without hardware. Frames come
// from a user callback (default: a blob moving along the array) and can be RLE-compressed when
// the host asks. Faults are injected on request — garbage bytes, a bad CRC, a truncated packet,
// a stall, a disconnect — to exercise the host's recovery paths.
//
// `path()` is a symlink in a private temporary folder that points at the current pty slave.
// A disconnect closes the pty and removes the link; after the down time a new pty appears
// behind the same path, the way a udev name (/dev/serial/by-id/...) survives a replug.
//
// The folder, `tacmap-weiss-XXXXXX`, is made in `emulator_options::temp_dir`, else $TMPDIR,
// else /tmp, and removed by the destructor. A process that dies without running it (SIGKILL,
// SIGTERM/SIGINT/SIGHUP with the default action, a crash) leaves the folder behind: the library
// installs no signal handlers (that would be global state, overriding the application's own).
// Instead each folder holds a `lock` file that its emulator keeps flock()ed for its lifetime;
// the kernel drops the lock when the process dies, however it dies. Every emulator, when it
// starts, removes the folders in its temp folder whose lock nobody holds
// (`remove_stale_emulator_dirs`, also callable on its own, e.g. from a signal-aware
// application's shutdown or a test fixture). Folders of live emulators — in this process or
// another, in any pid namespace — are never touched.
//
// POSIX only. Intended for tests and demos, not for production use.
#pragma once

#include <dirent.h>
#include <fcntl.h>
#include <poll.h>
#include <stdlib.h>    // posix_openpt, grantpt, unlockpt, ptsname_r, mkdtemp
#include <sys/file.h>  // flock
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "tacmap/devices/serial_port.hpp"  // device_error
#include "tacmap/devices/weiss/codec.hpp"

namespace tacmap::weiss {

/// What the render callback is asked for: the frame number and the layout. It returns
/// res_x * res_y * matrix_count counts (0..4095) in wire order (matrix after matrix).
struct render_request {
  std::uint32_t frame_index = 0;
  std::uint16_t res_x = 0;
  std::uint16_t res_y = 0;
  std::uint16_t matrix_count = 1;
};
using render_function = std::function<std::vector<std::uint16_t>(const render_request&)>;

/// The default pattern: a Gaussian blob (sigma 1.5 cells, peak 4000) moving along y, one row
/// every four frames, in row-major x-fastest order; matrix m is shifted by m rows.
inline std::vector<std::uint16_t> moving_pattern(const render_request& r) {
  std::vector<std::uint16_t> cells;
  cells.reserve(static_cast<std::size_t>(r.res_x) * r.res_y * r.matrix_count);
  const double cx = (static_cast<double>(r.res_x) - 1.0) / 2.0;
  for (std::uint32_t m = 0; m < r.matrix_count; ++m) {
    const double cy =
        static_cast<double>((r.frame_index / 4U + m) % std::max<std::uint32_t>(r.res_y, 1U));
    for (std::uint32_t y = 0; y < r.res_y; ++y)
      for (std::uint32_t x = 0; x < r.res_x; ++x) {
        const double dx = static_cast<double>(x) - cx;
        const double dy = static_cast<double>(y) - cy;
        const double v = 4000.0 * std::exp(-(dx * dx + dy * dy) / (2.0 * 1.5 * 1.5));
        cells.push_back(static_cast<std::uint16_t>(std::lround(v)));
      }
  }
  return cells;
}

/// Which outgoing packet a fault applies to: the next one of this kind.
enum class packet_kind : std::uint8_t { any, frame, reply };

/// What the `emulator` pretends to be: controller family, matrix geometry, identity replies
/// and timing, and where its frames come from (`render`).
struct emulator_options {
  protocol_family family = protocol_family::wts;
  std::uint16_t res_x = 6;   ///< columns
  std::uint16_t res_y = 14;  ///< rows
  double cell_mm = 3.4;
  std::uint16_t full_scale = 4095;
  std::uint16_t matrix_count = 1;            ///< DSACON32m only; a WTS module has one matrix
  std::string sensor_type = "WTS 0614-34A";  ///< WTS 38h
  wts_system_info system_info{0x02, 0x01, 0x1234, 20240001U};  ///< WTS 50h
  std::uint32_t serial = 20240001U;                            ///< DSACON32m controller/sensor
  std::uint16_t sw_version = 300;                              ///< DSACON32m firmware revision
  /// DSACON32m push-mode period (the controller streams at its highest rate, about 30 fps).
  std::chrono::milliseconds dsa_frame_period{33};
  /// DSACON32m power-up: the ESC[5n banner comes this long after (re)connecting (about 7 s on
  /// hardware), and commands are ignored until `ready_delay` after the banner (about 1 s).
  /// Short by default: the emulator serves tests.
  std::chrono::milliseconds powerup_delay{30};
  std::chrono::milliseconds ready_delay{20};
  /// DSACON32m firmware R288 and older keep streaming after a single-frame request.
  bool legacy_single_frame = false;
  render_function render;  ///< empty: `moving_pattern`
  /// Where the emulator's private folder is made; empty: $TMPDIR, else /tmp.
  std::string temp_dir;
};

/// The folder emulators make their private folders in: `temp_dir` if given, else $TMPDIR (when
/// set and not empty), else /tmp.
inline std::string emulator_temp_dir(const std::string& temp_dir = {}) {
  if (!temp_dir.empty()) return temp_dir;
  const char* env = std::getenv("TMPDIR");  // NOLINT(concurrency-mt-unsafe): read only
  return env != nullptr && *env != '\0' ? std::string(env) : std::string("/tmp");
}

namespace detail {
inline constexpr std::string_view emulator_dir_prefix = "tacmap-weiss-";
inline constexpr const char* emulator_lock_name = "lock";
}  // namespace detail

/// Removes the `tacmap-weiss-*` folders in `temp_dir` (see `emulator_temp_dir`) that emulators
/// of dead processes left behind, and returns how many it removed. A folder is stale when its
/// `lock` file is not flock()ed: a live emulator holds that lock, and the kernel releases it
/// when its process dies, however it dies. Folders of other users, folders whose lock is held
/// and anything that is not a folder of that name are left alone; a folder without a lock file
/// (made by an older tacmap, which had none, or an emulator between mkdtemp and taking its
/// lock) is removed only once it is older than `unlocked_grace` (an hour: an older tacmap's
/// emulator may still be running in another process, and it has no lock to show it).
inline std::size_t remove_stale_emulator_dirs(
    const std::string& temp_dir = {}, std::chrono::seconds unlocked_grace = std::chrono::hours(1)) {
  const std::string base = emulator_temp_dir(temp_dir);
  DIR* d = ::opendir(base.c_str());
  if (d == nullptr) return 0;
  std::vector<std::string> names;
  while (const dirent* e = ::readdir(d)) {
    const std::string_view name(e->d_name);
    if (name.size() > detail::emulator_dir_prefix.size() &&
        name.substr(0, detail::emulator_dir_prefix.size()) == detail::emulator_dir_prefix)
      names.emplace_back(name);
  }
  ::closedir(d);
  std::size_t removed = 0;
  for (const std::string& name : names) {
    const std::string dir = base + "/" + name;
    struct stat st {};
    if (::lstat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode) || st.st_uid != ::geteuid())
      continue;
    const std::string lock = dir + "/" + detail::emulator_lock_name;
    const int fd = ::open(lock.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
    if (fd < 0) {
      if (errno != ENOENT) continue;
      const auto age =
          std::chrono::system_clock::now() - std::chrono::system_clock::from_time_t(st.st_mtime);
      if (age < unlocked_grace) continue;
    } else {
      const bool held = ::flock(fd, LOCK_EX | LOCK_NB) != 0;
      if (held) {
        ::close(fd);
        continue;
      }
    }
    // Ours now (or lockless and old): remove what an emulator puts there, then the folder.
    for (const char* entry : {"tty", "tty.new", detail::emulator_lock_name})
      ::unlink((dir + "/" + entry).c_str());
    if (::rmdir(dir.c_str()) == 0) ++removed;
    if (fd >= 0) ::close(fd);
  }
  return removed;
}

/// What the `emulator` has done so far (`emulator::stats()`).
struct emulator_stats {
  std::uint64_t commands = 0;          ///< requests answered
  std::uint64_t ignored_commands = 0;  ///< requests dropped (power-up, stall)
  std::uint64_t frames_sent = 0;       ///< frames written (streamed or single)
  std::uint64_t rle_frames_sent = 0;
  std::uint64_t frames_overrun = 0;  ///< frames dropped because the host was not reading
  std::uint64_t faults_applied = 0;
  std::uint32_t connects = 0;  ///< pty (re)creations
};

/// An emulated WTS module or DSACON32m on a pseudo-terminal, served by a background thread, with
/// fault injection; `path()` is what a device class opens (see the file comment). POSIX only;
/// for tests and demos.
class emulator {
 public:
  using clock = std::chrono::steady_clock;

  explicit emulator(emulator_options options = {}) : options_(std::move(options)) {
    if (!options_.render) options_.render = moving_pattern;
    if (options_.res_x == 0 || options_.res_y == 0 || options_.matrix_count == 0)
      tacmap::detail::fail<std::invalid_argument>("weiss::emulator: ", options_.res_x, " x ",
                                                  options_.res_y, " cells, ", options_.matrix_count,
                                                  " matrices; expected all >= 1");
    if (options_.family == protocol_family::wts && options_.matrix_count != 1)
      tacmap::detail::fail<std::invalid_argument>(
          "weiss::emulator: a WTS module has one matrix, got matrix_count = ",
          options_.matrix_count, "; use protocol_family::dsacon32m for several");
    if (5 + 2 * cells_total() + 2 > max_wire_payload)
      tacmap::detail::fail<std::invalid_argument>("weiss::emulator: ", cells_total(),
                                                  " cells do not fit one packet");
    const std::string base = emulator_temp_dir(options_.temp_dir);
    remove_stale_emulator_dirs(base);  // folders of emulators whose process was killed
    std::string dir_template = base + "/" + std::string(detail::emulator_dir_prefix) + "XXXXXX";
    if (::mkdtemp(dir_template.data()) == nullptr)
      tacmap::detail::fail<device_error>("weiss::emulator: cannot make a folder in '", base,
                                         "': ", std::strerror(errno),
                                         "; expected a writable temp folder (TMPDIR or "
                                         "emulator_options::temp_dir)");
    dir_ = dir_template;
    link_ = dir_ + "/tty";
    lock_path_ = dir_ + "/" + detail::emulator_lock_name;
    lock_fd_ = ::open(lock_path_.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0600);
    if (lock_fd_ < 0 || ::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0) {
      const int err = errno;
      remove_dir();
      tacmap::detail::fail<device_error>("weiss::emulator: cannot lock ", lock_path_, ": ",
                                         std::strerror(err));
    }
    start_ = clock::now();
    std::array<int, 2> wake{};
    if (::pipe(wake.data()) != 0) {
      const int err = errno;
      remove_dir();
      tacmap::detail::fail<device_error>("weiss::emulator: pipe failed: ", std::strerror(err));
    }
    wake_read_ = wake[0];
    wake_write_ = wake[1];
    for (const int fd : wake) {
      ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK);
      ::fcntl(fd, F_SETFD, FD_CLOEXEC);
    }
    try {
      open_pty();
    } catch (...) {
      release_fds();
      remove_dir();
      throw;
    }
    thread_ = std::thread([this] { run(); });
  }

  emulator(const emulator&) = delete;
  emulator& operator=(const emulator&) = delete;

  ~emulator() {
    stop_.store(true);
    wake();
    if (thread_.joinable()) thread_.join();
    close_pty();
    release_fds();
    remove_dir();
  }

  /// Stable path of the emulated device (a symlink to the current pty slave).
  const std::string& path() const noexcept { return link_; }
  /// The emulator's private folder (holds `path()` and its lock file; removed by the destructor).
  const std::string& folder() const noexcept { return dir_; }
  const emulator_options& options() const noexcept { return options_; }

  /// Writes `bytes` right before the next packet of `kind`.
  void inject_garbage(std::vector<std::uint8_t> bytes, packet_kind kind = packet_kind::any) {
    add_fault({fault::type_t::garbage, kind, std::move(bytes)});
  }
  /// Sends the next packet of `kind` with a wrong CRC.
  void corrupt_crc(packet_kind kind = packet_kind::any) {
    add_fault({fault::type_t::bad_crc, kind, {}});
  }
  /// Sends only the first half of the next packet of `kind`.
  void truncate(packet_kind kind = packet_kind::any) {
    add_fault({fault::type_t::truncated, kind, {}});
  }

  /// Stops answering for `duration`: requests arriving meanwhile are dropped, nothing is sent.
  void stall(std::chrono::milliseconds duration) {
    {
      std::lock_guard lock(mutex_);
      stall_until_ = clock::now() + duration;
    }
    wake();
  }

  /// Closes the pty now (the host sees a hang-up) and brings a new one up behind `path()`
  /// after `down_time`. Like a power cycle, acquisition stops; a DSACON32m sends its banner.
  void disconnect(std::chrono::milliseconds down_time) {
    {
      std::lock_guard lock(mutex_);
      disconnect_request_ = down_time;
    }
    wake();
    // Wait (bounded) until the thread has taken the pty down, so the caller can rely on it.
    std::unique_lock lock(mutex_);
    changed_.wait_for(lock, std::chrono::seconds(2), [&] { return !disconnect_request_; });
  }

  bool streaming() const {
    std::lock_guard lock(mutex_);
    return streaming_;
  }
  /// Cells (wire order, all matrices) of the last frame sent, and how many frames were rendered.
  std::vector<std::uint16_t> last_rendered() const {
    std::lock_guard lock(mutex_);
    return last_rendered_;
  }
  emulator_stats stats() const {
    std::lock_guard lock(mutex_);
    return stats_;
  }
  /// The message of an exception that ended the emulator thread, or "" while it runs fine.
  std::string error() const {
    std::lock_guard lock(mutex_);
    return error_;
  }

  /// Waits until at least `count` frames were sent in total; false on timeout.
  bool wait_frames_sent(std::uint64_t count, std::chrono::milliseconds timeout) const {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, timeout, [&] { return stats_.frames_sent >= count; });
  }

 private:
  struct fault {
    enum class type_t : std::uint8_t { garbage, bad_crc, truncated } type;
    packet_kind kind;
    std::vector<std::uint8_t> bytes;
  };

  std::size_t cells_total() const noexcept {
    return static_cast<std::size_t>(options_.res_x) * options_.res_y * options_.matrix_count;
  }

  void add_fault(fault f) {
    {
      std::lock_guard lock(mutex_);
      faults_.push_back(std::move(f));
    }
    wake();
  }

  void wake() const noexcept {
    const std::uint8_t b = 1;
    (void)!::write(wake_write_, &b, 1);
  }

  /// The lock goes last: until the folder is gone, no other process may take it for stale.
  void remove_dir() noexcept {
    ::unlink(link_.c_str());
    if (lock_fd_ >= 0) ::unlink(lock_path_.c_str());
    ::rmdir(dir_.c_str());
    if (lock_fd_ >= 0) ::close(lock_fd_);
    lock_fd_ = -1;
  }

  void release_fds() noexcept {
    if (wake_read_ >= 0) ::close(wake_read_);
    if (wake_write_ >= 0) ::close(wake_write_);
    wake_read_ = wake_write_ = -1;
  }

  // ---- pty ----------------------------------------------------------------------------

  void open_pty() {
    const int master = ::posix_openpt(O_RDWR | O_NOCTTY);
    if (master < 0)
      tacmap::detail::fail<device_error>(
          "weiss::emulator: posix_openpt failed: ", std::strerror(errno),
          "; are pseudo-terminals available (/dev/ptmx)?");
    std::array<char, 128> name{};
    if (::grantpt(master) != 0 || ::unlockpt(master) != 0 ||
        ::ptsname_r(master, name.data(), name.size()) != 0) {
      const int err = errno;
      ::close(master);
      tacmap::detail::fail<device_error>("weiss::emulator: cannot set up the pty: ",
                                         std::strerror(err));
    }
    ::fcntl(master, F_SETFL, ::fcntl(master, F_GETFL) | O_NONBLOCK);
    ::fcntl(master, F_SETFD, FD_CLOEXEC);
    // Hold the slave open ourselves: the master then never sees a hang-up between host
    // sessions, and the line is raw from the start (a cooked line would echo our banner back).
    const int slave = ::open(name.data(), O_RDWR | O_NOCTTY | O_CLOEXEC | O_NONBLOCK);
    termios tio{};
    if (slave < 0 || ::tcgetattr(slave, &tio) != 0) {
      const int err = errno;
      if (slave >= 0) ::close(slave);
      ::close(master);
      tacmap::detail::fail<device_error>("weiss::emulator: cannot open pty slave ", name.data(),
                                         ": ", std::strerror(err));
    }
    ::cfmakeraw(&tio);
    ::tcsetattr(slave, TCSANOW, &tio);
    const std::string tmp = link_ + ".new";
    ::unlink(tmp.c_str());
    if (::symlink(name.data(), tmp.c_str()) != 0 || ::rename(tmp.c_str(), link_.c_str()) != 0) {
      const int err = errno;
      ::close(slave);
      ::close(master);
      tacmap::detail::fail<device_error>("weiss::emulator: cannot link ", link_, " -> ",
                                         name.data(), ": ", std::strerror(err));
    }
    master_ = master;
    slave_ = slave;
    parser_.reset();
    out_.clear();
    out_head_ = 0;
    const auto now = clock::now();
    if (options_.family == protocol_family::dsacon32m) {
      banner_at_ = now + options_.powerup_delay;
      ready_at_ = *banner_at_ + options_.ready_delay;
    } else {
      banner_at_.reset();
      ready_at_ = now;
    }
    std::lock_guard lock(mutex_);
    streaming_ = false;
    ++stats_.connects;
  }

  void close_pty() noexcept {
    ::unlink(link_.c_str());  // a dangling link could later name someone else's pty
    if (slave_ >= 0) ::close(slave_);
    if (master_ >= 0) ::close(master_);
    slave_ = master_ = -1;
  }

  // ---- the loop -------------------------------------------------------------------------

  void run() noexcept {
    try {
      loop();
    } catch (const std::exception& e) {
      std::lock_guard lock(mutex_);
      error_ = e.what();
    }
    changed_.notify_all();
  }

  void loop() {
    std::optional<clock::time_point> reconnect_at;
    std::array<std::uint8_t, 512> buffer{};
    while (!stop_.load()) {
      clock::time_point stall_until;
      {
        std::lock_guard lock(mutex_);
        stall_until = stall_until_;
        if (disconnect_request_) {
          close_pty();
          reconnect_at = clock::now() + *disconnect_request_;
          disconnect_request_.reset();
          streaming_ = false;
          streaming_local_ = false;
          changed_.notify_all();
        }
      }
      auto now = clock::now();
      if (master_ < 0 && reconnect_at && now >= *reconnect_at) {
        open_pty();
        reconnect_at.reset();
      }
      // Sleep until the next event: a byte, a wake-up, a frame, the banner, the end of a stall.
      clock::time_point next = now + std::chrono::milliseconds(50);
      if (reconnect_at) next = std::min(next, *reconnect_at);
      if (master_ >= 0) {
        if (streaming_local_) next = std::min(next, next_frame_at_);
        if (banner_at_) next = std::min(next, *banner_at_);
        if (now < stall_until) next = std::min(next, stall_until);
      }
      std::array<pollfd, 2> fds{};
      fds[0] = {wake_read_, POLLIN, 0};
      nfds_t count = 1;
      if (master_ >= 0) {
        const bool pending_out = out_head_ < out_.size() && now >= stall_until;
        fds[1] = {master_, static_cast<short>(POLLIN | (pending_out ? POLLOUT : 0)), 0};
        count = 2;
      }
      const int ready = ::poll(fds.data(), count, tacmap::detail::poll_timeout_ms(next - now));
      if (ready < 0 && errno != EINTR)
        tacmap::detail::fail<std::runtime_error>("weiss::emulator: poll failed: ",
                                                 std::strerror(errno));
      if ((fds[0].revents & POLLIN) != 0)
        while (::read(wake_read_, buffer.data(), buffer.size()) > 0) {
        }
      if (master_ < 0) continue;
      {
        std::lock_guard lock(mutex_);  // a stall may have been requested while we slept
        stall_until = stall_until_;
      }
      now = clock::now();
      const bool stalled = now < stall_until;
      if ((fds[1].revents & POLLIN) != 0) {
        const ssize_t n = ::read(master_, buffer.data(), buffer.size());
        if (n > 0) {
          parser_.feed(std::span(buffer).first(static_cast<std::size_t>(n)), now);
          while (auto request = parser_.pop_command()) {
            if (stalled || now < ready_at_) {
              std::lock_guard lock(mutex_);
              ++stats_.ignored_commands;
            } else {
              handle(*request);
            }
          }
          parser_.clear_frames();  // a host never sends id 00
        }
      }
      if (banner_at_ && now >= *banner_at_) {
        banner_at_.reset();
        for (int i = 0; i < 3; ++i)
          out_.insert(out_.end(), dsacon32m_banner.begin(), dsacon32m_banner.end());
      }
      if (streaming_local_ && !stalled && now >= next_frame_at_) {
        send_frame(std::nullopt);
        next_frame_at_ += period_;
        if (next_frame_at_ < now) next_frame_at_ = now + period_;  // fell behind: skip
      } else if (streaming_local_ && stalled) {
        next_frame_at_ = std::max(next_frame_at_, stall_until);
      }
      if (!stalled) flush_out();
    }
  }

  void flush_out() {
    while (out_head_ < out_.size()) {
      const ssize_t n = ::write(master_, out_.data() + out_head_, out_.size() - out_head_);
      if (n <= 0) break;  // the host is not reading: keep the rest for later
      out_head_ += static_cast<std::size_t>(n);
    }
    if (out_head_ == out_.size()) {
      out_.clear();
      out_head_ = 0;
    }
  }

  // ---- packets --------------------------------------------------------------------------

  void send(packet_kind kind, std::uint8_t id, const std::vector<std::uint8_t>& payload) {
    std::vector<std::uint8_t> wire = encode_packet(options_.family, id, payload);
    std::optional<fault> f;
    {
      std::lock_guard lock(mutex_);
      for (auto it = faults_.begin(); it != faults_.end(); ++it)
        if (it->kind == packet_kind::any || it->kind == kind) {
          f = std::move(*it);
          faults_.erase(it);
          ++stats_.faults_applied;
          break;
        }
    }
    if (f) {
      switch (f->type) {
        case fault::type_t::garbage:
          wire.insert(wire.begin(), f->bytes.begin(), f->bytes.end());
          break;
        case fault::type_t::bad_crc:
          wire.back() ^= 0x5A;
          break;
        case fault::type_t::truncated:
          wire.resize(wire.size() / 2);
          break;
      }
    }
    constexpr std::size_t max_backlog = 64 * 1024;
    if (kind == packet_kind::frame && out_.size() - out_head_ + wire.size() > max_backlog) {
      std::lock_guard lock(mutex_);
      ++stats_.frames_overrun;
      return;
    }
    out_.insert(out_.end(), wire.begin(), wire.end());
  }

  std::vector<std::uint8_t> reply_status(status s) const {
    std::vector<std::uint8_t> out;
    detail::put_u16(out, status_to_wire(options_.family, s));
    return out;
  }

  void reply(std::uint8_t id, status s, const std::vector<std::uint8_t>& data = {}) {
    std::vector<std::uint8_t> payload = reply_status(s);
    payload.insert(payload.end(), data.begin(), data.end());
    send(packet_kind::reply, id, payload);
  }

  /// Renders the next frame; its payload goes out as a streamed frame (id 00), or as the data
  /// of a reply when `reply_id` is set (WTS 20h).
  void send_frame(std::optional<std::uint8_t> reply_id) {
    render_request request{frame_index_++, options_.res_x, options_.res_y, options_.matrix_count};
    std::vector<std::uint16_t> cells = options_.render(request);
    if (cells.size() != cells_total())
      tacmap::detail::fail<std::invalid_argument>(
          "weiss::emulator: render returned ", cells.size(), " cells for frame ",
          request.frame_index, "; expected res_x * res_y * matrix_count = ", cells_total());
    const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(clock::now() - start_);
    const std::vector<std::uint8_t> data =
        encode_frame_payload(static_cast<std::uint32_t>(ms.count()), cells, rle_);
    if (reply_id)
      reply(*reply_id, status::success, data);
    else
      send(packet_kind::frame, frame_id, data);
    {
      std::lock_guard lock(mutex_);
      last_rendered_ = std::move(cells);
      ++stats_.frames_sent;
      if (rle_) ++stats_.rle_frames_sent;
    }
    changed_.notify_all();
  }

  void set_streaming(bool on, std::chrono::milliseconds period) {
    streaming_local_ = on;
    period_ = std::max(period, std::chrono::milliseconds(1));
    next_frame_at_ = clock::now() + period_;
    std::lock_guard lock(mutex_);
    streaming_ = on;
  }

  void handle(const packet& request) {
    {
      std::lock_guard lock(mutex_);
      ++stats_.commands;
    }
    if (options_.family == protocol_family::wts)
      handle_wts(request);
    else
      handle_dsacon32m(request);
  }

  void handle_wts(const packet& r) {
    const auto& p = r.payload;
    const auto no_params = [&] {
      if (p.empty()) return true;
      reply(r.id, status::no_param_expected);
      return false;
    };
    switch (r.id) {
      case wts_command::loop: {
        reply(r.id, status::success, p);
        return;
      }
      case wts_command::read_single_frame:
        if (p.size() != 1) return reply(r.id, status::cmd_format_error);
        if (streaming_local_) return reply(r.id, status::already_running);
        rle_ = (p[0] & frame_flag_rle) != 0;
        return send_frame(r.id);
      case wts_command::start_periodic: {
        if (p.size() != 3) return reply(r.id, status::cmd_format_error);
        if (streaming_local_) return reply(r.id, status::already_running);
        const std::uint16_t period = detail::get_u16(p.data() + 1);
        if (period == 0) return reply(r.id, status::invalid_parameter);
        rle_ = (p[0] & frame_flag_rle) != 0;
        reply(r.id, status::success);
        return set_streaming(true, std::chrono::milliseconds(period));
      }
      case wts_command::stop_periodic:
        if (!no_params()) return;
        set_streaming(false, period_);
        return reply(r.id, status::success);
      case wts_command::matrix_info:
        if (!no_params()) return;
        return reply(
            r.id, status::success,
            encode_wts_matrix_info({options_.res_x, options_.res_y, options_.cell_mm,
                                    options_.cell_mm, static_cast<double>(options_.full_scale)}));
      case wts_command::sensor_type:
        if (!no_params()) return;
        return reply(
            r.id, status::success,
            std::vector<std::uint8_t>(options_.sensor_type.begin(), options_.sensor_type.end()));
      case wts_command::system_info:
        if (!no_params()) return;
        return reply(r.id, status::success, encode_wts_system_info(options_.system_info));
      default:
        return reply(r.id, status::cmd_unknown);
    }
  }

  void handle_dsacon32m(const packet& r) {
    const auto& p = r.payload;
    switch (r.id) {
      case dsacon32m_command::loop:  // echo only (whether a status word leads is unconfirmed)
        return send(packet_kind::reply, r.id, p);
      case dsacon32m_command::controller_info: {
        dsacon32m_controller_info c;
        c.serial = options_.serial;
        c.hw_version = 1;
        c.sw_version = options_.sw_version;
        c.status_flags = static_cast<std::uint8_t>(0x80U | (streaming_local_ ? 0x40U : 0U));
        c.can_baudrate = 1000000;
        std::vector<std::uint8_t> data = encode_dsacon32m_controller_info(c);
        data.push_back(0x00);  // firmware sends 18 bytes: one byte of can_id
        return reply(r.id, status::success, data);
      }
      case dsacon32m_command::sensor_info:
        return reply(
            r.id, status::success,
            encode_dsacon32m_sensor_info({options_.matrix_count, 0, 1, options_.serial + 1U, 0}));
      case dsacon32m_command::matrix_info: {
        if (p.size() != 1) return reply(r.id, status::cmd_format_error);
        if (p[0] >= options_.matrix_count) return reply(r.id, status::index_out_of_bounds);
        dsacon32m_matrix_info m;
        m.matrix = {options_.res_x, options_.res_y, options_.cell_mm, options_.cell_mm, 0.0};
        m.uid = {0x10, 0x20, 0x30, 0x40, 0x50, p[0]};
        m.hw_revision = 2;
        m.full_scale_raw = options_.full_scale;
        return reply(r.id, status::success, encode_dsacon32m_matrix_info(m));
      }
      case dsacon32m_command::configure_acquisition: {
        if (p.size() != 3) return reply(r.id, status::cmd_format_error);
        const bool enable = (p[0] & dsacon32m_command::flag_enable) != 0;
        const std::uint16_t rate = detail::get_u16(p.data() + 1);
        rle_ = (p[0] & dsacon32m_command::flag_rle) != 0;
        reply(r.id, status::success);
        if (!enable) return set_streaming(false, options_.dsa_frame_period);
        if (rate > 0) return set_streaming(true, options_.dsa_frame_period);
        send_frame(std::nullopt);  // single frame, pushed as id 00 after the ack
        if (options_.legacy_single_frame) set_streaming(true, options_.dsa_frame_period);
        return;
      }
      default:
        return reply(r.id, status::cmd_unknown);
    }
  }

  emulator_options options_;
  std::string dir_;
  std::string link_;
  std::string lock_path_;
  int lock_fd_ = -1;
  clock::time_point start_;
  int master_ = -1;
  int slave_ = -1;
  int wake_read_ = -1;
  int wake_write_ = -1;
  std::thread thread_;
  std::atomic<bool> stop_{false};

  // Owned by the emulator thread.
  packet_parser parser_{options_.family};
  std::vector<std::uint8_t> out_;
  std::size_t out_head_ = 0;
  std::optional<clock::time_point> banner_at_;
  clock::time_point ready_at_{};
  bool streaming_local_ = false;
  bool rle_ = false;
  std::chrono::milliseconds period_{50};
  clock::time_point next_frame_at_{};
  std::uint32_t frame_index_ = 0;

  // Shared with the API, under mutex_.
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  std::deque<fault> faults_;
  clock::time_point stall_until_{};
  std::optional<std::chrono::milliseconds> disconnect_request_;
  bool streaming_ = false;
  std::vector<std::uint16_t> last_rendered_;
  emulator_stats stats_;
  std::string error_;
};

}  // namespace tacmap::weiss
