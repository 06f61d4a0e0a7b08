// tacmap: what the two Weiss device classes share — one serial transport, one packet parser,
// command/reply matching with timeouts, frame queueing and decoding into `tactile_frame`s, and
// reconnection. `wts_device` and `dsacon32m_device` are thin protocol layers on top.
//
// Replies and streamed frames share the line: a reply may arrive after frames (DSACON32m push
// mode, WTS periodic mode), so every wait routes id 00 into the parser's bounded frame queue and
// hands other ids to the pending command. Every wait has a deadline; nothing here can hang.
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "tacmap/devices/serial_port.hpp"
#include "tacmap/devices/weiss/codec.hpp"
#include "tacmap/tactile/frame.hpp"

namespace tacmap::weiss {

/// Options of both device classes. Defaults suit real hardware; tests shorten the timeouts.
struct device_options {
  unsigned baud = 115200;
  std::chrono::milliseconds command_timeout{1000};  ///< wait for each command's reply
  /// A packet still incomplete after this much silence on the line is abandoned (a truncated
  /// packet, or garbage that looked like a header), so that what follows is not held back.
  /// At 115200 baud a 179-byte frame takes 16 ms.
  std::chrono::milliseconds idle_flush{50};
  cell_order order = cell_order::x_fastest;  ///< row-major x fastest is inferred for the WTS
  bool rle = false;                          ///< ask the device for RLE-compressed frames
  parser_limits limits{};
  // DSACON32m only.
  std::chrono::milliseconds powerup_timeout{10000};  ///< ~8 s after power-on until ready
  std::chrono::milliseconds powerup_retry{500};      ///< "stop acquisition" resend interval
  std::chrono::milliseconds powerup_settle{100};     ///< drain time before flushing input
  std::uint16_t matrix_index = 0;                    ///< which matrix frames are taken from
  bool stop_after_single_frame = true;               ///< firmware <= R288 keeps streaming otherwise
};

/// Counters of one device object (kept across reconnects).
struct device_stats {
  parser_stats link;                     ///< bytes, packets, garbage, bad CRCs, ...
  std::uint64_t frames_delivered = 0;    ///< frames handed out (sequence numbers used)
  std::uint64_t corrupt_frames = 0;      ///< frames with a good CRC that did not decode
  std::uint64_t frames_discarded = 0;    ///< stale frames dropped when acquisition (re)starts
  std::uint64_t unexpected_replies = 0;  ///< replies nobody waited for (late, after a timeout)
  std::uint64_t reconnects = 0;
  std::string last_corrupt_frame;  ///< why the last corrupt frame was rejected
};

namespace detail {

/// "30h" for messages, in the notation of the Weiss manuals.
inline std::string hex_id(std::uint8_t id) {
  constexpr std::string_view digits = "0123456789ABCDEF";
  return {digits[id >> 4U], digits[id & 0xFU], 'h'};
}

/// The shared core. Not thread-safe: use a device from one thread at a time.
class device_base {
 public:
  using clock = std::chrono::steady_clock;

  device_base(const device_base&) = delete;
  device_base& operator=(const device_base&) = delete;
  device_base(device_base&&) = default;
  device_base& operator=(device_base&&) = default;
  virtual ~device_base() = default;

  const std::string& path() const noexcept { return path_; }
  protocol_family family() const noexcept { return family_; }
  const device_options& options() const noexcept { return options_; }
  bool is_connected() const noexcept { return port_.is_open(); }
  bool is_streaming() const noexcept { return streaming_; }

  /// Geometry of the matrix frames are taken from, as the device reported it.
  const taxel_geometry& geometry() const noexcept { return geometry_; }
  const matrix_info& matrix() const noexcept { return matrices_.at(selected_); }

  /// The device's own timestamp of the last frame delivered (ms on the DSACON32m; unconfirmed
  /// unit on the WTS).
  std::uint32_t last_device_timestamp() const noexcept { return last_device_timestamp_; }

  device_stats stats() const {
    device_stats s = stats_;
    s.link = parser_.stats();
    return s;
  }

  /// The next streamed frame, waiting at most `timeout`. Frames with a good CRC that do not
  /// decode are skipped and counted. Throws device_error on timeout or disconnect.
  tactile_frame next_frame(std::chrono::milliseconds timeout) {
    return await_frame(clock::now() + timeout, "the next frame");
  }

  /// Closes the port (a later reconnect() reopens it).
  void close() noexcept { port_.close(); }

  /// Reopens the port — retrying for up to `timeout` while the device is away (unplugged,
  /// rebooting) — queries the geometry again, and restarts periodic acquisition if it was
  /// running. Frames received before are dropped; sequence numbers continue.
  void reconnect(std::chrono::milliseconds timeout = std::chrono::milliseconds(5000)) {
    const bool was_streaming = streaming_;
    port_.close();
    parser_.reset();
    open_port(timeout);
    ++stats_.reconnects;
    streaming_ = false;
    initialize();
    if (was_streaming) resume_streaming();
  }

 protected:
  device_base(std::string path, device_options options, protocol_family family)
      : path_(std::move(path)),
        options_(options),
        family_(family),
        parser_(family, options.limits) {
    if (options_.command_timeout <= std::chrono::milliseconds(0) ||
        options_.idle_flush <= std::chrono::milliseconds(0))
      tacmap::detail::fail<std::invalid_argument>(
          family_name(family_), " device: command_timeout = ", options_.command_timeout.count(),
          " ms, idle_flush = ", options_.idle_flush.count(), " ms; expected both > 0");
  }

  /// Protocol-specific set-up after the port opened: stop stray acquisition, read geometry.
  virtual void initialize() = 0;
  /// Restart periodic acquisition with the last parameters (after a reconnect).
  virtual void resume_streaming() = 0;

  /// Opens the port, retrying until `timeout` (a single attempt when it is 0).
  void open_port(std::chrono::milliseconds timeout) {
    const auto deadline = clock::now() + timeout;
    for (;;) {
      try {
        port_ = serial_port(path_, options_.baud);
        last_rx_ = clock::now();
        return;
      } catch (const device_error& e) {
        if (clock::now() >= deadline) {
          if (timeout.count() == 0) throw;
          tacmap::detail::fail<device_error>(e.what(), " (still failing after retrying for ",
                                             timeout.count(), " ms)");
        }
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }

  void send(std::uint8_t id, std::span<const std::uint8_t> payload) {
    require_connected();
    port_.write_all(encode_packet(family_, id, payload), options_.command_timeout);
  }

  /// Sends a command and returns its reply payload. Stale replies (late answers to commands
  /// that timed out) are dropped first; frames arriving meanwhile stay queued.
  std::vector<std::uint8_t> command(std::uint8_t id, std::span<const std::uint8_t> payload,
                                    std::string_view what) {
    while (parser_.pop_command()) ++stats_.unexpected_replies;
    send(id, payload);
    auto reply = await_reply(id, clock::now() + options_.command_timeout);
    if (!reply)
      tacmap::detail::fail<device_error>(
          family_name(family_), " at ", path_, ": no reply to ", what, " (", hex_id(id),
          ") within ", options_.command_timeout.count(),
          " ms. Check that the device is powered and connected, that it is a ",
          family_name(family_),
          " (the other Weiss family frames replies differently), and "
          "that nothing else uses the port");
    return std::move(reply->payload);
  }

  /// The data after a reply's status word; throws device_error naming the status unless it is
  /// E_SUCCESS.
  std::vector<std::uint8_t> checked(std::vector<std::uint8_t> reply, std::string_view what) {
    const status_reply s = decode(what, [&] { return split_status(reply, what); });
    if (s.code != 0)
      tacmap::detail::fail<device_error>(family_name(family_), " at ", path_, " refused ", what,
                                         ": ", describe_status(family_, s.code));
    return {s.data.begin(), s.data.end()};
  }

  /// Runs a codec function, turning its protocol_error into a device_error naming the port.
  template <class F>
  auto decode(std::string_view what, F&& f) -> decltype(f()) {
    try {
      return f();
    } catch (const protocol_error& e) {
      tacmap::detail::fail<device_error>(family_name(family_), " at ", path_, ": ", what, ": ",
                                         e.what());
    }
  }

  /// Waits for the reply with `id` until `deadline`; other replies are counted and dropped.
  std::optional<packet> await_reply(std::uint8_t id, clock::time_point deadline) {
    for (;;) {
      while (auto p = parser_.pop_command()) {
        if (p->id == id) return p;
        ++stats_.unexpected_replies;
      }
      if (clock::now() >= deadline) return std::nullopt;
      pump(deadline);
    }
  }

  /// The next decodable frame (id 00) until `deadline`; throws device_error on timeout.
  tactile_frame await_frame(clock::time_point deadline, std::string_view what,
                            std::string_view silence_hint = {}) {
    const std::uint64_t corrupt_before = stats_.corrupt_frames;
    const auto start = clock::now();
    for (;;) {
      while (auto p = parser_.pop_frame())
        if (auto f = to_frame(p->payload, p->received)) return std::move(*f);
      if (clock::now() >= deadline) break;
      pump(deadline);
    }
    const auto waited = std::chrono::duration_cast<std::chrono::milliseconds>(clock::now() - start);
    std::string hint =
        !silence_hint.empty() ? "; " + std::string(silence_hint)
        : streaming_ ? "; the device stopped streaming — check the cable and power, or reconnect()"
                     : "; periodic acquisition is not running — call start_periodic() first";
    if (stats_.corrupt_frames > corrupt_before)
      hint += "; " + std::to_string(stats_.corrupt_frames - corrupt_before) +
              " corrupt frame(s) were rejected meanwhile, the last because: " +
              stats_.last_corrupt_frame;
    tacmap::detail::fail<device_error>(family_name(family_), " at ", path_, ": no ", what,
                                       " within ", waited.count(), " ms", hint);
  }

  /// Decodes a frame payload into a tactile_frame; a corrupt one is counted and gives nullopt.
  std::optional<tactile_frame> to_frame(std::span<const std::uint8_t> payload,
                                        clock::time_point received) {
    try {
      const frame_payload fp = decode_frame_payload(payload, total_cells_);
      tactile_frame f = make_tactile_frame(fp, matrix(), options_.order, offset_);
      f.timestamp = received;
      f.sequence = sequence_++;
      last_device_timestamp_ = fp.timestamp;
      ++stats_.frames_delivered;
      return f;
    } catch (const protocol_error& e) {
      ++stats_.corrupt_frames;
      stats_.last_corrupt_frame = e.what();
      return std::nullopt;
    }
  }

  /// Reads once (bounded by `deadline`) and feeds the parser. A packet left incomplete for
  /// `idle_flush` of silence is abandoned so that it cannot hold back what follows.
  void pump(clock::time_point deadline) {
    require_connected();
    auto now = clock::now();
    auto wait = deadline - now;
    if (parser_.buffered() > 0)
      wait = std::min<clock::duration>(
          wait,
          std::max<clock::duration>(last_rx_ + options_.idle_flush - now, clock::duration::zero()));
    const auto ms = std::max<std::chrono::milliseconds>(
        std::chrono::ceil<std::chrono::milliseconds>(wait), std::chrono::milliseconds(0));
    const std::size_t n = port_.read_some(buffer_, ms);  // throws on hang-up
    now = clock::now();
    if (n > 0) {
      last_rx_ = now;
      parser_.feed(std::span(buffer_).first(n), now);
    } else if (parser_.buffered() > 0 && now - last_rx_ >= options_.idle_flush) {
      parser_.flush_partial(now);
    }
  }

  /// Reads and parses for `duration`, then drops everything received (stale replies, frames).
  void drain_for(std::chrono::milliseconds duration) {
    const auto deadline = clock::now() + duration;
    while (clock::now() < deadline) pump(deadline);
    discard_frames();
    while (parser_.pop_command()) {
    }
  }

  /// Drops queued frames (stale ones, before acquisition starts), counting them.
  void discard_frames() noexcept {
    stats_.frames_discarded += parser_.queued_frames();
    parser_.clear_frames();
  }

  /// Installs the matrices the device reported and selects the one frames are taken from.
  void set_matrices(std::vector<matrix_info> matrices, std::size_t selected) {
    if (selected >= matrices.size())
      tacmap::detail::fail<device_error>(
          family_name(family_), " at ", path_, ": matrix_index = ", selected,
          " but the sensor "
          "reports ",
          matrices.size(), " matri", matrices.size() == 1 ? "x" : "ces",
          "; choose an index below that");
    geometry_ = decode("matrix information", [&] { return matrices[selected].geometry(); });
    total_cells_ = 0;
    offset_ = 0;
    for (std::size_t i = 0; i < matrices.size(); ++i) {
      if (i == selected) offset_ = total_cells_;
      total_cells_ += matrices[i].cell_count();
    }
    const std::size_t frame_bytes = frame_header_size + 2 * total_cells_ + 2;
    if (frame_bytes > parser_.limits().max_payload)
      tacmap::detail::fail<device_error>(
          family_name(family_), " at ", path_, ": a frame of ", total_cells_, " cells needs ",
          frame_bytes, " payload bytes but limits.max_payload is ", parser_.limits().max_payload,
          "; raise device_options::limits.max_payload");
    matrices_ = std::move(matrices);
    selected_ = selected;
  }

  void require_connected() const {
    if (!port_.is_open())
      tacmap::detail::fail<device_error>(family_name(family_), " at ", path_,
                                         ": not connected (the device went away or was "
                                         "closed); call reconnect()");
  }

  std::string path_;
  device_options options_;
  protocol_family family_;
  serial_port port_;
  packet_parser parser_;
  std::array<std::uint8_t, 1024> buffer_{};
  clock::time_point last_rx_{};
  bool streaming_ = false;
  std::vector<matrix_info> matrices_{matrix_info{}};
  std::size_t selected_ = 0;
  std::size_t total_cells_ = 0;
  std::size_t offset_ = 0;
  taxel_geometry geometry_{};
  std::uint32_t sequence_ = 0;
  std::uint32_t last_device_timestamp_ = 0;
  device_stats stats_;
};

}  // namespace detail
}  // namespace tacmap::weiss
