// Weiss codec: CRC16, framing of both families, frame payloads, RLE, status codes and the
// matrix-info replies. Every byte vector of /work/shared/reference/weiss-tactile-protocols.md
// appears here verbatim.
#include <doctest/doctest.h>

#include <cstdint>
#include <string_view>
#include <utility>
#include <vector>

#include "tacmap/devices/weiss/codec.hpp"

namespace test_codec {

namespace w = tacmap::weiss;
using bytes = std::vector<std::uint8_t>;

namespace {

std::span<const std::uint8_t> ascii(std::string_view s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

}  // namespace

TEST_CASE("crc16: table, check value, residue and the preamble value") {
  CHECK(w::detail::crc16_table[0] == 0x0000);
  CHECK(w::detail::crc16_table[1] == 0x1021);
  CHECK(w::detail::crc16_table[255] == 0x1EF0);
  CHECK(w::crc16(ascii("123456789")) == 0x6EB4);
  static_assert(w::crc16(std::span<const std::uint8_t>{}) == 0xFFFF);
  const bytes pre{0xAA, 0xAA, 0xAA};
  CHECK(w::crc16(pre) == 0x50F5);
  // Continuing from a partial CRC equals one pass.
  CHECK(w::crc16(ascii("6789"), w::crc16(ascii("12345"))) == 0x6EB4);
  // Residue: message followed by its CRC, low byte first, gives 0.
  bytes msg{0xAA, 0xAA, 0xAA, 0x01, 0x02, 0x00, 0x12, 0x34};
  const std::uint16_t crc = w::crc16(msg);
  CHECK(crc == 0x666D);
  msg.push_back(static_cast<std::uint8_t>(crc & 0xFF));
  msg.push_back(static_cast<std::uint8_t>(crc >> 8));
  CHECK(w::crc16(msg) == 0x0000);
  // Not CRC-16/CCITT-FALSE (0x29B1) nor X-25 (0x906E).
  CHECK(w::crc16(ascii("123456789")) != 0x29B1);
  CHECK(w::crc16(ascii("123456789")) != 0x906E);
}

TEST_CASE("crc16: the vendor's mix is weaker than a CRC (codec.hpp): 13 bits, blind bursts") {
  // One step maps the state difference 0xA189 to 0: T[0x89] = 0x00A1.
  CHECK(w::detail::crc16_table[0x89] == 0x00A1);
  CHECK((w::crc16_update(0xA189, 0x00) ^ w::crc16_update(0x0000, 0x00)) == 0);
  // After three steps the reachable states are 2^13 of the 2^16 (for all 65536 starts).
  std::vector<bool> seen(65536);
  std::size_t reachable = 0;
  for (std::uint32_t s = 0; s < 65536U; ++s) {
    std::uint16_t c = static_cast<std::uint16_t>(s);
    for (int k = 0; k < 3; ++k) c = w::crc16_update(c, 0);
    if (!seen[c]) ++reachable;
    seen[c] = true;
  }
  CHECK(reachable == 8192);
  // Exactly seven 2-byte bursts go unnoticed wherever three or more bytes follow them, in any
  // message; a CRC-16 has none.
  bytes message(40);
  for (std::size_t i = 0; i < message.size(); ++i) message[i] = static_cast<std::uint8_t>(i * 37);
  const std::uint16_t good = w::crc16(message);
  std::vector<std::pair<int, int>> blind;
  for (int a = 1; a < 256; ++a)
    for (int b = 0; b < 256; ++b) {
      bytes hit = message;
      hit[17] = static_cast<std::uint8_t>(hit[17] ^ a);
      hit[18] = static_cast<std::uint8_t>(hit[18] ^ b);
      if (w::crc16(hit) == good) blind.emplace_back(a, b);
    }
  CHECK(blind == std::vector<std::pair<int, int>>{{0x0A, 0xC3},
                                                  {0x17, 0x55},
                                                  {0x1D, 0x96},
                                                  {0x83, 0x62},
                                                  {0x89, 0xA1},
                                                  {0x94, 0x37},
                                                  {0x9E, 0xF4}});
}

TEST_CASE("encode_packet: every WTS vector of the reference, byte for byte") {
  const auto wts = w::protocol_family::wts;
  CHECK(w::encode_packet(wts, 0x01, bytes{0x12, 0x34}) ==
        bytes{0xAA, 0xAA, 0xAA, 0x01, 0x02, 0x00, 0x12, 0x34, 0x6D, 0x66});
  CHECK(w::encode_packet(wts, 0x01, {}) == bytes{0xAA, 0xAA, 0xAA, 0x01, 0x00, 0x00, 0xE8, 0x10});
  CHECK(w::encode_packet(wts, w::wts_command::loop, {}) ==
        bytes{0xAA, 0xAA, 0xAA, 0x06, 0x00, 0x00, 0x97, 0x26});
  CHECK(w::encode_packet(wts, w::wts_command::matrix_info, {}) ==
        bytes{0xAA, 0xAA, 0xAA, 0x30, 0x00, 0x00, 0xCA, 0xCF});
  CHECK(w::encode_packet(wts, w::wts_command::stop_periodic, {}) ==
        bytes{0xAA, 0xAA, 0xAA, 0x22, 0x00, 0x00, 0x0E, 0x76});
  CHECK(w::encode_packet(wts, 0x22, bytes{0x00, 0x00}) ==
        bytes{0xAA, 0xAA, 0xAA, 0x22, 0x02, 0x00, 0x00, 0x00, 0xA7, 0x2E});
  CHECK(w::encode_packet(wts, w::wts_command::start_periodic, bytes{0x00, 0x32, 0x00}) ==
        bytes{0xAA, 0xAA, 0xAA, 0x21, 0x03, 0x00, 0x00, 0x32, 0x00, 0xF3, 0x5E});
  CHECK(w::encode_packet(wts, 0x21, bytes{0x00, 0x00}) ==
        bytes{0xAA, 0xAA, 0xAA, 0x21, 0x02, 0x00, 0x00, 0x00, 0x28, 0x04});
  CHECK(w::encode_packet(wts, w::wts_command::read_single_frame, bytes{0x00}) ==
        bytes{0xAA, 0xAA, 0xAA, 0x20, 0x01, 0x00, 0x00, 0x8F, 0x83});
  // Matrix info reply, 6 x 14, 3.4 mm, full scale 4095 — built from the struct.
  w::matrix_info m{6, 14, 3.4, 3.4, 4095.0};
  bytes reply{0x00, 0x00};
  const bytes data = w::encode_wts_matrix_info(m);
  reply.insert(reply.end(), data.begin(), data.end());
  CHECK(w::encode_packet(wts, 0x30, reply) == bytes{0xAA, 0xAA, 0xAA, 0x30, 0x0C, 0x00, 0x00,
                                                    0x00, 0x06, 0x00, 0x0E, 0x00, 0x54, 0x01,
                                                    0x54, 0x01, 0xFF, 0x0F, 0x59, 0x3E});
}

TEST_CASE("encode_packet: DSACON32m excludes the preamble from the CRC and omits it when empty") {
  const auto dsa = w::protocol_family::dsacon32m;
  CHECK(
      w::encode_packet(dsa, w::dsacon32m_command::configure_acquisition, bytes{0x81, 0x1E, 0x00}) ==
      bytes{0xAA, 0xAA, 0xAA, 0x03, 0x03, 0x00, 0x81, 0x1E, 0x00, 0x2C, 0x76});
  CHECK(w::encode_packet(dsa, w::dsacon32m_command::matrix_info, bytes{0x00}) ==
        bytes{0xAA, 0xAA, 0xAA, 0x0B, 0x01, 0x00, 0x00, 0xCB, 0xFB});
  CHECK(w::encode_packet(dsa, w::dsacon32m_command::controller_info, {}) ==
        bytes{0xAA, 0xAA, 0xAA, 0x01, 0x00, 0x00});
  // The DSACON32m CRC is the CRC of everything after the preamble.
  const bytes p = w::encode_packet(dsa, 0x06, bytes{1, 2, 3});
  CHECK(w::crc16(std::span(p).subspan(3)) == 0x0000);
  CHECK(w::crc16(p) != 0x0000);
  // ... and the WTS one covers the preamble too.
  const bytes q = w::encode_packet(w::protocol_family::wts, 0x06, bytes{1, 2, 3});
  CHECK(w::crc16(q) == 0x0000);
  CHECK_THROWS_AS(w::encode_packet(dsa, 0xAA, {}), std::invalid_argument);
  CHECK_THROWS_AS(w::encode_packet(dsa, 0x06, bytes(70000, 0)), std::invalid_argument);
}

TEST_CASE("parser: decodes every reference vector and routes replies apart from frames") {
  w::packet_parser parser(w::protocol_family::wts);
  parser.feed(bytes{0xAA, 0xAA, 0xAA, 0x22, 0x02, 0x00, 0x00, 0x00, 0xA7, 0x2E});
  parser.feed(bytes{0xAA, 0xAA, 0xAA, 0x30, 0x0C, 0x00, 0x00, 0x00, 0x06, 0x00,
                    0x0E, 0x00, 0x54, 0x01, 0x54, 0x01, 0xFF, 0x0F, 0x59, 0x3E});
  const std::vector<std::uint16_t> cells(84, 7);
  parser.feed(w::encode_packet(w::protocol_family::wts, w::frame_id,
                               w::encode_frame_payload(99, cells, false)));
  CHECK(parser.stats().commands == 2);
  CHECK(parser.stats().frames == 1);
  CHECK(parser.stats().garbage_bytes == 0);
  auto ack = parser.pop_command();
  REQUIRE(ack);
  CHECK(ack->id == 0x22);
  CHECK(w::split_status(ack->payload, "ack").code == 0);
  auto info = parser.pop_command();
  REQUIRE(info);
  CHECK(info->id == 0x30);
  const auto split = w::split_status(info->payload, "matrix info");
  CHECK(split.code == 0);
  const w::matrix_info m = w::parse_wts_matrix_info(split.data);
  CHECK(m.res_x == 6);
  CHECK(m.res_y == 14);
  CHECK(m.cell_width_mm == doctest::Approx(3.4));
  CHECK(m.full_scale == 4095.0);
  const tacmap::taxel_geometry g = m.geometry();
  CHECK(g.rows == 14);
  CHECK(g.cols == 6);
  CHECK(g.pitch_mm == doctest::Approx(3.4));
  CHECK_FALSE(parser.pop_command());
  auto frame = parser.pop_frame();
  REQUIRE(frame);
  CHECK(w::decode_frame_payload(frame->payload, 84).timestamp == 99);

  w::packet_parser dsa(w::protocol_family::dsacon32m);
  dsa.feed(bytes{0xAA, 0xAA, 0xAA, 0x03, 0x03, 0x00, 0x81, 0x1E, 0x00, 0x2C, 0x76});
  dsa.feed(bytes{0xAA, 0xAA, 0xAA, 0x01, 0x00, 0x00});  // empty payload: no CRC
  dsa.feed(bytes{0xAA, 0xAA, 0xAA, 0x0B, 0x01, 0x00, 0x00, 0xCB, 0xFB});
  CHECK(dsa.stats().commands == 3);
  CHECK(dsa.stats().bad_crc == 0);
  CHECK(dsa.pop_command()->payload == bytes{0x81, 0x1E, 0x00});
  CHECK(dsa.pop_command()->payload.empty());
  CHECK(dsa.pop_command()->id == 0x0B);
  // A WTS packet read with DSACON32m rules fails the CRC (the coverage differs).
  dsa.feed(bytes{0xAA, 0xAA, 0xAA, 0x20, 0x01, 0x00, 0x00, 0x8F, 0x83});
  CHECK(dsa.stats().bad_crc == 1);
  CHECK_FALSE(dsa.pop_command());
}

TEST_CASE("frame payload: plain layout, size, 12-bit check") {
  std::vector<std::uint16_t> cells(84);
  for (std::size_t i = 0; i < cells.size(); ++i) cells[i] = static_cast<std::uint16_t>(i * 48);
  const bytes payload = w::encode_frame_payload(0x01020304, cells, false);
  CHECK(payload.size() == 173);  // 5 + 2 * 84, as the reference says
  CHECK(payload[0] == 0x04);
  CHECK(payload[3] == 0x01);
  CHECK(payload[4] == 0x00);
  CHECK(payload[5 + 2 * 10] == ((10 * 48) & 0xFF));
  CHECK(payload[5 + 2 * 10 + 1] == ((10 * 48) >> 8));
  const w::frame_payload f = w::decode_frame_payload(payload, 84);
  CHECK(f.timestamp == 0x01020304);
  CHECK_FALSE(f.rle());
  CHECK(f.cells == cells);
  CHECK_THROWS_AS(w::decode_frame_payload(payload, 85), w::protocol_error);
  CHECK_THROWS_AS(w::decode_frame_payload(std::span(payload).first(4), 84), w::protocol_error);
  CHECK_THROWS_AS(w::decode_frame_payload(std::span(payload).first(172), 84), w::protocol_error);
  bytes high = payload;
  high[6] = 0x10;  // cell 0 = 0x1000: above 12 bits
  CHECK_THROWS_WITH_AS(w::decode_frame_payload(high, 84), doctest::Contains("12-bit"),
                       w::protocol_error);
  cells[3] = 4096;
  CHECK_THROWS_AS(w::encode_frame_payload(0, cells, false), std::invalid_argument);
}

TEST_CASE("RLE: unit layout, runs longer than 15, count validation") {
  const std::vector<std::uint16_t> cells{5, 5, 5, 4095, 0, 0};
  const auto units = w::rle_encode(cells);
  REQUIRE(units.size() == 3);
  CHECK(units[0] == ((3 << 12) | 5));
  CHECK(units[1] == ((1 << 12) | 4095));
  CHECK(units[2] == ((2 << 12) | 0));
  CHECK(w::rle_decode(units, 6) == cells);

  const std::vector<std::uint16_t> long_run(40, 123);  // 15 + 15 + 10
  const auto lu = w::rle_encode(long_run);
  REQUIRE(lu.size() == 3);
  CHECK((lu[0] >> 12) == 15);
  CHECK((lu[2] >> 12) == 10);
  CHECK(w::rle_decode(lu, 40) == long_run);

  CHECK_THROWS_WITH_AS(w::rle_decode(units, 7), doctest::Contains("expected 7"), w::protocol_error);
  CHECK_THROWS_WITH_AS(w::rle_decode(units, 5), doctest::Contains("expands past 5"),
                       w::protocol_error);
  const std::vector<std::uint16_t> zero_count{0x0005};
  CHECK_THROWS_WITH_AS(w::rle_decode(zero_count, 1), doctest::Contains("repeat count 0"),
                       w::protocol_error);

  // Through a frame payload: the flag selects RLE, the payload is shorter.
  std::vector<std::uint16_t> frame(84, 0);
  frame[40] = 2000;
  const bytes packed = w::encode_frame_payload(7, frame, true);
  CHECK(packed[4] == w::frame_flag_rle);
  CHECK(packed.size() < 173);
  const auto decoded = w::decode_frame_payload(packed, 84);
  CHECK(decoded.rle());
  CHECK(decoded.cells == frame);
  CHECK_THROWS_AS(w::decode_frame_payload(packed, 83), w::protocol_error);
}

TEST_CASE("cells_to_counts: configurable cell order") {
  const std::size_t rx = 3, ry = 2;
  std::vector<std::uint16_t> cells(rx * ry);
  for (std::size_t i = 0; i < cells.size(); ++i) cells[i] = static_cast<std::uint16_t>(i);
  const auto a = w::cells_to_counts(cells, rx, ry, w::cell_order::x_fastest);
  REQUIRE(a.rows() == 2);
  REQUIRE(a.cols() == 3);
  CHECK(a(0, 0) == 0.0F);
  CHECK(a(0, 2) == 2.0F);  // x fastest along a row
  CHECK(a(1, 0) == 3.0F);
  const auto b = w::cells_to_counts(cells, rx, ry, w::cell_order::y_fastest);
  CHECK(b(1, 0) == 1.0F);  // y fastest down a column
  CHECK(b(0, 1) == 2.0F);
  CHECK(b(1, 2) == 5.0F);
  CHECK_THROWS_AS(w::cells_to_counts(cells, 4, 2, w::cell_order::x_fastest), std::invalid_argument);
}

TEST_CASE("status codes: names, and the DSACON32m shift from 12 on") {
  using w::status;
  const auto wts = w::protocol_family::wts;
  const auto dsa = w::protocol_family::dsacon32m;
  CHECK(w::status_name(status::success) == "E_SUCCESS");
  CHECK(w::status_name(status::file_exists) == "E_FILE_EXISTS");
  CHECK(w::status_from_wire(wts, 12) == status::no_param_expected);
  CHECK(w::status_from_wire(wts, 14) == status::cmd_unknown);
  CHECK(w::status_from_wire(wts, 30) == status::file_exists);
  CHECK_FALSE(w::status_from_wire(wts, 31));
  CHECK(w::status_from_wire(dsa, 11) == status::checksum_error);
  CHECK(w::status_from_wire(dsa, 12) == status::not_enough_params);
  CHECK(w::status_from_wire(dsa, 13) == status::cmd_unknown);
  CHECK(w::status_from_wire(dsa, 27) == status::range_error);
  CHECK_FALSE(w::status_from_wire(dsa, 28));
  CHECK(w::status_to_wire(dsa, status::cmd_unknown) == 13);
  CHECK(w::status_to_wire(wts, status::cmd_unknown) == 14);
  CHECK(w::status_to_wire(dsa, status::timeout) == 7);
  CHECK_THROWS_AS(w::status_to_wire(dsa, status::no_param_expected), std::invalid_argument);
  CHECK_THROWS_AS(w::status_to_wire(dsa, status::file_exists), std::invalid_argument);
  for (std::uint16_t code = 0; code <= 27; ++code)  // round trip over the DSACON32m range
    CHECK(w::status_to_wire(dsa, *w::status_from_wire(dsa, code)) == code);
  CHECK(w::describe_status(wts, 14) == "E_CMD_UNKNOWN (14)");
  CHECK(w::describe_status(dsa, 14) == "E_CMD_FORMAT_ERROR (14)");
  CHECK(w::describe_status(dsa, 99) == "unknown status (99)");
}

TEST_CASE("matrix info: WTS 30h and DSACON32m 0Bh into taxel_geometry") {
  // WTS: short reply fails loudly.
  const bytes shortish{0x06, 0x00, 0x0E, 0x00};
  CHECK_THROWS_WITH_AS(w::parse_wts_matrix_info(shortish), doctest::Contains("cell_width"),
                       w::protocol_error);
  // Non-square cells and empty matrices are refused when converting to taxel_geometry.
  CHECK_THROWS_AS((w::matrix_info{6, 14, 3.4, 3.0, 4095}.geometry()), w::protocol_error);
  CHECK_THROWS_AS((w::matrix_info{0, 14, 3.4, 3.4, 4095}.geometry()), w::protocol_error);

  // DSACON32m: 52 bytes with the status, f32 millimetres.
  w::dsacon32m_matrix_info info;
  info.matrix = {6, 14, 3.4, 3.4, 0};
  info.uid = {1, 2, 3, 4, 5, 6};
  info.hw_revision = 3;
  info.center_mm = {1.0F, 2.0F, 3.0F};
  info.theta = {0.5F, 0.0F, -0.5F};
  info.full_scale_raw = 4095;
  info.flags = 0x42;
  const bytes data = w::encode_dsacon32m_matrix_info(info);
  CHECK(data.size() + 2 == 52);
  const auto back = w::parse_dsacon32m_matrix_info(data);
  CHECK(back.matrix.res_x == 6);
  CHECK(back.matrix.res_y == 14);
  CHECK(back.matrix.cell_width_mm == 3.4);  // f32 rounded to 1 um: exactly the double 3.4
  CHECK(back.matrix.full_scale == 4095.0);
  CHECK(back.uid == info.uid);
  CHECK(back.center_mm == info.center_mm);
  CHECK(back.theta == info.theta);
  CHECK(back.flags == 0x42);
  CHECK(back.matrix.geometry() == tacmap::taxel_geometry{14, 6, 3.4});
  CHECK_THROWS_AS(w::parse_dsacon32m_matrix_info(std::span(data).first(49)), w::protocol_error);
  // The ambiguous full-scale field: an f32 4095.0 reads the same as an i32 4095.
  CHECK(w::dsacon32m_full_scale(std::bit_cast<std::uint32_t>(4095.0F)) == 4095.0);
  CHECK(w::dsacon32m_full_scale(4095U) == 4095.0);
  CHECK(w::dsacon32m_full_scale(0U) == 4095.0);
}

TEST_CASE("identity replies round-trip, the DSACON32m controller info may lack can_id") {
  w::wts_system_info s{2, 1, 0x1234, 987654};
  CHECK(w::parse_wts_system_info(w::encode_wts_system_info(s)) == s);
  CHECK(s.firmware_string() == "1.2.3.4");

  w::dsacon32m_controller_info c;
  c.serial = 42;
  c.sw_version = 288;
  c.status_flags = 0x80;
  c.can_baudrate = 1000000;
  bytes wire = w::encode_dsacon32m_controller_info(c);
  CHECK(wire.size() + 2 == 17);
  CHECK(w::parse_dsacon32m_controller_info(wire) == c);
  wire.push_back(0x23);  // firmware sends 18 bytes: half a can_id, which is ignored
  CHECK(w::parse_dsacon32m_controller_info(wire) == c);
  c.can_id = 0x123;
  wire = w::encode_dsacon32m_controller_info(c);
  CHECK(wire.size() + 2 == 19);  // the documented struct
  CHECK(w::parse_dsacon32m_controller_info(wire) == c);

  w::dsacon32m_sensor_info si{1, 7, 2, 555, 0};
  wire = w::encode_dsacon32m_sensor_info(si);
  CHECK(wire.size() + 2 == 12);
  CHECK(w::parse_dsacon32m_sensor_info(wire) == si);
}

TEST_CASE("make_tactile_frame: one matrix out of a multi-matrix frame, rows = res_y") {
  w::frame_payload fp;
  fp.cells.resize(2 * 3 * 2);
  for (std::size_t i = 0; i < fp.cells.size(); ++i) fp.cells[i] = static_cast<std::uint16_t>(i);
  const w::matrix_info m{3, 2, 3.4, 3.4, 4095};
  const tacmap::tactile_frame first = w::make_tactile_frame(fp, m, w::cell_order::x_fastest);
  CHECK(first.geometry == tacmap::taxel_geometry{2, 3, 3.4});
  CHECK(first.counts(1, 2) == 5.0F);
  const tacmap::tactile_frame second = w::make_tactile_frame(fp, m, w::cell_order::x_fastest, 6);
  CHECK(second.counts(0, 0) == 6.0F);
  CHECK(second.counts(1, 2) == 11.0F);
  CHECK_NOTHROW(second.validate());
  CHECK_THROWS_AS(w::make_tactile_frame(fp, m, w::cell_order::x_fastest, 7), w::protocol_error);
}

}  // namespace test_codec
