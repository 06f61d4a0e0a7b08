// Tests of the simulation scenarios (sim/scenario.hpp): the camera map, the object's relief under
// either polarity, per-press variations of the simulator, and the realistic scenario wired
// through localization_experiment.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "gecko_protocol.hpp"
#include "tacmap/sim/experiment.hpp"
#include "tacmap/sim/protocol.hpp"
#include "tacmap/sim/scenario.hpp"
#include "tacmap/sim/tactile_simulator.hpp"
#include "test_support.hpp"

namespace test_scenario {

namespace {

using tacmap_test::gecko;

// A map with a bright square on a mid-grey ground, and a relief of the same size.
tacmap::image<float> square_map() {
  tacmap::image<float> m = tacmap::image<float>::Constant(40, 50, 0.3F);
  m.block(10, 15, 20, 20).setConstant(0.8F);
  return m;
}

// A map whose intensity changes everywhere (a diagonal ramp through [0, 1]).
tacmap::image<float> ramp_map(Eigen::Index rows, Eigen::Index cols) {
  tacmap::image<float> m(rows, cols);
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index c = 0; c < cols; ++c)
      m(r, c) = static_cast<float>(r + c) / static_cast<float>(rows + cols - 2);
  return m;
}

constexpr tacmap::relief_params continuous_relief{.kind = tacmap::relief_kind::continuous,
                                                  .threshold = 0.5F,
                                                  .height_mm = 4.0,
                                                  .edge_smoothing_px = 0.0};

// The mixed-polarity weight w as object_relief applies it: on a black map under a continuous
// 4 mm relief, this polarity's relief is 0 and the opposite one 4 mm, so relief / 4 = w.
tacmap::image<float> mixed_weight(double fraction, std::uint64_t seed) {
  tacmap::scenario_params s;
  s.mixed_polarity = fraction;
  const tacmap::image<float> black = tacmap::image<float>::Zero(120, 120);
  return tacmap::object_relief(black, continuous_relief, s, +1, seed) / 4.0F;
}

double fraction_above(const tacmap::image<float>& values, float level) {
  return (values > level).cast<double>().mean();
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

TEST_CASE("object_relief: sign +1 is the protocol's relief, sign -1 raises the dark parts") {
  const auto& g = gecko();
  const tacmap::scenario_params ideal;
  SUBCASE("sign +1 without mixed polarity is relief_from_image, bit for bit") {
    CHECK((tacmap::object_relief(g.map, g.relief, ideal, +1, 5) ==
           tacmap::relief_from_image(g.map, g.relief))
              .all());
    const auto ramp = ramp_map(30, 40);
    CHECK((tacmap::object_relief(ramp, continuous_relief, ideal, +1, 5) ==
           tacmap::relief_from_image(ramp, continuous_relief))
              .all());
    // Only mixed polarity changes the relief: the camera effects and the polarity field (the
    // sign is the experiment's draw) do not.
    auto camera_only = tacmap::scenario_params::realistic();
    camera_only.ink_coverage = 0.1;
    camera_only.albedo_contrast = 0.5;
    camera_only.polarity = tacmap::relief_polarity::dark_raised;
    CHECK((tacmap::object_relief(g.map, g.relief, camera_only, +1, 5) ==
           tacmap::relief_from_image(g.map, g.relief))
              .all());
  }
  SUBCASE("sign -1 is the inverted image's relief: high where the photo is dark") {
    const auto map = square_map();  // bright square (0.8) on a grey ground (0.3)
    const auto bright = tacmap::object_relief(map, continuous_relief, ideal, +1, 5);
    const auto dark = tacmap::object_relief(map, continuous_relief, ideal, -1, 5);
    CHECK(dark(0, 0) == doctest::Approx(4.0 * 0.7).epsilon(1e-6));
    CHECK(dark(20, 25) == doctest::Approx(4.0 * 0.2).epsilon(1e-6));
    CHECK(bright(20, 25) > bright(0, 0));
    CHECK(dark(0, 0) > dark(20, 25));
    // The gecko's binary relief: the ground is raised and the gecko is a 4 mm pocket.
    const auto gecko_dark = tacmap::object_relief(g.map, g.relief, ideal, -1, 5);
    const tacmap::image<float> inverted = 1.0F - g.map;
    CHECK((gecko_dark == tacmap::relief_from_image(inverted, g.relief)).all());
    const auto gecko_bright = tacmap::relief_from_image(g.map, g.relief);
    CHECK(((gecko_dark > 0.0F) != (gecko_bright > 0.0F)).cast<double>().mean() > 0.99);
  }
  SUBCASE("a sign other than +1 or -1 is refused") {
    for (const int sign : {0, 2, -2}) {
      const std::string m = tacmap_test::message_of(
          [&] { static_cast<void>(tacmap::object_relief(g.map, g.relief, ideal, sign, 5)); });
      CHECK(m.find("object_relief: sign = " + std::to_string(sign)) != std::string::npos);
      CHECK(m.find("expected +1") != std::string::npos);
    }
  }
}

TEST_CASE("object_relief: mixed polarity flips smooth regions of about the fraction asked for") {
  const auto w = mixed_weight(0.3, 21);
  CHECK(w.minCoeff() >= 0.0F);
  CHECK(w.maxCoeff() <= 1.0F + 1e-6F);
  CHECK(fraction_above(w, 0.5F) == doctest::Approx(0.3).epsilon(0.1 / 0.3));
  CHECK(w.cast<double>().mean() == doctest::Approx(0.3).epsilon(0.1 / 0.3));
  // Regions, not speckle: most of the map is clearly one side or the other...
  CHECK((w < 0.05F || w > 0.95F).cast<double>().mean() > 0.6);
  // ...and the transitions are smooth: no step from one polarity to the other between
  // neighbouring pixels (a hard step would be a relief edge the object does not have).
  const Eigen::Index n = w.rows();
  CHECK((w.rightCols(n - 1) - w.leftCols(n - 1)).abs().maxCoeff() < 0.35F);
  CHECK((w.bottomRows(n - 1) - w.topRows(n - 1)).abs().maxCoeff() < 0.35F);
  // Fixed per map by the seed, another seed gives other regions.
  CHECK((mixed_weight(0.3, 21) == w).all());
  const auto other = mixed_weight(0.3, 22);
  CHECK((other - w).abs().mean() > 0.1F);
  // Other fractions.
  CHECK(fraction_above(mixed_weight(0.1, 3), 0.5F) == doctest::Approx(0.1).epsilon(0.5));
  CHECK(fraction_above(mixed_weight(0.7, 3), 0.5F) == doctest::Approx(0.7).epsilon(0.1 / 0.7));
  CHECK((mixed_weight(1.0, 3) - 1.0F).abs().maxCoeff() < 1e-5F);
  // The regions are the same whatever the sequence's sign: relief = w R(opposite) + (1 - w)
  // R(this sign), so for sign -1 on the black map (R(-1) = 4 mm, R(+1) = 0) it is 4 (1 - w).
  tacmap::scenario_params s;
  s.mixed_polarity = 0.3;
  const tacmap::image<float> black = tacmap::image<float>::Zero(120, 120);
  const auto dark = tacmap::object_relief(black, continuous_relief, s, -1, 21);
  CHECK((dark - 4.0F * (1.0F - w)).abs().maxCoeff() < 1e-5F);
  // Where w is near 0.5 the relief of a ramp flattens to half the height (R(+1) + R(-1) is the
  // height everywhere): the photo's ramp continues, the relief does not follow it.
  const auto ramp = ramp_map(120, 120);
  const auto mixed = tacmap::object_relief(ramp, continuous_relief, s, +1, 21);
  const auto own = tacmap::relief_from_image(ramp, continuous_relief);
  const tacmap::image<float> expected =
      w * (4.0F - own) + (1.0F - w) * own;  // R(-1) = 4 (1 - ramp) = 4 - R(+1)
  CHECK((mixed - expected).abs().maxCoeff() < 1e-4F);
}

TEST_CASE("camera_image: printed ink changes the map, never the relief") {
  const tacmap::image<float> grey = tacmap::image<float>::Constant(120, 120, 0.5F);
  const tacmap::image<float> flat = tacmap::image<float>::Zero(120, 120);
  tacmap::scenario_params s;
  s.ink_coverage = 0.1;
  s.ink_contrast = 0.4;
  CHECK(s.changes_map());
  CHECK_FALSE(s.changes_relief());
  const auto out = tacmap::camera_image(grey, flat, 1.0, s, 9);
  // Half the strokes pull towards black, half towards white, by the contrast: 0.5 becomes
  // 0.6 x 0.5 = 0.3 or 0.6 x 0.5 + 0.4 = 0.7; everything else is untouched.
  const auto darkened = (out - 0.3F).abs() < 1e-6F;
  const auto lightened = (out - 0.7F).abs() < 1e-6F;
  const auto untouched = out == 0.5F;
  CHECK((darkened || lightened || untouched).all());
  const double inked = 1.0 - untouched.cast<double>().mean();
  CHECK(inked == doctest::Approx(0.1).epsilon(0.2));
  const double dark_share = darkened.cast<double>().mean() / inked;
  CHECK(dark_share > 0.3);
  CHECK(dark_share < 0.7);
  // Strokes, not scattered dots: an inked pixel has about 5 inked 8-neighbours on average
  // (pixels inked independently at this coverage would have 0.8).
  const tacmap::image<float> ink = (!untouched).cast<float>();
  tacmap::image<float> neighbours = tacmap::image<float>::Zero(118, 118);
  for (Eigen::Index dr = 0; dr < 3; ++dr)
    for (Eigen::Index dc = 0; dc < 3; ++dc)
      if (dr != 1 || dc != 1) neighbours += ink.block(dr, dc, 118, 118);
  const tacmap::image<float> centre = ink.block(1, 1, 118, 118);
  CHECK((centre * neighbours).sum() > 3.0F * centre.sum());
  // Deterministic for the seed; another seed prints elsewhere.
  CHECK((tacmap::camera_image(grey, flat, 1.0, s, 9) == out).all());
  CHECK_FALSE((tacmap::camera_image(grey, flat, 1.0, s, 10) == out).all());
  // More coverage, more ink.
  s.ink_coverage = 0.4;
  const auto more = tacmap::camera_image(grey, flat, 1.0, s, 9);
  CHECK((more != 0.5F).cast<double>().mean() == doctest::Approx(0.4).epsilon(0.1));
  // The relief the sensor presses ignores ink entirely.
  const auto& g = gecko();
  CHECK((tacmap::object_relief(g.map, g.relief, s, +1, 9) ==
         tacmap::relief_from_image(g.map, g.relief))
            .all());
  // Ink on the realistic scenario's camera map changes it; the realistic map itself is not the
  // inked one.
  auto realistic = tacmap::scenario_params::realistic();
  const auto relief = g.relief_mm();
  const auto plain = tacmap::camera_image(g.map, relief, g.mm_per_px, realistic, 11);
  realistic.ink_coverage = 0.05;
  CHECK_FALSE((tacmap::camera_image(g.map, relief, g.mm_per_px, realistic, 11) == plain).all());
}

TEST_CASE("camera_image: albedo contrast scales the map's contrast about its mean") {
  const auto map = square_map();
  const tacmap::image<float> flat = tacmap::image<float>::Zero(40, 50);
  const double mean = map.cast<double>().mean();
  tacmap::scenario_params s;
  s.albedo_contrast = 0.0;
  CHECK(s.changes_map());
  // An object of one colour on a flat relief: a constant picture (no noise asked for).
  const auto one_colour = tacmap::camera_image(map, flat, 1.0, s, 1);
  CHECK(one_colour.maxCoeff() - one_colour.minCoeff() < 1e-6F);
  CHECK(one_colour(0, 0) == doctest::Approx(mean).epsilon(1e-6));
  // With a relief and shading, only the relief's walls show.
  s.shading = 0.5;
  const tacmap::image<float> relief = (map > 0.5F).cast<float>() * 4.0F;
  const auto shaded = tacmap::camera_image(map, relief, 1.0, s, 1);
  CHECK(shaded(20, 25) == doctest::Approx(mean).epsilon(1e-6));
  CHECK(shaded(0, 0) == doctest::Approx(mean).epsilon(1e-6));
  CHECK(shaded.maxCoeff() - shaded.minCoeff() > 0.05F);
  // Half the contrast: halfway between the map and its mean.
  s = {};
  s.albedo_contrast = 0.5;
  const auto half = tacmap::camera_image(map, flat, 1.0, s, 1);
  CHECK(half(20, 25) == doctest::Approx(mean + 0.5 * (0.8 - mean)).epsilon(1e-6));
  CHECK(half(0, 0) == doctest::Approx(mean + 0.5 * (0.3 - mean)).epsilon(1e-6));
  // Contrast 1 and ink of any opacity at coverage 0 are no effect: the map comes back as is.
  s = {};
  s.ink_contrast = 1.0;
  CHECK_FALSE(s.changes_map());
  CHECK((tacmap::camera_image(map, flat, 1.0, s, 1) == map).all());
}

TEST_CASE("scenario_params: polarity, ink and albedo fields are validated; unknown_object()") {
  tacmap::scenario_params s;
  s.ink_coverage = 1.5;
  std::string m = tacmap_test::message_of([&] { s.validate(); });
  CHECK(m.find("ink_coverage = 1.5") != std::string::npos);
  CHECK(m.find("expected 0 .. 1") != std::string::npos);
  s = {};
  s.ink_contrast = -0.1;
  CHECK_THROWS_WITH_AS(s.validate(), doctest::Contains("ink_contrast = -0.1"),
                       std::invalid_argument);
  s = {};
  s.albedo_contrast = std::nan("");
  CHECK_THROWS_WITH_AS(s.validate(), doctest::Contains("albedo_contrast = nan"),
                       std::invalid_argument);
  s = {};
  s.mixed_polarity = 2.0;
  m = tacmap_test::message_of([&] { s.validate(); });
  CHECK(m.find("mixed_polarity = 2") != std::string::npos);
  CHECK(m.find("expected 0 .. 1") != std::string::npos);
  s = {};
  s.polarity = static_cast<tacmap::relief_polarity>(7);
  CHECK_THROWS_WITH_AS(s.validate(), doctest::Contains("polarity = 7; expected"),
                       std::invalid_argument);
  // object_relief and camera_image validate too.
  s = {};
  s.mixed_polarity = -0.5;
  CHECK_THROWS_WITH_AS(
      static_cast<void>(tacmap::object_relief(square_map(), continuous_relief, s, 1, 1)),
      doctest::Contains("mixed_polarity = -0.5"), std::invalid_argument);

  // The defaults and the realistic scenario change nothing about polarity or ink.
  CHECK(tacmap::scenario_params{}.polarity == tacmap::relief_polarity::bright_raised);
  CHECK_FALSE(tacmap::scenario_params{}.changes_relief());
  CHECK_FALSE(tacmap::scenario_params::realistic().changes_relief());
  CHECK(tacmap::scenario_params::realistic().ink_coverage == 0.0);
  CHECK(tacmap::scenario_params::realistic().albedo_contrast == 1.0);
  // The unknown object: realistic plus random polarity, mixed polarity and ink.
  const auto unknown = tacmap::scenario_params::unknown_object();
  CHECK_NOTHROW(unknown.validate());
  CHECK(unknown.polarity == tacmap::relief_polarity::random);
  CHECK(unknown.mixed_polarity > 0.0);
  CHECK(unknown.ink_coverage > 0.0);
  CHECK(unknown.changes_map());
  CHECK(unknown.changes_relief());
  CHECK(unknown.moves_sensor());
  CHECK(unknown.camera_gamma == tacmap::scenario_params::realistic().camera_gamma);

  CHECK(std::string(tacmap::to_string(tacmap::scenario_kind::ideal)) == "ideal");
  CHECK(std::string(tacmap::to_string(tacmap::scenario_kind::realistic)) == "realistic");
  CHECK(std::string(tacmap::to_string(tacmap::scenario_kind::unknown)) == "unknown");
  CHECK(std::string(tacmap::to_string(tacmap::relief_polarity::bright_raised)) == "bright");
  CHECK(std::string(tacmap::to_string(tacmap::relief_polarity::dark_raised)) == "dark");
  CHECK(std::string(tacmap::to_string(tacmap::relief_polarity::random)) == "random");
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
  CHECK(c.name() == "classic_sift/aligned/exponential/per_window/tau=0.5/latent");
  c.appearance = tacmap::appearance_handling::fixed;
  CHECK(c.name() == "classic_sift/aligned/exponential/per_window/tau=0.5");
  c.model = tacmap::measurement_kind::ncc;
  c.tau = 0.1;
  CHECK(c.name() == "ncc/tau=0.1");
  c.appearance = tacmap::appearance_handling::latent;
  c.appearance_switch = 0.2;
  CHECK(c.name() == "ncc/tau=0.1/latent/switch=0.2");
  CHECK(c.switch_probability() == 0.2);
  c.appearance_switch.reset();
  CHECK(c.switch_probability() == tacmap::localization_config::default_appearance_switch);
  c.appearance = tacmap::appearance_handling::fixed;
  CHECK(c.switch_probability() == 0.0);
  // A switch with a fixed appearance contradicts it: the error names both.
  c.appearance_switch = 0.1;
  const std::string m = tacmap_test::message_of([&] { c.validate(); });
  CHECK(m.find("appearance_switch = 0.1 needs appearance = latent") != std::string::npos);
  CHECK(m.find("appearance = fixed") != std::string::npos);
}

}  // namespace test_scenario
