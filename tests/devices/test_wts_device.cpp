// wts_device end-to-end against the emulator on a real pseudo-terminal: queries, frames,
// streaming, and every injected fault.
#include <doctest/doctest.h>

#include <string>
#include <thread>

#include "tacmap/devices/weiss/dsacon32m.hpp"
#include "tacmap/devices/weiss/wts.hpp"
#include "weiss_test_support.hpp"

namespace test_wts_device {

using namespace weiss_test;

namespace {

w::emulator_options wts_emulator() {
  w::emulator_options o;
  o.family = w::protocol_family::wts;
  o.render = indexed_pattern;
  return o;
}

}  // namespace

TEST_CASE("wts: geometry and identity come from the device") {
  w::emulator emu(wts_emulator());
  w::wts_device dev(emu.path(), fast_options());
  CHECK(dev.is_connected());
  CHECK(dev.geometry() == tacmap::taxel_geometry{14, 6, 3.4});
  CHECK(dev.matrix().full_scale == 4095.0);
  const w::wts_identity id = dev.identity();
  CHECK(id.sensor_type == "WTS 0614-34A");
  CHECK(id.system == emu.options().system_info);
  CHECK_NOTHROW(dev.ping());
  CHECK(emu.error().empty());

  // Another geometry: nothing is hard-coded.
  w::emulator_options o = wts_emulator();
  o.res_x = 4;
  o.res_y = 5;
  o.cell_mm = 2.5;
  o.sensor_type = "WTS 0504-25";
  w::emulator other(o);
  w::wts_device dev2(other.path(), fast_options());
  CHECK(dev2.geometry() == tacmap::taxel_geometry{5, 4, 2.5});
  CHECK(dev2.identity().sensor_type == "WTS 0504-25");
}

TEST_CASE("wts: a single frame equals what the emulator rendered, with and without RLE") {
  for (const bool rle : {false, true}) {
    CAPTURE(rle);
    w::emulator emu(wts_emulator());
    auto opts = fast_options();
    opts.rle = rle;
    w::wts_device dev(emu.path(), opts);
    const auto before = std::chrono::steady_clock::now();
    const tacmap::tactile_frame f = dev.read_single_frame();
    check_counts(f, emu.last_rendered(), 6, 14);
    CHECK(f.geometry == dev.geometry());
    CHECK(f.timestamp >= before);
    CHECK(f.sequence == 0);
    CHECK(emu.stats().rle_frames_sent == (rle ? 1U : 0U));
    const tacmap::tactile_frame g = dev.read_single_frame();
    CHECK(g.sequence == 1);
    CHECK(frame_number(g) == frame_number(f) + 1);
    check_counts(g, emu.last_rendered(), 6, 14);
  }
}

TEST_CASE("wts: periodic streaming with command replies interleaved loses no frame") {
  for (const bool rle : {false, true}) {
    CAPTURE(rle);
    w::emulator emu(wts_emulator());
    auto opts = fast_options();
    opts.rle = rle;
    w::wts_device dev(emu.path(), opts);
    dev.start_periodic(5ms);
    CHECK(dev.is_streaming());
    CHECK(emu.streaming());
    std::vector<tacmap::tactile_frame> frames = collect(dev, 5);
    for (int round = 0; round < 4; ++round) {  // replies now arrive between frames
      CHECK(dev.identity().sensor_type == "WTS 0614-34A");
      dev.ping();
      CHECK(dev.query_matrix_info().res_y == 14);
      for (auto& f : collect(dev, 3)) frames.push_back(std::move(f));
    }
    CHECK(missing_frames(frames) == 0);
    for (std::size_t i = 1; i < frames.size(); ++i) {
      CHECK(frames[i].sequence == frames[i - 1].sequence + 1);
      CHECK(frames[i].timestamp >= frames[i - 1].timestamp);
    }
    for (const auto& f : frames) CHECK(f.geometry == tacmap::taxel_geometry{14, 6, 3.4});
    // Refused during streaming, with a message that says what to do.
    CHECK_THROWS_WITH_AS(dev.read_single_frame(), doctest::Contains("stop_periodic()"),
                         tacmap::device_error);
    dev.stop_periodic();
    CHECK_FALSE(dev.is_streaming());
    CHECK_FALSE(emu.streaming());
    const auto s = dev.stats();
    CHECK(s.link.bad_crc == 0);
    CHECK(s.link.garbage_bytes == 0);
    CHECK(s.corrupt_frames == 0);
    CHECK(emu.stats().rle_frames_sent == (rle ? emu.stats().frames_sent : 0U));
  }
}

TEST_CASE("wts: garbage before a frame is skipped, counted, and no frame is lost") {
  w::emulator emu(wts_emulator());
  w::wts_device dev(emu.path(), fast_options());
  dev.start_periodic(5ms);
  auto frames = collect(dev, 3);
  // Line noise, a partial preamble, and a fake header whose size (AA AA) is impossible.
  const std::vector<std::uint8_t> garbage{0x13, 0x00, 0xAA, 0xAA, 0x42, 0xAA, 0xAA, 0xAA, 0x05};
  emu.inject_garbage(garbage, w::packet_kind::frame);
  for (auto& f : collect(dev, 6)) frames.push_back(std::move(f));
  CHECK(emu.stats().faults_applied == 1);
  CHECK(missing_frames(frames) == 0);
  CHECK(dev.stats().link.garbage_bytes == garbage.size());
  CHECK(dev.stats().link.bad_size == 1);
}

TEST_CASE("wts: a frame with a bad CRC is counted and skipped") {
  w::emulator emu(wts_emulator());
  w::wts_device dev(emu.path(), fast_options());
  dev.start_periodic(5ms);
  auto frames = collect(dev, 3);
  emu.corrupt_crc(w::packet_kind::frame);
  for (auto& f : collect(dev, 6)) frames.push_back(std::move(f));
  CHECK(missing_frames(frames) == 1);
  CHECK(dev.stats().link.bad_crc == 1);
  CHECK(dev.stats().corrupt_frames == 0);
}

TEST_CASE("wts: a truncated frame costs only itself, a truncated reply times out cleanly") {
  w::emulator emu(wts_emulator());
  w::wts_device dev(emu.path(), fast_options());
  dev.start_periodic(5ms);
  auto frames = collect(dev, 3);
  emu.truncate(w::packet_kind::frame);
  for (auto& f : collect(dev, 6)) frames.push_back(std::move(f));
  CHECK(missing_frames(frames) == 1);
  const auto s = dev.stats();
  CHECK(s.link.bad_crc + s.link.truncated == 1);
  dev.stop_periodic();

  // A truncated reply: the command times out with a clear message; the next one works.
  emu.truncate(w::packet_kind::reply);
  const auto t0 = std::chrono::steady_clock::now();
  CHECK_THROWS_WITH_AS(dev.query_matrix_info(), doctest::Contains("no reply to get matrix"),
                       tacmap::device_error);
  CHECK(std::chrono::steady_clock::now() - t0 < 1s);
  CHECK(dev.stats().link.truncated >= 1);  // abandoned after idle_flush of silence
  CHECK(dev.query_matrix_info().res_x == 6);
}

TEST_CASE("wts: a frame with a good CRC that does not decode is rejected and counted") {
  w::emulator emu(wts_emulator());
  w::wts_device dev(emu.path(), fast_options());
  dev.start_periodic(5ms);
  auto frames = collect(dev, 2);
  // An RLE frame decoding to 83 cells instead of 84, correctly framed.
  std::vector<std::uint8_t> bad{0, 0, 0, 0, w::frame_flag_rle};
  for (int i = 0; i < 5; ++i) {
    w::detail::put_u16(bad, static_cast<std::uint16_t>((15U << 12U) | 7U));  // 75 cells
  }
  w::detail::put_u16(bad, static_cast<std::uint16_t>((8U << 12U) | 7U));  // +8 = 83
  emu.inject_garbage(w::encode_packet(w::protocol_family::wts, w::frame_id, bad),
                     w::packet_kind::frame);
  for (auto& f : collect(dev, 4)) frames.push_back(std::move(f));
  CHECK(missing_frames(frames) == 0);
  const auto s = dev.stats();
  CHECK(s.corrupt_frames == 1);
  CHECK(s.last_corrupt_frame.find("expected 84") != std::string::npos);
}

TEST_CASE("wts: a stall gives a timeout error, and the device recovers afterwards") {
  w::emulator emu(wts_emulator());
  w::wts_device dev(emu.path(), fast_options());
  dev.start_periodic(5ms);
  (void)collect(dev, 2);
  emu.stall(500ms);
  // Drain what was in flight, then the silence must end in a clear error within the timeout.
  const auto t0 = std::chrono::steady_clock::now();
  bool timed_out = false;
  while (!timed_out && std::chrono::steady_clock::now() - t0 < 1s) {
    try {
      (void)dev.next_frame(100ms);
    } catch (const tacmap::device_error& e) {
      timed_out = true;
      CHECK(std::string(e.what()).find("stopped streaming") != std::string::npos);
    }
  }
  CHECK(timed_out);
  CHECK_THROWS_WITH_AS(dev.ping(), doctest::Contains("no reply to loop"), tacmap::device_error);
  // After the stall frames flow again and commands are answered.
  const auto f = dev.next_frame(800ms);
  CHECK_NOTHROW(f.validate());
  CHECK_NOTHROW(dev.ping());
  CHECK(emu.stats().ignored_commands >= 1);
}

TEST_CASE("wts: a disconnect gives an error, reconnect() restores streaming") {
  w::emulator emu(wts_emulator());
  w::wts_device dev(emu.path(), fast_options());
  dev.start_periodic(5ms);
  auto before = collect(dev, 3);
  emu.disconnect(150ms);
  bool failed = false;
  for (int i = 0; i < 100 && !failed; ++i) {  // frames in flight may still be read first
    try {
      (void)dev.next_frame(200ms);
    } catch (const tacmap::device_error& e) {
      failed = true;
      CHECK(std::string(e.what()).find("disconnected") != std::string::npos);
    }
  }
  CHECK(failed);
  CHECK_FALSE(dev.is_connected());
  CHECK_THROWS_WITH_AS(dev.next_frame(10ms), doctest::Contains("reconnect()"),
                       tacmap::device_error);
  dev.reconnect(2s);
  CHECK(dev.is_connected());
  CHECK(dev.is_streaming());
  CHECK(emu.streaming());
  const auto after = collect(dev, 3);
  CHECK(after.front().sequence > before.back().sequence);
  CHECK(missing_frames(after) == 0);
  CHECK(dev.stats().reconnects == 1);
  CHECK(emu.stats().connects == 2);
}

TEST_CASE("wts: misuse and mismatches fail loudly and quickly") {
  CHECK_THROWS_WITH_AS(w::wts_device("/dev/ttyACM_missing_77", fast_options()),
                       doctest::Contains("ls /dev/ttyACM*"), tacmap::device_error);
  // A WTS host talking to a DSACON32m: the replies' CRCs do not match WTS rules.
  w::emulator_options o;
  o.family = w::protocol_family::dsacon32m;
  o.powerup_delay = 0ms;
  o.ready_delay = 0ms;
  w::emulator dsa(o);
  const auto t0 = std::chrono::steady_clock::now();
  CHECK_THROWS_WITH_AS(w::wts_device(dsa.path(), fast_options()),
                       doctest::Contains("no reply to stop periodic acquisition"),
                       tacmap::device_error);
  CHECK(std::chrono::steady_clock::now() - t0 < 1s);

  w::emulator emu(wts_emulator());
  w::wts_device dev(emu.path(), fast_options());
  CHECK_THROWS_AS(dev.start_periodic(0ms), std::invalid_argument);
  CHECK_THROWS_AS(dev.start_periodic(70000ms), std::invalid_argument);
  CHECK_THROWS_WITH_AS(dev.next_frame(50ms), doctest::Contains("start_periodic()"),
                       tacmap::device_error);
  // Restarting acquisition while it runs is allowed (it stops first).
  dev.start_periodic(10ms);
  dev.start_periodic(5ms);
  CHECK(dev.period() == 5ms);
  CHECK_NOTHROW(dev.next_frame(500ms));
  // Moving a device keeps it working.
  w::wts_device moved = std::move(dev);
  CHECK_NOTHROW(moved.next_frame(500ms));
}

}  // namespace test_wts_device
