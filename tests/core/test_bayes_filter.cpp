#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "tacmap/tacmap.hpp"
#include "test_support.hpp"

namespace test_bayes_filter {

using tacmap_test::message_of;

namespace {

// A measurement model whose measurement *is* a log-likelihood table (tests the plumbing).
template <class T>
struct table_likelihood {
  using measurement_type = Eigen::Array<T, Eigen::Dynamic, 1>;
  template <class G>
  void log_likelihood(const G&, const measurement_type& z, tacmap::belief_array<G>& out) const {
    out = z;
  }
};

// A broken model that resizes the filter's buffer (the concept forbids it).
struct resizing_likelihood {
  struct measurement_type {};
  template <class G>
  void log_likelihood(const G&, const measurement_type&, tacmap::belief_array<G>& out) const {
    out.setZero(3);
  }
};

template <class T>
using grid_t = tacmap::planar_grid<T>;
template <class T>
using filter_t = tacmap::bayes_filter<grid_t<T>, tacmap::odometry_gaussian, table_likelihood<T>>;

template <class T>
filter_t<T> small_filter() {
  // 5 x 4 states at 2 mm per px (map 7 x 5 px, window 3 x 2 px).
  return filter_t<T>(grid_t<T>({.width = 7, .height = 5}, 2.0, {.width = 3, .height = 2}),
                     tacmap::odometry_gaussian({.sigma_mm = 1.0, .k = 8}), table_likelihood<T>{});
}

}  // namespace

TEST_CASE_TEMPLATE("the initial belief is uniform (the paper assumes no prior knowledge)", T, float,
                   double) {
  auto f = small_filter<T>();
  REQUIRE(f.belief().size() == 20);
  CHECK((f.belief() - T(1) / T(20)).abs().maxCoeff() < T(1e-7));
  const auto e = f.estimate();
  CHECK(e.entropy_nats == doctest::Approx(std::log(20.0)).epsilon(1e-6));
  CHECK(f.belief_image().rows() == 4);
  CHECK(f.belief_image().cols() == 5);
}

TEST_CASE_TEMPLATE("an update equals Bayes' rule computed by hand", T, float, double) {
  auto f = small_filter<T>();
  std::mt19937 rng(7);
  Eigen::Array<double, Eigen::Dynamic, 1> prior(20);
  Eigen::Array<double, Eigen::Dynamic, 1> ll(20);
  for (Eigen::Index i = 0; i < 20; ++i) {
    prior(i) = 0.1 + static_cast<double>(rng() % 1000) / 100.0;
    ll(i) = -static_cast<double>(rng() % 5000) / 100.0;  // log-likelihoods down to -50
  }
  f.set_prior(prior);
  const auto report = f.update(ll.cast<T>());
  // By hand: posterior(i) = prior(i) * exp(ll(i)) / sum_j prior(j) * exp(ll(j)).
  const Eigen::ArrayXd unnorm = (prior / prior.sum()) * ll.exp();
  const Eigen::ArrayXd expected = unnorm / unnorm.sum();
  for (Eigen::Index i = 0; i < 20; ++i)
    CHECK(static_cast<double>(f.belief()(i)) == doctest::Approx(expected(i)).epsilon(1e-5));
  CHECK(report.log_evidence ==
        doctest::Approx(std::log(unnorm.sum()) - ll.maxCoeff()).epsilon(1e-4));
  CHECK(static_cast<double>(f.belief().sum()) == doctest::Approx(1.0));
}

TEST_CASE("sharp log-likelihoods cannot underflow: the maximum is subtracted first") {
  auto f = small_filter<float>();
  Eigen::ArrayXf ll = Eigen::ArrayXf::Constant(20, -1e6F);  // exp(-1e6) underflows on its own
  ll(7) = -1e6F + 2.0F;
  f.update(ll);
  const float e2 = std::exp(2.0F);
  CHECK(f.belief()(7) == doctest::Approx(e2 / (e2 + 19.0F)));
  // The same update again, through the image-shaped overload.
  tacmap::image<float> img = Eigen::Map<tacmap::image<float>>(ll.data(), 4, 5);
  f.update_log_likelihood(img);
  const float e4 = std::exp(4.0F);
  CHECK(f.belief()(7) == doctest::Approx(e4 / (e4 + 19.0F)));
}

TEST_CASE("the belief is normalised after every predict and update") {
  auto f = small_filter<double>();
  std::mt19937 rng(3);
  for (int step = 0; step < 50; ++step) {
    f.predict({static_cast<double>(rng() % 5) - 2.0, static_cast<double>(rng() % 3) - 1.0});
    CHECK(f.belief().sum() == doctest::Approx(1.0).epsilon(1e-12));
    CHECK(f.belief().minCoeff() >= 0.0);
    Eigen::ArrayXd ll(20);
    for (Eigen::Index i = 0; i < 20; ++i) ll(i) = -static_cast<double>(rng() % 300) / 100.0;
    f.update(ll);
    CHECK(f.belief().sum() == doctest::Approx(1.0).epsilon(1e-12));
    CHECK(f.belief().allFinite());
  }
}

TEST_CASE("degenerate updates raise a clear error and leave the belief as it was") {
  auto f = small_filter<float>();
  Eigen::ArrayXf prior = Eigen::ArrayXf::LinSpaced(20, 1.0F, 20.0F);
  prior(3) = 0.0F;
  f.set_prior(prior);
  const Eigen::ArrayXf before = f.belief();
  const auto unchanged = [&] { return (f.belief() - before).abs().maxCoeff() == 0.0F; };

  Eigen::ArrayXf nan = Eigen::ArrayXf::Zero(20);
  nan(11) = std::numeric_limits<float>::quiet_NaN();
  const auto m_nan = message_of<std::domain_error>([&] { f.update(nan); });
  CHECK(m_nan.find("NaN at state 11") != std::string::npos);
  CHECK(unchanged());

  const Eigen::ArrayXf minus_inf = Eigen::ArrayXf::Constant(20, -INFINITY);
  CHECK(message_of<std::domain_error>([&] { f.update(minus_inf); }).find("-infinity everywhere") !=
        std::string::npos);
  CHECK(unchanged());

  Eigen::ArrayXf plus_inf = Eigen::ArrayXf::Zero(20);
  plus_inf(2) = INFINITY;
  CHECK(message_of<std::domain_error>([&] { f.update(plus_inf); }).find("+infinity") !=
        std::string::npos);
  CHECK(unchanged());

  // Only state 3 is allowed by the likelihood, and the prior rules it out: contradiction.
  Eigen::ArrayXf disjoint = Eigen::ArrayXf::Constant(20, -INFINITY);
  disjoint(3) = 0.0F;
  CHECK(message_of<std::domain_error>([&] { f.update(disjoint); }).find("zero probability") !=
        std::string::npos);
  CHECK(unchanged());

  const auto m_shape =
      message_of<std::invalid_argument>([&] { f.update_log_likelihood(Eigen::ArrayXf::Zero(19)); });
  CHECK(m_shape.find("19 x 1") != std::string::npos);
  CHECK(m_shape.find("expected 20 x 1") != std::string::npos);
  CHECK(message_of<std::invalid_argument>([&] {
          f.update_log_likelihood(tacmap::image<float>::Zero(5, 4));
        }).find("belief image 4 x 5") != std::string::npos);
  CHECK(unchanged());

  // A log-likelihood with -infinity on some states is fine: those states are excluded.
  Eigen::ArrayXf partial = Eigen::ArrayXf::Zero(20);
  partial.head(10).setConstant(-INFINITY);
  f.update(partial);
  CHECK(f.belief().head(10).sum() == 0.0F);
  CHECK(f.belief().sum() == doctest::Approx(1.0F));
}

TEST_CASE("a measurement model that resizes its output is caught") {
  tacmap::bayes_filter<grid_t<float>, tacmap::odometry_gaussian, resizing_likelihood> f(
      grid_t<float>({.width = 7, .height = 5}, 2.0, {.width = 3, .height = 2}),
      tacmap::odometry_gaussian{}, resizing_likelihood{});
  CHECK(message_of<std::invalid_argument>([&] { f.update({}); }).find("resized its output to 3") !=
        std::string::npos);
  CHECK(f.belief().sum() == doctest::Approx(1.0F));
  CHECK_THROWS_AS(f.update({}), std::invalid_argument);  // and the filter stays usable
}

TEST_CASE("a failed prediction leaves the belief as it was") {
  auto f = small_filter<double>();
  Eigen::ArrayXd prior = Eigen::ArrayXd::Zero(20);
  prior(0) = 1.0;
  f.set_prior(prior);
  CHECK_THROWS_AS(f.predict({-100.0, 0.0}), std::domain_error);  // everything off the grid
  CHECK_THROWS_AS(f.predict({std::nan(""), 0.0}), std::invalid_argument);
  CHECK(f.belief()(0) == 1.0);
}

TEST_CASE("bad priors are rejected") {
  auto f = small_filter<float>();
  CHECK(message_of<std::invalid_argument>([&] {
          f.set_prior(Eigen::ArrayXf::Zero(20));
        }).find("sums to 0") != std::string::npos);
  Eigen::ArrayXf neg = Eigen::ArrayXf::Ones(20);
  neg(4) = -1.0F;
  CHECK(message_of<std::invalid_argument>([&] { f.set_prior(neg); }).find("state 4") !=
        std::string::npos);
  CHECK(message_of<std::invalid_argument>([&] {
          f.set_prior(Eigen::ArrayXf::Ones(21));
        }).find("21 x 1") != std::string::npos);
  CHECK(f.belief().maxCoeff() == doctest::Approx(1.0F / 20.0F));
  // A prior given as an image is laid out row-major like the belief.
  tacmap::image<float> img = tacmap::image<float>::Zero(4, 5);
  img(2, 3) = 5.0F;
  f.set_prior(img);
  CHECK(f.belief()(2 * 5 + 3) == 1.0F);
  CHECK(f.belief_image()(2, 3) == 1.0F);
  f.reset();
  CHECK(f.belief()(0) == doctest::Approx(0.05F));
}

TEST_CASE("estimate(): MAP, mean, covariance and entropy in millimetres") {
  auto f = small_filter<double>();
  const auto& g = f.grid();
  Eigen::ArrayXd prior = Eigen::ArrayXd::Zero(20);
  prior(g.index({1, 1})) = 0.5;
  prior(g.index({1, 3})) = 0.25;
  prior(g.index({3, 1})) = 0.25;
  f.set_prior(prior);
  const auto e = f.estimate();
  CHECK(e.map_index == g.index({1, 1}));
  CHECK(e.map_probability == doctest::Approx(0.5));
  // Centres: x = (col + 1.5) * 2 mm, y = (row + 1) * 2 mm.
  CHECK(e.map_mm.x() == doctest::Approx(5.0));
  CHECK(e.map_mm.y() == doctest::Approx(4.0));
  CHECK(e.mean_mm.x() == doctest::Approx(0.75 * 5.0 + 0.25 * 9.0));
  CHECK(e.mean_mm.y() == doctest::Approx(0.75 * 4.0 + 0.25 * 8.0));
  CHECK(e.covariance_mm2(0, 0) == doctest::Approx(0.25 * 0.75 * 16.0));
  CHECK(e.covariance_mm2(1, 1) == doctest::Approx(0.25 * 0.75 * 16.0));
  CHECK(e.covariance_mm2(0, 1) == doctest::Approx(-0.25 * 0.25 * 16.0));
  CHECK(e.entropy_nats == doctest::Approx(-(0.5 * std::log(0.5) + 0.5 * std::log(0.25))));
}

TEST_CASE("estimate() on a lattice: the rows' sums give the per-state moments") {
  // estimate() takes the mean and covariance of a lattice's belief from per-row sums of p, c p
  // and c^2 p; estimate_per_state sums a 2 x 2 outer product per state. Spiky, flat, edge and
  // single-state beliefs, planar and latent grids, steps that are not whole millimetres.
  const auto compare = [](const auto& grid, std::uint32_t seed) {
    using G = std::decay_t<decltype(grid)>;
    const tacmap::detail::position_statistics<G> stats(grid);
    REQUIRE(stats.positions_form_lattice());
    const Eigen::Index n = grid.size();
    std::uint32_t state = seed;
    for (int trial = 0; trial < 5; ++trial) {
      CAPTURE(trial);
      Eigen::ArrayXf b(n);
      for (Eigen::Index i = 0; i < n; ++i) {
        state = state * 1664525U + 1013904223U;
        b(i) = trial == 0   ? static_cast<float>(state >> 8) / 16777216.0F
               : trial == 1 ? ((state >> 8) % 89 == 0 ? 1.0F : 1e-6F)
               : trial == 2 ? (i % grid.cols() == grid.cols() - 1 ? 1.0F : 0.0F)  // last column
               : trial == 3 ? (i == n - 1 ? 1.0F : 0.0F)                          // one state
                            : std::exp(-0.001F * static_cast<float>(i % 997));
      }
      b /= b.sum();
      const typename tacmap::detail::position_statistics<G>::view_type v(b.data(), n);
      const auto fast = stats.estimate(grid, v);
      const auto ref = stats.estimate_per_state(grid, v);
      CHECK((fast.mean_mm - ref.mean_mm).norm() <= 1e-9 * (1.0 + ref.mean_mm.norm()));
      CHECK((fast.covariance_mm2 - ref.covariance_mm2).norm() <=
            1e-9 * (1.0 + ref.mean_mm.squaredNorm()));
      CHECK(fast.map_index == ref.map_index);
      // Variances never below 0; a one-state belief's exactly 0 (as the per-state sums give).
      CHECK(fast.covariance_mm2.diagonal().minCoeff() >= 0.0);
      if (trial == 3) CHECK(fast.covariance_mm2.isZero(0.0));
      // Ties keep the first state (as maxCoeff(&index) did): the last column's first cell.
      if (trial == 2) CHECK(fast.map_index == grid.cols() - 1);
      CHECK(fast.entropy_nats == ref.entropy_nats);
      CHECK(fast.hypothesis_probability == ref.hypothesis_probability);
    }
  };
  const tacmap::planar_grid<float> paper({.width = 120, .height = 120}, 1.13,
                                         {.width = 18, .height = 42});
  compare(paper, 7U);
  compare(tacmap::planar_grid<float>({.width = 37, .height = 5}, 0.2, {.width = 1, .height = 1}),
          8U);
  compare(tacmap::latent_grid<tacmap::planar_grid<float>>(paper, {"as_photographed", "inverted"}),
          9U);
}

TEST_CASE("toy localization on a small 2-D map converges to the true state") {
  // A 30 x 30 map of coloured tiles (4 colours, drawn once from a fixed seed). The sensor sees
  // the colour under it correctly 80 % of the time; the arm's odometry is exact in whole pixels
  // plus a small known error. The filter must end on the true tile.
  using T = float;
  const grid_t<T> grid({.width = 30, .height = 30}, 1.0, {.width = 1, .height = 1});
  std::mt19937 rng(2015);
  std::vector<int> colour(static_cast<std::size_t>(grid.size()));
  for (auto& c : colour) c = static_cast<int>(rng() % 4);

  struct tile_likelihood {
    using measurement_type = int;  // the colour seen
    const std::vector<int>* colours;
    void log_likelihood(const grid_t<T>&, int seen, tacmap::belief_array<grid_t<T>>& out) const {
      for (Eigen::Index i = 0; i < out.size(); ++i)
        out(i) = (*colours)[static_cast<std::size_t>(i)] == seen ? std::log(0.8F)
                                                                 : std::log(0.2F / 3.0F);
    }
  };
  tacmap::bayes_filter filter(grid, tacmap::odometry_gaussian({.sigma_mm = 0.4, .k = 8}),
                              tile_likelihood{&colour});

  tacmap::grid_cell truth{4, 5};
  const auto sense = [&] {
    const int real = colour[static_cast<std::size_t>(grid.index(truth))];
    return rng() % 10 < 8 ? real
                          : static_cast<int>((static_cast<unsigned>(real) + 1U + rng() % 3) % 4);
  };
  filter.update(sense());
  const int moves[][2] = {{1, 0}, {1, 1}, {0, 1}, {2, 0}, {0, 2}, {1, 1}, {-1, 1},
                          {1, 0}, {0, 1}, {1, 1}, {2, 1}, {1, 2}, {0, 1}, {1, 0},
                          {1, 1}, {1, 1}, {0, 1}, {1, 0}, {1, 1}, {2, 1}};
  for (const auto& m : moves) {
    truth.col += m[0];
    truth.row += m[1];
    filter.predict({.dx_mm = m[0] + 0.05, .dy_mm = m[1] - 0.05});
    filter.update(sense());
  }
  const auto e = filter.estimate();
  CHECK(e.map_index == grid.index(truth));
  CHECK(e.map_probability > 0.5);
  CHECK(e.entropy_nats < 2.0);
  CHECK((e.mean_mm - grid.state_mm(grid.index(truth))).norm() < 1.0);
}

}  // namespace test_bayes_filter
