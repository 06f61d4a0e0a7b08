// tacmap: session logs — record a touch session (tactile frames and sensor poses) as it happens,
// replay it later through the same filter, or open it in Python or MATLAB without tacmap.
//
// Format "tacmap-session", version 1 (also in io/SESSION_FORMAT.md, with a Python reader):
//
//   tacmap-session 1
//   geometry 14 6 3.4
//   map gecko.pgm
//   mm_per_px 1.1333333333333333
//   calibration 1 0 0 0 0 1 0 0 0 1
//   frame 1718000000000000 0 0 12 4095 ... (rows x cols values, row-major)
//   pose 1718000000500000 12.5 -3.25 40 0.01
//
// * UTF-8 text, one item per line, each line ended by "\n" (a "\r" before it is tolerated).
//   Fields are separated by spaces or tabs. No blank lines, no comments.
// * Line 1 is "tacmap-session <version>". A reader refuses versions it does not know.
// * Header lines follow, "<key> <value>", each key at most once, all before the first record.
//   Keys are lower-case letters, digits and "_". Known keys:
//     geometry <rows> <cols> <pitch_mm>   the taxel layout of every frame (required for frames)
//     map <file name>                     the visual map, relative to the log's folder (the rest
//                                         of the line: spaces allowed)
//     mm_per_px <scale>                   the map's scale, mm per map pixel
//     calibration <ux> <uy> <uz> <vx> <vy> <vz> <rotation_rad> <tx_mm> <ty_mm> <scale>
//                                         device frame -> map frame: map = t + scale R(rotation)
//                                         [u.p; v.p] (devices/position_source.hpp)
//   Other keys are kept as free text (a reader ignores keys it does not know).
// * Records, in the order they were recorded (not necessarily sorted by time):
//     frame <t_ns> <seq> <v_1> ... <v_n>   a tactile frame: n = rows x cols raw counts, row by
//                                          row (finite, >= 0); seq = the source's frame number
//     pose <t_ns> <x_mm> <y_mm> <z_mm> <yaw_rad>   the sensor centre in the device frame
//   t_ns: integer nanoseconds of the recording machine's steady clock (an arbitrary epoch: only
//   differences mean something, and frames and poses share the clock); |t_ns| <= 2^62.
// * Numbers are decimal (as C, Python and MATLAB print them); never NaN or infinity.
// * Every record is written and flushed as one line, so after a crash the file holds every record
//   written before it, and at most the last line is cut off (then it lacks its "\n").
//
// Errors: a log that breaks these rules throws `session_log_error` naming the file, the line, the
// field, the offending text and what was expected.
#pragma once

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <istream>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "tacmap/devices/position_source.hpp"
#include "tacmap/image.hpp"
#include "tacmap/tactile/frame.hpp"

#if defined(__unix__) || defined(__APPLE__)
#include <unistd.h>  // fsync
#endif

namespace tacmap {

/// The session format version this tacmap writes and reads.
inline constexpr int session_format_version = 1;

/// A session log could not be read or written: the message names the file, the line (1-based)
/// and the field, what was found and what was expected. `line()` is 0 when the problem is not
/// about one line (the file cannot be opened, a write failed).
class session_log_error : public std::runtime_error {
 public:
  session_log_error(const std::string& message, std::uint64_t line, std::string field)
      : std::runtime_error(message), line_(line), field_(std::move(field)) {}
  [[nodiscard]] std::uint64_t line() const noexcept { return line_; }
  [[nodiscard]] const std::string& field() const noexcept { return field_; }

 private:
  std::uint64_t line_;
  std::string field_;
};

/// The header of a session: what a reader needs to interpret the records.
struct session_header {
  int version = session_format_version;    ///< as read; a recorder always writes the current one
  std::optional<taxel_geometry> geometry;  ///< required once the log holds frames
  std::string map_file;                    ///< the map image, relative to the log's folder
  std::optional<double> mm_per_px;         ///< the map's scale
  std::optional<map_calibration> calibration;              ///< device frame -> map frame
  std::vector<std::pair<std::string, std::string>> extra;  ///< other keys, in file order

  /// The value of an extra key, if present.
  [[nodiscard]] std::optional<std::string> value(std::string_view key) const {
    for (const auto& [k, v] : extra)
      if (k == key) return v;
    return std::nullopt;
  }
  friend bool operator==(const session_header&, const session_header&) = default;
};

/// One record of a session.
using session_record = std::variant<tactile_frame, sensor_pose>;

namespace detail {

inline constexpr std::string_view session_magic = "tacmap-session";
/// Taxels a frame may have: generous for tactile arrays, and it bounds what a corrupt header
/// can make a reader allocate.
inline constexpr Eigen::Index session_max_taxels = 65536;
/// The largest |t_ns| a log may hold: 2^62 ns, 146 years of a steady clock's uptime. Anything
/// beyond is a corrupt or unset timestamp, and within it any two timestamps differ by less than
/// 2^63 ns, so their difference never overflows the clock's signed 64-bit count.
inline constexpr std::int64_t session_max_abs_t_ns = std::int64_t{1} << 62;

/// Keys the format itself defines (not available as extra keys).
inline bool session_reserved_key(std::string_view key) {
  return key == "frame" || key == "pose" || key == "geometry" || key == "map" ||
         key == "mm_per_px" || key == "calibration";
}

inline bool session_key_syntax(std::string_view key) {
  if (key.empty()) return false;
  for (const char c : key)
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) return false;
  return true;
}

inline bool session_space(char c) { return c == ' ' || c == '\t'; }

/// Header values: no control characters but tab, no spaces at either end (readers trim).
inline bool session_value_syntax(std::string_view value) {
  for (const char c : value)
    if (static_cast<unsigned char>(c) < 0x20 && c != '\t') return false;
  return value.empty() || (!session_space(value.front()) && !session_space(value.back()));
}

/// Up to 40 bytes of `text` for a message, quoted, with control bytes escaped.
inline std::string session_quote(std::string_view text) {
  std::string out = "'";
  const std::size_t shown = std::min<std::size_t>(text.size(), 40);
  for (std::size_t i = 0; i < shown; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c < 0x20 || c == 0x7F) {
      std::array<char, 8> hex{};
      std::snprintf(hex.data(), hex.size(), "\\x%02X", c);
      out += hex.data();
    } else {
      out += static_cast<char>(c);
    }
  }
  out += text.size() > shown ? "'..." : "'";
  return out;
}

template <class T>
void append_number(std::string& out, T value) {
  std::array<char, 64> buffer{};
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  TACMAP_ASSERT(result.ec == std::errc{}, "to_chars cannot fail for 64 characters");
  out.append(buffer.data(), result.ptr);
}

/// A decimal number, the whole token; a leading '+' is accepted (some writers emit it).
template <class T>
std::optional<T> parse_session_number(std::string_view token) {
  if (token.size() > 1 && token.front() == '+' && token[1] != '-' && token[1] != '+')
    token.remove_prefix(1);
  if (token.empty()) return std::nullopt;
  T value{};
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec != std::errc{} || end != token.data() + token.size()) return std::nullopt;
  return value;
}

inline std::int64_t session_time_ns(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
}

inline std::chrono::steady_clock::time_point session_time_point(std::int64_t ns) {
  return std::chrono::steady_clock::time_point(
      std::chrono::duration_cast<std::chrono::steady_clock::duration>(
          std::chrono::nanoseconds(ns)));
}

/// Throws std::invalid_argument unless `header` can be written (and read back identically).
inline void validate_session_header(const session_header& h) {
  if (h.geometry) {
    h.geometry->validate();
    if (h.geometry->rows * h.geometry->cols > session_max_taxels)
      fail("session_header: geometry ", h.geometry->rows, " x ", h.geometry->cols,
           " has more than ", session_max_taxels, " taxels; expected a tactile array");
  }
  if (!session_value_syntax(h.map_file))
    fail("session_header: map_file ", session_quote(h.map_file),
         " has control characters or spaces at an end; expected a plain file name");
  if (h.mm_per_px && !(std::isfinite(*h.mm_per_px) && *h.mm_per_px > 0.0))
    fail("session_header: mm_per_px = ", *h.mm_per_px, "; expected a finite scale > 0");
  if (h.calibration) h.calibration->validate();
  for (std::size_t i = 0; i < h.extra.size(); ++i) {
    const auto& [key, value] = h.extra[i];
    if (!session_key_syntax(key) || session_reserved_key(key))
      fail("session_header: extra key ", session_quote(key),
           " is not usable; expected lower-case letters, digits and '_', and none of frame, "
           "pose, geometry, map, mm_per_px, calibration (use the typed fields for those)");
    if (!session_value_syntax(value))
      fail("session_header: the value of '", key, "' (", session_quote(value),
           ") has control characters or spaces at an end; expected one line of text");
    for (std::size_t j = 0; j < i; ++j)
      if (h.extra[j].first == key)
        fail("session_header: extra key '", key, "' appears twice; expected each key once");
  }
}

/// The header lines of `h` (validated).
inline std::string format_session_header(const session_header& h) {
  validate_session_header(h);
  std::string out(session_magic);
  out += ' ';
  append_number(out, session_format_version);
  out += '\n';
  if (h.geometry) {
    out += "geometry ";
    append_number(out, h.geometry->rows);
    out += ' ';
    append_number(out, h.geometry->cols);
    out += ' ';
    append_number(out, h.geometry->pitch_mm);
    out += '\n';
  }
  if (!h.map_file.empty()) out += "map " + h.map_file + "\n";
  if (h.mm_per_px) {
    out += "mm_per_px ";
    append_number(out, *h.mm_per_px);
    out += '\n';
  }
  if (h.calibration) {
    const map_calibration& c = *h.calibration;
    out += "calibration";
    for (Eigen::Index r = 0; r < 2; ++r)
      for (Eigen::Index k = 0; k < 3; ++k) {
        out += ' ';
        append_number(out, c.plane_axes(r, k));
      }
    for (const double v : {c.rotation_rad, c.translation_mm.x(), c.translation_mm.y(), c.scale}) {
      out += ' ';
      append_number(out, v);
    }
    out += '\n';
  }
  for (const auto& [key, value] : h.extra) out += key + (value.empty() ? "" : " " + value) + "\n";
  return out;
}

/// The line of a frame record (appended to `out`). The frame must be valid.
inline void format_session_frame(std::string& out, const tactile_frame& f) {
  out += "frame ";
  append_number(out, session_time_ns(f.timestamp));
  out += ' ';
  append_number(out, f.sequence);
  for (Eigen::Index r = 0; r < f.counts.rows(); ++r)
    for (Eigen::Index c = 0; c < f.counts.cols(); ++c) {
      out += ' ';
      append_number(out, f.counts(r, c));
    }
  out += '\n';
}

/// The line of a pose record (appended to `out`). The pose must be finite.
inline void format_session_pose(std::string& out, const sensor_pose& p) {
  out += "pose ";
  append_number(out, session_time_ns(p.timestamp));
  for (const double v : {p.x_mm, p.y_mm, p.z_mm, p.yaw_rad}) {
    out += ' ';
    append_number(out, v);
  }
  out += '\n';
}

}  // namespace detail

/// Options of `session_recorder`.
struct session_recorder_options {
  bool overwrite = false;         ///< replace an existing file (default: refuse, keep the data)
  bool sync_each_record = false;  ///< also fsync every record: survives power loss, slower
};

/// Writes a session log record by record. Every record is flushed to the operating system as
/// one line before `record` returns, so it survives the process dying right after (and with
/// `sync_each_record`, a power loss). Move-only; not thread-safe (serialise calls yourself).
class session_recorder {
 public:
  /// Creates `path` and writes the header. Throws std::invalid_argument for a header that cannot
  /// be written, session_log_error when the file exists (unless `overwrite`) or cannot be created.
  session_recorder(std::filesystem::path path, session_header header,
                   session_recorder_options options = {})
      : path_(std::move(path)), header_(std::move(header)), options_(options) {
    header_.version = session_format_version;
    line_ = detail::format_session_header(header_);  // validates before touching the disk
    errno = 0;
    file_ = std::fopen(path_.string().c_str(), options_.overwrite ? "wb" : "wbx");
    if (file_ == nullptr) {
      const int err = errno;
      std::string message = "session log " + path_.string() + ": cannot create it: " +
                            (err != 0 ? std::strerror(err) : "unknown error");
      if (err == EEXIST)
        message +=
            " — it already exists; choose another name, or set "
            "session_recorder_options::overwrite to replace it";
      else
        message += " — check that the folder exists and is writable";
      throw session_log_error(message, 0, "");
    }
    write_line();
  }

  session_recorder(const session_recorder&) = delete;
  session_recorder& operator=(const session_recorder&) = delete;
  session_recorder(session_recorder&& other) noexcept
      : path_(std::move(other.path_)),
        header_(std::move(other.header_)),
        options_(other.options_),
        file_(std::exchange(other.file_, nullptr)),
        records_(other.records_),
        broken_(other.broken_) {}
  session_recorder& operator=(session_recorder&& other) noexcept {
    if (this != &other) {
      close_quietly();
      path_ = std::move(other.path_);
      header_ = std::move(other.header_);
      options_ = other.options_;
      file_ = std::exchange(other.file_, nullptr);
      records_ = other.records_;
      broken_ = other.broken_;
    }
    return *this;
  }
  ~session_recorder() { close_quietly(); }

  /// Appends a frame. Throws std::invalid_argument for an invalid frame or one whose geometry
  /// differs from the header's (nothing is written then), session_log_error when writing fails.
  void record(const tactile_frame& frame) {
    frame.validate();
    check_time("frame", frame.timestamp);
    if (!header_.geometry)
      detail::fail(
          "session_recorder: a frame, but the session header has no geometry; set "
          "session_header::geometry to the sensor's layout when creating the recorder");
    if (!(frame.geometry == *header_.geometry))
      detail::fail("session_recorder: frame geometry ", frame.geometry.rows, " x ",
                   frame.geometry.cols, " at ", frame.geometry.pitch_mm,
                   " mm differs from the session's ", header_.geometry->rows, " x ",
                   header_.geometry->cols, " at ", header_.geometry->pitch_mm,
                   " mm; record each sensor in its own session");
    line_.clear();
    detail::format_session_frame(line_, frame);
    write_line();
    ++records_;
  }

  /// Appends a pose. Throws std::invalid_argument for a pose that is not finite (nothing is
  /// written then), session_log_error when writing fails.
  void record(const sensor_pose& pose) {
    if (!pose.finite())
      detail::fail("session_recorder: pose (", pose.x_mm, ", ", pose.y_mm, ", ", pose.z_mm,
                   " mm, yaw ", pose.yaw_rad,
                   " rad) is not finite; expected a valid sample from the position source");
    check_time("pose", pose.timestamp);
    line_.clear();
    detail::format_session_pose(line_, pose);
    write_line();
    ++records_;
  }

  void record(const session_record& r) {
    std::visit([this](const auto& x) { record(x); }, r);
  }

  /// Closes the file; throws session_log_error if the final flush fails.
  void close() {
    if (file_ == nullptr) return;
    const int rc = std::fclose(std::exchange(file_, nullptr));
    if (rc != 0) io_failure("close");
  }

  [[nodiscard]] std::uint64_t records() const { return records_; }
  [[nodiscard]] const session_header& header() const { return header_; }
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  [[nodiscard]] bool is_open() const { return file_ != nullptr; }

 private:
  /// A timestamp the reader would refuse is not written (std::invalid_argument, nothing written).
  static void check_time(std::string_view what, std::chrono::steady_clock::time_point t) {
    const std::int64_t ns = detail::session_time_ns(t);
    if (ns < -detail::session_max_abs_t_ns || ns > detail::session_max_abs_t_ns)
      detail::fail("session_recorder: ", what, " timestamp ", ns,
                   " ns is not a steady-clock time; expected |t| <= 2^62 ns (146 years) — set "
                   "it from std::chrono::steady_clock::now()");
  }

  void write_line() {
    if (file_ == nullptr || broken_)
      throw session_log_error("session log " + path_.string() +
                                  (broken_ ? ": an earlier write failed; nothing more is written "
                                             "— start a new recorder (check disk space)"
                                           : ": the recorder is closed"),
                              0, "");
    errno = 0;
    if (std::fwrite(line_.data(), 1, line_.size(), file_) != line_.size()) io_failure("write");
    if (std::fflush(file_) != 0) io_failure("flush");
#if defined(__unix__) || defined(__APPLE__)
    if (options_.sync_each_record && ::fsync(::fileno(file_)) != 0) io_failure("fsync");
#endif
  }

  [[noreturn]] void io_failure(const char* what) {
    const int err = errno;
    broken_ = true;
    throw session_log_error("session log " + path_.string() + ": " + what +
                                " failed: " + (err != 0 ? std::strerror(err) : "unknown error") +
                                " — is the disk full or the medium gone? Records before this "
                                "one are in the file",
                            0, "");
  }

  void close_quietly() noexcept {
    if (file_ != nullptr) std::fclose(std::exchange(file_, nullptr));
  }

  std::filesystem::path path_;
  session_header header_;
  session_recorder_options options_;
  std::FILE* file_ = nullptr;
  std::uint64_t records_ = 0;
  bool broken_ = false;
  std::string line_;  // reused: recording does not allocate once warm
};

/// Options of `session_reader`.
struct session_read_options {
  /// A last line without its `"\n"` is a record cut off by a crash. By default it is an error
  /// (nothing is dropped silently); when true it is dropped and reported in `stats()`.
  bool accept_truncated_tail = false;
  std::size_t max_line_bytes = std::size_t{4} << 20U;  ///< longer lines are corrupt
};

/// What a reader has seen.
struct session_read_stats {
  std::uint64_t lines = 0;           ///< lines read so far (header included)
  std::uint64_t frames = 0;          ///< frame records returned
  std::uint64_t poses = 0;           ///< pose records returned
  std::uint64_t frames_skipped = 0;  ///< frames passed over by next_pose()
  std::uint64_t poses_skipped = 0;   ///< poses passed over by next_frame()
  std::uint64_t truncated_line = 0;  ///< the cut-off last line dropped (0: none)
  std::size_t truncated_bytes = 0;   ///< its length
};

/// Reads a session log record by record (streaming: the file is never loaded whole). Also a
/// `position_source` (next_pose) and a frame source (next_frame), for replay through the same
/// code as a live session. Not thread-safe.
///
/// After a session_log_error about one record the reader stands after that line: catch the error
/// and call next() again to skip the bad record.
class session_reader {
 public:
  /// Opens `path` and reads the header. Throws session_log_error when the file cannot be opened
  /// or its header is not a valid session header.
  explicit session_reader(const std::filesystem::path& path, session_read_options options = {})
      : name_(path.string()), folder_(path.parent_path()), options_(options) {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec))
      throw session_log_error(
          "session log " + name_ + " is a folder; expected a session log file (*.session) in it", 0,
          "");
    auto file = std::make_unique<std::ifstream>(path, std::ios::binary);
    if (!file->is_open()) {
      const int err = errno;
      throw session_log_error("session log " + name_ + ": cannot open it: " +
                                  (err != 0 ? std::strerror(err) : "unknown error") +
                                  " — check the path",
                              0, "");
    }
    owned_ = std::move(file);
    in_ = owned_.get();
    read_header();
  }

  /// Reads from `in` (which must outlive the reader); `name` appears in messages, `folder` is
  /// where a relative map file is looked for.
  explicit session_reader(std::istream& in, std::string name = "<stream>",
                          std::filesystem::path folder = {}, session_read_options options = {})
      : name_(std::move(name)), folder_(std::move(folder)), options_(options), in_(&in) {
    read_header();
  }

  session_reader(const session_reader&) = delete;
  session_reader& operator=(const session_reader&) = delete;
  session_reader(session_reader&&) noexcept = default;
  session_reader& operator=(session_reader&&) noexcept = default;
  ~session_reader() = default;

  [[nodiscard]] const session_header& header() const { return header_; }
  [[nodiscard]] const session_read_stats& stats() const { return stats_; }
  [[nodiscard]] const std::string& name() const { return name_; }

  /// The map file resolved against the log's folder; empty when the header names none.
  [[nodiscard]] std::filesystem::path map_path() const {
    if (header_.map_file.empty()) return {};
    const std::filesystem::path p(header_.map_file);
    return p.is_absolute() ? p : folder_ / p;
  }

  /// The next record in file order, or nothing at the end of the log. Throws session_log_error
  /// for a corrupt record (see the class comment to skip it) or a cut-off last line.
  std::optional<session_record> next() {
    pending_line line;
    if (pending_) {
      line = std::move(*pending_);
      pending_.reset();
    } else if (!read_line(line)) {
      return std::nullopt;
    }
    if (!line.terminated) {
      if (!options_.accept_truncated_tail)
        fail_at(line.number, "", "the last line is cut off (", line.text.size(),
                " bytes without a newline at the end of the file): the recording stopped in "
                "the middle of a record. The records before it are complete; read them with "
                "session_read_options::accept_truncated_tail = true");
      stats_.truncated_line = line.number;
      stats_.truncated_bytes = line.text.size();
      return std::nullopt;
    }
    return parse_record(line);
  }

  /// `position_source`: the next pose record (frames in between are skipped and counted in
  /// `stats().frames_skipped`), or nothing at the end. Never waits.
  std::optional<sensor_pose> next_pose(std::chrono::milliseconds /*timeout*/ = {}) {
    while (auto r = next()) {
      if (auto* p = std::get_if<sensor_pose>(&*r)) return *p;
      ++stats_.frames_skipped;
    }
    return std::nullopt;
  }

  /// The next frame record (poses in between are skipped and counted in
  /// `stats().poses_skipped`), or nothing at the end. Never waits.
  std::optional<tactile_frame> next_frame(std::chrono::milliseconds /*timeout*/ = {}) {
    while (auto r = next()) {
      if (auto* f = std::get_if<tactile_frame>(&*r)) return std::move(*f);
      ++stats_.poses_skipped;
    }
    return std::nullopt;
  }

  /// All remaining records.
  std::vector<session_record> read_all() {
    std::vector<session_record> records;
    while (auto r = next()) records.push_back(std::move(*r));
    return records;
  }

 private:
  struct pending_line {
    std::string text;
    std::uint64_t number = 0;
    bool terminated = true;
  };

  template <class... Parts>
  [[noreturn]] void fail_at(std::uint64_t line, const std::string& field, const Parts&... parts) {
    std::ostringstream out;
    out.precision(17);
    out << "session log " << name_ << ", line " << line;
    if (!field.empty()) out << ", " << field;
    out << ": ";
    (out << ... << parts);
    throw session_log_error(out.str(), line, field);
  }

  /// The next line into `line`; false at the end of the input.
  bool read_line(pending_line& line) {
    line.text.clear();
    std::streambuf* buffer = in_->rdbuf();
    if (buffer == nullptr) return false;
    for (;;) {
      const auto c = buffer->sbumpc();
      if (std::char_traits<char>::eq_int_type(c, std::char_traits<char>::eof())) {
        if (line.text.empty()) return false;
        line.terminated = false;
        break;
      }
      if (std::char_traits<char>::to_char_type(c) == '\n') {
        line.terminated = true;
        break;
      }
      if (line.text.size() >= options_.max_line_bytes) {
        // Skip the rest of it, so that a caller who continues starts at the next line.
        auto rest = c;
        while (!std::char_traits<char>::eq_int_type(rest, std::char_traits<char>::eof()) &&
               std::char_traits<char>::to_char_type(rest) != '\n')
          rest = buffer->sbumpc();
        line.text.clear();
        fail_at(++stats_.lines, "", "the line is longer than ", options_.max_line_bytes,
                " bytes; expected a session log line (is this file a session log? if it is, raise "
                "session_read_options::max_line_bytes)");
      }
      line.text.push_back(std::char_traits<char>::to_char_type(c));
    }
    line.number = ++stats_.lines;
    if (line.terminated && !line.text.empty() && line.text.back() == '\r') line.text.pop_back();
    return true;
  }

  static std::vector<std::string_view> split(std::string_view text) {
    std::vector<std::string_view> tokens;
    std::size_t i = 0;
    while (i < text.size()) {
      while (i < text.size() && detail::session_space(text[i])) ++i;
      const std::size_t start = i;
      while (i < text.size() && !detail::session_space(text[i])) ++i;
      if (i > start) tokens.push_back(text.substr(start, i - start));
    }
    return tokens;
  }

  /// The text after the first token, trimmed.
  static std::string_view rest_of_line(std::string_view text) {
    std::size_t i = 0;
    while (i < text.size() && detail::session_space(text[i])) ++i;
    while (i < text.size() && !detail::session_space(text[i])) ++i;
    while (i < text.size() && detail::session_space(text[i])) ++i;
    std::size_t end = text.size();
    while (end > i && detail::session_space(text[end - 1])) --end;
    return text.substr(i, end - i);
  }

  template <class T>
  T number(const pending_line& line, std::string_view token, std::size_t field_index,
           std::string_view field_name, std::string_view record) {
    const std::string field =
        "field " + std::to_string(field_index) + " (" + std::string(field_name) + ")";
    const auto v = detail::parse_session_number<T>(token);
    if (!v) {
      if constexpr (std::is_integral_v<T>)
        fail_at(line.number, field, detail::session_quote(token), " in this ", record,
                " record is not an integer in range; expected ",
                std::is_signed_v<T> ? "a whole number" : "a non-negative whole number", " below 2^",
                sizeof(T) * 8 - (std::is_signed_v<T> ? 1 : 0), " — the file is corrupt here");
      else
        fail_at(line.number, field, detail::session_quote(token), " in this ", record,
                " record is not a decimal number in range; expected a finite number such as "
                "12.5 — the file is corrupt here");
    }
    if constexpr (std::is_floating_point_v<T>) {
      if (!std::isfinite(*v))
        fail_at(line.number, field, field_name, " = ", *v, " in this ", record,
                " record; expected a finite number — the source recorded an invalid value, or "
                "the file was edited");
    }
    return *v;
  }

  /// Field 2 of a record: t_ns, at most 2^62 in magnitude (`detail::session_max_abs_t_ns`).
  std::int64_t t_ns(const pending_line& line, std::string_view token, std::string_view record) {
    const auto t = number<std::int64_t>(line, token, 2, "t_ns", record);
    if (t < -detail::session_max_abs_t_ns || t > detail::session_max_abs_t_ns)
      fail_at(line.number, "field 2 (t_ns)", "t_ns = ", t, " in this ", record,
              " record is not a steady-clock time; expected |t_ns| <= 2^62 (",
              detail::session_max_abs_t_ns,
              " ns, 146 years) — the timestamp is corrupt or was never set");
    return t;
  }

  void read_header() {
    pending_line line;
    if (!read_line(line))
      fail_at(1, "", "the file is empty; expected the header line 'tacmap-session ",
              session_format_version, "' — is this a session log, and did the recording start?");
    const auto tokens = split(line.text);
    if (tokens.empty() || tokens[0] != detail::session_magic)
      fail_at(1, "", "not a tacmap session log: the first line is ",
              detail::session_quote(line.text), "; expected 'tacmap-session ",
              session_format_version, "'");
    if (tokens.size() != 2)
      fail_at(1, "field 2 (version)", "the first line is ", detail::session_quote(line.text),
              "; expected exactly 'tacmap-session <version>'");
    const auto version = detail::parse_session_number<int>(tokens[1]);
    if (!version || *version < 1)
      fail_at(1, "field 2 (version)", "version ", detail::session_quote(tokens[1]),
              " is not a format version; expected ", session_format_version);
    if (*version != session_format_version)
      fail_at(1, "field 2 (version)", "format version ", *version,
              " is newer than this tacmap understands (", session_format_version,
              "); read it with a newer tacmap");
    if (!line.terminated)
      fail_at(1, "",
              "the file ends inside its header line: the recording stopped right after it "
              "started, and the log holds no records");
    header_.version = *version;

    std::vector<std::string> seen;
    while (read_line(line)) {
      if (!line.terminated) {  // a cut-off line: next() reports it
        pending_ = std::move(line);
        return;
      }
      const auto fields = split(line.text);
      if (fields.empty())
        fail_at(line.number, "",
                "the line is empty; expected a header line '<key> <value>' or a "
                "record (frame, pose)");
      const std::string_view key = fields[0];
      if (key == "frame" || key == "pose") {
        pending_ = std::move(line);
        return;
      }
      if (!detail::session_key_syntax(key))
        fail_at(line.number, "field 1 (key)", detail::session_quote(key),
                " is neither a header key (lower-case letters, digits, '_') nor a record "
                "(frame, pose) — the file is corrupt here");
      for (const auto& s : seen)
        if (s == key)
          fail_at(line.number, "field 1 (key)", "header key '", key,
                  "' appears a second time; expected each key once");
      seen.emplace_back(key);
      parse_header_line(line, fields);
    }
  }

  void parse_header_line(const pending_line& line, const std::vector<std::string_view>& f) {
    const std::string_view key = f[0];
    const auto expect_fields = [&](std::size_t n, std::string_view layout) {
      if (f.size() != n)
        fail_at(line.number, "", "the '", key, "' header line has ", f.size() - 1,
                " values; expected ", n - 1, ": '", layout, "'");
    };
    if (key == "geometry") {
      expect_fields(4, "geometry <rows> <cols> <pitch_mm>");
      taxel_geometry g;
      g.rows = number<Eigen::Index>(line, f[1], 2, "rows", "geometry");
      g.cols = number<Eigen::Index>(line, f[2], 3, "cols", "geometry");
      g.pitch_mm = number<double>(line, f[3], 4, "pitch_mm", "geometry");
      if (g.rows <= 0 || g.cols <= 0 || g.rows > detail::session_max_taxels ||
          g.cols > detail::session_max_taxels || g.rows * g.cols > detail::session_max_taxels ||
          !(g.pitch_mm > 0.0))
        fail_at(line.number, "", "geometry ", g.rows, " x ", g.cols, " at ", g.pitch_mm,
                " mm; expected rows, cols > 0 with at most ", detail::session_max_taxels,
                " taxels and a pitch > 0 mm");
      header_.geometry = g;
    } else if (key == "map") {
      const std::string_view value = rest_of_line(line.text);
      if (value.empty() || !detail::session_value_syntax(value))
        fail_at(line.number, "field 2 (file name)", "the map file name ",
                detail::session_quote(value),
                " is empty or has control characters; expected a file name");
      header_.map_file = std::string(value);
    } else if (key == "mm_per_px") {
      expect_fields(2, "mm_per_px <scale>");
      const double s = number<double>(line, f[1], 2, "mm_per_px", "mm_per_px");
      if (!(s > 0.0))
        fail_at(line.number, "field 2 (mm_per_px)", "mm_per_px = ", s,
                "; expected the map's scale, > 0 mm per pixel");
      header_.mm_per_px = s;
    } else if (key == "calibration") {
      expect_fields(11,
                    "calibration <ux> <uy> <uz> <vx> <vy> <vz> <rotation_rad> <tx_mm> "
                    "<ty_mm> <scale>");
      static constexpr std::array<std::string_view, 10> names = {
          "ux", "uy", "uz", "vx", "vy", "vz", "rotation_rad", "tx_mm", "ty_mm", "scale"};
      std::array<double, 10> v{};
      for (std::size_t i = 0; i < v.size(); ++i)
        v[i] = number<double>(line, f[i + 1], i + 2, names[i], "calibration");
      map_calibration c;
      c.plane_axes << v[0], v[1], v[2], v[3], v[4], v[5];
      c.rotation_rad = v[6];
      c.translation_mm = {v[7], v[8]};
      c.scale = v[9];
      try {
        c.validate();
      } catch (const std::invalid_argument& e) {
        fail_at(line.number, "", e.what());
      }
      header_.calibration = c;
    } else {
      const std::string_view value = rest_of_line(line.text);
      if (!detail::session_value_syntax(value))
        fail_at(line.number, "field 2 (value)", "the value of '", key, "' (",
                detail::session_quote(value), ") has control characters; expected text");
      header_.extra.emplace_back(std::string(key), std::string(value));
    }
  }

  session_record parse_record(const pending_line& line) {
    const auto f = split(line.text);
    if (f.empty()) fail_at(line.number, "", "the line is empty; expected a record (frame or pose)");
    if (f[0] == "pose") {
      if (f.size() != 6)
        fail_at(line.number, "", "a pose record with ", f.size() - 1,
                " values; expected 5: 'pose <t_ns> <x_mm> <y_mm> <z_mm> <yaw_rad>'",
                f.size() < 6 ? " (the line may have been cut short)" : "");
      sensor_pose p;
      p.timestamp = detail::session_time_point(t_ns(line, f[1], "pose"));
      p.x_mm = number<double>(line, f[2], 3, "x_mm", "pose");
      p.y_mm = number<double>(line, f[3], 4, "y_mm", "pose");
      p.z_mm = number<double>(line, f[4], 5, "z_mm", "pose");
      p.yaw_rad = number<double>(line, f[5], 6, "yaw_rad", "pose");
      ++stats_.poses;
      return p;
    }
    if (f[0] == "frame") {
      if (!header_.geometry)
        fail_at(line.number, "",
                "a frame record, but the header has no 'geometry' line; "
                "expected 'geometry <rows> <cols> <pitch_mm>' before the first "
                "record");
      const taxel_geometry& g = *header_.geometry;
      const auto n = static_cast<std::size_t>(g.rows * g.cols);
      if (f.size() != 3 + n)
        fail_at(line.number, "", "a frame record with ", f.size() < 3 ? 0 : f.size() - 3,
                " taxel values; expected ", n, " (geometry ", g.rows, " x ", g.cols,
                ") after 'frame <t_ns> <seq>'",
                f.size() < 3 + n ? " (the line may have been cut short)" : "");
      tactile_frame frame;
      frame.geometry = g;
      frame.timestamp = detail::session_time_point(t_ns(line, f[1], "frame"));
      frame.sequence = number<std::uint32_t>(line, f[2], 3, "seq", "frame");
      frame.counts.resize(g.rows, g.cols);
      for (std::size_t k = 0; k < n; ++k) {
        const auto r = static_cast<Eigen::Index>(k) / g.cols;
        const auto c = static_cast<Eigen::Index>(k) % g.cols;
        auto v = detail::parse_session_number<float>(f[3 + k]);
        if (!(v && std::isfinite(*v) && *v >= 0.0F)) {  // the slow path names the taxel
          const std::string name = "taxel (" + std::to_string(r) + ", " + std::to_string(c) + ")";
          v = number<float>(line, f[3 + k], 4 + k, name, "frame");
          fail_at(line.number, "field " + std::to_string(4 + k) + " (" + name + ")", name, " = ",
                  *v, "; expected a raw count >= 0");
        }
        frame.counts(r, c) = *v;
      }
      ++stats_.frames;
      return frame;
    }
    if (detail::session_key_syntax(f[0]))
      fail_at(line.number, "field 1 (record type)", "'", f[0],
              "' is not a record type; expected 'frame' or 'pose' (header lines such as '", f[0],
              " ...' go before the first record)");
    fail_at(line.number, "field 1 (record type)", detail::session_quote(f[0]),
            " is not a record type; expected 'frame' or 'pose' — the file is corrupt here");
  }

  std::string name_;
  std::filesystem::path folder_;
  session_read_options options_;
  std::unique_ptr<std::istream> owned_;
  std::istream* in_ = nullptr;
  session_header header_;
  session_read_stats stats_;
  std::optional<pending_line> pending_;
};

static_assert(position_source<session_reader>);

}  // namespace tacmap
