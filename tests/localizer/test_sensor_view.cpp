// Tests of the map as the sensor sees it (localizer_config::pad_spread_mm): `gaussian_blurred`
// against its definition, the localizers describing the blurred map (the same belief as a
// localizer given the blurred map itself, in the photograph's millimetres, the library too),
// and bad settings refused with the value named.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "tacmap/library_localizer.hpp"
#include "tacmap/localizer.hpp"
#include "tacmap/sim/random.hpp"
#include "tacmap/sim/tactile_simulator.hpp"
#include "test_support.hpp"

namespace test_sensor_view {

namespace {

// A 60 x 50 px object with detail at every scale: smooth blobs plus a one-pixel texture (the
// fine detail a touch cannot show). Values in [0, 1].
tacmap::image<float> textured(std::uint64_t seed) {
  tacmap::sim_rng rng(seed);
  tacmap::image<float> out = tacmap::image<float>::Zero(50, 60);
  for (int b = 0; b < 12; ++b) {
    const double x = rng.uniform() * 60.0, y = rng.uniform() * 50.0;
    const double radius = 2.0 + 4.0 * rng.uniform();
    for (Eigen::Index r = 0; r < out.rows(); ++r)
      for (Eigen::Index c = 0; c < out.cols(); ++c) {
        const double dx = static_cast<double>(c) - x, dy = static_cast<double>(r) - y;
        out(r, c) += static_cast<float>(std::exp(-(dx * dx + dy * dy) / (2 * radius * radius)));
      }
  }
  for (Eigen::Index i = 0; i < out.size(); ++i) out(i) += static_cast<float>(0.3 * rng.uniform());
  return out / out.maxCoeff();
}

constexpr double mm_per_px = 3.4 / 3.0;  // the default working resolution: used as it is

// A frame pressed at (x, y) mm on `map` by the paper's array.
tacmap::tactile_frame press(const tacmap::image<float>& map, double x_mm, double y_mm) {
  tacmap::tactile_simulator sim(map * 4.0F, {.width = map.cols(), .height = map.rows()}, mm_per_px,
                                {.seed = 5});
  return sim.render({.x_mm = x_mm, .y_mm = y_mm});
}

double max_abs_difference(const tacmap::image<float>& a, const tacmap::image<float>& b) {
  REQUIRE(a.rows() == b.rows());
  REQUIRE(a.cols() == b.cols());
  return static_cast<double>((a - b).abs().maxCoeff());
}

}  // namespace

TEST_CASE("gaussian_blurred: an impulse becomes a unit-mass Gaussian of the given sigma") {
  const double sigma = 2.5;
  tacmap::image<float> impulse = tacmap::image<float>::Zero(41, 45);
  impulse(20, 22) = 1.0F;
  const tacmap::image<float> g = tacmap::gaussian_blurred(impulse, sigma);
  CHECK(g.sum() == doctest::Approx(1.0).epsilon(1e-5));  // far from the border: mass kept
  double mx = 0.0, my = 0.0, vx = 0.0, vy = 0.0;
  for (Eigen::Index r = 0; r < g.rows(); ++r)
    for (Eigen::Index c = 0; c < g.cols(); ++c) {
      const double w = g(r, c), dx = static_cast<double>(c - 22), dy = static_cast<double>(r - 20);
      mx += w * dx;
      my += w * dy;
      vx += w * dx * dx;
      vy += w * dy * dy;
    }
  CHECK(std::abs(mx) < 1e-5);  // centred: no shift
  CHECK(std::abs(my) < 1e-5);
  // Taps to 3 sigma lose 2.7 % of the variance: sigma itself, not sigma^2 or 2 sigma.
  CHECK(std::sqrt(vx) == doctest::Approx(sigma).epsilon(0.03));
  CHECK(std::sqrt(vy) == doctest::Approx(sigma).epsilon(0.03));
  CHECK(g(20, 22 + 2) == doctest::Approx(g(20, 22 - 2)));  // symmetric
  CHECK(g(20 + 3, 22) == doctest::Approx(g(20, 22 + 3)));  // the same along both axes
  // Against the separable Gaussian's own value at the centre, 1 / (2 pi sigma^2) renormalised
  // over the taps: within 1 %.
  CHECK(g(20, 22) == doctest::Approx(1.0 / (2.0 * std::numbers::pi * sigma * sigma)).epsilon(0.01));
}

TEST_CASE("gaussian_blurred: a constant stays constant to the border; sigma 0 is the image") {
  const tacmap::image<float> flat = tacmap::image<float>::Constant(9, 7, 0.625F);
  CHECK(max_abs_difference(tacmap::gaussian_blurred(flat, 4.0), flat) < 1e-6);
  const tacmap::image<float> map = textured(1);
  CHECK(max_abs_difference(tacmap::gaussian_blurred(map, 0.0), map) == 0.0);
  // Sub-pixel sigma: taps to 3 sigma round up to one pixel either side, and it smooths.
  CHECK(max_abs_difference(tacmap::gaussian_blurred(map, 0.4), map) > 0.01);
  for (const double bad : {-1.0, std::numeric_limits<double>::quiet_NaN(), 1001.0,
                           std::numeric_limits<double>::infinity()}) {
    CAPTURE(bad);
    CHECK_THROWS_WITH_AS(static_cast<void>(tacmap::gaussian_blurred(map, bad)),
                         doctest::Contains("gaussian_blurred: sigma_px = "), std::invalid_argument);
  }
}

TEST_CASE("pad_spread_mm: the localizer describes the map blurred by it, in millimetres") {
  const tacmap::image<float> map = textured(2);
  const tacmap::tactile_frame first = press(map, 30.0, 30.0);
  const tacmap::tactile_frame second = press(map, 36.0, 27.0);
  const auto belief_after_two = [&](const tacmap::image<float>& m, double spread_mm) {
    tacmap::localizer_config c;
    c.pad_spread_mm = spread_mm;
    tacmap::localizer loc(m, mm_per_px, c);
    CHECK(loc.map().cols() == m.cols());  // matched at the photograph's own scale
    static_cast<void>(loc.touch(first));
    static_cast<void>(loc.touch(second, tacmap::odometry{.dx_mm = 6.0, .dy_mm = -3.0}));
    return loc.belief();
  };
  // The default: half the sensor's pitch, 1.7 mm for the paper's array.
  CHECK(!tacmap::localizer_config{}.pad_spread_mm);
  CHECK(tacmap::localizer_config{}.pad_spread(tacmap::taxel_geometry{}) == doctest::Approx(1.7));
  CHECK(tacmap::localizer_config{}.pad_spread({.rows = 8, .cols = 8, .pitch_mm = 2.0}) ==
        doctest::Approx(1.0));
  {  // ... which is what an empty setting does
    tacmap::localizer_config told;
    told.pad_spread_mm = 1.7;
    tacmap::localizer explicit_spread(map, mm_per_px, told), defaulted(map, mm_per_px);
    static_cast<void>(explicit_spread.touch(first));
    static_cast<void>(defaulted.touch(first));
    CHECK(max_abs_difference(explicit_spread.belief(), defaulted.belief()) == 0.0);
  }
  for (const double spread : {1.7, 3.4}) {
    CAPTURE(spread);
    // The blur is the map's, sigma = spread / mm_per_px pixels: a localizer given that map
    // already blurred (and told not to blur it again) believes the same.
    const tacmap::image<float> told = belief_after_two(map, spread);
    const tacmap::image<float> blurred =
        belief_after_two(tacmap::gaussian_blurred(map, spread / mm_per_px), 0.0);
    CHECK(max_abs_difference(told, blurred) < 1e-5);
    // ... and not the same as the photograph as it is, nor as a blur in other units.
    CHECK(max_abs_difference(told, belief_after_two(map, 0.0)) > 1e-3);
    CHECK(max_abs_difference(told, belief_after_two(tacmap::gaussian_blurred(map, spread), 0.0)) >
          1e-3);
  }
}

TEST_CASE("pad_spread_mm: a library's maps are described blurred too") {
  const tacmap::image<float> a = textured(3), b = textured(4);
  const tacmap::tactile_frame frame = press(a, 30.0, 28.0);
  // Object a's belief over positions after the touch.
  const auto belief = [&](const tacmap::image<float>& ma, const tacmap::image<float>& mb,
                          double spread_mm) {
    tacmap::localizer_config c;
    c.pad_spread_mm = spread_mm;
    tacmap::library_localizer lib({{"a", ma, mm_per_px}, {"b", mb, mm_per_px}}, c);
    static_cast<void>(lib.touch(frame));
    return lib.object_belief_image(0);
  };
  const double s = 1.7 / mm_per_px;
  const tacmap::image<float> told = belief(a, b, 1.7);
  CHECK(max_abs_difference(told, belief(tacmap::gaussian_blurred(a, s),
                                        tacmap::gaussian_blurred(b, s), 0.0)) < 1e-6);
  CHECK(max_abs_difference(told, belief(a, b, 0.0)) > 1e-4);
}

TEST_CASE("pad_spread_mm: a spread that is not a spread is refused, naming it") {
  const tacmap::image<float> map = textured(5);
  for (const double bad : {-0.5, std::numeric_limits<double>::quiet_NaN(), 101.0}) {
    CAPTURE(bad);
    tacmap::localizer_config c;
    c.pad_spread_mm = bad;
    CHECK_THROWS_WITH_AS(c.validate(), doctest::Contains("pad_spread_mm = "),
                         std::invalid_argument);
    CHECK_THROWS_WITH_AS(static_cast<void>(tacmap::localizer(map, mm_per_px, c)),
                         doctest::Contains("leave it empty for half the sensor's pitch"),
                         std::invalid_argument);
  }
  // In range in mm, but thousands of pixels on a map of 0.05 mm per px: refused with the
  // scale named, before any work.
  tacmap::localizer_config wide;
  wide.pad_spread_mm = 100.0;
  wide.working_mm_per_px = 0.05;
  tacmap::image<float> fine = tacmap::image<float>::Zero(960, 420);
  fine(0, 0) = 1.0F;
  CHECK_THROWS_WITH_AS(
      static_cast<void>(tacmap::localizer(fine, 0.05, wide)),
      doctest::Contains("(pad_spread_mm) 100 mm is 2000 px on a map of 0.05 mm per px"),
      std::invalid_argument);
}

}  // namespace test_sensor_view
