// Tests of the conditions a lab has (issue 34, item 1) in the simulator and the camera map: the
// sensor's drift, saturation and hysteresis, the photograph's shadow and defocus, the harsh
// preset, and that every one is off by default.
#include <doctest/doctest.h>

#include <cmath>
#include <string>

#include "sim_fixtures.hpp"
#include "tacmap/sim/scenario.hpp"
#include "tacmap/sim/tactile_simulator.hpp"
#include "test_support.hpp"

namespace test_lab_conditions {

using tacmap::image;
using tacmap::map_pose;
using tacmap::scenario_params;
using tacmap::simulator_params;
using tacmap::tactile_simulator;
using tacmap_test::message_of;

namespace {

constexpr double px = tacmap_test::paper_mm_per_px;
using tacmap_test::flat_relief;
using tacmap_test::quiet;
using tacmap_test::step_relief;

}  // namespace

TEST_CASE("lab conditions are off by default: the default sensor renders as before") {
  const simulator_params p;
  CHECK(p.saturation_counts == 0.0);
  CHECK(p.hysteresis == 0.0);
  CHECK(p.baseline_drift_counts == 0.0);
  const scenario_params s;
  CHECK_FALSE(s.changes_map());
  CHECK_FALSE(s.moves_sensor());
  // The realistic scenario does not switch any of them on.
  const scenario_params r = scenario_params::realistic();
  CHECK(r.shadow_depth == 0.0);
  CHECK(r.defocus_px == 0.0);
  CHECK(r.map_scale_error == 0.0);
  CHECK(r.light_press_fraction == 0.0);
  CHECK(r.partial_press_fraction == 0.0);
  const simulator_params rs = tacmap::realistic_sensor();
  CHECK(rs.saturation_counts == 0.0);
  CHECK(rs.hysteresis == 0.0);
  CHECK(rs.baseline_drift_counts == 0.0);
  // The noise stream does not depend on the new streams: two simulators with the same seed,
  // one asking for nothing new, render identical frames.
  tactile_simulator a(step_relief(), {120, 120}, px), b(step_relief(), {120, 120}, px);
  for (int i = 0; i < 3; ++i)
    CHECK((a.render({68.0, 60.0, 0.0}).counts == b.render({68.0, 60.0, 0.0}).counts).all());
}

TEST_CASE("saturation compresses the response towards its level, hard full scale still holds") {
  simulator_params p = quiet();
  p.press_depth_mm = 1.0;  // 2000 counts on a flat relief
  tactile_simulator linear(flat_relief(), {120, 120}, px, p);
  p.saturation_counts = 3000.0;
  tactile_simulator soft(flat_relief(), {120, 120}, px, p);
  const float l = linear.render({60.0, 60.0, 0.0}).counts(7, 3);
  const float s = soft.render({60.0, 60.0, 0.0}).counts(7, 3);
  CHECK(l == 2000.0F);
  CHECK(s == std::round(static_cast<float>(3000.0 * std::tanh(2000.0 / 3000.0))));  // 1751
  p.press_depth_mm = 5.0;  // 10000 counts linear: the soft level caps it near 3000
  tactile_simulator deep(flat_relief(), {120, 120}, px, p);
  CHECK(deep.render({60.0, 60.0, 0.0}).counts(7, 3) == doctest::Approx(3000.0).epsilon(0.01));
}

TEST_CASE("hysteresis leaves a ghost of the previous press") {
  simulator_params p = quiet();
  p.hysteresis = 0.1;
  tactile_simulator sim(step_relief(), {120, 120}, px, p);
  // First press on the raised half, then on the flat base: the base reads 0 without hysteresis.
  const auto first = sim.render({100.0, 60.0, 0.0});
  CHECK(first.counts(7, 3) == 2000.0F);  // no earlier press: nothing added
  const auto second = sim.render({20.0, 60.0, 0.0});
  // The base has no relief above it, so the plane sits on it: the whole array is pressed
  // evenly; every taxel reads its own load plus 10 % of the first press's.
  CHECK(second.counts(7, 3) == 2000.0F + 200.0F);
  const auto third = sim.render({20.0, 60.0, 0.0});
  CHECK(third.counts(7, 3) == 2000.0F + 200.0F);  // the ghost is of the previous frame only
  p.hysteresis = 1.0;
  CHECK(message_of([&] { p.validate(); }).find("hysteresis = 1") != std::string::npos);
}

TEST_CASE("baseline drift is a random walk added to every live taxel, loaded or not") {
  simulator_params p = quiet();
  p.baseline_drift_counts = 20.0;
  p.dead_fraction = 0.1;
  tactile_simulator sim(step_relief(), {120, 120}, px, p);
  const map_pose off_relief{20.0, 60.0, 0.0};  // evenly pressed base: 2000 everywhere
  image<double> sum = image<double>::Zero(14, 6);
  double walked = 0.0;
  for (int i = 0; i < 50; ++i) {
    const auto f = sim.render(off_relief);
    for (Eigen::Index t = 0; t < 84; ++t) {
      if (sim.dead_taxels().data()[t]) {
        CHECK(f.counts.data()[t] == 0.0F);
        continue;
      }
      CHECK(f.counts.data()[t] == std::round(2000.0F + std::round(sim.baseline().data()[t])));
    }
    walked = std::max(walked, static_cast<double>(sim.baseline().abs().maxCoeff()));
  }
  // After 50 steps of 20 counts a walk has typically gone ~140 counts: clearly not 0, not huge.
  CHECK(walked > 40.0);
  CHECK(walked < 1000.0);
  // Taxels drift together (half the variance is common) but not identically.
  CHECK(sim.baseline().maxCoeff() != sim.baseline().minCoeff());
}

TEST_CASE("camera_image: a cast shadow darkens 20-40 % of the map; defocus blurs with a disc") {
  const image<float> grey = image<float>::Constant(80, 80, 0.5F);
  const image<float> relief = image<float>::Zero(80, 80);
  scenario_params s;
  s.shadow_depth = 0.4;
  s.shadow_edge_px = 0.0;
  const image<float> shadowed = tacmap::camera_image(grey, relief, px, s, 9);
  const double dark = (shadowed < 0.4F).cast<double>().mean();
  CHECK(dark >= 0.19);
  CHECK(dark <= 0.41);
  CHECK(shadowed.minCoeff() == doctest::Approx(0.5F * 0.6F));
  CHECK(shadowed.maxCoeff() == doctest::Approx(0.5F));
  // Deterministic for a seed; another seed casts it elsewhere.
  CHECK((tacmap::camera_image(grey, relief, px, s, 9) == shadowed).all());
  CHECK_FALSE((tacmap::camera_image(grey, relief, px, s, 10) == shadowed).all());

  // Defocus: a single bright pixel spreads evenly over the disc of the radius.
  image<float> dot = image<float>::Zero(21, 21);
  dot(10, 10) = 1.0F;
  scenario_params d;
  d.defocus_px = 2.0;
  const image<float> blurred = tacmap::camera_image(dot, image<float>::Zero(21, 21), px, d, 1);
  // 13 pixels within radius 2: each gets 1/13 (gamma 1, no noise).
  CHECK(blurred(10, 10) == doctest::Approx(1.0 / 13.0));
  CHECK(blurred(10, 12) == doctest::Approx(1.0 / 13.0));
  CHECK(blurred(11, 11) == doctest::Approx(1.0 / 13.0));
  CHECK(blurred(11, 12) == 0.0F);  // sqrt(5) > 2
  CHECK(blurred.sum() == doctest::Approx(1.0));
}

TEST_CASE("the harsh preset: a lab's levels, valid, and more than the realistic one") {
  const scenario_params h = scenario_params::harsh();
  h.validate();
  CHECK(h.shadow_depth > 0.0);
  CHECK(h.defocus_px > 0.0);
  CHECK(h.map_scale_error == doctest::Approx(0.03));
  CHECK(h.light_press_fraction > 0.0);
  CHECK(h.partial_press_fraction > 0.0);
  CHECK(h.polarity == tacmap::relief_polarity::random);  // as unknown_object()
  CHECK(h.changes_map());
  CHECK(h.moves_sensor());
  const simulator_params s = tacmap::harsh_sensor();
  s.validate();
  CHECK(s.noise_counts == 200.0);  // 5 % of full scale
  CHECK(s.dead_fraction == 0.1);
  CHECK(s.saturation_counts > 0.0);
  CHECK(s.hysteresis > 0.0);
  CHECK(s.baseline_drift_counts > 0.0);
  CHECK(std::string(tacmap::to_string(tacmap::scenario_kind::harsh)) == "harsh");
}

TEST_CASE("the new scenario and sensor fields are validated, naming field and range") {
  scenario_params s;
  s.map_scale_error = 0.5;
  CHECK(message_of([&] { s.validate(); }).find("map_scale_error = 0.5") != std::string::npos);
  s = {};
  s.shadow_depth = -0.1;
  CHECK(message_of([&] { s.validate(); }).find("shadow_depth") != std::string::npos);
  s = {};
  s.partial_press_tilt_deg = 30.0;
  CHECK(message_of([&] { s.validate(); }).find("partial_press_tilt_deg = 30") != std::string::npos);
  s = {};
  s.light_press_scale = 2.0;
  CHECK(message_of([&] { s.validate(); }).find("light_press_scale") != std::string::npos);
  simulator_params p;
  p.saturation_counts = -1.0;
  CHECK(message_of([&] { p.validate(); }).find("saturation_counts = -1") != std::string::npos);
  p = {};
  p.baseline_drift_counts = std::nan("");
  CHECK(message_of([&] { p.validate(); }).find("baseline_drift_counts") != std::string::npos);
}

}  // namespace test_lab_conditions
