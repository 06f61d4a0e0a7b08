// Fuzz target: the Weiss byte-stream parser, frame payload decoding (plain and RLE) and the
// reply parsers — everything a misbehaving sensor or a noisy line can feed the host.
//
// Input layout: byte 0 picks the protocol family (bit 0) and the chunk size the stream is fed in
// (bits 1..7), byte 1 the cell count frames are decoded against; the rest is the byte stream.
// Besides "no crash, no sanitizer report, only protocol_error", it checks properties:
//  * the parser's counters add up and flush_partial() leaves nothing buffered;
//  * every accepted packet re-encodes to bytes that parse back to the same packet;
//  * a decoded frame has exactly the expected cells, all 12-bit, and survives an RLE round trip;
//  * replies that parse re-encode to bytes that parse to the same value.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "fuzz_check.hpp"
#include "tacmap/devices/weiss/codec.hpp"

namespace {

namespace w = tacmap::weiss;

void check_reencodes(w::protocol_family family, const w::packet& p) {
  const std::vector<std::uint8_t> wire = w::encode_packet(family, p.id, p.payload);
  w::packet_parser again(
      family,
      {.max_payload = w::max_wire_payload, .max_queued_frames = 4, .max_queued_commands = 4});
  again.feed(wire);
  auto q = p.id == w::frame_id ? again.pop_frame() : again.pop_command();
  TACMAP_FUZZ_CHECK(q.has_value());
  TACMAP_FUZZ_CHECK(q->id == p.id);
  TACMAP_FUZZ_CHECK(q->payload == p.payload);
  TACMAP_FUZZ_CHECK(again.stats().garbage_bytes == 0 && again.buffered() == 0);
}

void check_frame(const w::packet& p, std::size_t cells) {
  w::frame_payload f;
  try {
    f = w::decode_frame_payload(p.payload, cells);
  } catch (const w::protocol_error&) {
    return;
  }
  TACMAP_FUZZ_CHECK(f.cells.size() == cells);
  TACMAP_FUZZ_CHECK(std::all_of(f.cells.begin(), f.cells.end(),
                                [](std::uint16_t c) { return c <= w::max_cell_value; }));
  const std::vector<std::uint16_t> units = w::rle_encode(f.cells);
  TACMAP_FUZZ_CHECK(w::rle_decode(units, cells) == f.cells);
  const std::vector<std::uint8_t> plain = w::encode_frame_payload(f.timestamp, f.cells, false);
  const w::frame_payload back = w::decode_frame_payload(plain, cells);
  TACMAP_FUZZ_CHECK(back.cells == f.cells && back.timestamp == f.timestamp);
}

template <class Parse, class Encode>
void check_reply(std::span<const std::uint8_t> data, Parse parse, Encode encode) {
  try {
    const auto value = parse(data);
    const auto bytes = encode(value);
    TACMAP_FUZZ_CHECK(parse(bytes) == value);
  } catch (const w::protocol_error&) {
  }
}

void check_command(const w::packet& p) {
  std::span<const std::uint8_t> data;
  try {
    data = w::split_status(p.payload, "fuzzed reply").data;
  } catch (const w::protocol_error&) {
    return;
  }
  check_reply(data, w::parse_wts_matrix_info, w::encode_wts_matrix_info);
  check_reply(data, w::parse_wts_system_info, w::encode_wts_system_info);
  check_reply(data, w::parse_dsacon32m_sensor_info, w::encode_dsacon32m_sensor_info);
  check_reply(data, w::parse_dsacon32m_controller_info, w::encode_dsacon32m_controller_info);
  try {  // floats may be NaN (NaN != NaN): only decode, and ask for the geometry
    const w::dsacon32m_matrix_info m = w::parse_dsacon32m_matrix_info(data);
    (void)m.matrix.geometry();
  } catch (const w::protocol_error&) {
  }
  try {
    (void)w::parse_wts_matrix_info(data).geometry();
  } catch (const w::protocol_error&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  const w::protocol_family family =
      (data[0] & 1U) != 0 ? w::protocol_family::dsacon32m : w::protocol_family::wts;
  const std::size_t chunk = 1U + (static_cast<std::size_t>(data[0]) >> 1U) % 64U;
  const std::size_t cells = 1U + static_cast<std::size_t>(data[1]) % 200U;
  const std::span<const std::uint8_t> stream(data + 2, size - 2);

  w::packet_parser parser(family,
                          {.max_payload = 1024, .max_queued_frames = 8, .max_queued_commands = 8});
  const auto drain = [&] {
    while (auto p = parser.pop_frame()) {
      check_reencodes(family, *p);
      check_frame(*p, cells);
    }
    while (auto p = parser.pop_command()) {
      check_reencodes(family, *p);
      check_command(*p);
    }
  };
  for (std::size_t offset = 0; offset < stream.size(); offset += chunk) {
    parser.feed(stream.subspan(offset, std::min(chunk, stream.size() - offset)));
    drain();
  }
  parser.flush_partial();
  drain();
  const w::parser_stats& s = parser.stats();
  TACMAP_FUZZ_CHECK(s.bytes == stream.size());
  TACMAP_FUZZ_CHECK(s.packets == s.frames + s.commands);
  TACMAP_FUZZ_CHECK(parser.buffered() == 0);
  TACMAP_FUZZ_CHECK(s.garbage_bytes <= s.bytes);

  // RLE decoding straight from the stream's bytes, as u16 units.
  std::vector<std::uint16_t> units(stream.size() / 2);
  for (std::size_t i = 0; i < units.size(); ++i)
    units[i] = static_cast<std::uint16_t>(stream[2 * i] | (stream[2 * i + 1] << 8U));
  try {
    const std::vector<std::uint16_t> decoded = w::rle_decode(units, cells);
    TACMAP_FUZZ_CHECK(decoded.size() == cells);
  } catch (const w::protocol_error&) {
  }
  return 0;
}
