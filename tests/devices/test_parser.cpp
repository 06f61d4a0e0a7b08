// Weiss byte-stream parser: resynchronisation, rejection and counting, with the stream cut into
// random chunk sizes (a serial port delivers arbitrary pieces).
#include <doctest/doctest.h>

#include <cstdint>
#include <random>
#include <vector>

#include "tacmap/devices/weiss/codec.hpp"

namespace test_parser {

namespace w = tacmap::weiss;
using bytes = std::vector<std::uint8_t>;

namespace {

struct expected_packet {
  std::uint8_t id;
  bytes payload;
};

/// Feeds `stream` in random chunks of 1..max_chunk bytes (0-byte chunks included).
void feed_chunked(w::packet_parser& parser, const bytes& stream, std::mt19937& rng,
                  std::size_t max_chunk) {
  std::uniform_int_distribution<std::size_t> chunk(0, max_chunk);
  std::size_t pos = 0;
  while (pos < stream.size()) {
    const std::size_t n = std::min(chunk(rng), stream.size() - pos);
    parser.feed(std::span(stream).subspan(pos, n));
    pos += n;
  }
}

/// Pops everything, frames and commands, and checks them against `sent` in order per kind.
void check_received(w::packet_parser& parser, const std::vector<expected_packet>& sent) {
  std::vector<expected_packet> frames, commands;
  for (const auto& p : sent) (p.id == w::frame_id ? frames : commands).push_back(p);
  for (const auto& e : frames) {
    auto p = parser.pop_frame();
    REQUIRE(p);
    CHECK(p->id == e.id);
    CHECK(p->payload == e.payload);
  }
  for (const auto& e : commands) {
    auto p = parser.pop_command();
    REQUIRE(p);
    CHECK(p->id == e.id);
    CHECK(p->payload == e.payload);
  }
  CHECK_FALSE(parser.pop_frame());
  CHECK_FALSE(parser.pop_command());
}

bytes random_payload(std::mt19937& rng, std::size_t max_size) {
  std::uniform_int_distribution<std::size_t> size(0, max_size);
  std::uniform_int_distribution<int> byte(0, 255);
  bytes p(size(rng));
  for (auto& b : p) b = static_cast<std::uint8_t>(byte(rng));
  return p;
}

std::uint8_t random_id(std::mt19937& rng) {
  std::uniform_int_distribution<int> id(0, 0x60);
  const auto v = static_cast<std::uint8_t>(id(rng));
  return v % 3 == 0 ? w::frame_id : v;  // about a third streamed frames
}

}  // namespace

TEST_CASE("parser: random packets, random non-preamble garbage, random chunk sizes") {
  for (const auto family : {w::protocol_family::wts, w::protocol_family::dsacon32m}) {
    for (unsigned seed = 1; seed <= 20; ++seed) {
      CAPTURE(seed);
      std::mt19937 rng(seed);
      std::uniform_int_distribution<int> garbage_len(0, 12);
      std::uniform_int_distribution<int> garbage_byte(0, 254);  // never 0xAA below
      bytes stream;
      std::size_t garbage = 0;
      std::vector<expected_packet> sent;
      for (int i = 0; i < 60; ++i) {
        const int g = garbage_len(rng);
        for (int k = 0; k < g; ++k) {
          auto b = static_cast<std::uint8_t>(garbage_byte(rng));
          stream.push_back(b == 0xAA ? std::uint8_t{0x55} : b);
        }
        garbage += static_cast<std::size_t>(g);
        expected_packet p{random_id(rng), random_payload(rng, 200)};
        const bytes wire = w::encode_packet(family, p.id, p.payload);
        stream.insert(stream.end(), wire.begin(), wire.end());
        sent.push_back(std::move(p));
      }
      w::packet_parser parser(family);
      feed_chunked(parser, stream, rng, 1 + seed * 7);
      CHECK(parser.stats().bytes == stream.size());
      CHECK(parser.stats().packets == sent.size());
      CHECK(parser.stats().garbage_bytes == garbage);
      CHECK(parser.stats().bad_crc == 0);
      CHECK(parser.stats().bad_size == 0);
      CHECK(parser.buffered() == 0);
      check_received(parser, sent);
    }
  }
}

TEST_CASE("parser: adversarial garbage — preamble runs, fake headers, corrupt packets") {
  const auto family = w::protocol_family::wts;
  for (unsigned seed = 100; seed < 130; ++seed) {
    CAPTURE(seed);
    std::mt19937 rng(seed);
    std::uniform_int_distribution<int> kind(0, 5);
    bytes stream;
    std::size_t packet_bytes = 0;
    std::vector<expected_packet> sent;
    for (int i = 0; i < 40; ++i) {
      switch (kind(rng)) {
        case 0:  // partial and over-long preamble runs
          stream.insert(stream.end(), {0xAA, 0xAA});
          break;
        case 1:
          stream.insert(stream.end(), {0xAA, 0xAA, 0xAA, 0xAA, 0xAA});
          break;
        case 2:  // a header announcing an impossible size
          stream.insert(stream.end(), {0xAA, 0xAA, 0xAA, 0x21, 0xFF, 0x7F});
          break;
        case 3: {  // a complete packet with one payload byte flipped: bad CRC
          bytes bad = w::encode_packet(family, 0x30, bytes{1, 2, 3, 4});
          bad[7] ^= 0x40;
          stream.insert(stream.end(), bad.begin(), bad.end());
          break;
        }
        case 4: {  // a truncated packet: header promises more than follows
          const bytes whole = w::encode_packet(family, 0x00, bytes(40, 9));
          stream.insert(stream.end(), whole.begin(), whole.begin() + 20);
          break;
        }
        default:
          break;
      }
      expected_packet p{random_id(rng), random_payload(rng, 60)};
      const bytes wire = w::encode_packet(family, p.id, p.payload);
      stream.insert(stream.end(), wire.begin(), wire.end());
      packet_bytes += wire.size();
      sent.push_back(std::move(p));
    }
    w::packet_parser parser(family, {.max_payload = 300});
    feed_chunked(parser, stream, rng, 33);
    parser.flush_partial();  // end of stream: nothing may stay pending
    CHECK(parser.buffered() == 0);
    CHECK(parser.stats().packets == sent.size());
    CHECK(parser.stats().garbage_bytes == stream.size() - packet_bytes);
    check_received(parser, sent);
  }
}

TEST_CASE("parser: a bad CRC is counted and only that packet is lost") {
  const auto family = w::protocol_family::dsacon32m;
  bytes a = w::encode_packet(family, 0x00, bytes(173, 1));
  bytes b = w::encode_packet(family, 0x00, bytes(173, 2));
  const bytes c = w::encode_packet(family, 0x00, bytes(173, 3));
  b[b.size() - 1] ^= 0x01;  // corrupt b's CRC
  bytes stream = a;
  stream.insert(stream.end(), b.begin(), b.end());
  stream.insert(stream.end(), c.begin(), c.end());
  w::packet_parser parser(family);
  parser.feed(stream);
  CHECK(parser.stats().bad_crc == 1);
  CHECK(parser.stats().frames == 2);
  CHECK(parser.stats().garbage_bytes == b.size());
  CHECK(parser.pop_frame()->payload[0] == 1);
  CHECK(parser.pop_frame()->payload[0] == 3);
}

TEST_CASE("parser: a truncated packet does not swallow the next one") {
  const auto family = w::protocol_family::wts;
  const bytes whole = w::encode_packet(family, 0x00, bytes(173, 5));
  const bytes next = w::encode_packet(family, 0x20, bytes{0, 0, 1});
  std::mt19937 rng(7);
  bytes stream(whole.begin(), whole.begin() + 90);
  stream.insert(stream.end(), next.begin(), next.end());
  // Streamed case: more data arrives later and completes the bogus candidate, whose CRC fails;
  // the rescan finds `next` inside it.
  w::packet_parser parser(family);
  feed_chunked(parser, stream, rng, 16);
  CHECK(parser.stats().commands == 0);  // still waiting: the header promised 173 bytes
  parser.feed(bytes(120, 0x00));
  CHECK(parser.stats().bad_crc == 1);
  auto p = parser.pop_command();
  REQUIRE(p);
  CHECK(p->id == 0x20);
  // Quiet-line case: nothing more arrives; flush_partial gives up on the candidate.
  w::packet_parser quiet(family);
  feed_chunked(quiet, stream, rng, 16);
  CHECK_FALSE(quiet.pop_command());
  quiet.flush_partial();
  CHECK(quiet.stats().truncated == 1);
  CHECK(quiet.buffered() == 0);
  p = quiet.pop_command();
  REQUIRE(p);
  CHECK(p->payload == bytes{0, 0, 1});
  CHECK(quiet.stats().garbage_bytes == 90);
}

TEST_CASE("parser: impossible sizes are rejected at the header, without waiting") {
  const auto family = w::protocol_family::wts;
  w::packet_parser parser(family, {.max_payload = 200});
  bytes stream{0xAA, 0xAA, 0xAA, 0x00, 0xC9, 0x00};  // 201 > 200
  const bytes good = w::encode_packet(family, 0x38, bytes{'W', 'T', 'S'});
  stream.insert(stream.end(), good.begin(), good.end());
  parser.feed(stream);
  CHECK(parser.stats().bad_size == 1);
  CHECK(parser.stats().garbage_bytes == 6);
  auto p = parser.pop_command();
  REQUIRE(p);
  CHECK(p->payload == bytes{'W', 'T', 'S'});
  // A payload of exactly max_payload is fine.
  w::packet_parser edge(family, {.max_payload = 200});
  edge.feed(w::encode_packet(family, 0x00, bytes(200, 1)));
  CHECK(edge.stats().frames == 1);
}

TEST_CASE("parser: preamble runs longer than three, the DSACON32m banner, queue bounds") {
  const auto family = w::protocol_family::dsacon32m;
  w::packet_parser parser(family, {.max_payload = 4096, .max_queued_frames = 2});
  bytes stream;
  for (int i = 0; i < 3; ++i)
    stream.insert(stream.end(), w::dsacon32m_banner.begin(), w::dsacon32m_banner.end());
  stream.insert(stream.end(), {0xAA, 0xAA});  // five AA bytes before the real preamble's id
  for (std::uint8_t k = 0; k < 5; ++k) {
    const bytes f = w::encode_packet(family, 0x00, bytes{k});
    stream.insert(stream.end(), f.begin(), f.end());
  }
  parser.feed(stream);
  CHECK(parser.stats().garbage_bytes == 12 + 2);
  CHECK(parser.stats().frames == 5);
  CHECK(parser.stats().dropped == 3);  // only the newest two are kept
  CHECK(parser.queued_frames() == 2);
  CHECK(parser.pop_frame()->payload == bytes{3});
  CHECK(parser.pop_frame()->payload == bytes{4});
  // A trailing partial preamble is kept, not counted, until more bytes decide.
  parser.feed(bytes{0x11, 0xAA, 0xAA});
  CHECK(parser.buffered() == 2);
  parser.feed(bytes{0xAA, 0x06, 0x00, 0x00});  // DSACON32m empty payload: no CRC
  CHECK(parser.pop_command()->id == 0x06);
  CHECK(parser.buffered() == 0);
  parser.reset();
  CHECK(parser.queued_frames() == 0);
  CHECK_THROWS_AS(w::packet_parser(family, {.max_payload = 10, .max_queued_frames = 0}),
                  std::invalid_argument);
}

}  // namespace test_parser
