#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"
#include "test_support.hpp"

namespace test_odometry_gaussian {

using tacmap::odometry;
using tacmap::odometry_gaussian;
using grid_t = tacmap::planar_grid<double>;
using belief_t = tacmap::belief_array<grid_t>;

using tacmap_test::message_of;

namespace {

// 40 x 40 states at 0.5 mm per px (a 1 x 1 px window, so state (r, c) is pixel (r, c)).
grid_t small_grid() { return grid_t({.width = 40, .height = 40}, 0.5, {.width = 1, .height = 1}); }

belief_t one_hot(const grid_t& g, Eigen::Index row, Eigen::Index col) {
  belief_t b = belief_t::Zero(g.size());
  b(g.index({row, col})) = 1.0;
  return b;
}

struct moments {
  Eigen::Vector2d mean;
  Eigen::Matrix2d cov;
};
moments moments_mm(const grid_t& g, const belief_t& b) {
  moments m{Eigen::Vector2d::Zero(), Eigen::Matrix2d::Zero()};
  for (Eigen::Index i = 0; i < g.size(); ++i) m.mean += b(i) * g.state_mm(i);
  for (Eigen::Index i = 0; i < g.size(); ++i) {
    const Eigen::Vector2d d = g.state_mm(i) - m.mean;
    m.cov += b(i) * d * d.transpose();
  }
  return m;
}

// Variance (px^2) of a Gaussian with sigma_px sampled at -1, 0, 1 and normalised: the paper's
// k = 8 (3 x 3) stencil is separable, so this is its per-axis variance.
double three_tap_variance(double sigma_px) {
  const double a = std::exp(-0.5 / (sigma_px * sigma_px));
  return 2.0 * a / (1.0 + 2.0 * a);
}

belief_t predict(const odometry_gaussian& m, const grid_t& g, const belief_t& in, odometry u,
                 tacmap::prediction_report* report = nullptr) {
  belief_t out(g.size());
  const auto r = m.predict(g, in, out, u);
  if (report != nullptr) *report = r;
  return out;
}

}  // namespace

TEST_CASE("a whole-pixel motion of a one-hot belief gives the paper's 3 x 3 Gaussian kernel") {
  const auto g = small_grid();
  const odometry_gaussian model({.sigma_mm = 0.5, .k = 8});  // sigma = 1 px
  const belief_t out = predict(model, g, one_hot(g, 20, 20), {.dx_mm = 2.0, .dy_mm = -1.5});
  // Expected target: 4 px right, 3 px up.
  const double a = std::exp(-0.5);
  const double z = (1 + 2 * a) * (1 + 2 * a);
  CHECK(out(g.index({17, 24})) == doctest::Approx(1.0 / z));
  CHECK(out(g.index({17, 25})) == doctest::Approx(a / z));
  CHECK(out(g.index({16, 24})) == doctest::Approx(a / z));
  CHECK(out(g.index({18, 23})) == doctest::Approx(a * a / z));
  CHECK(out.sum() == doctest::Approx(1.0));
  CHECK((out > 0).count() == 9);

  const moments m = moments_mm(g, out);
  const Eigen::Vector2d start = g.state_mm(g.index({20, 20}));
  CHECK(m.mean.x() == doctest::Approx(start.x() + 2.0));
  CHECK(m.mean.y() == doctest::Approx(start.y() - 1.5));
  const double var_mm2 = three_tap_variance(1.0) * 0.25;
  CHECK(m.cov(0, 0) == doctest::Approx(var_mm2));
  CHECK(m.cov(1, 1) == doctest::Approx(var_mm2));
  CHECK(m.cov(0, 1) == doctest::Approx(0.0));
}

TEST_CASE("sub-pixel motion: the mean equals the odometry exactly") {
  const auto g = small_grid();
  const odometry_gaussian model({.sigma_mm = 0.5, .k = 8});
  for (const odometry u : {odometry{0.3, 0.0}, odometry{-0.85, 0.6}, odometry{1.1, -2.45}}) {
    CAPTURE(u.dx_mm);
    CAPTURE(u.dy_mm);
    const moments m = moments_mm(g, predict(model, g, one_hot(g, 20, 20), u));
    const Eigen::Vector2d start = g.state_mm(g.index({20, 20}));
    CHECK(m.mean.x() == doctest::Approx(start.x() + u.dx_mm).epsilon(1e-9));
    CHECK(m.mean.y() == doctest::Approx(start.y() + u.dy_mm).epsilon(1e-9));
    // Spread = truncated Gaussian + the bilinear split's f (1 - f), per axis (px^2 -> mm^2).
    const double fx = u.dx_mm / 0.5 - std::floor(u.dx_mm / 0.5);
    const double fy = u.dy_mm / 0.5 - std::floor(u.dy_mm / 0.5);
    CHECK(m.cov(0, 0) == doctest::Approx((three_tap_variance(1.0) + fx * (1 - fx)) * 0.25));
    CHECK(m.cov(1, 1) == doctest::Approx((three_tap_variance(1.0) + fy * (1 - fy)) * 0.25));
  }
}

TEST_CASE("with a large support the covariance approaches sigma squared") {
  const auto g = small_grid();
  // k = 316 is the disc of radius 10 px: no practical truncation for sigma = 1.5 px.
  const odometry_gaussian model({.sigma_mm = 0.75, .k = 316});
  CHECK(model.radius_px() == 10);
  const moments m = moments_mm(g, predict(model, g, one_hot(g, 20, 20), {0.0, 0.0}));
  CHECK(m.cov(0, 0) == doctest::Approx(0.75 * 0.75).epsilon(1e-3));
  CHECK(m.cov(1, 1) == doctest::Approx(0.75 * 0.75).epsilon(1e-3));
  CHECK(std::abs(m.cov(0, 1)) < 1e-12);
  // Truncating the same sigma at k = 8 gives visibly less spread: truncation is real.
  const odometry_gaussian paper({.sigma_mm = 0.75, .k = 8});
  const moments t = moments_mm(g, predict(paper, g, one_hot(g, 20, 20), {0.0, 0.0}));
  CHECK(t.cov(0, 0) == doctest::Approx(three_tap_variance(1.5) * 0.25));
  CHECK(t.cov(0, 0) < 0.75 * m.cov(0, 0));
}

TEST_CASE("two predictions compose: means add, covariances add") {
  const auto g = small_grid();
  const odometry_gaussian model({.sigma_mm = 0.5, .k = 24});
  const odometry u1{1.25, 0.5};
  const odometry u2{-0.5, 1.75};
  const belief_t start = one_hot(g, 15, 18);
  const moments a = moments_mm(g, predict(model, g, start, u1));
  const moments b = moments_mm(g, predict(model, g, start, u2));
  const moments ab = moments_mm(g, predict(model, g, predict(model, g, start, u1), u2));
  const Eigen::Vector2d s = g.state_mm(g.index({15, 18}));
  CHECK(ab.mean.x() == doctest::Approx(s.x() + u1.dx_mm + u2.dx_mm));
  CHECK(ab.mean.y() == doctest::Approx(s.y() + u1.dy_mm + u2.dy_mm));
  CHECK(ab.cov(0, 0) == doctest::Approx(a.cov(0, 0) + b.cov(0, 0)));
  CHECK(ab.cov(1, 1) == doctest::Approx(a.cov(1, 1) + b.cov(1, 1)));
  CHECK(ab.cov(0, 1) == doctest::Approx(a.cov(0, 1) + b.cov(0, 1)));
}

TEST_CASE("the prediction is a convolution: linear and shift-invariant over the whole grid") {
  const auto g = small_grid();
  const odometry_gaussian model({.sigma_mm = 0.6, .k = 12});
  belief_t mix = 0.25 * one_hot(g, 10, 10) + 0.75 * one_hot(g, 25, 30);
  const odometry u{0.7, -0.3};
  const belief_t out = predict(model, g, mix, u);
  const belief_t expected = 0.25 * predict(model, g, one_hot(g, 10, 10), u) +
                            0.75 * predict(model, g, one_hot(g, 25, 30), u);
  CHECK((out - expected).abs().maxCoeff() < 1e-12);
}

TEST_CASE("mass carried off the grid is reported and the rest renormalised") {
  const auto g = small_grid();
  const odometry_gaussian model({.sigma_mm = 0.5, .k = 8});
  tacmap::prediction_report report;
  // From column 0, one pixel to the left: only the kernel's right tap lands on the grid.
  const belief_t out = predict(model, g, one_hot(g, 20, 0), {-0.5, 0.0}, &report);
  const double a = std::exp(-0.5);
  CHECK(report.mass_lost == doctest::Approx(1.0 - a / (1 + 2 * a)));
  CHECK(out.sum() == doctest::Approx(1.0));
  CHECK(out(g.index({20, 0})) == doctest::Approx(1.0 / (1 + 2 * a)));  // renormalised column 0
  CHECK(out(g.index({20, 1})) == doctest::Approx(0.0));
}

TEST_CASE("with off_grid::clamp the mass piles onto the edge and nothing is lost") {
  const auto g = small_grid();
  const odometry_gaussian model({.sigma_mm = 0.5, .k = 8, .boundary = tacmap::off_grid::clamp});
  tacmap::prediction_report report;
  const belief_t out = predict(model, g, one_hot(g, 0, 2), {-3.0, -2.0}, &report);
  CHECK(report.mass_lost == doctest::Approx(0.0));
  CHECK(out.sum() == doctest::Approx(1.0));
  CHECK(out(g.index({0, 0})) == doctest::Approx(1.0));  // 6 px left, 4 px up: the corner
  // A partial overhang: every x tap (columns -2, -1, 0) lands on column 0; rows keep the kernel.
  const belief_t side = predict(model, g, one_hot(g, 20, 0), {-0.5, 0.0}, &report);
  const double a = std::exp(-0.5);
  CHECK(side(g.index({20, 0})) == doctest::Approx(1.0 / (1 + 2 * a)));
  CHECK(side(g.index({19, 0})) == doctest::Approx(a / (1 + 2 * a)));
  CHECK(side(g.index({20, 1})) == doctest::Approx(0.0));
  CHECK(side.sum() == doctest::Approx(1.0));
}

TEST_CASE("a motion that leaves no mass on the grid is an error, not an all-zero belief") {
  const auto g = small_grid();
  const odometry_gaussian model({.sigma_mm = 0.5, .k = 8});
  belief_t out(g.size());
  CHECK_THROWS_AS(model.predict(g, one_hot(g, 0, 0), out, {-10.0, 0.0}), std::domain_error);
  CHECK_THROWS_AS(model.predict(g, one_hot(g, 0, 0), out, {1e300, 0.0}), std::domain_error);
}

TEST_CASE("bad motion configuration and odometry are rejected with clear messages") {
  const auto k7 = message_of([] { odometry_gaussian({.sigma_mm = 1.0, .k = 7}); });
  CHECK(k7.find("k = 7") != std::string::npos);
  CHECK(k7.find("4, 8, 12, 20, 24") != std::string::npos);
  CHECK(message_of([] { odometry_gaussian({.sigma_mm = 0.0, .k = 8}); }).find("sigma_mm = 0") !=
        std::string::npos);
  CHECK(message_of([] { odometry_gaussian({.sigma_mm = -1.0, .k = 8}); }).find("sigma_mm = -1") !=
        std::string::npos);
  CHECK(message_of([] { odometry_gaussian({.sigma_mm = 1.0, .k = 0}); }).find("k = 0") !=
        std::string::npos);
  for (const int k : {4, 8, 12, 20, 24, 28, 36, 44, 48, 316})
    CHECK_NOTHROW(odometry_gaussian({1.0, k}));

  const auto g = small_grid();
  const odometry_gaussian model;
  belief_t out(g.size());
  const auto nan = message_of([&] {
    model.predict(g, one_hot(g, 5, 5), out, {std::nan(""), 0.0});
  });
  CHECK(nan.find("(nan, 0)") != std::string::npos);
  CHECK(nan.find("expected finite displacements in millimetres") != std::string::npos);
  CHECK_THROWS_AS(model.predict(g, one_hot(g, 5, 5), out, {0.0, INFINITY}), std::invalid_argument);
}

namespace {
// The transition straight from its definition, one source state at a time: the mass of state
// (r, c) goes to (r + iy + dy + by, c + ix + dx + bx) for every Gaussian tap (dy, dx) of the
// square stencil (weight exp(-d^2 / 2 sigma^2), normalised over the stencil) and bilinear
// corner (by, bx) of the sub-pixel fraction; off the grid it is dropped, or with clamp moved to
// the nearest row / column per axis. Then renormalised, as predict() does.
belief_t scatter_reference(const grid_t& g, const belief_t& in, odometry u, double sigma_mm,
                           int radius, bool clamp, double* lost) {
  const double sx = u.dx_mm / g.mm_per_px();
  const double sy = u.dy_mm / g.mm_per_px();
  const auto ix = static_cast<Eigen::Index>(std::floor(sx));
  const auto iy = static_cast<Eigen::Index>(std::floor(sy));
  const double fx = sx - std::floor(sx);
  const double fy = sy - std::floor(sy);
  const double sigma = sigma_mm / g.mm_per_px();
  double norm = 0.0;
  for (int dy = -radius; dy <= radius; ++dy)
    for (int dx = -radius; dx <= radius; ++dx)
      norm += std::exp(-0.5 * (dx * dx + dy * dy) / (sigma * sigma));
  belief_t out = belief_t::Zero(g.size());
  for (Eigen::Index r = 0; r < g.rows(); ++r)
    for (Eigen::Index c = 0; c < g.cols(); ++c) {
      const double m = in(g.index({r, c}));
      if (m == 0.0) continue;
      for (int dy = -radius; dy <= radius; ++dy)
        for (int dx = -radius; dx <= radius; ++dx) {
          const double gw = std::exp(-0.5 * (dx * dx + dy * dy) / (sigma * sigma)) / norm;
          for (int b = 0; b < 4; ++b) {
            const int by = b / 2;
            const int bx = b % 2;
            const double bw = (by == 1 ? fy : 1.0 - fy) * (bx == 1 ? fx : 1.0 - fx);
            Eigen::Index tr = r + iy + dy + by;
            Eigen::Index tc = c + ix + dx + bx;
            const bool inside = tr >= 0 && tr < g.rows() && tc >= 0 && tc < g.cols();
            if (!inside && !clamp) continue;
            tr = std::clamp<Eigen::Index>(tr, 0, g.rows() - 1);
            tc = std::clamp<Eigen::Index>(tc, 0, g.cols() - 1);
            out(g.index({tr, tc})) += m * gw * bw;
          }
        }
    }
  const double kept = out.sum();
  *lost = 1.0 - kept / in.sum();
  return out / kept;
}
}  // namespace

TEST_CASE("the separable stencils (k = 8, 24) equal the transition scattered state by state") {
  // A non-square grid (rows and columns must not be mixed up), a random belief with mass near
  // every edge, and motions: sub-pixel, whole-pixel, larger than the stencil, most of the grid
  // away, in every direction; both boundaries.
  const grid_t g({.width = 31, .height = 23}, 0.5, {.width = 1, .height = 1});
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  belief_t in(g.size());
  for (double& v : in) v = u01(rng) < 0.3 ? u01(rng) : 0.0;
  in /= in.sum();
  const std::vector<odometry> motions = {{0.0, 0.0},   {0.3, -0.2},  {-0.5, 1.0},  {2.2, 3.7},
                                         {-4.1, -0.9}, {10.6, -6.3}, {-14.9, 0.2}, {0.1, 10.9}};
  for (const auto& [k, radius] : {std::pair{8, 1}, std::pair{24, 2}}) {
    for (const auto boundary : {tacmap::off_grid::renormalize, tacmap::off_grid::clamp}) {
      const odometry_gaussian model({.sigma_mm = 0.7, .k = k, .boundary = boundary});
      for (const odometry& u : motions) {
        CAPTURE(k);
        CAPTURE(static_cast<int>(boundary));
        CAPTURE(u.dx_mm);
        CAPTURE(u.dy_mm);
        double lost = 0.0;
        const belief_t want =
            scatter_reference(g, in, u, 0.7, radius, boundary == tacmap::off_grid::clamp, &lost);
        tacmap::prediction_report report;
        const belief_t got = predict(model, g, in, u, &report);
        CHECK((got - want).abs().maxCoeff() < 1e-12);
        CHECK(report.mass_lost == doctest::Approx(lost).epsilon(1e-9));
      }
    }
  }
  // Grids narrower or shorter than the stencil (1 x 3, 2 x 2, 3 x 1 states): every tap's
  // padding and edge pile at its limits.
  for (const auto& [rows, cols] : {std::pair<Eigen::Index, Eigen::Index>{1, 3}, {2, 2}, {3, 1}}) {
    const grid_t tiny({.width = cols, .height = rows}, 0.5, {.width = 1, .height = 1});
    belief_t b(tiny.size());
    for (double& v : b) v = 0.1 + u01(rng);
    b /= b.sum();
    for (const auto boundary : {tacmap::off_grid::renormalize, tacmap::off_grid::clamp}) {
      const odometry_gaussian model({.sigma_mm = 0.7, .k = 24, .boundary = boundary});
      for (const odometry& u : {odometry{0.2, -0.3}, odometry{0.5, 0.5}, odometry{-0.6, 0.1}}) {
        CAPTURE(rows);
        CAPTURE(cols);
        CAPTURE(static_cast<int>(boundary));
        CAPTURE(u.dx_mm);
        double lost = 0.0;
        const belief_t want =
            scatter_reference(tiny, b, u, 0.7, 2, boundary == tacmap::off_grid::clamp, &lost);
        const belief_t got = predict(model, tiny, b, u);
        CHECK((got - want).abs().maxCoeff() < 1e-12);
      }
    }
  }
}

TEST_CASE("with off_grid::clamp in float, a small edge pile beside a large mass is kept") {
  // The pile onto the bottom row must be the sum of the rows that fall off, not a difference of
  // large running sums (in float that would lose it): a heavy top row and a tiny bottom row,
  // moved down by a whole pixel with k = 8 (3 x 3): the bottom row keeps the tiny row's mass.
  using fgrid = tacmap::planar_grid<float>;
  const fgrid g({.width = 4, .height = 6}, 1.0, {.width = 1, .height = 1});
  tacmap::belief_array<fgrid> in = tacmap::belief_array<fgrid>::Zero(g.size());
  for (Eigen::Index c = 0; c < 4; ++c) {
    in(g.index({0, c})) = 1.0F;
    in(g.index({5, c})) = 1e-7F;
  }
  const odometry_gaussian model({.sigma_mm = 0.3, .k = 8, .boundary = tacmap::off_grid::clamp});
  tacmap::belief_array<fgrid> out(g.size());
  model.predict(g, in, out, {0.0, 1.0});
  const double total = static_cast<double>(in.sum());
  for (Eigen::Index c = 0; c < 4; ++c) {
    CAPTURE(c);
    // Row 5 gets the tiny row (all of it stays, clamped) and the Gaussian's far tail of row 4
    // (none: row 4 is empty); renormalised by the (unchanged) total.
    CHECK(static_cast<double>(out(g.index({5, c}))) == doctest::Approx(1e-7 / total).epsilon(1e-3));
  }
}

}  // namespace test_odometry_gaussian
