// Tests of a press read as a burst of frames (`simulator_params::frames_per_press`,
// `tactile_simulator::render_press`): one frame is exactly `render`, a burst's frames differ by
// their own noise and settle towards the full press, the hysteresis ghost is the previous
// press's and the baseline walks as far per press whatever the frames; bumps make outlier frames
// that leave the other frames as they were, and that combine_burst drops.
#include <doctest/doctest.h>

#include <cmath>
#include <cstddef>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "sim_fixtures.hpp"
#include "tacmap/sim/scenario.hpp"
#include "tacmap/sim/tactile_simulator.hpp"
#include "tacmap/tactile/burst.hpp"
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

TEST_CASE("bumps: outlier frames of their own force, the other frames as without them") {
  // With read-out noise, so that "as without them" is a strong claim: the bumped simulator's
  // unbumped frames equal the unbumped simulator's frames bit for bit (the bumps draw from a
  // stream of their own). On a flat relief a bump's slide changes nothing: a bumped frame
  // reads 2000 x its force factor, in [1 - 0.6, 1 + 0.6].
  simulator_params p = quiet();
  p.noise_counts = 40.0;
  p.frames_per_press = 20;
  p.settle_start = 1.0;
  simulator_params bumped = p;
  bumped.bump_probability = 0.3;
  tactile_simulator calm(flat_relief(), {120, 120}, px, p),
      shaken(flat_relief(), {120, 120}, px, bumped);
  std::size_t frames = 0, hits = 0;
  for (int press = 0; press < 40; ++press) {
    const map_pose at{40.0 + press, 60.0, 0.0};
    const auto a = calm.render_press(at);
    const auto b = shaken.render_press(at);
    REQUIRE(b.size() == 20);
    CHECK((a.front().counts == b.front().counts).all());  // the first frame is never bumped
    for (std::size_t k = 1; k < b.size(); ++k) {
      ++frames;
      CHECK(b[k].sequence == a[k].sequence);
      if ((a[k].counts == b[k].counts).all()) continue;
      ++hits;
      // The force: the frame's mean against the calm one's, the noise averaged over 84 taxels.
      const double factor = total(b[k]) / total(a[k]);
      CHECK(factor >= 0.4 - 0.01);
      CHECK(factor <= 1.6 + 0.01);
    }
  }
  // 760 frames at 0.3: 228 expected, standard deviation 12.6 (a factor within 1e-2 of 1 would
  // hide a hit only under a bit-identical noise draw, which cannot happen here).
  REQUIRE(frames == 760);
  CHECK(hits > 190);
  CHECK(hits < 266);
}

TEST_CASE("a bump slides the array over the surface, and never off the map") {
  // Across the step of step_relief, force unchanged: a bumped frame sees the step elsewhere.
  simulator_params p = quiet();
  p.frames_per_press = 20;
  p.settle_start = 1.0;
  p.bump_probability = 1.0;
  p.bump_depth_spread = 0.0;
  p.bump_shift_mm = 4.0;
  tactile_simulator sim(step_relief(), {120, 120}, px, p);
  const map_pose across{68.0, 60.0, 0.0};  // the step at x = 68 mm, under the array
  const auto burst = sim.render_press(across);
  std::size_t moved = 0;
  for (std::size_t k = 1; k < burst.size(); ++k)
    moved += (burst[k].counts != burst.front().counts).any() ? 1U : 0U;
  // Only a slide along y (the step's direction) leaves the reading alone: most frames moved.
  CHECK(moved >= 12);
  // At the map's edge a slide that would leave the map is not made: no refusal, every frame
  // read where it can be.
  const double half_width = 0.5 * 6 * 3.4;
  CHECK_NOTHROW((void)sim.render_press({half_width, 60.0, 0.0}));
}

TEST_CASE("combine_burst drops the bumped frames whose force is off, keeping the press") {
  // Quiet sensor, flat relief: the settled frames read exactly 2000 per taxel. Bumps of up to
  // +-60 % force; combine_burst (outliers: totals more than 15 % from the settled level) drops
  // the ones beyond that, and the per-taxel median of the rest is the calm press.
  simulator_params p = quiet();
  p.frames_per_press = 20;
  p.settle_start = 1.0;
  p.bump_probability = 0.25;
  tactile_simulator sim(flat_relief(), {120, 120}, px, p);
  std::size_t dropped = 0, strong = 0;
  for (int press = 0; press < 10; ++press) {
    const auto burst = sim.render_press({60.0, 60.0, 0.0});
    const tacmap::combined_burst c = tacmap::combine_burst(std::span<const tactile_frame>(burst));
    CHECK((c.frame.counts == 2000.0F).all());
    for (std::size_t k = 0; k < burst.size(); ++k) {
      const double off = std::abs(total(burst[k]) / (84 * 2000.0) - 1.0);
      if (off > 0.16) {
        ++strong;
        CHECK(c.status[k] == tacmap::burst_frame_status::outlier);
      }
      dropped += c.status[k] == tacmap::burst_frame_status::outlier ? 1U : 0U;
    }
  }
  CHECK(strong > 0);
  CHECK(dropped >= strong);
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
  p.settle_frames = 2.0;
  p.bump_probability = 1.5;
  CHECK(message_of([&] { p.validate(); }).find("bump_probability = 1.5") != std::string::npos);
  p.bump_probability = 0.1;
  p.bump_depth_spread = -0.1;
  CHECK(message_of([&] { p.validate(); }).find("bump_depth_spread = -0.1") != std::string::npos);
  p.bump_depth_spread = 0.5;
  p.bump_shift_mm = std::numeric_limits<double>::quiet_NaN();
  CHECK(message_of([&] { p.validate(); }).find("bump_shift_mm = nan") != std::string::npos);
  p.bump_shift_mm = 1.7;
  CHECK_NOTHROW(p.validate());
}

}  // namespace test_burst_simulation
