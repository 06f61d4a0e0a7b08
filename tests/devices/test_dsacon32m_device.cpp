// dsacon32m_device end-to-end against the emulator on a real pseudo-terminal: power-up,
// queries, frames (single, pushed, several matrices), and injected faults.
#include <doctest/doctest.h>

#include <string>

#include "tacmap/devices/weiss/dsacon32m.hpp"
#include "weiss_test_support.hpp"

namespace test_dsacon32m_device {

using namespace weiss_test;

namespace {

w::emulator_options dsa_emulator() {
  w::emulator_options o;
  o.family = w::protocol_family::dsacon32m;
  o.render = indexed_pattern;
  o.dsa_frame_period = 5ms;
  o.powerup_delay = 60ms;  // banner after 60 ms, commands accepted from 90 ms on
  o.ready_delay = 30ms;
  return o;
}

}  // namespace

TEST_CASE("dsacon32m: power-up — banner skipped, early commands retried, then geometry") {
  w::emulator emu(dsa_emulator());
  w::dsacon32m_device dev(emu.path(), fast_options());
  CHECK(emu.stats().ignored_commands >= 1);     // sent while the controller was still booting
  CHECK(dev.stats().link.garbage_bytes >= 12);  // three ESC [ 5 n
  CHECK(dev.geometry() == tacmap::taxel_geometry{14, 6, 3.4});
  REQUIRE(dev.matrices().size() == 1);
  CHECK(dev.matrices()[0].matrix.full_scale == 4095.0);
  CHECK(dev.matrices()[0].uid[0] == 0x10);
  const auto c = dev.controller_info();
  CHECK(c.serial == emu.options().serial);
  CHECK(c.sw_version == emu.options().sw_version);
  CHECK((c.status_flags & 0x80) != 0);  // operable
  CHECK_FALSE(c.can_id.has_value());    // the 18-byte firmware reply
  CHECK(dev.sensor_info().matrix_count == 1);
  CHECK_NOTHROW(dev.ping());
  // A refused command names the status in the DSACON32m numbering.
  CHECK_THROWS_WITH_AS(dev.query_matrix_info(3), doctest::Contains("E_INDEX_OUT_OF_BOUNDS (24)"),
                       tacmap::device_error);
}

TEST_CASE("dsacon32m: a controller that never becomes ready fails within powerup_timeout") {
  w::emulator_options o = dsa_emulator();
  o.powerup_delay = 5000ms;  // longer than the test waits
  w::emulator emu(o);
  auto opts = fast_options();
  opts.powerup_timeout = 250ms;
  const auto t0 = std::chrono::steady_clock::now();
  CHECK_THROWS_WITH_AS(w::dsacon32m_device(emu.path(), opts),
                       doctest::Contains("no answer to 'stop acquisition'"), tacmap::device_error);
  const auto waited = std::chrono::steady_clock::now() - t0;
  CHECK(waited >= 240ms);
  CHECK(waited < 1500ms);
}

TEST_CASE("dsacon32m: a single frame equals what the emulator rendered, with and without RLE") {
  for (const bool rle : {false, true}) {
    for (const bool legacy : {false, true}) {
      CAPTURE(rle);
      CAPTURE(legacy);
      w::emulator_options o = dsa_emulator();
      o.legacy_single_frame = legacy;
      w::emulator emu(o);
      auto opts = fast_options();
      opts.rle = rle;
      w::dsacon32m_device dev(emu.path(), opts);
      const tacmap::tactile_frame f = dev.read_single_frame();
      check_counts(f, emu.last_rendered(), 6, 14);
      CHECK(emu.stats().rle_frames_sent == (rle ? emu.stats().frames_sent : 0U));
      CHECK_FALSE(emu.streaming());  // old firmware was told to stop
      const tacmap::tactile_frame g = dev.read_single_frame();
      CHECK(g.sequence == f.sequence + 1);
      CHECK(frame_number(g) > frame_number(f));
      CHECK(dev.last_device_timestamp() > 0);
    }
  }
}

TEST_CASE("dsacon32m: an acknowledged single frame that never arrives is a clear timeout") {
  w::emulator emu(dsa_emulator());
  w::dsacon32m_device dev(emu.path(), fast_options());
  emu.truncate(w::packet_kind::frame);
  CHECK_THROWS_WITH_AS(dev.read_single_frame(), doctest::Contains("acknowledged the request"),
                       tacmap::device_error);
  const tacmap::tactile_frame f = dev.read_single_frame();  // then what was rendered
  check_counts(f, emu.last_rendered(), 6, 14);
  CHECK(dev.stats().link.truncated == 1);
}

TEST_CASE("dsacon32m: pushed frames that arrive before a reply are queued, not lost") {
  w::emulator emu(dsa_emulator());
  w::dsacon32m_device dev(emu.path(), fast_options());
  dev.start_periodic();
  CHECK(emu.streaming());
  auto frames = collect(dev, 2);
  for (int round = 0; round < 3; ++round) {
    // Let several frames queue up in the pty, so that the reply comes after them.
    const auto sent = emu.stats().frames_sent;
    REQUIRE(emu.wait_frames_sent(sent + 4, 1s));
    CHECK((dev.controller_info().status_flags & 0x40) != 0);  // acquisition running
    dev.ping();
    for (auto& f : collect(dev, 6)) frames.push_back(std::move(f));
  }
  CHECK(missing_frames(frames) == 0);
  CHECK(dev.stats().link.dropped == 0);
  dev.stop_periodic();
  CHECK_FALSE(emu.streaming());
}

TEST_CASE("dsacon32m: frames from the selected one of several matrices") {
  w::emulator_options o = dsa_emulator();
  o.matrix_count = 2;
  w::emulator emu(o);
  for (std::uint16_t index : {std::uint16_t{0}, std::uint16_t{1}}) {
    auto opts = fast_options();
    opts.matrix_index = index;
    w::dsacon32m_device dev(emu.path(), opts);
    CHECK(dev.matrices().size() == 2);
    const auto f = dev.read_single_frame();
    check_counts(f, emu.last_rendered(), 6, 14, index);
  }
  auto opts = fast_options();
  opts.matrix_index = 2;
  CHECK_THROWS_WITH_AS(w::dsacon32m_device(emu.path(), opts), doctest::Contains("matrix_index = 2"),
                       tacmap::device_error);
}

TEST_CASE("dsacon32m: bad CRC, garbage and truncation in push mode") {
  w::emulator emu(dsa_emulator());
  w::dsacon32m_device dev(emu.path(), fast_options());
  dev.start_periodic();
  auto frames = collect(dev, 3);
  const auto garbage_before = dev.stats().link.garbage_bytes;
  emu.corrupt_crc(w::packet_kind::frame);
  for (auto& f : collect(dev, 4)) frames.push_back(std::move(f));
  emu.inject_garbage({0xAA, 0xAA, 0x1B, 0x5B, 0x35, 0x6E}, w::packet_kind::frame);
  for (auto& f : collect(dev, 4)) frames.push_back(std::move(f));
  emu.truncate(w::packet_kind::frame);
  for (auto& f : collect(dev, 4)) frames.push_back(std::move(f));
  CHECK(missing_frames(frames) == 2);  // the bad-CRC frame and the truncated one
  const auto s = dev.stats();
  CHECK(s.link.bad_crc + s.link.truncated == 2);
  CHECK(s.link.garbage_bytes - garbage_before >= 6);
  CHECK(s.corrupt_frames == 0);
}

TEST_CASE("dsacon32m: stall then disconnect, reconnect() goes through power-up again") {
  w::emulator emu(dsa_emulator());
  w::dsacon32m_device dev(emu.path(), fast_options());
  dev.start_periodic();
  (void)collect(dev, 2);
  emu.stall(400ms);
  CHECK_THROWS_WITH_AS(dev.controller_info(), doctest::Contains("no reply to query controller"),
                       tacmap::device_error);
  (void)dev.next_frame(800ms);  // streaming resumes after the stall
  emu.disconnect(100ms);
  bool failed = false;
  for (int i = 0; i < 100 && !failed; ++i) {
    try {
      (void)dev.next_frame(200ms);
    } catch (const tacmap::device_error& e) {
      failed = true;
      CHECK(std::string(e.what()).find("disconnected") != std::string::npos);
    }
  }
  CHECK(failed);
  const auto garbage_before = dev.stats().link.garbage_bytes;
  dev.reconnect(2s);
  CHECK(dev.stats().link.garbage_bytes - garbage_before >= 12);  // the banner again
  CHECK(dev.is_streaming());
  const auto after = collect(dev, 4);
  CHECK(missing_frames(after) == 0);
  CHECK(emu.error().empty());
}

}  // namespace test_dsacon32m_device
