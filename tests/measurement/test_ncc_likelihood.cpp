#include <doctest/doctest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/measurement/ncc_likelihood.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"
#include "test_support.hpp"

namespace test_ncc_likelihood {

namespace {

tacmap::image<float> random_map(Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  std::mt19937 rng(seed);
  tacmap::image<float> m(rows, cols);
  for (float& v : m.reshaped()) v = static_cast<float>(rng() % 1000) / 1000.0F;
  return m;
}

// Brute force, straight from the definition, in double.
double ncc_direct(const tacmap::image<float>& m, const tacmap::image<float>& z) {
  const Eigen::ArrayXXd a = m.cast<double>() - m.cast<double>().mean();
  const Eigen::ArrayXXd b = z.cast<double>() - z.cast<double>().mean();
  const double den = std::sqrt(a.square().sum() * b.square().sum());
  return den > 0 ? (a * b).sum() / den : 0.0;
}

}  // namespace

static_assert(tacmap::measurement_model<tacmap::ncc_likelihood<float>, tacmap::planar_grid<float>>);
static_assert(
    tacmap::measurement_model<tacmap::ncc_likelihood<double>, tacmap::planar_grid<double>>);

TEST_CASE_TEMPLATE("ncc_likelihood equals the brute-force NCC of every window", T, float, double) {
  const auto map = random_map(30, 25, 1);
  const tacmap::planar_grid<T> grid({.width = 25, .height = 30}, 1.0, {.width = 6, .height = 9});
  const tacmap::ncc_likelihood<T> model(map, grid.window_size(), {.tau = 0.5, .tempering = 2.0});
  const auto z = random_map(9, 6, 2);
  tacmap::belief_array<tacmap::planar_grid<T>> ll(grid.size());
  model.log_likelihood(grid, z, ll);
  for (Eigen::Index i = 0; i < grid.size(); ++i) {
    const auto c = grid.cell(i);
    const tacmap::image<float> window = map.block(c.row, c.col, 9, 6);
    CHECK(static_cast<double>(ll(i)) ==
          doctest::Approx(2.0 / 0.5 * ncc_direct(window, z)).epsilon(1e-4));
  }
}

TEST_CASE("a tactile image cut from the map ranks its own window first, NCC = 1") {
  const auto map = random_map(60, 50, 3);
  const tacmap::planar_grid<float> grid({.width = 50, .height = 60}, 1.0,
                                        {.width = 18, .height = 42});
  const tacmap::ncc_likelihood<float> model(map, grid.window_size(), {.tau = 1.0});
  Eigen::ArrayXf ll(grid.size());
  const tacmap::image<float> z = 0.5F * map.block(11, 17, 42, 18) + 0.2F;  // gain and offset
  model.log_likelihood(grid, z, ll);
  Eigen::Index best = 0;
  CHECK(ll.maxCoeff(&best) == doctest::Approx(1.0F).epsilon(1e-4));
  CHECK(best == grid.index({11, 17}));
}

TEST_CASE("flat images and windows carry no correlation") {
  tacmap::image<float> map = random_map(20, 20, 4);
  map.block(0, 0, 10, 20).setConstant(0.3F);  // a flat top half
  const tacmap::planar_grid<float> grid({.width = 20, .height = 20}, 1.0,
                                        {.width = 4, .height = 4});
  const tacmap::ncc_likelihood<float> model(map, grid.window_size());
  Eigen::ArrayXf ll(grid.size());
  model.log_likelihood(grid, random_map(4, 4, 5), ll);
  CHECK(ll(grid.index({2, 3})) == 0.0F);  // inside the flat half
  CHECK(ll.allFinite());
  model.log_likelihood(grid, tacmap::image<float>::Constant(4, 4, 0.7F), ll);
  CHECK((ll == 0.0F).all());
}

TEST_CASE("ncc_likelihood rejects bad input with messages naming the value") {
  const auto map = random_map(30, 30, 6);
  const tacmap::planar_grid<float> grid({.width = 30, .height = 30}, 1.0,
                                        {.width = 6, .height = 9});
  const tacmap::ncc_likelihood<float> model(map, grid.window_size());
  Eigen::ArrayXf ll(grid.size());
  CHECK(tacmap_test::message_of([&] {
          model.log_likelihood(grid, random_map(8, 6, 1), ll);
        }).find("tactile image is 8 x 6 px (rows x cols); expected 9 x 6") != std::string::npos);
  tacmap::image<float> nan = random_map(9, 6, 1);
  nan(3, 3) = NAN;
  CHECK(tacmap_test::message_of([&] { model.log_likelihood(grid, nan, ll); }).find("NaN") !=
        std::string::npos);
  const tacmap::planar_grid<float> other({.width = 40, .height = 30}, 1.0,
                                         {.width = 6, .height = 9});
  Eigen::ArrayXf ll_other(other.size());
  CHECK(tacmap_test::message_of([&] {
          model.log_likelihood(other, random_map(9, 6, 1), ll_other);
        }).find("same map and window") != std::string::npos);
  CHECK(tacmap_test::message_of([&] {
          tacmap::ncc_likelihood<float>(random_map(5, 5, 1), {.width = 6, .height = 9});
        }).find("no larger than the map") != std::string::npos);
  CHECK(tacmap_test::message_of([&] {
          tacmap::ncc_likelihood<float>(map, {.width = 6, .height = 9}, {.tau = 0.0});
        }).find("tau = 0") != std::string::npos);
}

TEST_CASE("the NCC model localizes a noiseless touch sequence in the filter") {
  const auto map = random_map(80, 60, 7);
  const tacmap::planar_grid<float> grid({.width = 60, .height = 80}, 1.0,
                                        {.width = 18, .height = 42});
  tacmap::bayes_filter filter(
      grid, tacmap::odometry_gaussian({.sigma_mm = 0.5, .k = 8}),
      tacmap::ncc_likelihood<float>(map, grid.window_size(), {.tau = 0.05}));
  tacmap::grid_cell truth{5, 5};
  filter.update(tacmap::image<float>(map.block(truth.row, truth.col, 42, 18)));
  for (int step = 0; step < 3; ++step) {
    truth.row += 4;
    truth.col += 3;
    filter.predict({.dx_mm = 3.0, .dy_mm = 4.0});
    filter.update(tacmap::image<float>(map.block(truth.row, truth.col, 42, 18)));
  }
  CHECK(filter.estimate().map_index == grid.index(truth));
}

}  // namespace test_ncc_likelihood
