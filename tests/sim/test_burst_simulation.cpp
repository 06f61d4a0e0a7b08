// Tests of a press read as a burst of frames (`simulator_params::frames_per_press`,
// `tactile_simulator::render_press`): one frame is exactly `render`, a burst's frames differ by
// their own noise and settle towards the full press, the hysteresis ghost is the previous
// press's and the baseline walks as far per press whatever the frames.
#include <doctest/doctest.h>

#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "sim_fixtures.hpp"
#include "tacmap/sim/scenario.hpp"
#include "tacmap/sim/tactile_simulator.hpp"
#include "test_support.hpp"

namespace test_burst_simulation {

using tacmap::image;
using tacmap::map_pose;
using tacmap::simulator_params;
using tacmap::tactile_frame;
using tacmap::tactile_simulator;
using tacmap_test::message_of;

namespace {

constexpr double px = tacmap_test::paper_mm_per_px;
using tacmap_test::flat_relief;
using tacmap_test::quiet;
using tacmap_test::step_relief;

double total(const tactile_frame& f) { return f.counts.cast<double>().sum(); }

}  // namespace

TEST_CASE("one frame per press is exactly render, under every lab condition") {
  // The harsh sensor: noise, gains, dead taxels, saturation, hysteresis and drift all on.
  simulator_params p = tacmap::harsh_sensor();
  p.seed = 7;
  REQUIRE(p.frames_per_press == 1);
  tactile_simulator a(step_relief(), {120, 120}, px, p), b(step_relief(), {120, 120}, px, p);
  const map_pose poses[] = {{60.0, 60.0, 0.0}, {30.0, 50.0, 0.3}, {90.0, 70.0, -0.2}};
  for (int round = 0; round < 3; ++round)
    for (const map_pose& at : poses) {
      const tacmap::press_variation press{.depth_scale = 0.8, .tilt_u_rad = 0.01};
      const std::vector<tactile_frame> burst = a.render_press(at, press);
      const tactile_frame one = b.render(at, press);
      REQUIRE(burst.size() == 1);
      CHECK((burst.front().counts == one.counts).all());
      CHECK(burst.front().sequence == one.sequence);
      CHECK(burst.front().timestamp == one.timestamp);
      CHECK((a.baseline() == b.baseline()).all());
    }
}

TEST_CASE("a burst's frames differ by their own noise around the settled press") {
  simulator_params p = quiet();
  p.noise_counts = 40.0;
  p.frames_per_press = 20;
  p.settle_start = 1.0;  // no settling here: only the noise
  tactile_simulator sim(flat_relief(), {120, 120}, px, p);
  const std::vector<tactile_frame> burst = sim.render_press({60.0, 60.0, 0.0});
  REQUIRE(burst.size() == 20);
  std::size_t differ = 0;
  double sum = 0.0, sum2 = 0.0;
  for (std::size_t k = 0; k < burst.size(); ++k) {
    CHECK(burst[k].sequence == k);  // numbered one after the other
    if (k > 0 && (burst[k].counts != burst[k - 1].counts).any()) ++differ;
    const double v = burst[k].counts(7, 3);
    sum += v;
    sum2 += v * v;
  }
  CHECK(differ == 19);  // every frame its own noise, none a copy of the previous one
  // One taxel over 20 frames: mean 2000 within a few standard errors (40 / sqrt(20) = 9), a
  // spread of about 40 counts.
  const double mean = sum / 20.0;
  const double sd = std::sqrt(sum2 / 20.0 - mean * mean);
  CHECK(mean == doctest::Approx(2000.0).epsilon(0.02));
  CHECK(sd > 20.0);
  CHECK(sd < 70.0);
}

TEST_CASE("a burst settles: its first frames under-pressed, rising to the full press") {
  simulator_params p = quiet();
  p.frames_per_press = 12;
  p.settle_start = 0.5;
  p.settle_frames = 2.0;
  tactile_simulator sim(flat_relief(), {120, 120}, px, p);
  const std::vector<tactile_frame> burst = sim.render_press({60.0, 60.0, 0.0});
  REQUIRE(burst.size() == 12);
  // A flat relief is indented evenly, so every taxel reads 2000 x the frame's depth fraction.
  for (std::size_t k = 0; k < burst.size(); ++k) {
    const double fraction = 1.0 - 0.5 * std::exp(-static_cast<double>(k) / 2.0);
    CHECK(sim.settling(k, 12) == doctest::Approx(fraction));
    CHECK(burst[k].counts(7, 3) == static_cast<float>(std::round(2000.0 * fraction)));
    if (k > 0) {
      CHECK(total(burst[k]) > total(burst[k - 1]));
    }
  }
  CHECK(burst.front().counts(7, 3) == 1000.0F);
  CHECK(total(burst.back()) == doctest::Approx(84 * 2000.0).epsilon(0.01));
  // A single frame is read once the press has settled.
  CHECK(sim.settling(0, 1) == 1.0);
  // Settling 0: only the first frame is short.
  p.settle_frames = 0.0;
  tactile_simulator abrupt(flat_relief(), {120, 120}, px, p);
  const auto b = abrupt.render_press({60.0, 60.0, 0.0});
  CHECK(b[0].counts(7, 3) == 1000.0F);
  CHECK(b[1].counts(7, 3) == 2000.0F);
}

TEST_CASE("in a burst the hysteresis ghost is the previous press's, on every frame") {
  simulator_params p = quiet();
  p.hysteresis = 0.1;
  p.frames_per_press = 5;
  p.settle_start = 1.0;
  tactile_simulator sim(step_relief(), {120, 120}, px, p);
  // First press on the raised half: no earlier press, nothing added to any frame (a ghost of
  // the previous FRAME would add 10 % from the second frame on).
  for (const auto& f : sim.render_press({100.0, 60.0, 0.0})) CHECK(f.counts(7, 3) == 2000.0F);
  // Then on the flat base: every frame reads its own load plus 10 % of the first press's.
  for (const auto& f : sim.render_press({20.0, 60.0, 0.0})) CHECK(f.counts(7, 3) == 2200.0F);
}

TEST_CASE("the baseline walks as far per press whatever the frames per press") {
  // Over 300 presses the per-press change of a taxel's baseline has the standard deviation
  // baseline_drift_counts (20), for one frame per press and for bursts of 4 (a step of 20 per
  // frame would make it 40).
  for (const std::size_t frames : {std::size_t{1}, std::size_t{4}}) {
    CAPTURE(frames);
    simulator_params p = quiet();
    p.baseline_drift_counts = 20.0;
    p.frames_per_press = frames;
    p.supersample = 1;
    tactile_simulator sim(flat_relief(), {120, 120}, px, p);
    double sum2 = 0.0;
    constexpr int presses = 300;
    for (int i = 0; i < presses; ++i) {
      const double before = sim.baseline()(3, 2);
      (void)sim.render_press({60.0, 60.0, 0.0});
      const double step = sim.baseline()(3, 2) - before;
      sum2 += step * step;
    }
    const double sd = std::sqrt(sum2 / presses);
    CHECK(sd > 16.0);
    CHECK(sd < 24.0);
  }
}

TEST_CASE("frames per press and the settling are validated, naming the field") {
  simulator_params p;
  p.frames_per_press = 0;
  CHECK(message_of([&] { p.validate(); }).find("frames_per_press = 0") != std::string::npos);
  p.frames_per_press = 20;
  p.settle_start = 1.5;
  CHECK(message_of([&] { p.validate(); }).find("settle_start = 1.5") != std::string::npos);
  p.settle_start = 0.5;
  p.settle_frames = -1.0;
  CHECK(message_of([&] { p.validate(); }).find("settle_frames = -1") != std::string::npos);
}

}  // namespace test_burst_simulation
