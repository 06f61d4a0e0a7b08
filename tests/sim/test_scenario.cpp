// Tests of the simulation scenarios (sim/scenario.hpp): the camera map, per-press variations of
// the simulator, and the realistic scenario wired through localization_experiment.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "tacmap/sim/experiment.hpp"
#include "tacmap/sim/protocol.hpp"
#include "tacmap/sim/scenario.hpp"
#include "tacmap/sim/tactile_simulator.hpp"
#include "test_support.hpp"

namespace {

const tacmap::touch_protocol& gecko() {
  static const tacmap::touch_protocol p =
      tacmap::load_protocol(std::filesystem::path(TACMAP_DATA_DIR) / "gecko" / "protocol.txt");
  return p;
}

// A map with a bright square on a mid-grey ground, and a relief of the same size.
tacmap::image<float> square_map() {
  tacmap::image<float> m = tacmap::image<float>::Constant(40, 50, 0.3F);
  m.block(10, 15, 20, 20).setConstant(0.8F);
  return m;
}

}  // namespace

TEST_CASE("camera_image: the ideal scenario returns the map unchanged") {
  const auto map = square_map();
  const tacmap::image<float> flat = tacmap::image<float>::Zero(40, 50);
  const auto out = tacmap::camera_image(map, flat, 1.0, {}, 7);
  CHECK((out == map).all());
}

TEST_CASE("camera_image: each effect does what its comment says") {
  const auto map = square_map();
  const tacmap::image<float> flat = tacmap::image<float>::Zero(40, 50);
  SUBCASE("gamma: linear intensity^(1/gamma)") {
    tacmap::scenario_params s;
    s.camera_gamma = 2.2;
    const auto out = tacmap::camera_image(map, flat, 1.0, s, 1);
    CHECK(out(0, 0) == doctest::Approx(std::pow(0.3, 1.0 / 2.2)).epsilon(1e-6));
    CHECK(out(20, 25) == doctest::Approx(std::pow(0.8, 1.0 / 2.2)).epsilon(1e-6));
  }
  SUBCASE("shading leaves a flat surface as it is (flat = 1) and marks a step's walls") {
    tacmap::scenario_params s;
    s.shading = 0.5;
    CHECK((tacmap::camera_image(map, flat, 1.0, s, 1) - map).abs().maxCoeff() < 1e-6F);
    const tacmap::image<float> relief = (map > 0.5F).cast<float>() * 4.0F;
    const auto out = tacmap::camera_image(map, relief, 1.0, s, 1);
    // Interior and ground unchanged; the walls (the square's border pixels) change.
    CHECK(out(20, 25) == doctest::Approx(0.8).epsilon(1e-6));
    CHECK(out(0, 0) == doctest::Approx(0.3).epsilon(1e-6));
    const float wall_change =
        std::max({std::abs(out(20, 15) - map(20, 15)), std::abs(out(20, 34) - map(20, 34)),
                  std::abs(out(10, 25) - map(10, 25)), std::abs(out(29, 25) - map(29, 25))});
    CHECK(wall_change > 0.05F);
  }
  SUBCASE("illumination gradient: at most the peak-to-peak change, across the map") {
    tacmap::scenario_params s;
    s.illumination_gradient = 0.2;
    const tacmap::image<float> grey = tacmap::image<float>::Constant(40, 50, 0.5F);
    const auto out = tacmap::camera_image(grey, flat, 1.0, s, 3);
    CHECK(out.maxCoeff() <= 0.5F * 1.1F + 1e-6F);
    CHECK(out.minCoeff() >= 0.5F * 0.9F - 1e-6F);
    CHECK(out.maxCoeff() - out.minCoeff() > 0.5F * 0.1F);
    CHECK(out.mean() == doctest::Approx(0.5).epsilon(0.02));
  }
  SUBCASE("albedo texture: the relative spread asked for") {
    tacmap::scenario_params s;
    s.albedo_variation = 0.05;
    const tacmap::image<float> grey = tacmap::image<float>::Constant(40, 50, 0.5F);
    const auto out = tacmap::camera_image(grey, flat, 1.0, s, 3);
    const double mean = out.cast<double>().mean();
    const double sd = std::sqrt((out.cast<double>() - mean).square().mean());
    CHECK(sd / 0.5 == doctest::Approx(0.05).epsilon(0.01));
  }
}

TEST_CASE("camera_image: realistic is deterministic for a seed, in [0, 1], and not the map") {
  const auto& g = gecko();
  const auto relief = g.relief_mm();
  const auto s = tacmap::scenario_params::realistic();
  const auto a = tacmap::camera_image(g.map, relief, g.mm_per_px, s, 11);
  const auto b = tacmap::camera_image(g.map, relief, g.mm_per_px, s, 11);
  const auto c = tacmap::camera_image(g.map, relief, g.mm_per_px, s, 12);
  CHECK((a == b).all());
  CHECK_FALSE((a == c).all());
  CHECK(a.minCoeff() >= 0.0F);
  CHECK(a.maxCoeff() <= 1.0F);
  CHECK((a - g.map).abs().mean() > 0.05F);
  // Still a picture of the gecko: strongly correlated with the map.
  const Eigen::ArrayXd x = g.map.cast<double>().reshaped();
  const Eigen::ArrayXd y = a.cast<double>().reshaped();
  const double r = ((x - x.mean()) * (y - y.mean())).mean() /
                   std::sqrt((x - x.mean()).square().mean() * (y - y.mean()).square().mean());
  CHECK(r > 0.9);
}

TEST_CASE("scenario_params: validation names the field, the value and the range") {
  CHECK_NOTHROW(tacmap::scenario_params{}.validate());
  CHECK_NOTHROW(tacmap::scenario_params::realistic().validate());
  tacmap::scenario_params s;
  s.camera_gamma = 0.0;
  const std::string m = tacmap_test::message_of([&] { s.validate(); });
  CHECK(m.find("camera_gamma = 0") != std::string::npos);
  CHECK(m.find("expected 0.1 .. 10") != std::string::npos);
  s = {};
  s.orientation_jitter_deg = std::nan("");
  CHECK_THROWS_WITH_AS(s.validate(), doctest::Contains("orientation_jitter_deg = nan"),
                       std::invalid_argument);
  s = {};
  s.press_depth_jitter = -0.1;
  CHECK_THROWS_WITH_AS(s.validate(), doctest::Contains("press_depth_jitter = -0.1"),
                       std::invalid_argument);
  const tacmap::image<float> map = square_map();
  CHECK_THROWS_WITH_AS(
      static_cast<void>(tacmap::camera_image(map, tacmap::image<float>::Zero(4, 4), 1.0, {}, 1)),
      doctest::Contains("the relief is 4 x 4 px"), std::invalid_argument);
}

TEST_CASE("tactile_simulator: press_variation scales the depth and tilts the plane") {
  // A flat relief: every taxel is indented by exactly the press depth when the array is level.
  const tacmap::image<float> flat = tacmap::image<float>::Constant(90, 90, 2.0F);
  tacmap::simulator_params p;
  p.press_depth_mm = 1.0;
  const tacmap::tactile_simulator sim(flat, {90, 90}, 1.0, p);
  const tacmap::map_pose centre{45.0, 45.0, 0.0};
  const auto level = sim.indentation_mm(centre);
  CHECK((level - 1.0F).abs().maxCoeff() < 1e-5F);
  CHECK((sim.indentation_mm(centre, {}) == level).all());
  const auto deeper = sim.indentation_mm(centre, {.depth_scale = 1.5});
  CHECK((deeper - 1.5F).abs().maxCoeff() < 1e-5F);
  // Tilted about the row axis (slope along u, the columns): one side is pressed harder; the
  // highest point still gets the press depth, the far side loses slope x span.
  const double tilt = 0.01;  // rad
  const auto tilted = sim.indentation_mm(centre, {.tilt_u_rad = tilt});
  const Eigen::Index last = tilted.cols() - 1;
  CHECK(tilted(0, 0) > tilted(0, last));
  CHECK(tilted.maxCoeff() <= 1.0F + 1e-5F);
  const double span = static_cast<double>(last) * p.geometry.pitch_mm;
  CHECK(tilted(0, 0) - tilted(0, last) == doctest::Approx(std::tan(tilt) * span).epsilon(0.02));
  // Each row is the same along v.
  CHECK((tilted.row(0) - tilted.row(tilted.rows() - 1)).abs().maxCoeff() < 1e-5F);
  CHECK_THROWS_WITH_AS(static_cast<void>(sim.indentation_mm(centre, {.depth_scale = -1.0})),
                       doctest::Contains("depth_scale = -1"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(static_cast<void>(sim.indentation_mm(centre, {.tilt_v_rad = 1.0})),
                       doctest::Contains("tilt_v_rad = 1"), std::invalid_argument);
}

TEST_CASE("localization_experiment: a registration error shifts what the sensor feels") {
  // Only a 6-pixel (6.8 mm) registration shift, a perfect sensor and NCC: every touch feels the
  // map 6.8 mm away from where the arm says it is, so the estimate is off by about that much.
  tacmap::localization_config config;
  config.model = tacmap::measurement_kind::ncc;
  config.scenario.registration_shift_mm = 6.0 * gecko().mm_per_px;
  tacmap::localization_experiment experiment(gecko(), config);
  CHECK((experiment.visual_map() == gecko().map).all());  // no camera effect asked for
  // Per sequence the final error depends on the shift's direction against the local shape (a
  // shift along a straight edge is not seen); the median over sequences is the shift. Seven
  // sequences keep the test quick in Debug builds.
  std::vector<double> finals;
  for (std::size_t q = 0; q < 7; ++q) finals.push_back(experiment.run(q).touches.back().error_mm);
  const double shift = 6.0 * gecko().mm_per_px;
  CHECK(tacmap::median(finals) > shift - 1.5 * gecko().mm_per_px);
  CHECK(tacmap::median(finals) < shift + 1.5 * gecko().mm_per_px);
  // Without the shift the same runs end within a pixel.
  config.scenario = {};
  tacmap::localization_experiment ideal(gecko(), config);
  CHECK(ideal.run(0).touches.back().error_mm < 1.2 * gecko().mm_per_px);
}

TEST_CASE("localization_experiment: the realistic scenario runs and is reproducible") {
  tacmap::localization_config config;
  config.model = tacmap::measurement_kind::ncc;
  config.scenario = tacmap::scenario_params::realistic();
  config.simulator = tacmap::realistic_sensor(config.simulator);
  tacmap::localization_experiment experiment(gecko(), config);
  CHECK_FALSE((experiment.visual_map() == gecko().map).all());  // the camera's map
  const auto a = experiment.run(3, true);
  const auto b = experiment.run(3);
  REQUIRE(a.touches.size() == b.touches.size());
  for (std::size_t t = 0; t < a.touches.size(); ++t) {
    CHECK(a.touches[t].error_mm == b.touches[t].error_mm);
    CHECK(a.touches[t].entropy_nats == b.touches[t].entropy_nats);
  }
  // The sequence's touches near the border still render (the relief is padded) and localize.
  CHECK(a.touches.back().error_mm < 5.0);
}

TEST_CASE("localization_config::name shows tau when it is set") {
  tacmap::localization_config c;
  c.tau = 0.5;
  CHECK(c.name() == "classic_sift/aligned/exponential/per_window/tau=0.5");
  c.model = tacmap::measurement_kind::ncc;
  c.tau = 0.1;
  CHECK(c.name() == "ncc/tau=0.1");
}
