// pose_grid: layout, headings, wrap-around and bad input.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

#include "tacmap/grid/pose_grid.hpp"
#include "test_support.hpp"

namespace test_pose_grid {

using tacmap_test::message_of;

static_assert(tacmap::state_grid<tacmap::pose_grid<float>>);
static_assert(tacmap::state_grid<tacmap::pose_grid<double>>);
static_assert(tacmap::pose_grid<float>::dimension == 3);
static_assert(!tacmap::pose_grid<float>::circular[0] && !tacmap::pose_grid<float>::circular[1] &&
              tacmap::pose_grid<float>::circular[2]);

namespace {

constexpr double pi = std::numbers::pi;
constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();

// 25 x 21 positions per layer (a 30 x 24 px map, a 6 x 4 px window) at 0.5 mm per px.
tacmap::planar_grid<float> positions() {
  return tacmap::planar_grid<float>({.width = 30, .height = 24}, 0.5, {.width = 6, .height = 4});
}

bool contains(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

}  // namespace

TEST_CASE("pose_grid: sizes and the layer-after-layer, row-major layout") {
  const tacmap::pose_grid<float> g(positions(), 36);
  CHECK(g.rows() == 21);
  CHECK(g.cols() == 25);
  CHECK(g.layer_size() == 21 * 25);
  CHECK(g.size() == 21 * 25 * 36);
  CHECK(g.angle_count() == 36);
  CHECK(g.angle_step_rad() == doctest::Approx(10.0 * pi / 180.0));
  CHECK(g.mm_per_px() == 0.5);
  CHECK(g.window_size().width == 6);
  CHECK(g.window_size().height == 4);
  for (const Eigen::Index layer : {0, 1, 17, 18, 35})
    for (const tacmap::grid_cell cell :
         {tacmap::grid_cell{0, 0}, tacmap::grid_cell{3, 7}, tacmap::grid_cell{20, 24}}) {
      CAPTURE(layer);
      const Eigen::Index i = g.index(layer, cell);
      CHECK(i == layer * (21 * 25) + cell.row * 25 + cell.col);
      CHECK(g.layer(i) == layer);
      CHECK(g.cell(i) == cell);
      const auto s = g.state_mm(i);
      const auto xy = g.positions().state_mm(g.positions().index(cell));
      CHECK(s.x() == xy.x());
      CHECK(s.y() == xy.y());
      CHECK(s.z() == g.heading(layer));
    }
  // The window centre, in mm: (col + 6/2) * 0.5, (row + 4/2) * 0.5.
  const auto s = g.state_mm(g.index(9, {3, 7}));
  CHECK(s.x() == doctest::Approx(5.0));
  CHECK(s.y() == doctest::Approx(2.5));
  CHECK(s.z() == doctest::Approx(pi / 2));
}

TEST_CASE("pose_grid: headings are a * step wrapped to -pi .. pi, the middle layer exactly -pi") {
  const tacmap::pose_grid<float> g(positions(), 36);
  CHECK(g.heading(0) == 0.0);
  CHECK(g.heading(9) == doctest::Approx(pi / 2));
  CHECK(g.heading(18) == -pi);  // exactly: never +pi by rounding
  CHECK(g.heading(27) == doctest::Approx(-pi / 2));
  CHECK(g.heading(35) == doctest::Approx(-pi / 18));
  // Every count, including those where (-A/2) * (2 pi / A) rounds below -pi (50, 100).
  for (const int count : {1, 2, 3, 5, 36, 50, 72, 82, 100, 360, 3600}) {
    CAPTURE(count);
    const tacmap::pose_grid<float> h(positions(), count);
    bool in_range = true;
    bool round_trip = true;
    for (Eigen::Index a = 0; a < count; ++a) {
      const double theta = h.heading(a);
      in_range = in_range && theta >= -pi && theta < pi;
      round_trip = round_trip && h.layer_of(theta) == a;
    }
    CHECK(in_range);
    CHECK(round_trip);
    if (count % 2 == 0) CHECK(h.heading(count / 2) == -pi);
  }
}

TEST_CASE("pose_grid: layer_of rounds to the nearest heading and wraps at +-pi") {
  const tacmap::pose_grid<float> g(positions(), 36);
  const double step = g.angle_step_rad();
  CHECK(g.layer_of(0.0) == 0);
  CHECK(g.layer_of(0.49 * step) == 0);
  CHECK(g.layer_of(0.51 * step) == 1);
  CHECK(g.layer_of(-0.49 * step) == 0);
  CHECK(g.layer_of(-0.51 * step) == 35);
  CHECK(g.layer_of(pi / 2) == 9);
  CHECK(g.layer_of(-pi / 2) == 27);
  CHECK(g.layer_of(-pi) == 18);
  // Just below +pi is nearest to -pi (the same direction), not to layer 17 (+170 degrees).
  CHECK(g.layer_of(std::nextafter(pi, 0.0)) == 18);
  CHECK(g.layer_of(pi - 0.4 * step) == 18);
  CHECK(g.layer_of(pi - 0.6 * step) == 17);
  // One heading: everything is layer 0.
  const tacmap::pose_grid<float> one(positions(), 1);
  CHECK(one.size() == one.layer_size());
  CHECK(one.heading(0) == 0.0);
  CHECK(one.layer_of(-pi) == 0);
  CHECK(one.layer_of(3.0) == 0);
}

TEST_CASE("pose_grid: with_step_deg accepts steps that divide the circle and names bad ones") {
  CHECK(tacmap::pose_grid<float>::with_step_deg(positions(), 10.0).angle_count() == 36);
  CHECK(tacmap::pose_grid<float>::with_step_deg(positions(), 7.5).angle_count() == 48);
  CHECK(tacmap::pose_grid<float>::with_step_deg(positions(), 360.0).angle_count() == 1);
  CHECK(tacmap::pose_grid<float>::with_step_deg(positions(), 0.1).angle_count() == 3600);
  const std::string m =
      message_of([] { (void)tacmap::pose_grid<float>::with_step_deg(positions(), 7.0); });
  CAPTURE(m);
  CHECK(contains(m, "step = 7 degrees"));
  CHECK(contains(m, "does not divide the circle"));
  // A suggestion: the neighbouring whole numbers of headings (51 and 52).
  CHECK(contains(m, "51 headings"));
  CHECK(contains(m, "52 headings"));
  for (const double bad : {0.0, -10.0, nan_value, std::numeric_limits<double>::infinity(), 400.0}) {
    CAPTURE(bad);
    const std::string b =
        message_of([bad] { (void)tacmap::pose_grid<float>::with_step_deg(positions(), bad); });
    CHECK(contains(b, "angular step"));
    CHECK(contains(b, "(0, 360]"));
  }
}

TEST_CASE("pose_grid: angle_count must be at least 1") {
  for (const int bad : {0, -3}) {
    const std::string m = message_of([bad] { (void)tacmap::pose_grid<float>(positions(), bad); });
    CAPTURE(m);
    CHECK(contains(m, "angle_count = " + std::to_string(bad)));
    CHECK(contains(m, "expected between 1 and 3600"));
  }
}

TEST_CASE("pose_grid: NaN headings and headings outside -pi .. pi are rejected with the value") {
  const tacmap::pose_grid<float> g(positions(), 36);
  for (const double bad : {nan_value, pi, 4.0, -3.2, std::numeric_limits<double>::infinity()}) {
    CAPTURE(bad);
    const std::string a = message_of([&] { (void)g.layer_of(bad); });
    const std::string b = message_of([&] { (void)g.nearest_state(5.0, 2.5, bad); });
    const std::string c = message_of([&] { (void)g.gaussian_prior(5.0, 2.5, bad, 1.0, 0.1); });
    CAPTURE(a);
    CAPTURE(b);
    CAPTURE(c);
    CHECK(contains(a, "pose_grid::layer_of: heading theta = "));
    CHECK(contains(b, "pose_grid::nearest_state: heading theta = "));
    CHECK(contains(c, "pose_grid::gaussian_prior: heading theta = "));
    CHECK(contains(a, "[-pi, pi)"));
    CHECK(contains(c, "[-pi, pi)"));
    if (std::isnan(bad)) {
      CHECK(contains(a, "nan"));
    } else if (std::isfinite(bad)) {
      // Names the value and what wrapping it would give.
      CHECK(contains(
          a, "theta = " + [&] {
            std::ostringstream s;
            s << bad;
            return s.str();
          }()));
      CHECK(contains(a, "wrap_angle"));
    }
  }
  // -pi itself is valid.
  CHECK(g.layer_of(-pi) == 18);
}

TEST_CASE("pose_grid: nearest_state") {
  const tacmap::pose_grid<float> g(positions(), 36);
  const Eigen::Index i = g.index(9, {3, 7});
  const auto s = g.state_mm(i);
  REQUIRE(g.nearest_state(s.x(), s.y(), s.z()).has_value());
  CHECK(*g.nearest_state(s.x(), s.y(), s.z()) == i);
  CHECK(*g.nearest_state(s.x() + 0.1, s.y() - 0.1, s.z() + 0.04) == i);
  CHECK(*g.nearest_state(s.x(), s.y(), -pi) == g.index(18, {3, 7}));
  CHECK(!g.nearest_state(-10.0, s.y(), 0.0).has_value());  // off the positions
  CHECK(!g.nearest_state(nan_value, s.y(), 0.0).has_value());
}

TEST_CASE("pose_grid: gaussian_prior peaks at the pose, an infinite sigma makes its axis flat") {
  const tacmap::pose_grid<float> g(positions(), 36);
  const Eigen::Index want = g.index(27, {12, 4});
  const auto s = g.state_mm(want);
  const auto p = g.gaussian_prior(s.x(), s.y(), s.z(), 1.0, 0.2);
  REQUIRE(p.size() == g.size());
  CHECK((p >= 0.0F).all());
  Eigen::Index best = 0;
  p.maxCoeff(&best);
  CHECK(best == want);
  CHECK(p(want) == doctest::Approx(1.0));
  // Wrapped around the circle: headings -80 and -100 degrees are equally likely around -90.
  CHECK(p(g.index(26, {12, 4})) == doctest::Approx(p(g.index(28, {12, 4}))));
  CHECK(p(g.index(26, {12, 4})) < p(want));
  // Around -pi: +170 (layer 17) and -170 (layer 19) are neighbours of -180 (layer 18).
  const auto q = g.gaussian_prior(s.x(), s.y(), -pi, 1.0, 0.2);
  CHECK(q(g.index(17, {12, 4})) == doctest::Approx(q(g.index(19, {12, 4}))));
  CHECK(q(g.index(17, {12, 4})) > 0.5F * q(g.index(18, {12, 4})));
  CHECK(q(g.index(0, {12, 4})) < 1e-6F);

  // Flat in heading: every layer equal at a position.
  const auto flat_theta =
      g.gaussian_prior(s.x(), s.y(), 0.0, 1.0, std::numeric_limits<double>::infinity());
  for (Eigen::Index a = 0; a < 36; ++a) {
    CHECK(flat_theta(g.index(a, {12, 4})) == flat_theta(want));
    CHECK(flat_theta(g.index(a, {0, 0})) == flat_theta(g.index(0, {0, 0})));
  }
  CHECK(flat_theta(g.index(0, {0, 0})) < flat_theta(want));
  // Flat in position: every position equal within a layer, still peaked in heading.
  const auto flat_xy =
      g.gaussian_prior(s.x(), s.y(), s.z(), std::numeric_limits<double>::infinity(), 0.2);
  const auto layer27 = flat_xy.segment(27 * g.layer_size(), g.layer_size());
  CHECK(layer27.minCoeff() == layer27.maxCoeff());
  CHECK(flat_xy(g.index(0, {0, 0})) < flat_xy(g.index(27, {0, 0})));
}

TEST_CASE("pose_grid: gaussian_prior rejects NaN centres and sigmas that are not > 0") {
  const tacmap::pose_grid<float> g(positions(), 36);
  const std::string a = message_of([&] { (void)g.gaussian_prior(nan_value, 1.0, 0.0, 1.0, 0.1); });
  CAPTURE(a);
  CHECK(contains(a, "centre (nan, 1) mm"));
  for (const auto& [sm, sr] : {std::pair{0.0, 0.1}, std::pair{1.0, -0.1}, std::pair{nan_value, 0.1},
                               std::pair{1.0, nan_value}}) {
    const std::string m = message_of([&] { (void)g.gaussian_prior(5.0, 2.5, 0.0, sm, sr); });
    CAPTURE(m);
    CHECK(contains(m, "sigma_mm = "));
    CHECK(contains(m, "sigma_rad = "));
    CHECK(contains(m, "expected both > 0"));
  }
}

TEST_CASE("pose_grid: wrap_angle maps onto -pi .. pi") {
  using G = tacmap::pose_grid<float>;
  CHECK(G::wrap_angle(0.0) == 0.0);
  CHECK(G::wrap_angle(pi) == -pi);
  CHECK(G::wrap_angle(-pi) == -pi);
  CHECK(G::wrap_angle(3 * pi) == -pi);
  CHECK(G::wrap_angle(4.0) == doctest::Approx(4.0 - 2 * pi));
  CHECK(G::wrap_angle(-4.0) == doctest::Approx(2 * pi - 4.0));
  CHECK(G::wrap_angle(0.5 + 20 * pi) == doctest::Approx(0.5));
  for (double t = -20.0; t < 20.0; t += 0.37) {
    const double w = G::wrap_angle(t);
    CHECK(w >= -pi);
    CHECK(w < pi);
    CHECK(std::remainder(w - t, 2 * pi) == doctest::Approx(0.0).epsilon(1e-12).scale(1.0));
  }
}

}  // namespace test_pose_grid
