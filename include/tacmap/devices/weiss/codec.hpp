// tacmap: the Weiss tactile-sensor wire codec — CRC16, packet framing, a resynchronising
// byte-stream parser, frame payloads (plain and RLE), status codes and the matrix-info replies.
//
// Two controller families carry the paper's sensor (Sec. IV-A: a Weiss Robotics resistive
// array, 14 rows x 6 columns of 3.4 mm cells): the WTS tactile modules and the DSACON32m
// controller. They share one framing,
//
//     AA AA AA | id (u8) | size (u16 LE) | payload (size bytes) | crc16 (u16 LE)
//
// and differ only in what the CRC covers (see `protocol_family`). Nothing in this header does
// I/O: it is pure byte arithmetic, so it is tested byte-exactly and reused by the emulator.
// Facts and uncertain points come from /work/shared/reference/weiss-tactile-protocols.md; every
// uncertain point is a parameter here and mismatches fail loudly (`protocol_error`).
//
// How much the CRC catches (measured; tests/devices/test_codec_soak.cpp). The vendor's CRC16
// (below) is no true CRC: its per-byte update, crc' = T[(crc ^ b) & 0xFF] ^ (crc >> 8), is
// singular — T[0x89] = 0x00A1 < 0x100, so state difference 0xA189 vanishes in one step — and
// after three bytes its 2^16 states have collapsed onto 2^13. A corruption more than three bytes
// before the CRC field therefore goes unnoticed with probability 2^-13 = 1.2e-4, not 2^-16; and
// some 16-bit bursts are never noticed at all: XOR (0A C3), (17 55), (1D 96), (83 62), (89 A1),
// (94 37) or (9E F4) into two adjacent bytes with three or more bytes after them, and the CRC
// is unchanged (a true CRC-16 catches every burst up to 16 bits).
// Through `packet_parser`, 10^6 WTS frames of the 14 x 6 array with 1 % of their bytes
// replaced at random (tests/devices/test_codec_soak.cpp, tacmap::sim_rng seed as there):
// 838,408 frames hit, every clean frame arrived, and 123 hit frames passed the CRC (1.5e-4 per
// hit frame, 10x 2^-16; an independent run saw 30 of 167,675, 1.8e-4; 4 of the 123 passed as
// command replies, their id byte hit). It is not
// resynchronisation onto a false header (hunting restarts one byte into a rejected candidate,
// and every frame that passed had the right size, 173 bytes) nor the length field
// (a wrong size compares the CRC against payload bytes: 2^-16): it is the CRC itself.
// What the protocol allows on top: `decode_frame_payload` checks the size (5 + 2 N bytes), that
// every cell is 12-bit data (the top nibble of each cell's high byte is a free check) and RLE
// counts, which rejects about 70 % of those: 36 of the 10^6 (4.3e-5 per hit frame) also
// decoded, every one with its damage in bits that carry no redundancy (the cells' 12 data bits,
// the timestamp, the flags). The protocol has no sequence number; the device timestamp's unit is
// unconfirmed for the WTS and may restart after a power cycle, so a continuity check on it would
// refuse valid frames to catch about 1 in 10 of the remaining 4e-5 — not done. Where a wrong
// frame matters, compare consecutive frames (a touch changes smoothly) or re-read.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <deque>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "tacmap/image.hpp"
#include "tacmap/tactile/frame.hpp"

namespace tacmap::weiss {

/// Thrown when bytes from a device do not follow the protocol (corrupt frame, short reply, ...).
/// The device classes turn it into a `tacmap::device_error` naming the port.
class protocol_error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The two controller families. The only framing difference is the CRC's coverage:
/// WTS: preamble + id + size + payload, always sent. DSACON32m: id + size + payload, and no CRC
/// at all when the payload is empty (such a packet is exactly 6 bytes).
enum class protocol_family : std::uint8_t { wts, dsacon32m };

constexpr std::string_view family_name(protocol_family family) noexcept {
  return family == protocol_family::wts ? "WTS" : "DSACON32m";
}

// ------------------------------------------------------------------------------------------
// CRC16
// ------------------------------------------------------------------------------------------

namespace detail {

/// The usual MSB-first table for polynomial 0x1021 (T[1] = 0x1021, T[255] = 0x1EF0).
constexpr std::array<std::uint16_t, 256> make_crc16_table() noexcept {
  std::array<std::uint16_t, 256> table{};
  for (std::uint32_t i = 0; i < 256U; ++i) {
    std::uint32_t v = i << 8U;
    for (int bit = 0; bit < 8; ++bit) v = (v & 0x8000U) != 0U ? (v << 1U) ^ 0x1021U : v << 1U;
    table[i] = static_cast<std::uint16_t>(v & 0xFFFFU);
  }
  return table;
}

inline constexpr std::array<std::uint16_t, 256> crc16_table = make_crc16_table();

}  // namespace detail

inline constexpr std::uint16_t crc16_init = 0xFFFF;

/// One CRC step. Note the mix: an MSB-first table driven by a reflected-style update. This is
/// not a catalogued CRC (check value 0x6EB4, not CCITT's 0x29B1): implement exactly this. The
/// mix makes the step singular: it keeps only 13 bits of a corruption's trace (file comment).
constexpr std::uint16_t crc16_update(std::uint16_t crc, std::uint8_t byte) noexcept {
  const std::uint32_t index = (static_cast<std::uint32_t>(crc) ^ byte) & 0xFFU;
  return static_cast<std::uint16_t>(detail::crc16_table[index] ^
                                    (static_cast<std::uint32_t>(crc) >> 8U));
}

/// CRC16 over `bytes`, continuing from `crc` (init 0xFFFF, no final XOR). Running it over a
/// message followed by its own CRC (low byte first) gives the residue 0.
constexpr std::uint16_t crc16(std::span<const std::uint8_t> bytes,
                              std::uint16_t crc = crc16_init) noexcept {
  for (const std::uint8_t b : bytes) crc = crc16_update(crc, b);
  return crc;
}

// ------------------------------------------------------------------------------------------
// Little-endian helpers
// ------------------------------------------------------------------------------------------

namespace detail {

inline void put_u8(std::vector<std::uint8_t>& out, std::uint8_t v) { out.push_back(v); }
inline void put_u16(std::vector<std::uint8_t>& out, std::uint16_t v) {
  out.push_back(static_cast<std::uint8_t>(v & 0xFFU));
  out.push_back(static_cast<std::uint8_t>(v >> 8U));
}
inline void put_u32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int shift = 0; shift < 32; shift += 8)
    out.push_back(static_cast<std::uint8_t>((v >> static_cast<unsigned>(shift)) & 0xFFU));
}
inline void put_f32(std::vector<std::uint8_t>& out, float v) {
  put_u32(out, std::bit_cast<std::uint32_t>(v));
}
constexpr std::uint16_t get_u16(const std::uint8_t* p) noexcept {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8U));
}

/// Reads little-endian fields from a reply; running short throws a protocol_error naming the
/// reply and the field, because a short reply means a firmware or protocol-family mismatch.
class byte_reader {
 public:
  byte_reader(std::span<const std::uint8_t> bytes, std::string_view what)
      : bytes_(bytes), what_(what) {}

  std::uint8_t u8(std::string_view field) { return need(1, field)[0]; }
  std::uint16_t u16(std::string_view field) { return get_u16(need(2, field)); }
  std::uint32_t u32(std::string_view field) {
    const std::uint8_t* p = need(4, field);
    return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8U) |
           (static_cast<std::uint32_t>(p[2]) << 16U) | (static_cast<std::uint32_t>(p[3]) << 24U);
  }
  float f32(std::string_view field) { return std::bit_cast<float>(u32(field)); }
  std::span<const std::uint8_t> bytes(std::size_t n, std::string_view field) {
    const std::uint8_t* p = need(n, field);
    return {p, n};
  }
  std::size_t remaining() const noexcept { return bytes_.size() - pos_; }

 private:
  const std::uint8_t* need(std::size_t n, std::string_view field) {
    if (bytes_.size() - pos_ < n)
      tacmap::detail::fail<protocol_error>(what_, ": ", bytes_.size(), " bytes end before field '",
                                           field, "' (needs ", n, " bytes at offset ", pos_,
                                           "); the device speaks a different firmware or protocol "
                                           "family than expected — check the device type");
    const std::uint8_t* p = bytes_.data() + pos_;
    pos_ += n;
    return p;
  }
  std::span<const std::uint8_t> bytes_;
  std::string_view what_;
  std::size_t pos_ = 0;
};

}  // namespace detail

// ------------------------------------------------------------------------------------------
// Packets
// ------------------------------------------------------------------------------------------

inline constexpr std::uint8_t preamble_byte = 0xAA;
inline constexpr std::size_t preamble_size = 3;
inline constexpr std::size_t header_size = 6;  ///< preamble + id + size
inline constexpr std::size_t crc_size = 2;
inline constexpr std::uint8_t frame_id = 0x00;  ///< streamed frames; never used by a command
inline constexpr std::size_t max_wire_payload = 0xFFFF;

/// True when a packet of this family with this payload size carries a CRC on the wire.
constexpr bool carries_crc(protocol_family family, std::size_t payload_size) noexcept {
  return family == protocol_family::wts || payload_size != 0;
}

/// The CRC a packet of `family` carries over header bytes `header` (6) and its payload.
inline std::uint16_t packet_crc(protocol_family family, std::span<const std::uint8_t> header,
                                std::span<const std::uint8_t> payload) noexcept {
  const auto covered = family == protocol_family::wts ? header : header.subspan(preamble_size);
  return crc16(payload, crc16(covered));
}

/// A packet without its framing: `id` and payload. Requests and replies share the id; streamed
/// frames use id 00. `received` is when the parser completed it (steady clock).
struct packet {
  std::uint8_t id = 0;
  std::vector<std::uint8_t> payload;
  std::chrono::steady_clock::time_point received{};
};

/// The complete wire bytes of one packet of `family`.
inline std::vector<std::uint8_t> encode_packet(protocol_family family, std::uint8_t id,
                                               std::span<const std::uint8_t> payload) {
  if (payload.size() > max_wire_payload)
    tacmap::detail::fail<std::invalid_argument>("weiss::encode_packet: payload of ", payload.size(),
                                                " bytes; the size field is a u16, "
                                                "so at most ",
                                                max_wire_payload, " bytes fit in one packet");
  if (id == preamble_byte)
    tacmap::detail::fail<std::invalid_argument>(
        "weiss::encode_packet: id 0xAA would read as a fourth preamble byte; no Weiss command "
        "uses it — pass the intended command id");
  std::vector<std::uint8_t> out;
  out.reserve(header_size + payload.size() + crc_size);
  out.insert(out.end(), preamble_size, preamble_byte);
  out.push_back(id);
  detail::put_u16(out, static_cast<std::uint16_t>(payload.size()));
  out.insert(out.end(), payload.begin(), payload.end());
  if (carries_crc(family, payload.size()))
    detail::put_u16(out, packet_crc(family, std::span(out).first(header_size), payload));
  return out;
}

// ------------------------------------------------------------------------------------------
// Byte-stream parser
// ------------------------------------------------------------------------------------------

/// Limits of a `packet_parser`. Sizes above `max_payload` are impossible for the sensor at
/// hand and are rejected at the header, so a corrupt size field cannot stall the stream.
struct parser_limits {
  std::size_t max_payload = 4096;        ///< bytes; > 5 + 2 * cells of the largest expected frame
  std::size_t max_queued_frames = 256;   ///< oldest frames are dropped (and counted) beyond this
  std::size_t max_queued_commands = 64;  ///< same for non-frame packets
};

/// What the parser has seen. `garbage_bytes` counts every byte that did not end up inside an
/// accepted packet: line noise, a power-up banner, and the bytes of rejected packets.
struct parser_stats {
  std::uint64_t bytes = 0;          ///< bytes fed
  std::uint64_t packets = 0;        ///< accepted packets (frames + commands)
  std::uint64_t frames = 0;         ///< accepted packets with id 00
  std::uint64_t commands = 0;       ///< accepted packets with another id
  std::uint64_t garbage_bytes = 0;  ///< bytes skipped while hunting for a preamble
  std::uint64_t bad_crc = 0;        ///< complete packets whose CRC did not match
  std::uint64_t bad_size = 0;       ///< headers announcing more than `max_payload` bytes
  std::uint64_t truncated = 0;      ///< partial packets abandoned by `flush_partial()`
  std::uint64_t dropped = 0;        ///< accepted packets dropped because a queue was full
};

/// A state machine fed arbitrary chunks of a byte stream. It hunts for AA AA AA, checks the
/// size against the limit and the CRC, and queues accepted packets: streamed frames (id 00)
/// apart from everything else (command replies on the host side, requests on the device side).
///
/// Resynchronisation: when a candidate packet is rejected (bad size or CRC), hunting resumes at
/// the byte after its first preamble byte, not after the whole candidate. A truncated packet
/// followed by a good one thus costs only the truncated one: the good packet's bytes are still
/// buffered and are found on the rescan. No command uses id 0xAA, so in a run of more than three
/// AA bytes the last three are the preamble.
class packet_parser {
 public:
  explicit packet_parser(protocol_family family, parser_limits limits = {})
      : family_(family), limits_(limits) {
    if (limits_.max_queued_frames == 0 || limits_.max_queued_commands == 0)
      tacmap::detail::fail<std::invalid_argument>(
          "weiss::packet_parser: queue capacities are ", limits_.max_queued_frames, " and ",
          limits_.max_queued_commands, "; expected both >= 1");
    limits_.max_payload = std::min(limits_.max_payload, max_wire_payload);
  }

  /// Feed the next chunk of the stream (any size, including 0).
  void feed(std::span<const std::uint8_t> bytes,
            std::chrono::steady_clock::time_point received = std::chrono::steady_clock::now()) {
    stats_.bytes += bytes.size();
    if (head_ > 0 && head_ >= buffer_.size() / 2) {  // compact: keep the buffer bounded
      buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(head_));
      head_ = 0;
    }
    buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
    scan(received);
  }

  /// The line has gone quiet with a packet still incomplete: give it up (counted in
  /// `truncated`), and rescan the bytes after its preamble for packets that were hiding inside
  /// (a corrupt size field can swallow a good packet that follows).
  void flush_partial(std::chrono::steady_clock::time_point now = std::chrono::steady_clock::now()) {
    bool counted = false;
    while (head_ < buffer_.size()) {
      if (!counted && buffer_.size() - head_ > preamble_size) {
        ++stats_.truncated;
        counted = true;
      }
      drop(1);
      scan(now);
    }
  }

  /// Drop buffered bytes and queued packets (after a port flush or reconnect); stats are kept.
  void reset() noexcept {
    buffer_.clear();
    head_ = 0;
    frames_.clear();
    commands_.clear();
  }

  std::optional<packet> pop_frame() { return pop(frames_); }
  std::optional<packet> pop_command() { return pop(commands_); }
  void clear_frames() noexcept { frames_.clear(); }
  std::size_t queued_frames() const noexcept { return frames_.size(); }
  std::size_t queued_commands() const noexcept { return commands_.size(); }
  std::size_t buffered() const noexcept { return buffer_.size() - head_; }  ///< partial bytes
  const parser_stats& stats() const noexcept { return stats_; }
  const parser_limits& limits() const noexcept { return limits_; }
  protocol_family family() const noexcept { return family_; }

 private:
  static std::optional<packet> pop(std::deque<packet>& queue) {
    if (queue.empty()) return std::nullopt;
    packet p = std::move(queue.front());
    queue.pop_front();
    return p;
  }

  void drop(std::size_t n) noexcept {
    head_ += n;
    stats_.garbage_bytes += n;
  }

  void scan(std::chrono::steady_clock::time_point received) {
    for (;;) {
      // Hunt: the first run of >= 3 AA bytes followed by a non-AA byte (the id).
      const std::uint8_t* d = buffer_.data();
      const std::size_t n = buffer_.size();
      std::size_t run = 0;
      std::size_t start = n;
      for (std::size_t i = head_; i < n; ++i) {
        if (d[i] == preamble_byte) {
          ++run;
          continue;
        }
        if (run >= preamble_size) {
          start = i - preamble_size;
          break;
        }
        run = 0;
      }
      if (start == n) {  // no candidate yet: keep at most a trailing partial preamble
        drop(n - std::min(run, preamble_size) - head_);
        return;
      }
      drop(start - head_);
      if (n - head_ < header_size) return;  // wait for the size field
      const std::size_t size = detail::get_u16(d + head_ + 4);
      if (size > limits_.max_payload) {
        ++stats_.bad_size;
        drop(1);
        continue;
      }
      const bool has_crc = carries_crc(family_, size);
      const std::size_t total = header_size + size + (has_crc ? crc_size : 0);
      if (n - head_ < total) return;  // wait for the rest
      const std::span<const std::uint8_t> header(d + head_, header_size);
      const std::span<const std::uint8_t> payload(d + head_ + header_size, size);
      if (has_crc &&
          packet_crc(family_, header, payload) != detail::get_u16(d + head_ + header_size + size)) {
        ++stats_.bad_crc;
        drop(1);
        continue;
      }
      packet p{header[3], std::vector<std::uint8_t>(payload.begin(), payload.end()), received};
      head_ += total;
      ++stats_.packets;
      if (p.id == frame_id) {
        ++stats_.frames;
        push(frames_, std::move(p), limits_.max_queued_frames);
      } else {
        ++stats_.commands;
        push(commands_, std::move(p), limits_.max_queued_commands);
      }
    }
  }

  void push(std::deque<packet>& queue, packet&& p, std::size_t capacity) {
    if (queue.size() >= capacity) {
      queue.pop_front();
      ++stats_.dropped;
    }
    queue.push_back(std::move(p));
  }

  protocol_family family_;
  parser_limits limits_;
  std::vector<std::uint8_t> buffer_;
  std::size_t head_ = 0;
  std::deque<packet> frames_;
  std::deque<packet> commands_;
  parser_stats stats_;
};

// ------------------------------------------------------------------------------------------
// Status codes
// ------------------------------------------------------------------------------------------

/// Status codes in WTS numbering (every WTS reply starts with one as a u16; 0 = success).
/// The DSACON32m lacks `no_param_expected`, so its wire codes from 12 on are one lower and it
/// has nothing above `range_error`; convert with `status_to_wire` / `status_from_wire`.
enum class status : std::uint16_t {
  success = 0,
  not_available,
  no_sensor,
  not_initialized,
  already_running,
  feature_not_supported,
  inconsistent_data,
  timeout,
  read_error,
  write_error,
  insufficient_resources,
  checksum_error,
  no_param_expected,
  not_enough_params,
  cmd_unknown,
  cmd_format_error,
  access_denied,
  already_open,
  cmd_failed,
  cmd_aborted,
  invalid_handle,
  not_found,
  not_open,
  io_error,
  invalid_parameter,
  index_out_of_bounds,
  cmd_pending,
  overrun,
  range_error,
  axis_blocked,
  file_exists
};

inline constexpr std::array<std::string_view, 31> status_names = {"E_SUCCESS",
                                                                  "E_NOT_AVAILABLE",
                                                                  "E_NO_SENSOR",
                                                                  "E_NOT_INITIALIZED",
                                                                  "E_ALREADY_RUNNING",
                                                                  "E_FEATURE_NOT_SUPPORTED",
                                                                  "E_INCONSISTENT_DATA",
                                                                  "E_TIMEOUT",
                                                                  "E_READ_ERROR",
                                                                  "E_WRITE_ERROR",
                                                                  "E_INSUFFICIENT_RESOURCES",
                                                                  "E_CHECKSUM_ERROR",
                                                                  "E_NO_PARAM_EXPECTED",
                                                                  "E_NOT_ENOUGH_PARAMS",
                                                                  "E_CMD_UNKNOWN",
                                                                  "E_CMD_FORMAT_ERROR",
                                                                  "E_ACCESS_DENIED",
                                                                  "E_ALREADY_OPEN",
                                                                  "E_CMD_FAILED",
                                                                  "E_CMD_ABORTED",
                                                                  "E_INVALID_HANDLE",
                                                                  "E_NOT_FOUND",
                                                                  "E_NOT_OPEN",
                                                                  "E_IO_ERROR",
                                                                  "E_INVALID_PARAMETER",
                                                                  "E_INDEX_OUT_OF_BOUNDS",
                                                                  "E_CMD_PENDING",
                                                                  "E_OVERRUN",
                                                                  "E_RANGE_ERROR",
                                                                  "E_AXIS_BLOCKED",
                                                                  "E_FILE_EXISTS"};

constexpr std::string_view status_name(status s) noexcept {
  const auto i = static_cast<std::size_t>(s);
  return i < status_names.size() ? status_names[i] : std::string_view("E_UNKNOWN");
}

/// The status a wire code means for `family`; nullopt for codes the family does not define.
constexpr std::optional<status> status_from_wire(protocol_family family,
                                                 std::uint16_t code) noexcept {
  const unsigned c = code;
  const auto no_param = static_cast<unsigned>(status::no_param_expected);
  if (family == protocol_family::wts) {
    if (c <= static_cast<unsigned>(status::file_exists)) return static_cast<status>(c);
    return std::nullopt;
  }
  if (c < no_param) return static_cast<status>(c);
  if (c < static_cast<unsigned>(status::range_error)) return static_cast<status>(c + 1U);
  return std::nullopt;
}

/// The wire code of `s` for `family`; throws std::invalid_argument for codes the DSACON32m
/// does not have (no_param_expected, axis_blocked, file_exists).
inline std::uint16_t status_to_wire(protocol_family family, status s) {
  const auto code = static_cast<std::uint16_t>(s);
  if (family == protocol_family::wts) return code;
  if (s == status::no_param_expected || s > status::range_error)
    tacmap::detail::fail<std::invalid_argument>(
        "weiss::status_to_wire: ", status_name(s),
        " has no DSACON32m code (that family stops at E_RANGE_ERROR and lacks "
        "E_NO_PARAM_EXPECTED); pick a status the DSACON32m defines");
  return s < status::no_param_expected ? code : static_cast<std::uint16_t>(code - 1U);
}

/// "E_CMD_UNKNOWN (14)" or "unknown status 99" — for error messages.
inline std::string describe_status(protocol_family family, std::uint16_t code) {
  const auto s = status_from_wire(family, code);
  std::string out = s ? std::string(status_name(*s)) : std::string("unknown status");
  return out + " (" + std::to_string(code) + ")";
}

// ------------------------------------------------------------------------------------------
// Command ids
// ------------------------------------------------------------------------------------------

namespace wts_command {
inline constexpr std::uint8_t loop = 0x06;
inline constexpr std::uint8_t read_single_frame = 0x20;  ///< u8 flags (bit0 = RLE)
inline constexpr std::uint8_t start_periodic = 0x21;     ///< u8 flags, u16 period in ms
inline constexpr std::uint8_t stop_periodic = 0x22;
inline constexpr std::uint8_t tare = 0x23;
inline constexpr std::uint8_t matrix_info = 0x30;
inline constexpr std::uint8_t sensor_type = 0x38;
inline constexpr std::uint8_t temperature = 0x46;
inline constexpr std::uint8_t system_info = 0x50;
inline constexpr std::uint8_t device_tag = 0x52;
}  // namespace wts_command

namespace dsacon32m_command {
inline constexpr std::uint8_t full_frame = 0x00;
inline constexpr std::uint8_t controller_info = 0x01;
inline constexpr std::uint8_t sensor_info = 0x02;
inline constexpr std::uint8_t configure_acquisition = 0x03;  ///< u8 flags, u16 framerate
inline constexpr std::uint8_t loop = 0x06;
inline constexpr std::uint8_t matrix_info = 0x0B;  ///< u8 matrix index
/// Flags of configure_acquisition.
inline constexpr std::uint8_t flag_enable = 0x80;
inline constexpr std::uint8_t flag_internal_trigger = 0x20;
inline constexpr std::uint8_t flag_rle = 0x01;
}  // namespace dsacon32m_command

/// The DSACON32m power-up banner: ESC [ 5 n, sent three times about 7 s after power-on.
inline constexpr std::array<std::uint8_t, 4> dsacon32m_banner = {0x1B, 0x5B, 0x35, 0x6E};

/// Splits a reply payload into its leading u16 status and the data after it.
struct status_reply {
  std::uint16_t code = 0;
  std::span<const std::uint8_t> data;
};
inline status_reply split_status(std::span<const std::uint8_t> payload, std::string_view what) {
  detail::byte_reader in(payload, what);
  const std::uint16_t code = in.u16("status");
  return {code, payload.subspan(2)};
}

// ------------------------------------------------------------------------------------------
// Frames
// ------------------------------------------------------------------------------------------

inline constexpr std::size_t frame_header_size = 5;  ///< u32 timestamp + u8 flags
inline constexpr std::uint8_t frame_flag_rle = 0x01;
inline constexpr std::uint16_t max_cell_value = 0x0FFF;  ///< cells carry 12-bit data
inline constexpr std::uint16_t max_rle_run = 15;

/// Order of cells in a frame. Row-major with x fastest (index = y * res_x + x) is documented for
/// the DSACON32m and inferred for the WTS; the other order exists so that hardware which
/// disagrees can be read without code changes.
enum class cell_order : std::uint8_t { x_fastest, y_fastest };

/// Index of cell (x, y) in a frame of `res_x` x `res_y` cells.
constexpr std::size_t cell_index(std::size_t x, std::size_t y, std::size_t res_x, std::size_t res_y,
                                 cell_order order) noexcept {
  return order == cell_order::x_fastest ? y * res_x + x : x * res_y + y;
}

/// A decoded frame payload: the device's timestamp (ms, unconfirmed for the WTS), flags, and
/// the cells of all matrices in wire order.
struct frame_payload {
  std::uint32_t timestamp = 0;
  std::uint8_t flags = 0;
  std::vector<std::uint16_t> cells;
  bool rle() const noexcept { return (flags & frame_flag_rle) != 0; }
};

/// Run-length units: value = unit & 0x0FFF, repeat count = unit >> 12 (1..15).
inline std::vector<std::uint16_t> rle_encode(std::span<const std::uint16_t> cells) {
  std::vector<std::uint16_t> units;
  for (std::size_t i = 0; i < cells.size();) {
    const std::uint16_t v = cells[i];
    if (v > max_cell_value)
      tacmap::detail::fail<std::invalid_argument>("weiss::rle_encode: cell ", i, " = ", v,
                                                  "; expected 12-bit data (0..4095)");
    std::size_t run = 1;
    while (run < max_rle_run && i + run < cells.size() && cells[i + run] == v) ++run;
    units.push_back(static_cast<std::uint16_t>((run << 12U) | v));
    i += run;
  }
  return units;
}

/// Expands RLE units; the decoded count must equal `expected_cells`, anything else (including a
/// zero repeat count) is a corrupt frame.
inline std::vector<std::uint16_t> rle_decode(std::span<const std::uint16_t> units,
                                             std::size_t expected_cells) {
  std::vector<std::uint16_t> cells;
  cells.reserve(expected_cells);
  for (std::size_t i = 0; i < units.size(); ++i) {
    const std::size_t count = units[i] >> 12U;
    if (count == 0)
      tacmap::detail::fail<protocol_error>(
          "RLE frame: unit ", i, " (value ", units[i],
          ") has repeat count 0; expected 1..15 — the frame is corrupt");
    if (cells.size() + count > expected_cells)
      tacmap::detail::fail<protocol_error>(
          "RLE frame: unit ", i, " of ", units.size(), " expands past ", expected_cells,
          " cells; expected exactly the sensor's cell count — corrupt frame or wrong geometry");
    cells.insert(cells.end(), count, static_cast<std::uint16_t>(units[i] & max_cell_value));
  }
  if (cells.size() != expected_cells)
    tacmap::detail::fail<protocol_error>("RLE frame: decodes to ", cells.size(),
                                         " cells; expected ", expected_cells,
                                         " — corrupt frame or wrong geometry");
  return cells;
}

/// Encodes a frame payload (u32 timestamp, u8 flags, then u16 LE cells or RLE units).
inline std::vector<std::uint8_t> encode_frame_payload(std::uint32_t timestamp,
                                                      std::span<const std::uint16_t> cells,
                                                      bool rle) {
  std::vector<std::uint8_t> out;
  detail::put_u32(out, timestamp);
  detail::put_u8(out, rle ? frame_flag_rle : std::uint8_t{0});
  if (rle) {
    for (const std::uint16_t unit : rle_encode(cells)) detail::put_u16(out, unit);
  } else {
    for (std::size_t i = 0; i < cells.size(); ++i) {
      if (cells[i] > max_cell_value)
        tacmap::detail::fail<std::invalid_argument>("weiss::encode_frame_payload: cell ", i, " = ",
                                                    cells[i], "; expected 12-bit data (0..4095)");
      detail::put_u16(out, cells[i]);
    }
  }
  return out;
}

/// Decodes a frame payload holding `expected_cells` cells (all matrices). Throws protocol_error
/// on a wrong size, a cell above 12 bits, or an RLE stream that does not decode to the count.
inline frame_payload decode_frame_payload(std::span<const std::uint8_t> payload,
                                          std::size_t expected_cells) {
  detail::byte_reader in(payload, "frame payload");
  frame_payload frame;
  frame.timestamp = in.u32("timestamp");
  frame.flags = in.u8("flags");
  const std::size_t rest = in.remaining();
  if (rest % 2 != 0)
    tacmap::detail::fail<protocol_error>("frame payload: ", payload.size(), " bytes leave an odd ",
                                         rest, " bytes of cell data; expected u16 units");
  std::vector<std::uint16_t> units(rest / 2);
  for (auto& u : units) u = in.u16("cell");
  if (frame.rle()) {
    frame.cells = rle_decode(units, expected_cells);
    return frame;
  }
  if (units.size() != expected_cells)
    tacmap::detail::fail<protocol_error>(
        "frame payload: ", payload.size(), " bytes hold ", units.size(), " cells; expected ",
        expected_cells, " (", frame_header_size + 2 * expected_cells,
        " bytes) — corrupt frame or wrong geometry (query the matrix info again)");
  for (std::size_t i = 0; i < units.size(); ++i)
    if (units[i] > max_cell_value)
      tacmap::detail::fail<protocol_error>("frame payload: cell ", i, " = ", units[i],
                                           "; expected 12-bit data (0..4095) — corrupt frame");
  frame.cells = std::move(units);
  return frame;
}

/// Counts image (rows = res_y, cols = res_x) from the `res_x * res_y` cells of one matrix.
inline image<float> cells_to_counts(std::span<const std::uint16_t> cells, std::size_t res_x,
                                    std::size_t res_y, cell_order order) {
  if (cells.size() != res_x * res_y)
    tacmap::detail::fail<std::invalid_argument>("weiss::cells_to_counts: ", cells.size(),
                                                " cells for a ", res_x, " x ", res_y,
                                                " matrix; expected ", res_x * res_y);
  image<float> counts(static_cast<Eigen::Index>(res_y), static_cast<Eigen::Index>(res_x));
  for (std::size_t y = 0; y < res_y; ++y)
    for (std::size_t x = 0; x < res_x; ++x)
      counts(static_cast<Eigen::Index>(y), static_cast<Eigen::Index>(x)) =
          static_cast<float>(cells[cell_index(x, y, res_x, res_y, order)]);
  return counts;
}

// ------------------------------------------------------------------------------------------
// Matrix information and identity replies (data after the status word)
// ------------------------------------------------------------------------------------------

/// One sensor matrix as the device describes it. res_x = columns, res_y = rows (for the 14 x 6
/// array expect res_x = 6, res_y = 14 — inferred; always read it from the device).
struct matrix_info {
  std::uint16_t res_x = 0;
  std::uint16_t res_y = 0;
  double cell_width_mm = 0.0;
  double cell_height_mm = 0.0;
  double full_scale = 0.0;  ///< largest count the matrix reports (4095 for 12-bit data)
  friend bool operator==(const matrix_info&, const matrix_info&) = default;

  std::size_t cell_count() const noexcept {
    return static_cast<std::size_t>(res_x) * static_cast<std::size_t>(res_y);
  }

  /// The matrix as a `taxel_geometry`; throws protocol_error for an empty matrix or for
  /// non-square cells (taxel_geometry has one pitch).
  taxel_geometry geometry() const {
    if (res_x == 0 || res_y == 0)
      tacmap::detail::fail<protocol_error>("matrix info: ", res_x, " x ", res_y,
                                           " cells; expected a non-empty matrix — is a sensor "
                                           "matrix connected to the controller?");
    if (!(std::isfinite(cell_width_mm) && cell_width_mm > 0.0 && std::isfinite(cell_height_mm) &&
          cell_height_mm > 0.0))
      tacmap::detail::fail<protocol_error>("matrix info: cell size ", cell_width_mm, " x ",
                                           cell_height_mm, " mm; expected finite sizes > 0 mm");
    if (std::abs(cell_width_mm - cell_height_mm) > 1e-3)
      tacmap::detail::fail<protocol_error>(
          "matrix info: cells are ", cell_width_mm, " x ", cell_height_mm,
          " mm; tacmap's taxel_geometry needs square cells (one pitch) — resample the frames "
          "yourself for this sensor");
    taxel_geometry g;
    g.rows = static_cast<Eigen::Index>(res_y);
    g.cols = static_cast<Eigen::Index>(res_x);
    g.pitch_mm = cell_width_mm;
    return g;
  }
};

/// A `tactile_frame` from one matrix of a decoded frame payload. The matrix's cells start at
/// `offset` in `frame.cells` (the cell count of the matrices before it; 0 for a WTS module).
/// The receipt time and sequence number are the caller's to fill in.
inline tactile_frame make_tactile_frame(const frame_payload& frame, const matrix_info& matrix,
                                        cell_order order, std::size_t offset = 0) {
  if (offset > frame.cells.size() || frame.cells.size() - offset < matrix.cell_count())
    tacmap::detail::fail<protocol_error>(
        "frame: ", frame.cells.size(), " cells, but a ", matrix.res_x, " x ", matrix.res_y,
        " matrix at offset ", offset, " needs ", offset + matrix.cell_count(),
        " — corrupt frame or wrong geometry (query the matrix info again)");
  tactile_frame f;
  f.geometry = matrix.geometry();
  f.counts = cells_to_counts(std::span(frame.cells).subspan(offset, matrix.cell_count()),
                             matrix.res_x, matrix.res_y, order);
  return f;
}

namespace detail {
/// f32 millimetres carry ~7 digits; round to 1 um so 3.4f reads as 3.4.
inline double round_um(float mm) { return std::round(static_cast<double>(mm) * 1000.0) / 1000.0; }
}  // namespace detail

/// WTS 30h reply data: u16 res_x, u16 res_y, u16 cell width, u16 cell height (0.01 mm units,
/// one source), u16 full scale.
inline matrix_info parse_wts_matrix_info(std::span<const std::uint8_t> data) {
  detail::byte_reader in(data, "WTS matrix info (30h) reply");
  matrix_info m;
  m.res_x = in.u16("res_x");
  m.res_y = in.u16("res_y");
  m.cell_width_mm = static_cast<double>(in.u16("cell_width")) / 100.0;
  m.cell_height_mm = static_cast<double>(in.u16("cell_height")) / 100.0;
  m.full_scale = static_cast<double>(in.u16("full_scale"));
  return m;
}

inline std::vector<std::uint8_t> encode_wts_matrix_info(const matrix_info& m) {
  std::vector<std::uint8_t> out;
  detail::put_u16(out, m.res_x);
  detail::put_u16(out, m.res_y);
  detail::put_u16(out, static_cast<std::uint16_t>(std::lround(m.cell_width_mm * 100.0)));
  detail::put_u16(out, static_cast<std::uint16_t>(std::lround(m.cell_height_mm * 100.0)));
  detail::put_u16(out, static_cast<std::uint16_t>(std::lround(m.full_scale)));
  return out;
}

/// DSACON32m 0Bh reply (52 bytes with the status word).
struct dsacon32m_matrix_info {
  matrix_info matrix;
  std::array<std::uint8_t, 6> uid{};
  std::uint8_t hw_revision = 0;
  std::array<float, 3> center_mm{};
  std::array<float, 3> theta{};
  std::uint32_t full_scale_raw = 0;  ///< f32 in one driver, i32 in another: kept raw
  std::uint8_t flags = 0;
};

/// Full scale from the ambiguous 4-byte field: a plausible i32 (1..65535) wins, else a finite
/// positive f32, else 4095. The two readings never overlap for real values (an i32 4095 is a
/// denormal float; a float 4095.0 is a huge integer).
inline double dsacon32m_full_scale(std::uint32_t raw) {
  if (raw >= 1 && raw <= 65535) return static_cast<double>(raw);
  const float f = std::bit_cast<float>(raw);
  if (std::isfinite(f) && f >= 1.0F && f <= 65535.0F) return static_cast<double>(f);
  return static_cast<double>(max_cell_value);
}

inline dsacon32m_matrix_info parse_dsacon32m_matrix_info(std::span<const std::uint8_t> data) {
  detail::byte_reader in(data, "DSACON32m matrix info (0Bh) reply");
  dsacon32m_matrix_info info;
  info.matrix.cell_width_mm = detail::round_um(in.f32("texel_width"));
  info.matrix.cell_height_mm = detail::round_um(in.f32("texel_height"));
  info.matrix.res_x = in.u16("cells_x");
  info.matrix.res_y = in.u16("cells_y");
  const auto uid = in.bytes(6, "uid");
  std::copy(uid.begin(), uid.end(), info.uid.begin());
  (void)in.bytes(2, "reserved");
  info.hw_revision = in.u8("hw_revision");
  for (auto& c : info.center_mm) c = in.f32("center");
  for (auto& t : info.theta) t = in.f32("theta");
  info.full_scale_raw = in.u32("full_scale");
  info.flags = in.u8("flags");
  info.matrix.full_scale = dsacon32m_full_scale(info.full_scale_raw);
  return info;
}

inline std::vector<std::uint8_t> encode_dsacon32m_matrix_info(const dsacon32m_matrix_info& info) {
  std::vector<std::uint8_t> out;
  detail::put_f32(out, static_cast<float>(info.matrix.cell_width_mm));
  detail::put_f32(out, static_cast<float>(info.matrix.cell_height_mm));
  detail::put_u16(out, info.matrix.res_x);
  detail::put_u16(out, info.matrix.res_y);
  out.insert(out.end(), info.uid.begin(), info.uid.end());
  out.insert(out.end(), 2, std::uint8_t{0});
  detail::put_u8(out, info.hw_revision);
  for (const float c : info.center_mm) detail::put_f32(out, c);
  for (const float t : info.theta) detail::put_f32(out, t);
  detail::put_u32(out, info.full_scale_raw);
  detail::put_u8(out, info.flags);
  return out;
}

/// WTS 50h reply data: u8 type, u8 hw_rev, u16 firmware (one version digit per nibble), u32 serial.
struct wts_system_info {
  std::uint8_t type = 0;
  std::uint8_t hw_revision = 0;
  std::uint16_t firmware = 0;
  std::uint32_t serial = 0;
  friend bool operator==(const wts_system_info&, const wts_system_info&) = default;

  /// "1.2.3.4" from the firmware nibbles, most significant first.
  std::string firmware_string() const {
    std::string s;
    for (int shift = 12; shift >= 0; shift -= 4) {
      s += std::to_string((firmware >> static_cast<unsigned>(shift)) & 0xFU);
      if (shift > 0) s += '.';
    }
    return s;
  }
};

inline wts_system_info parse_wts_system_info(std::span<const std::uint8_t> data) {
  detail::byte_reader in(data, "WTS system info (50h) reply");
  wts_system_info s;
  s.type = in.u8("type");
  s.hw_revision = in.u8("hw_rev");
  s.firmware = in.u16("firmware");
  s.serial = in.u32("serial");
  return s;
}

inline std::vector<std::uint8_t> encode_wts_system_info(const wts_system_info& s) {
  std::vector<std::uint8_t> out;
  detail::put_u8(out, s.type);
  detail::put_u8(out, s.hw_revision);
  detail::put_u16(out, s.firmware);
  detail::put_u32(out, s.serial);
  return out;
}

/// DSACON32m 01h reply data. The documented struct has 19 bytes with the status; firmware
/// actually sends 18, i.e. only one byte of `can_id` — so it is optional and read only when
/// both bytes are there.
struct dsacon32m_controller_info {
  std::uint32_t serial = 0;
  std::uint8_t hw_version = 0;
  std::uint16_t sw_version = 0;
  std::uint8_t status_flags = 0;  ///< bit7 operable, bit6 acquisition running
  std::uint8_t feature_flags = 0;
  std::uint8_t senscon_type = 0;
  std::uint8_t active_interface = 0;
  std::uint32_t can_baudrate = 0;
  std::optional<std::uint16_t> can_id;
  friend bool operator==(const dsacon32m_controller_info&,
                         const dsacon32m_controller_info&) = default;
};

inline dsacon32m_controller_info parse_dsacon32m_controller_info(
    std::span<const std::uint8_t> data) {
  detail::byte_reader in(data, "DSACON32m controller info (01h) reply");
  dsacon32m_controller_info c;
  c.serial = in.u32("serial");
  c.hw_version = in.u8("hw_version");
  c.sw_version = in.u16("sw_version");
  c.status_flags = in.u8("status_flags");
  c.feature_flags = in.u8("feature_flags");
  c.senscon_type = in.u8("senscon_type");
  c.active_interface = in.u8("active_interface");
  c.can_baudrate = in.u32("can_baudrate");
  if (in.remaining() >= 2) c.can_id = in.u16("can_id");
  return c;
}

inline std::vector<std::uint8_t> encode_dsacon32m_controller_info(
    const dsacon32m_controller_info& c) {
  std::vector<std::uint8_t> out;
  detail::put_u32(out, c.serial);
  detail::put_u8(out, c.hw_version);
  detail::put_u16(out, c.sw_version);
  detail::put_u8(out, c.status_flags);
  detail::put_u8(out, c.feature_flags);
  detail::put_u8(out, c.senscon_type);
  detail::put_u8(out, c.active_interface);
  detail::put_u32(out, c.can_baudrate);
  if (c.can_id) detail::put_u16(out, *c.can_id);
  return out;
}

/// DSACON32m 02h reply data (12 bytes with the status).
struct dsacon32m_sensor_info {
  std::uint16_t matrix_count = 0;
  std::uint16_t generated_by = 0;
  std::uint8_t hw_revision = 0;
  std::uint32_t serial = 0;
  std::uint8_t feature_flags = 0;
  friend bool operator==(const dsacon32m_sensor_info&, const dsacon32m_sensor_info&) = default;
};

inline dsacon32m_sensor_info parse_dsacon32m_sensor_info(std::span<const std::uint8_t> data) {
  detail::byte_reader in(data, "DSACON32m sensor info (02h) reply");
  dsacon32m_sensor_info s;
  s.matrix_count = in.u16("nb_matrices");
  s.generated_by = in.u16("generated_by");
  s.hw_revision = in.u8("hw_revision");
  s.serial = in.u32("serial");
  s.feature_flags = in.u8("feature_flags");
  return s;
}

inline std::vector<std::uint8_t> encode_dsacon32m_sensor_info(const dsacon32m_sensor_info& s) {
  std::vector<std::uint8_t> out;
  detail::put_u16(out, s.matrix_count);
  detail::put_u16(out, s.generated_by);
  detail::put_u8(out, s.hw_revision);
  detail::put_u32(out, s.serial);
  detail::put_u8(out, s.feature_flags);
  return out;
}

}  // namespace tacmap::weiss
