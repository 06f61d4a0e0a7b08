// bayes_filter over a pose_grid: circular statistics for the heading, and a small localization
// with unknown position and heading.
#include <doctest/doctest.h>

#include <cmath>
#include <numbers>

#include "pose_test_support.hpp"
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/grid/pose_grid.hpp"
#include "tacmap/measurement/rotated_descriptor_likelihood.hpp"
#include "tacmap/motion/pose_odometry_gaussian.hpp"

namespace test_pose_filter {

static_assert(tacmap::has_circular_coordinates<tacmap::pose_grid<float>>);
static_assert(!tacmap::has_circular_coordinates<tacmap::planar_grid<float>>);
static_assert(tacmap::motion_model<tacmap::pose_odometry_gaussian, tacmap::pose_grid<float>>);
static_assert(tacmap::measurement_model<tacmap::rotated_descriptor_likelihood<tacmap::sift_lite>,
                                        tacmap::pose_grid<float>>);

namespace {

constexpr double pi = std::numbers::pi;

// A measurement model that knows nothing: the estimate tests set the belief with set_prior.
struct no_measurement {
  using measurement_type = int;
  template <class G>
  void log_likelihood(const G&, const int&, tacmap::belief_array<G>& out) const {
    out.setZero();
  }
};

using small_filter =
    tacmap::bayes_filter<tacmap::pose_grid<double>, tacmap::pose_odometry_gaussian, no_measurement>;

// 10 x 10 positions, 1 mm per px, 36 headings.
small_filter make_small_filter() {
  return small_filter(
      tacmap::pose_grid<double>(
          tacmap::planar_grid<double>({.width = 10, .height = 10}, 1.0, {.width = 1, .height = 1}),
          36),
      tacmap::pose_odometry_gaussian{}, no_measurement{});
}

}  // namespace

TEST_CASE("pose filter: estimate() takes the circular mean and wrapped spread of the heading") {
  auto f = make_small_filter();
  const auto& g = f.grid();
  const double step = g.angle_step_rad();
  {  // Half at +170 deg, half at -170 deg, same position: the mean is 180 deg, not 0.
    Eigen::ArrayXd prior = Eigen::ArrayXd::Zero(g.size());
    prior(g.index(17, {4, 5})) = 0.5;
    prior(g.index(19, {4, 5})) = 0.5;
    f.set_prior(prior);
    const auto e = f.estimate();
    CHECK(std::abs(e.mean_mm(2)) == doctest::Approx(pi));
    CHECK(e.mean_mm(2) >= -pi);
    CHECK(e.mean_mm(2) < pi);
    CHECK(e.covariance_mm2(2, 2) == doctest::Approx(step * step));  // +-10 deg around 180
    CHECK(e.mean_mm(0) == doctest::Approx(5.5));
    CHECK(e.mean_mm(1) == doctest::Approx(4.5));
    CHECK(e.covariance_mm2(0, 0) == doctest::Approx(0.0).scale(1.0));
    CHECK(e.covariance_mm2(0, 2) == doctest::Approx(0.0).scale(1.0));
    CHECK(e.map_mm(2) == doctest::Approx(17 * step));
  }
  {  // Unequal weights: the circular mean, computed by hand.
    Eigen::ArrayXd prior = Eigen::ArrayXd::Zero(g.size());
    prior(g.index(17, {4, 5})) = 0.75;
    prior(g.index(19, {4, 5})) = 0.25;
    f.set_prior(prior);
    const auto e = f.estimate();
    const double a = g.heading(17);
    const double b = g.heading(19);
    const double mean = std::atan2(0.75 * std::sin(a) + 0.25 * std::sin(b),
                                   0.75 * std::cos(a) + 0.25 * std::cos(b));
    CHECK(mean == doctest::Approx(pi * 175 / 180).epsilon(1e-3));
    CHECK(e.mean_mm(2) == doctest::Approx(mean));
    const double da = tacmap::pose_grid<double>::wrap_angle(a - mean);
    const double db = tacmap::pose_grid<double>::wrap_angle(b - mean);
    CHECK(e.covariance_mm2(2, 2) == doctest::Approx(0.75 * da * da + 0.25 * db * db));
    CHECK(e.covariance_mm2(2, 2) < 0.05);  // a linear mean would give about 2.6 rad^2
  }
  {  // Position and heading vary together across the wrap: x-theta covariance with wrapped
     // deviations: x = 3 mm at +170 deg, x = 7 mm at -170 deg.
    Eigen::ArrayXd prior = Eigen::ArrayXd::Zero(g.size());
    prior(g.index(17, {4, 3})) = 0.5;
    prior(g.index(19, {4, 7})) = 0.5;
    f.set_prior(prior);
    const auto e = f.estimate();
    CHECK(e.mean_mm(0) == doctest::Approx(5.5));
    CHECK(e.covariance_mm2(0, 0) == doctest::Approx(4.0));
    CHECK(e.covariance_mm2(0, 2) == doctest::Approx(2.0 * step));
    CHECK(e.covariance_mm2(2, 0) == doctest::Approx(2.0 * step));
  }
  {  // Around 0 nothing changes: mean 0, spread 10 deg.
    Eigen::ArrayXd prior = Eigen::ArrayXd::Zero(g.size());
    prior(g.index(35, {2, 2})) = 0.5;
    prior(g.index(1, {2, 2})) = 0.5;
    f.set_prior(prior);
    const auto e = f.estimate();
    CHECK(e.mean_mm(2) == doctest::Approx(0.0).scale(1.0));
    CHECK(e.covariance_mm2(2, 2) == doctest::Approx(step * step));
  }
}

TEST_CASE("pose filter: touches at an unknown heading localize position and heading") {
  // The paper's window and scale on a 64 x 64 px textured map, 36 headings (10 degree steps),
  // uniform prior. The sensor is at +60 deg; between touches it moves in its own frame.
  const auto map = pose_test::textured_map(64, 64, 5);
  const tacmap::pose_grid<float> grid(
      tacmap::planar_grid<float>({.width = 64, .height = 64}, 3.4 / 3.0,
                                 {.width = 18, .height = 42}),
      36);
  tacmap::bayes_filter filter(
      grid, tacmap::pose_odometry_gaussian{},
      tacmap::rotated_descriptor_likelihood<tacmap::sift_lite>(tacmap::sift_lite{}, map, grid));
  const double mm = grid.mm_per_px();
  double theta = pi / 3;
  double cx = 27.0;  // sensor centre, map px
  double cy = 25.0;
  struct move {
    double du_px, dv_px, dtheta;
  };
  const auto touch = [&] { return pose_test::render(map, cx, cy, theta, grid.window_size()); };
  filter.update(touch());
  for (const move m : {move{5.0, 0.0, 0.0}, move{0.0, -6.0, 0.0}, move{-4.0, 3.0, 0.0}}) {
    // Sensor frame -> map frame with the heading before the move.
    cx += std::cos(theta) * m.du_px - std::sin(theta) * m.dv_px;
    cy += std::sin(theta) * m.du_px + std::cos(theta) * m.dv_px;
    theta += m.dtheta;
    filter.predict({m.du_px * mm, m.dv_px * mm, m.dtheta});
    filter.update(touch());
  }
  auto e = filter.estimate();
  CAPTURE(e.map_mm.transpose());
  CAPTURE(cx * mm);
  CAPTURE(cy * mm);
  INFO("after 4 touches at 60 deg: MAP (", e.map_mm(0) / mm, ", ", e.map_mm(1) / mm, ") px, ",
       e.map_mm(2) * 180 / pi, " deg; truth (", cx, ", ", cy, ") px; MAP p = ", e.map_probability);
  CHECK(std::abs(e.map_mm(0) / mm - cx) <= 2.0);
  CHECK(std::abs(e.map_mm(1) / mm - cy) <= 2.0);
  CHECK(std::abs(tacmap::pose_grid<float>::wrap_angle(e.map_mm(2) - theta)) <=
        grid.angle_step_rad() + 1e-9);
  CHECK(std::abs(tacmap::pose_grid<float>::wrap_angle(e.mean_mm(2) - theta)) <=
        grid.angle_step_rad());
  // Most of the belief is near the truth, not only its peak.
  const auto mass_near = [&] {
    double mass = 0.0;
    for (Eigen::Index i = 0; i < grid.size(); ++i) {
      const auto s = grid.state_mm(i);
      if (std::abs(s.x() / mm - cx) <= 2.5 && std::abs(s.y() / mm - cy) <= 2.5 &&
          std::abs(tacmap::pose_grid<float>::wrap_angle(s.z() - theta)) <=
              1.01 * grid.angle_step_rad())
        mass += static_cast<double>(filter.belief()(i));
    }
    return mass;
  };
  // Measured: 0.21 (a uniform belief puts 0.002 there).
  const double near4 = mass_near();
  INFO("mass within 2.5 px and one heading step of the truth: ", near4);
  CHECK(near4 > 0.1);

  // Then the finger turns by +10 deg while moving: the heading follows the turn.
  const move turn{3.0, 2.0, grid.angle_step_rad()};
  cx += std::cos(theta) * turn.du_px - std::sin(theta) * turn.dv_px;
  cy += std::sin(theta) * turn.du_px + std::cos(theta) * turn.dv_px;
  theta += turn.dtheta;
  filter.predict({turn.du_px * mm, turn.dv_px * mm, turn.dtheta});
  filter.update(touch());
  e = filter.estimate();
  INFO("after the turn to 70 deg: MAP (", e.map_mm(0) / mm, ", ", e.map_mm(1) / mm, ") px, ",
       e.map_mm(2) * 180 / pi, " deg; truth (", cx, ", ", cy, ") px");
  CHECK(std::abs(e.map_mm(0) / mm - cx) <= 2.0);
  CHECK(std::abs(e.map_mm(1) / mm - cy) <= 2.0);
  CHECK(grid.layer(e.map_index) == grid.layer_of(theta));
  // Measured: 0.35.
  const double near5 = mass_near();
  INFO("mass within 2.5 px and one heading step of the truth: ", near5);
  CHECK(near5 > 0.15);
}

}  // namespace test_pose_filter
