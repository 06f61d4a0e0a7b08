// robust_motion: the base model's prediction with a floor under every state.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "table_filter.hpp"
#include "tacmap/motion/robust_motion.hpp"
#include "tacmap/tacmap.hpp"
#include "test_support.hpp"

namespace test_robust_motion {

using tacmap_test::message_of;

namespace {

// Three passes of a box of radius r along each axis of a rows x cols plane, each a direct sum
// over the window with zero outside (mass blurred off the plane is gone): the reference for
// robust_motion's sliding sums.
std::vector<double> three_box_blur(std::vector<double> plane, Eigen::Index rows, Eigen::Index cols,
                                   Eigen::Index r) {
  const double norm = 1.0 / static_cast<double>(2 * r + 1);
  for (const bool along_rows : {true, false})
    for (int pass = 0; pass < 3; ++pass) {
      const std::vector<double> before = plane;
      for (Eigen::Index row = 0; row < rows; ++row)
        for (Eigen::Index col = 0; col < cols; ++col) {
          double sum = 0.0;
          for (Eigen::Index d = -r; d <= r; ++d) {
            const Eigen::Index rr = along_rows ? row : row + d, cc = along_rows ? col + d : col;
            if (rr >= 0 && rr < rows && cc >= 0 && cc < cols)
              sum += before[static_cast<std::size_t>(rr * cols + cc)];
          }
          plane[static_cast<std::size_t>(row * cols + col)] = sum * norm;
        }
    }
  return plane;
}

// The base model that does not move anything (the blurs alone are under test), for grid `G`
// and its control type.
template <class G, class Control = tacmap::odometry>
struct identity_motion {
  using control_type = Control;
  tacmap::prediction_report predict(const G&, const tacmap::belief_array<G>& a,
                                    tacmap::belief_array<G>& b, const control_type&) const {
    b = a;
    return {};
  }
};

}  // namespace

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

// The blur of robust_motion<identity> on a rows x cols planar grid of scalar T, against
// `three_box_blur` in double: a non-square grid with mass near every edge, so that the mass
// dropped at the border, both axes' passes and (for the sliding sums) the transposed pass are
// all exercised. sigma_mm at 1 mm per px gives radius r = box_radius(sigma). With a floor
// `lambda`, renormalised and floored in one pass: (1 - lambda) mix / sum(mix) + lambda / N.
template <class T>
void check_wide_blur(double sigma_mm, Eigen::Index r, double tolerance, double lambda = 0.0) {
  CAPTURE(sigma_mm);
  CAPTURE(r);
  CAPTURE(lambda);
  using grid_type = tacmap::planar_grid<T>;
  const grid_type grid({.width = 40, .height = 23}, 1.0, {.width = 3, .height = 3});
  const Eigen::Index rows = grid.rows(), cols = grid.cols();
  tacmap::belief_array<grid_type> in(grid.size());
  for (Eigen::Index i = 0; i < in.size(); ++i)
    in(i) = T(1) + static_cast<T>((i * 37) % 11) + (i % cols == 0 ? T(30) : T(0)) +
            (i / cols == rows - 1 ? T(20) : T(0));
  in /= in.sum();
  // No motion noise to speak of: base = identity.
  using identity = identity_motion<grid_type>;
  const double w = 0.3;
  const tacmap::robust_motion<identity> wide(
      {}, {.lost_probability = lambda, .wide_probability = w, .wide_sigma_mm = sigma_mm});
  tacmap::belief_array<grid_type> got(grid.size());
  // Twice: the second prediction reuses the scratch (whose margins must still be zero).
  for (int round = 0; round < 2; ++round) {
    CAPTURE(round);
    wide.predict(grid, in, got, {});
    std::vector<double> blurred(static_cast<std::size_t>(in.size()));
    for (Eigen::Index i = 0; i < in.size(); ++i)
      blurred[static_cast<std::size_t>(i)] = static_cast<double>(in(i));
    blurred = three_box_blur(blurred, rows, cols, r);
    std::vector<double> want(static_cast<std::size_t>(in.size()));
    double total = 0.0;
    for (Eigen::Index i = 0; i < in.size(); ++i) {
      want[static_cast<std::size_t>(i)] =
          (1 - w) * static_cast<double>(in(i)) + w * blurred[static_cast<std::size_t>(i)];
      total += want[static_cast<std::size_t>(i)];
    }
    double worst = 0.0;
    for (Eigen::Index i = 0; i < in.size(); ++i) {
      const double v = (1.0 - lambda) * want[static_cast<std::size_t>(i)] / total +
                       lambda / static_cast<double>(in.size());
      worst = std::max(worst, std::abs(static_cast<double>(got(i)) - v) / v);
    }
    CHECK(worst <= tolerance);
    in = got;  // a different belief the second time
  }
}

TEST_CASE("robust_motion: the wide blur equals a direct 2-D convolution with three boxes") {
  // Radii 1-3 sum the taps directly (in float for float grids), wider ones slide sums in
  // double; double grids always take the sliding sums.
  const std::pair<double, Eigen::Index> spreads[] = {{1.0, 1}, {2.0, 2}, {3.0, 3},
                                                     {4.5, 4}, {6.0, 6}, {9.0, 9}};
  for (const auto& [sigma, r] : spreads) {
    check_wide_blur<float>(sigma, r, 1e-5);
    check_wide_blur<double>(sigma, r, 1e-12);
    check_wide_blur<float>(sigma, r, 1e-5, 0.01);
    check_wide_blur<double>(sigma, r, 1e-12, 0.01);
  }
}

TEST_CASE("robust_motion: one model on two grids whose padded planes have the same shape") {
  // 20 x 20 states at 1 mm (radius 1 for 1 mm) and 18 x 18 at 0.5 mm (radius 2): both blur in
  // 22 x 22 padded planes, with the margins in different places. The second grid's blur must
  // not read the first one's values where its own margins are.
  using grid_type = tacmap::planar_grid<float>;
  const grid_type first({.width = 22, .height = 22}, 1.0, {.width = 3, .height = 3});
  const grid_type second({.width = 20, .height = 20}, 0.5, {.width = 3, .height = 3});
  REQUIRE(first.cols() + 2 == second.cols() + 4);
  using identity = identity_motion<grid_type>;
  const double w = 0.5;
  const tacmap::robust_motion<identity> wide({}, {.wide_probability = w, .wide_sigma_mm = 1.0});
  tacmap::belief_array<grid_type> in_first = tacmap::belief_array<grid_type>::Constant(
      first.size(), 1.0F / static_cast<float>(first.size()));
  tacmap::belief_array<grid_type> out_first(first.size());
  wide.predict(first, in_first, out_first, {});
  tacmap::belief_array<grid_type> in_second(second.size());
  for (Eigen::Index i = 0; i < in_second.size(); ++i)
    in_second(i) = 1.0F + static_cast<float>((i * 29) % 7);
  in_second /= in_second.sum();
  tacmap::belief_array<grid_type> got(second.size());
  wide.predict(second, in_second, got, {});
  std::vector<double> blurred(static_cast<std::size_t>(in_second.size()));
  for (Eigen::Index i = 0; i < in_second.size(); ++i)
    blurred[static_cast<std::size_t>(i)] = static_cast<double>(in_second(i));
  blurred = three_box_blur(blurred, second.rows(), second.cols(), 2);
  double total = 0.0;
  std::vector<double> want(blurred.size());
  for (Eigen::Index i = 0; i < in_second.size(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    want[k] = (1 - w) * static_cast<double>(in_second(i)) + w * blurred[k];
    total += want[k];
  }
  double worst = 0.0;
  for (Eigen::Index i = 0; i < got.size(); ++i) {
    const double v = want[static_cast<std::size_t>(i)] / total;
    worst = std::max(worst, std::abs(static_cast<double>(got(i)) - v) / v);
  }
  CHECK(worst <= 1e-5);
}

TEST_CASE("robust_motion: on a latent pose grid the wide component blurs every heading's layer") {
  // 2 hypotheses x 3 headings x (9 x 12) positions at 1 mm per px; no motion noise to speak of.
  // Each layer is blurred on its own (an outlier moves the sensor, not its heading or the
  // object's appearance), so hypotheses and headings keep their masses.
  using grid_type = tacmap::latent_grid<tacmap::pose_grid<float>>;
  const grid_type grid(
      tacmap::pose_grid<float>(
          tacmap::planar_grid<float>({.width = 14, .height = 12}, 1.0, {.width = 3, .height = 4}),
          3),
      {"a", "b"});
  const Eigen::Index plane = grid.rows() * grid.cols(), layers = 2 * 3;
  REQUIRE(grid.size() == layers * plane);
  tacmap::belief_array<grid_type> in(grid.size());
  for (Eigen::Index i = 0; i < in.size(); ++i)
    in(i) = 0.5F + static_cast<float>((i * 53) % 17) + (i < plane ? 40.0F : 0.0F);
  in /= in.sum();
  using identity = identity_motion<grid_type, tacmap::sensor_odometry>;
  const double w = 0.25;
  const tacmap::robust_motion<identity> wide({}, {.wide_probability = w, .wide_sigma_mm = 2.0});
  tacmap::belief_array<grid_type> got(grid.size());
  wide.predict(grid, in, got, {});
  // Reference: every layer blurred on its own (r = 2), then the whole normalised.
  std::vector<double> want(static_cast<std::size_t>(in.size()));
  double total = 0.0;
  for (Eigen::Index l = 0; l < layers; ++l) {
    std::vector<double> layer(static_cast<std::size_t>(plane));
    for (Eigen::Index i = 0; i < plane; ++i)
      layer[static_cast<std::size_t>(i)] = static_cast<double>(in(l * plane + i));
    const std::vector<double> blurred = three_box_blur(layer, grid.rows(), grid.cols(), 2);
    for (Eigen::Index i = 0; i < plane; ++i) {
      const auto at = static_cast<std::size_t>(l * plane + i);
      want[at] =
          (1 - w) * layer[static_cast<std::size_t>(i)] + w * blurred[static_cast<std::size_t>(i)];
      total += want[at];
    }
  }
  for (Eigen::Index i = 0; i < in.size(); ++i)
    CHECK(static_cast<double>(got(i)) ==
          doctest::Approx(want[static_cast<std::size_t>(i)] / total).epsilon(1e-5));
  // The first layer (hypothesis a, heading 0) holds most of the mass and keeps it, up to what
  // the blur carried off the plane's edges.
  CHECK(static_cast<double>(got.head(plane).sum()) ==
        doctest::Approx(static_cast<double>(in.head(plane).sum())).epsilon(0.05));
}

// The broad component on a 120 x 120 grid of 1 mm per state, around a point mass: b of the mass
// spread by about sigma per axis, the mean where it was (the blocks' split is the transpose of
// the interpolation back), the rest where it was.
template <class T>
void check_broad(double at_x, double at_y) {
  CAPTURE(at_x);
  CAPTURE(at_y);
  using grid_type = tacmap::planar_grid<T>;
  const grid_type grid({.width = 122, .height = 122}, 1.0, {.width = 3, .height = 3});
  using identity = identity_motion<grid_type>;
  const auto centre =
      static_cast<Eigen::Index>(at_y) * grid.cols() + static_cast<Eigen::Index>(at_x);
  tacmap::belief_array<grid_type> in = tacmap::belief_array<grid_type>::Zero(grid.size());
  in(centre) = T(1);
  const double b = 0.5, sigma = 10.0;
  const tacmap::robust_motion<identity> broad({},
                                              {.broad_probability = b, .broad_sigma_mm = sigma});
  tacmap::belief_array<grid_type> got(grid.size());
  broad.predict(grid, in, got, {});
  CHECK(static_cast<double>(got.sum()) == doctest::Approx(1.0).epsilon(1e-6));
  CHECK((got >= T(0)).all());
  Eigen::Vector2d mean = Eigen::Vector2d::Zero(), second = Eigen::Vector2d::Zero();
  for (Eigen::Index i = 0; i < got.size(); ++i) {
    const Eigen::Vector2d d =
        grid.state_mm(i).template head<2>() - grid.state_mm(centre).template head<2>();
    mean += static_cast<double>(got(i)) * d;
    second += static_cast<double>(got(i)) * d.cwiseProduct(d);
  }
  CHECK(std::abs(mean(0)) < 0.01);
  CHECK(std::abs(mean(1)) < 0.01);
  // b sigma^2, within what the split between block centres changes with the place (f^2 / 6 at
  // most, f = 5 here: 4 %).
  CHECK(second(0) == doctest::Approx(b * sigma * sigma).epsilon(0.05));
  CHECK(second(1) == doctest::Approx(b * sigma * sigma).epsilon(0.05));
  // The point keeps 1 - b, plus the broad density's peak, about b / (2 pi sigma^2) (within what
  // the interpolation flattens a peak by).
  const double peak = static_cast<double>(got(centre)) - (1.0 - b);
  CHECK(peak == doctest::Approx(b / (2.0 * 3.14159265 * sigma * sigma)).epsilon(0.1));
}

TEST_CASE("robust_motion: the broad component spreads its share by sigma, the mean kept") {
  // Block centres at 2, 7, 12, ... (f = 5).
  check_broad<float>(60, 60);  // between two centres along both axes
  check_broad<float>(62, 49);  // on a centre along x, between two along y
  check_broad<double>(58, 71);
}

TEST_CASE("robust_motion: the broad component follows the position marginal, per plane mass") {
  // Two appearance planes: 0.7 of the mass at one place in plane a, 0.3 at another in plane b.
  // Each plane's broad part has the marginal's shape and its own share of the mass: a slip
  // moves the object, not the appearance.
  using grid_type = tacmap::latent_grid<tacmap::planar_grid<float>>;
  const grid_type grid(
      tacmap::planar_grid<float>({.width = 102, .height = 102}, 1.0, {.width = 3, .height = 3}),
      {"a", "b"});
  const Eigen::Index plane = grid.rows() * grid.cols();
  using identity = identity_motion<grid_type>;
  const Eigen::Index p = 40 * grid.cols() + 40, q = 60 * grid.cols() + 55;
  tacmap::belief_array<grid_type> in = tacmap::belief_array<grid_type>::Zero(grid.size());
  in(p) = 0.7F;
  in(plane + q) = 0.3F;
  const double b = 0.2;
  const tacmap::robust_motion<identity> broad({}, {.broad_probability = b, .broad_sigma_mm = 8.0});
  tacmap::belief_array<grid_type> got(grid.size());
  broad.predict(grid, in, got, {});
  CHECK(static_cast<double>(got.head(plane).sum()) == doctest::Approx(0.7).epsilon(1e-4));
  CHECK(static_cast<double>(got.tail(plane).sum()) == doctest::Approx(0.3).epsilon(1e-4));
  // Away from both points the two planes' values stand as their masses, 0.7 : 0.3.
  for (const Eigen::Index at : {p + 3, q - 2 * grid.cols(), Eigen::Index{50 * 100 + 47}}) {
    CAPTURE(at);
    CHECK(static_cast<double>(got(plane + at)) / static_cast<double>(got(at)) ==
          doctest::Approx(0.3 / 0.7).epsilon(1e-3));
  }
  // Plane b has mass near plane a's point, where it had none.
  CHECK(got(plane + p) > 1e-4F);
  CHECK(message_of([&] {
          tacmap::robust_motion<identity>({}, {.wide_probability = 0.5, .broad_probability = 0.6});
        }).find("broad_probability = 0.6 (with wide_probability 0.5 and lost_probability 0)") !=
        std::string::npos);
  CHECK(message_of([&] {
          tacmap::robust_motion<identity>({}, {.broad_probability = 0.1, .broad_sigma_mm = 0.0});
        }).find("broad_sigma_mm = 0; expected the broad component's spread in [0.001, 1000] mm") !=
        std::string::npos);
}

TEST_CASE("robust_motion: the broad component at the grid's ends keeps what a Gaussian keeps") {
  // 103 x 79 states of 1 mm (the paper's grid's shape; neither a multiple of f = 5): a point
  // mass near each corner. The broad part's mass kept on the grid and its mean against a
  // Gaussian of sigma sampled on the states, what falls outside dropped.
  using grid_type = tacmap::planar_grid<float>;
  const grid_type grid({.width = 105, .height = 81}, 1.0, {.width = 3, .height = 3});
  REQUIRE(grid.cols() == 103);
  REQUIRE(grid.rows() == 79);
  const double b = 0.5, sigma = 10.0;
  const tacmap::robust_motion<identity_motion<grid_type>> broad(
      {}, {.broad_probability = b, .broad_sigma_mm = sigma});
  const Eigen::Index corners[][2] = {{1, 2}, {101, 77}, {0, 78}, {102, 0}};
  for (const auto& at : corners) {
    const Eigen::Index x = at[0], y = at[1];
    CAPTURE(x);
    CAPTURE(y);
    const Eigen::Index centre = y * grid.cols() + x;
    tacmap::belief_array<grid_type> in = tacmap::belief_array<grid_type>::Zero(grid.size());
    in(centre) = 1.0F;
    tacmap::belief_array<grid_type> got(grid.size());
    broad.predict(grid, in, got, {});
    // got = ((1 - b) delta + b broad) / Z with Z = 1 - b + b kept; the broad density at the
    // point itself is small, so Z comes from the rest.
    double rest = 0.0;
    for (Eigen::Index i = 0; i < grid.size(); ++i)
      if (i != centre) rest += static_cast<double>(got(i));
    double kept_ref = 0.0, all_ref = 0.0, peak_ref = 0.0;
    Eigen::Vector2d mean_ref = Eigen::Vector2d::Zero(), mean = Eigen::Vector2d::Zero();
    for (Eigen::Index sy = -80; sy <= 160; ++sy)
      for (Eigen::Index sx = -80; sx <= 200; ++sx) {
        const Eigen::Vector2d d(static_cast<double>(sx - x), static_cast<double>(sy - y));
        const double g = std::exp(-0.5 * d.squaredNorm() / (sigma * sigma));
        all_ref += g;
        if (sx >= 0 && sx < grid.cols() && sy >= 0 && sy < grid.rows()) {
          kept_ref += g;
          mean_ref += g * d;
          if (sx == x && sy == y) peak_ref = g;
        }
      }
    // The broad mass kept off the point, relative to the point's: b kept' / (1 - b).
    const double kept_off = rest / static_cast<double>(got(centre)) * (1.0 - b) / b;
    CHECK(kept_off == doctest::Approx((kept_ref - peak_ref) / all_ref).epsilon(0.05));
    for (Eigen::Index i = 0; i < grid.size(); ++i)
      if (i != centre)
        mean +=
            static_cast<double>(got(i)) * Eigen::Vector2d(static_cast<double>(i % grid.cols() - x),
                                                          static_cast<double>(i / grid.cols() - y));
    // The mean of what was kept, within half a state of the Gaussian's.
    CHECK(std::abs(mean(0) / rest - mean_ref(0) / (kept_ref - peak_ref)) < 0.5);
    CHECK(std::abs(mean(1) / rest - mean_ref(1) / (kept_ref - peak_ref)) < 0.5);
  }
}

}  // namespace test_robust_motion
