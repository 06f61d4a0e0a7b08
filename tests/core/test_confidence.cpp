// The belief's confidence in its estimate (filter/confidence.hpp, bayes_filter::
// probability_within / most_probable_disc) and the normalisation that must not overflow.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

#include "table_filter.hpp"
#include "tacmap/tacmap.hpp"
#include "test_support.hpp"

namespace test_confidence {

using tacmap_test::message_of;
using filter_t = tacmap_test::table_filter;
using grid_t = tacmap_test::table_grid;
using tacmap_test::table_likelihood;

namespace {

// The brute-force mass of the states within r of c.
double mass_near(const filter_t& f, const Eigen::Vector2d& c, double r) {
  double m = 0;
  for (Eigen::Index i = 0; i < f.grid().size(); ++i)
    if ((f.grid().state_mm(i).cast<double>() - c).norm() <= r)
      m += static_cast<double>(f.belief()(i));
  return m;
}

}  // namespace

TEST_CASE("probability_within sums the belief over the disc, whatever the centre") {
  auto f = tacmap_test::lattice_filter();
  tacmap::belief_array<grid_t> prior(f.grid().size());
  for (Eigen::Index i = 0; i < prior.size(); ++i) prior(i) = static_cast<float>(1 + (i * 7) % 13);
  f.set_prior(prior);
  for (const Eigen::Vector2d& c :
       {Eigen::Vector2d(5.0, 4.0), Eigen::Vector2d(12.3, 7.7), Eigen::Vector2d(-3.0, 2.0)})
    for (const double r : {0.0, 1.0, 2.5, 5.0, 100.0})
      CHECK(f.probability_within(c, r) == doctest::Approx(mass_near(f, c, r)).epsilon(1e-6));
  CHECK(f.probability_within({10.0, 6.0}, 100.0) == doctest::Approx(1.0));
  CHECK(message_of<std::invalid_argument>([&] {
          (void)f.probability_within({1.0, 1.0}, -1.0);
        }).find("radius -1 mm; expected a finite radius >= 0") != std::string::npos);
  CHECK(message_of<std::invalid_argument>([&] {
          (void)f.probability_within({std::numeric_limits<double>::quiet_NaN(), 1.0}, 5.0);
        }).find("expected finite map coordinates") != std::string::npos);
}

TEST_CASE("most_probable_disc finds the disc holding the most mass, not the highest state") {
  auto f = tacmap_test::lattice_filter();
  REQUIRE(f.positions_form_lattice());
  // A sharp peak of 0.2 at one state, and 0.8 spread evenly over a 5 x 5 block elsewhere
  // (0.032 each): the MAP state is the peak, the most probable 2 mm disc is the block's centre.
  tacmap::belief_array<grid_t> prior = tacmap::belief_array<grid_t>::Zero(f.grid().size());
  const Eigen::Index cols = f.grid().cols();
  prior(1 * cols + 2) = 0.2F;
  for (Eigen::Index r = 3; r < 8; ++r)
    for (Eigen::Index c = 12; c < 17; ++c) prior(r * cols + c) = 0.8F / 25.0F;
  f.set_prior(prior);
  const auto e = f.estimate();
  CHECK(e.map_index == 1 * cols + 2);
  const auto [centre, mass] = f.most_probable_disc(2.0);
  const Eigen::Vector2d block_centre = f.grid().state_mm(5 * cols + 14).cast<double>();
  CHECK((centre - block_centre).norm() < 1e-6);
  CHECK(mass == doctest::Approx(mass_near(f, block_centre, 2.0)).epsilon(1e-6));
  CHECK(mass == doctest::Approx(13 * 0.8 / 25.0).epsilon(1e-5));  // 13 states within 2 mm
  // Against brute force everywhere: no centre holds more.
  for (Eigen::Index i = 0; i < f.grid().size(); ++i)
    CHECK(mass_near(f, f.grid().state_mm(i).cast<double>(), 2.0) <= mass + 1e-6);
  // A sharp peak: every 5 mm disc around it holds all of it; the centre is the peak itself.
  tacmap::belief_array<grid_t> peak = tacmap::belief_array<grid_t>::Zero(f.grid().size());
  peak(6 * cols + 9) = 1.0F;
  f.set_prior(peak);
  const auto [on_peak, all] = f.most_probable_disc(5.0);
  CHECK((on_peak - f.grid().state_mm(6 * cols + 9).cast<double>()).norm() < 1e-9);
  CHECK(all == doctest::Approx(1.0));
  f.set_prior(prior);
  // The verdict follows the mass against the threshold.
  const auto sure = tacmap::assess(f, {.radius_mm = 2.0, .threshold = 0.4});
  CHECK(sure.verdict == tacmap::verdict::localized);
  CHECK((sure.centre_mm - block_centre).norm() < 1e-6);
  CHECK(sure.probability_within == doctest::Approx(mass).epsilon(1e-9));
  CHECK(tacmap::assess(f, {.radius_mm = 2.0, .threshold = 0.5}).verdict ==
        tacmap::verdict::uncertain);
  CHECK(message_of<std::invalid_argument>([&] {
          (void)tacmap::assess(f, {.radius_mm = 2.0, .threshold = 1.5});
        }).find("threshold = 1.5; expected a probability in (0, 1]") != std::string::npos);
}

TEST_CASE("a uniform belief is not localized; a concentrated one is") {
  auto f = tacmap_test::lattice_filter();
  CHECK(tacmap::assess(f).verdict == tacmap::verdict::uncertain);
  // 200 positions, 5 mm disc: at most 81 of them (the grid's 1 mm lattice) -> P <= 0.405.
  CHECK(tacmap::assess(f).probability_within < 0.41);
  tacmap::belief_array<grid_t> ll(f.grid().size());
  for (Eigen::Index i = 0; i < ll.size(); ++i)
    ll(i) = -static_cast<float>(
        (f.grid().state_mm(i).cast<double>() - Eigen::Vector2d(8.5, 6.5)).squaredNorm());
  f.update(ll);
  const auto c = tacmap::assess(f);
  CHECK(c.verdict == tacmap::verdict::localized);
  CHECK((c.centre_mm - Eigen::Vector2d(8.5, 6.5)).norm() < 1e-6);  // a state's centre
  CHECK(c.heading_probability == 1.0);
}

TEST_CASE("a touch whose evidence underflows float still gives a finite, normalised belief") {
  // All prior mass on one state, which the touch rules out by e^-200 (0 in float), and a
  // denormal prior elsewhere: the posterior's sum (~1e-43) has a reciprocal beyond float's
  // range. It once came out NaN (0 * infinity).
  auto f = tacmap_test::lattice_filter();
  tacmap::belief_array<grid_t> prior =
      tacmap::belief_array<grid_t>::Constant(f.grid().size(), 1e-44F);
  prior(0) = 1.0F;
  f.set_prior(prior);
  tacmap::belief_array<grid_t> ll = tacmap::belief_array<grid_t>::Zero(f.grid().size());
  ll(0) = -200.0F;
  const auto report = f.update(ll);
  CHECK(f.belief().allFinite());
  CHECK(static_cast<double>(f.belief().sum()) == doctest::Approx(1.0).epsilon(1e-5));
  CHECK(f.belief()(0) == 0.0F);
  CHECK(report.log_evidence < -90.0);
  CHECK(report.log_marginal_likelihood() == doctest::Approx(report.log_evidence));
}

TEST_CASE("the evidence of a touch is absolute: a constant added to the model shows in it") {
  auto a = tacmap_test::lattice_filter();
  auto b = tacmap_test::lattice_filter();
  tacmap::belief_array<grid_t> ll(a.grid().size());
  for (Eigen::Index i = 0; i < ll.size(); ++i) ll(i) = -0.01F * static_cast<float>(i % 17);
  const auto ra = a.update(ll);
  const auto rb = b.update((ll - 3.0F).eval());
  // Same posterior, same relative evidence, absolute evidence 3 lower.
  CHECK(ra.log_evidence == doctest::Approx(rb.log_evidence));
  CHECK(rb.log_marginal_likelihood() == doctest::Approx(ra.log_marginal_likelihood() - 3.0));
  // log sum_x p(z|x) bel(x) with bel uniform over 200 states.
  double direct = 0;
  for (Eigen::Index i = 0; i < ll.size(); ++i) direct += std::exp(static_cast<double>(ll(i))) / 200;
  CHECK(ra.log_marginal_likelihood() == doctest::Approx(std::log(direct)).epsilon(1e-5));
}

TEST_CASE("pose grids: the heading's probability and the position's disc over every heading") {
  using pose_t = tacmap::pose_grid<float>;
  using pose_filter =
      tacmap::bayes_filter<pose_t, tacmap::pose_odometry_gaussian, table_likelihood<pose_t>>;
  const pose_t grid(grid_t({.width = 22, .height = 12}, 1.0, {.width = 3, .height = 3}), 8);
  pose_filter f(grid, tacmap::pose_odometry_gaussian({.sigma_mm = 1.0, .k = 8, .sigma_rad = 0.1}),
                {});
  REQUIRE(f.positions_form_lattice());
  // Mass on one position at headings 0 (0.7) and 45 degrees (0.3).
  tacmap::belief_array<pose_t> prior = tacmap::belief_array<pose_t>::Zero(grid.size());
  const Eigen::Index plane = grid.rows() * grid.cols(), at = 4 * grid.cols() + 9;
  prior(at) = 0.7F;
  prior(plane + at) = 0.3F;
  f.set_prior(prior);
  const auto [centre, mass] = f.most_probable_disc(0.5);  // no neighbour within 0.5 mm
  CHECK((centre - grid.state_mm(at).head<2>().cast<double>()).norm() < 1e-9);
  CHECK(mass == doctest::Approx(1.0));
  CHECK(f.heading_probability_within(0.0, 0.1) == doctest::Approx(0.7));
  CHECK(f.heading_probability_within(0.0, 0.8) == doctest::Approx(1.0));
  const auto c = tacmap::assess(f);
  CHECK(c.heading_probability == doctest::Approx(0.7));  // 15 degrees around the MAP heading 0
  CHECK(c.verdict == tacmap::verdict::uncertain);        // the heading is not sure enough
}

TEST_CASE("log_prediction_support: 0 from a uniform prediction, the log Bayes factor otherwise") {
  auto f = tacmap_test::lattice_filter();
  const Eigen::Index n = f.grid().size();
  tacmap::belief_array<grid_t> ll(n);
  for (Eigen::Index i = 0; i < n; ++i) ll(i) = -0.05F * static_cast<float>(i % 23);
  // Uniform prediction: it is the uniform belief, whatever the touch.
  CHECK(f.update(ll).log_prediction_support == doctest::Approx(0.0).epsilon(1e-6));

  // The prediction on one state: log p(z | x0) - log (1/n sum_x p(z | x)).
  double sum = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) sum += std::exp(static_cast<double>(ll(i)));
  for (const Eigen::Index at : {Eigen::Index{0}, Eigen::Index{22}}) {
    CAPTURE(at);
    tacmap::belief_array<grid_t> prior = tacmap::belief_array<grid_t>::Zero(n);
    prior(at) = 1.0F;
    f.set_prior(prior);
    const double expected = static_cast<double>(ll(at)) - std::log(sum / static_cast<double>(n));
    CHECK(f.update(ll).log_prediction_support == doctest::Approx(expected).epsilon(1e-5));
  }
  // State 0 fits best (support > 0), state 22 (ll = -1.1, about the mean) about as well as
  // anywhere; a prediction on a state that fits far worse than the rest is contradicted.
  tacmap::belief_array<grid_t> prior = tacmap::belief_array<grid_t>::Zero(n);
  prior(5) = 1.0F;
  f.set_prior(prior);
  tacmap::belief_array<grid_t> far = ll;
  far(5) = -30.0F;
  const auto report = f.update(far);
  CHECK(report.log_prediction_support < -25.0);
  const auto c = tacmap::assess(f, f.estimate(), report, tacmap::confidence_params{});
  CHECK(c.verdict == tacmap::verdict::contradicted);
  // Turned off, the same touch gets the belief's own verdict.
  tacmap::confidence_params off;
  off.contradiction = -std::numeric_limits<double>::infinity();
  CHECK(tacmap::assess(f, f.estimate(), report, off).verdict != tacmap::verdict::contradicted);
}

TEST_CASE("confidence_params refuses a contradiction threshold above 0 or NaN") {
  tacmap::confidence_params p;
  p.contradiction = 0.5;
  CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("contradiction = 0.5"),
                       std::invalid_argument);
  p.contradiction = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_AS(p.validate(), std::invalid_argument);
  CHECK(std::string(tacmap::to_string(tacmap::verdict::contradicted)) == "contradicted");
  CHECK(std::string(tacmap::to_string(tacmap::verdict::rejected_frame)) == "rejected_frame");
}

TEST_CASE("a planar lattice's summary: refreshed where cells changed, equal to the passes") {
  // position_statistics keeps a row summary of a planar latent belief (as of a pose belief):
  // refresh recomputes the rows a change touched. After random boxes change (marked as the
  // filter marks them, in every hypothesis), the refreshed summary equals one computed afresh
  // exactly, and its statistics equal the whole-belief passes: the MAP state and the disc bit
  // for bit, the moments within 1e-9, the entropy within 1e-6. A row left out, or a moment not
  // divided by the mass as estimate's are, fails here.
  using G = tacmap::latent_grid<tacmap::planar_grid<float>>;
  const G grid(tacmap::planar_grid<float>({.width = 70, .height = 50}, 3.4 / 3.0,
                                          {.width = 6, .height = 14}),
               {"as_photographed", "inverted"});
  const Eigen::Index n = grid.size(), rows = grid.rows(), cols = grid.cols();
  const Eigen::Index plane = rows * cols;
  tacmap_test::lcg next(777U);
  Eigen::ArrayXf b(n);
  for (Eigen::Index i = 0; i < n; ++i) b(i) = 1e-3F + static_cast<float>(next(1000)) * 1e-6F;
  b /= b.sum();
  const tacmap::detail::position_statistics<G> kept(grid);
  REQUIRE(kept.summarises());
  tacmap::detail::changed_cells changed(rows, cols);
  kept.refresh(grid, {b.data(), n}, changed);
  changed.clear();
  for (int round = 0; round < 6; ++round) {
    CAPTURE(round);
    for (int box = 0; box < 3; ++box) {
      const tacmap::grid_box g{
          .row = next(rows), .col = next(cols), .rows = 1 + next(6), .cols = 1 + next(12)};
      changed.mark(g);
      for (Eigen::Index h = 0; h < 2; ++h)
        for (Eigen::Index r = g.row; r < std::min(rows, g.row + g.rows); ++r)
          for (Eigen::Index c = g.col; c < std::min(cols, g.col + g.cols); ++c)
            b(h * plane + r * cols + c) *= 0.1F * static_cast<float>(1 + next(20 + round * 40));
    }
    kept.refresh(grid, {b.data(), n}, changed);
    changed.clear();
    const tacmap::detail::position_statistics<G> fresh(grid);
    tacmap::detail::changed_cells everything(rows, cols);
    everything.mark_all();
    fresh.refresh(grid, {b.data(), n}, everything);
    const auto got = kept.estimate_summarised(grid);
    const auto ref = fresh.estimate_summarised(grid);
    CHECK(got.map_index == ref.map_index);
    CHECK(got.mean_mm == ref.mean_mm);
    CHECK(got.covariance_mm2 == ref.covariance_mm2);
    CHECK(got.entropy_nats == ref.entropy_nats);
    CHECK(got.hypothesis_probability == ref.hypothesis_probability);
    CHECK(kept.most_probable_disc_summarised(grid, 3.0) ==
          fresh.most_probable_disc_summarised(grid, 3.0));
    // Against the whole-belief passes (not renormalised: the moments are divided by the mass).
    const tacmap::detail::position_statistics<G>::view_type v(b.data(), n);
    const auto pass = fresh.estimate(grid, v);
    CHECK(got.map_index == pass.map_index);
    CHECK(got.map_probability == pass.map_probability);
    CHECK((got.mean_mm - pass.mean_mm).cwiseAbs().maxCoeff() <= 1e-9);
    CHECK((got.covariance_mm2 - pass.covariance_mm2).cwiseAbs().maxCoeff() <= 1e-9);
    CHECK(got.entropy_nats == doctest::Approx(pass.entropy_nats).epsilon(1e-6));
    for (std::size_t h = 0; h < 2; ++h)
      CHECK(got.hypothesis_probability[h] ==
            doctest::Approx(pass.hypothesis_probability[h]).epsilon(1e-12));
    CHECK(kept.most_probable_disc_summarised(grid, 3.0) == fresh.most_probable_disc(grid, v, 3.0));
  }
}

TEST_CASE("most_probable_disc: rows skipped by their bound never hide an equal disc earlier") {
  // Two equal peaks (0.3 each) and 0.4 spread over the later peak's row, far from it: the later
  // rows have the larger bound and are scanned first, the earlier peak's rows reach the best
  // mass exactly and must still be scanned, and the first disc (row-major) holding the most
  // wins, as a scan of every row finds.
  auto f = tacmap_test::lattice_filter();
  const Eigen::Index cols = f.grid().cols();
  tacmap::belief_array<grid_t> prior = tacmap::belief_array<grid_t>::Zero(f.grid().size());
  prior(2 * cols + 3) = 0.3F;
  prior(7 * cols + 10) = 0.3F;
  for (Eigen::Index c = 14; c < 20; ++c) prior(7 * cols + c) = 0.4F / 6.0F;
  f.set_prior(prior);
  const auto [centre, mass] = f.most_probable_disc(1.0);
  CHECK((centre - f.grid().state_mm(2 * cols + 3).cast<double>()).norm() < 1e-9);
  CHECK(mass == doctest::Approx(mass_near(f, centre, 1.0)).epsilon(1e-6));
  for (Eigen::Index i = 0; i < f.grid().size(); ++i)
    CHECK(mass_near(f, f.grid().state_mm(i).cast<double>(), 1.0) <= mass + 1e-6);
  // The later peak alone a little heavier: found although the earlier rows are scanned too.
  prior(7 * cols + 10) = 0.31F;
  f.set_prior(prior);
  const auto [later, later_mass] = f.most_probable_disc(1.0);
  CHECK((later - f.grid().state_mm(7 * cols + 10).cast<double>()).norm() < 1e-9);
  CHECK(later_mass > mass);
}

TEST_CASE("most_probable_disc's mass is probability_within of its centre, for any belief") {
  auto f = tacmap_test::lattice_filter();
  const Eigen::Index n = f.grid().size();
  std::uint32_t state = 12345;
  for (int trial = 0; trial < 6; ++trial) {
    tacmap::belief_array<grid_t> prior(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      state = state * 1664525U + 1013904223U;
      // Spiky and flat beliefs, with the best disc near an edge in some of them.
      prior(i) = trial % 2 == 0 ? static_cast<float>(state >> 8) / 16777216.0F
                                : ((state >> 8) % 97 == 0 ? 1.0F : 1e-4F);
    }
    f.set_prior(prior / prior.sum());
    for (const double radius : {0.5, 1.0, 2.0, 3.7, 5.0, 9.0}) {
      CAPTURE(trial);
      CAPTURE(radius);
      const auto [centre, mass] = f.most_probable_disc(radius);
      CHECK(mass == doctest::Approx(f.probability_within(centre, radius)).epsilon(1e-9));
    }
  }
}

TEST_CASE("most_probable_disc: a radius beyond the grid covers all of it, up to DBL_MAX") {
  // Any finite radius is a valid setting (confidence_params); the disc's reach used to be an
  // integer conversion of radius / step (undefined beyond 2^63) and a vector of that length
  // (fuzz/localizer_api.cpp found it with 1e127 mm).
  auto f = tacmap_test::lattice_filter();
  const Eigen::Index n = f.grid().size();
  tacmap::belief_array<grid_t> prior(n);
  for (Eigen::Index i = 0; i < n; ++i) prior(i) = static_cast<float>(1 + (i * 11) % 17);
  f.set_prior(prior / prior.sum());
  const Eigen::Vector2d extent = (f.grid().state_mm(n - 1) - f.grid().state_mm(0)).cast<double>();
  const auto [covering_centre, covering_mass] = f.most_probable_disc(extent.norm() * 1.01);
  // The whole belief: 1 up to the float belief's rounding (about 1e-7).
  CHECK(covering_mass == doctest::Approx(1.0).epsilon(1e-6));
  for (const double radius :
       {extent.norm() * 3.0, 1e9, 1e127, 1e200, std::numeric_limits<double>::max()}) {
    CAPTURE(radius);
    const auto [centre, mass] = f.most_probable_disc(radius);
    CHECK(mass == doctest::Approx(1.0).epsilon(1e-6));
    CHECK((centre - covering_centre).norm() < 1e-9);
  }
}

}  // namespace test_confidence
