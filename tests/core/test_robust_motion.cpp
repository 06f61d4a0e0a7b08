// robust_motion: the base model's prediction with a floor under every state.
#include <doctest/doctest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "table_filter.hpp"
#include "tacmap/motion/robust_motion.hpp"
#include "tacmap/tacmap.hpp"
#include "test_support.hpp"

using tacmap_test::message_of;

TEST_CASE("robust_motion: (1 - lambda) base + lambda / N, and lambda = 0 is the base model") {
  const auto grid = tacmap_test::lattice_filter().grid();
  const tacmap::odometry_gaussian base({.sigma_mm = 1.0, .k = 8});
  tacmap::belief_array<tacmap_test::table_grid> in =
      tacmap::belief_array<tacmap_test::table_grid>::Zero(grid.size());
  in(5 * grid.cols() + 7) = 1.0F;
  tacmap::belief_array<tacmap_test::table_grid> want(grid.size()), got(grid.size());
  base.predict(grid, in, want, {.dx_mm = 2.0, .dy_mm = 1.0});
  tacmap::robust_motion<tacmap::odometry_gaussian>(base).predict(grid, in, got,
                                                                 {.dx_mm = 2.0, .dy_mm = 1.0});
  CHECK((got - want).abs().maxCoeff() == 0.0F);
  const double lambda = 0.01;
  tacmap::robust_motion<tacmap::odometry_gaussian>(base, {.lost_probability = lambda})
      .predict(grid, in, got, {.dx_mm = 2.0, .dy_mm = 1.0});
  const auto n = static_cast<double>(grid.size());
  for (Eigen::Index i = 0; i < grid.size(); ++i)
    CHECK(static_cast<double>(got(i)) ==
          doctest::Approx((1 - lambda) * static_cast<double>(want(i)) + lambda / n).epsilon(1e-5));
  CHECK(static_cast<double>(got.sum()) == doctest::Approx(1.0).epsilon(1e-5));
}

TEST_CASE("robust_motion: a move off the map leaves a uniform belief, or throws without a floor") {
  auto f = tacmap_test::lattice_filter();
  const tacmap::odometry_gaussian base({.sigma_mm = 1.0, .k = 8});
  tacmap::belief_array<tacmap_test::table_grid> in =
      tacmap::belief_array<tacmap_test::table_grid>::Constant(
          f.grid().size(), 1.0F / static_cast<float>(f.grid().size()));
  tacmap::belief_array<tacmap_test::table_grid> out(f.grid().size());
  const tacmap::robust_motion<tacmap::odometry_gaussian> robust(base, {.lost_probability = 0.001});
  const auto report = robust.predict(f.grid(), in, out, {.dx_mm = 500.0, .dy_mm = 0.0});
  CHECK(report.mass_lost == 1.0);
  CHECK((out - in).abs().maxCoeff() < 1e-7F);
  const tacmap::robust_motion<tacmap::odometry_gaussian> trusting(base);
  CHECK_THROWS_AS(trusting.predict(f.grid(), in, out, {.dx_mm = 500.0, .dy_mm = 0.0}),
                  std::domain_error);
  CHECK(message_of([&] {
          tacmap::robust_motion<tacmap::odometry_gaussian>(base, {.lost_probability = 1.0});
        }).find("lost_probability = 1; expected a probability in [0, 1)") != std::string::npos);
}

TEST_CASE("robust_motion: the wide component adds w r (r + 1) px^2 of variance per axis") {
  // 30 x 30 positions, 1 mm apart: the blur of a mass in the middle stays on the grid.
  const tacmap_test::table_grid grid({.width = 32, .height = 32}, 1.0, {.width = 3, .height = 3});
  const Eigen::Index centre = 15 * grid.cols() + 15;
  const tacmap::odometry_gaussian base({.sigma_mm = 0.5, .k = 8});
  tacmap::belief_array<tacmap_test::table_grid> in =
      tacmap::belief_array<tacmap_test::table_grid>::Zero(grid.size());
  in(centre) = 1.0F;
  tacmap::belief_array<tacmap_test::table_grid> b(grid.size()), got(grid.size());
  base.predict(grid, in, b, {});
  // sigma 2 mm -> box radius 2 -> three passes add 2 x 3 = 6 px^2; half of the mass takes it.
  const tacmap::robust_motion<tacmap::odometry_gaussian> wide(
      base, {.wide_probability = 0.5, .wide_sigma_mm = 2.0});
  wide.predict(grid, in, got, {});
  CHECK(static_cast<double>(got.sum()) == doctest::Approx(1.0).epsilon(1e-5));
  CHECK((got >= 0.0F).all());
  const auto x_variance = [&](const tacmap::belief_array<tacmap_test::table_grid>& p) {
    double m = 0, m2 = 0;
    for (Eigen::Index i = 0; i < p.size(); ++i) {
      const double x = grid.state_mm(i)(0), w = static_cast<double>(p(i));
      m += w * x;
      m2 += w * x * x;
    }
    return m2 - m * m;
  };
  CHECK(x_variance(got) == doctest::Approx(x_variance(b) + 0.5 * 6.0).epsilon(1e-3));
  // Mean unchanged: the blur is symmetric.
  double mean = 0;
  for (Eigen::Index i = 0; i < got.size(); ++i)
    mean += static_cast<double>(got(i)) * grid.state_mm(i)(0);
  CHECK(mean == doctest::Approx(grid.state_mm(centre)(0)).epsilon(1e-5));
  CHECK(message_of([&] {
          tacmap::robust_motion<tacmap::odometry_gaussian>(
              base, {.lost_probability = 0.5, .wide_probability = 0.6});
        }).find("wide_probability = 0.6 (with lost_probability 0.5)") != std::string::npos);
}

TEST_CASE("robust_motion: the wide blur equals a direct 2-D convolution with three boxes") {
  // A non-square grid (rows != cols, different radii per axis) with mass near every edge, so
  // the dropped-at-the-border mass and the transposed pass are both exercised.
  const tacmap_test::table_grid grid({.width = 26, .height = 17}, 1.0, {.width = 3, .height = 3});
  const Eigen::Index rows = grid.rows(), cols = grid.cols();
  tacmap::belief_array<tacmap_test::table_grid> in(grid.size());
  for (Eigen::Index i = 0; i < in.size(); ++i)
    in(i) = 1.0F + static_cast<float>((i * 37) % 11) + (i % cols == 0 ? 30.0F : 0.0F);
  in /= in.sum();
  // No motion noise to speak of: base = identity up to float rounding.
  struct identity {
    using control_type = tacmap::odometry;
    tacmap::prediction_report predict(const tacmap_test::table_grid&,
                                      const tacmap::belief_array<tacmap_test::table_grid>& a,
                                      tacmap::belief_array<tacmap_test::table_grid>& b,
                                      const control_type&) const {
      b = a;
      return {};
    }
  };
  const double w = 0.3;
  const tacmap::robust_motion<identity> wide({}, {.wide_probability = w, .wide_sigma_mm = 2.0});
  tacmap::belief_array<tacmap_test::table_grid> got(grid.size());
  wide.predict(grid, in, got, {});
  // Reference: three passes of a box of radius 2 (sigma 2 mm -> r = 2) along each axis, each
  // a direct sum over the window with zero outside (mass blurred off the grid is gone).
  std::vector<double> blurred(static_cast<std::size_t>(in.size()));
  for (Eigen::Index i = 0; i < in.size(); ++i)
    blurred[static_cast<std::size_t>(i)] = static_cast<double>(in(i));
  const auto at = [&](Eigen::Index r, Eigen::Index c) -> double& {
    return blurred[static_cast<std::size_t>(r * cols + c)];
  };
  for (const bool along_rows : {true, false})
    for (int pass = 0; pass < 3; ++pass) {
      const std::vector<double> before = blurred;
      for (Eigen::Index r = 0; r < rows; ++r)
        for (Eigen::Index c = 0; c < cols; ++c) {
          double sum = 0.0;
          for (Eigen::Index d = -2; d <= 2; ++d) {
            const Eigen::Index rr = along_rows ? r : r + d, cc = along_rows ? c + d : c;
            if (rr >= 0 && rr < rows && cc >= 0 && cc < cols)
              sum += before[static_cast<std::size_t>(rr * cols + cc)];
          }
          at(r, c) = sum / 5.0;
        }
    }
  std::vector<double> want(static_cast<std::size_t>(in.size()));
  for (Eigen::Index i = 0; i < in.size(); ++i)
    want[static_cast<std::size_t>(i)] =
        (1 - w) * static_cast<double>(in(i)) + w * blurred[static_cast<std::size_t>(i)];
  double total = 0.0;
  for (const double v : want) total += v;
  for (Eigen::Index i = 0; i < in.size(); ++i)
    CHECK(static_cast<double>(got(i)) ==
          doctest::Approx(want[static_cast<std::size_t>(i)] / total).epsilon(1e-5));
}
