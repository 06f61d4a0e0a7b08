// Tests of the discrete latent state: latent_grid, latent_motion, appearance_likelihood and what
// bayes_filter::estimate() reports over them.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "descriptor/blob_images.hpp"
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/descriptor/unsigned_orientation.hpp"
#include "tacmap/tacmap.hpp"
#include "test_support.hpp"

namespace test_latent {

using tacmap_test::message_of;

namespace {

using planar = tacmap::planar_grid<float>;
using latent = tacmap::latent_grid<planar>;

// 5 x 4 states at 2 mm per px (map 7 x 5 px, window 3 x 2 px).
planar small_grid() { return planar({.width = 7, .height = 5}, 2.0, {.width = 3, .height = 2}); }

// A measurement whose value is the log-likelihood table itself.
struct table_likelihood {
  using measurement_type = Eigen::ArrayXf;
  template <class G>
  void log_likelihood(const G&, const measurement_type& z, tacmap::belief_array<G>& out) const {
    out = z;
  }
};

// A map of soft blobs on a mid-grey ground: textured everywhere, no symmetry.
tacmap::image<float> blob_map(int rows, int cols, unsigned seed) {
  std::mt19937 gen(seed);
  tacmap::image<float> m = tacmap::image<float>::Constant(rows, cols, 0.1F);
  tacmap_test::add_blobs(m, gen, rows * cols / 60, 3.0);
  return m / m.maxCoeff();
}

// A measurement model without descriptor_likelihood's one-pass hooks (log_likelihood only).
template <class Model>
struct plain_model_of {
  Model inner;
  using measurement_type = tacmap::image<float>;
  template <class G>
  void log_likelihood(const G& g, const measurement_type& z, tacmap::belief_array<G>& out) const {
    inner.log_likelihood(g, z, out);
  }
};

}  // namespace

TEST_CASE("latent_grid: H copies of the base grid's states, hypothesis-major") {
  const latent g(small_grid(), {"a", "b", "c"});
  static_assert(tacmap::state_grid<latent>);
  static_assert(tacmap::latent_state_grid<latent>);
  static_assert(!tacmap::latent_state_grid<planar>);
  CHECK(g.hypotheses() == 3);
  CHECK(g.hypothesis_size() == 20);
  CHECK(g.size() == 60);
  CHECK(g.rows() == 4);
  CHECK(g.cols() == 5);
  for (Eigen::Index i = 0; i < 20; ++i) {
    CHECK(g.state_mm(i) == g.base().state_mm(i));
    CHECK(g.state_mm(20 + i) == g.base().state_mm(i));
    CHECK(g.state_mm(40 + i) == g.base().state_mm(i));
  }
  CHECK(g.hypothesis_name(2) == "c");
}

TEST_CASE("latent_grid: bad hypothesis lists are refused with the reason") {
  CHECK(message_of([] { latent(small_grid(), {}); }).find("no hypotheses") != std::string::npos);
  const auto m = message_of([] { latent(small_grid(), {"x", "y", "x"}); });
  CHECK(m.find("hypotheses 0 and 2 are both named 'x'") != std::string::npos);
}

TEST_CASE("latent_grid over a pose grid keeps the heading circular") {
  using pose = tacmap::pose_grid<float>;
  static_assert(tacmap::has_circular_coordinates<tacmap::latent_grid<pose>>);
  static_assert(!tacmap::has_circular_coordinates<latent>);
  const tacmap::latent_grid<pose> g(pose(small_grid(), 4), {"a", "b"});
  CHECK(g.size() == 2 * 4 * 20);
  CHECK(g.state_mm(80 + 25)(2) == doctest::Approx(g.base().state_mm(25)(2)));
}

TEST_CASE("latent_motion: each block moves as the base model moves it, keeping its weight") {
  const latent g(small_grid(), {"a", "b"});
  const tacmap::odometry_gaussian base({.sigma_mm = 1.0, .k = 8});
  const tacmap::latent_motion<tacmap::odometry_gaussian> motion(base);
  std::mt19937 gen(3);
  std::uniform_real_distribution<float> u(0.0F, 1.0F);
  Eigen::ArrayXf in(40);
  for (auto& v : in) v = u(gen);
  in.segment(20, 20) *= 3.0F;  // hypothesis b holds about 3/4 of the mass
  in /= in.sum();
  Eigen::ArrayXf out(40);
  const tacmap::odometry step{.dx_mm = 2.5, .dy_mm = -1.0};
  const auto report = motion.predict(g, in, out, step);

  // Reference: the base model per block, rescaled by the mass each block kept.
  double kept_total = 0.0;
  Eigen::ArrayXf expected(40);
  for (int h = 0; h < 2; ++h) {
    Eigen::ArrayXf block_in = in.segment(h * 20, 20), block_out(20);
    const double mass = block_in.sum();
    const auto r = base.predict(g.base(), block_in, block_out, step);
    const double kept = mass * (1.0 - r.mass_lost);
    expected.segment(h * 20, 20) = block_out * static_cast<float>(kept);
    kept_total += kept;
  }
  expected /= expected.sum();
  CHECK((out - expected).abs().maxCoeff() < 1e-6F);
  CHECK(out.sum() == doctest::Approx(1.0).epsilon(1e-5));
  CHECK(report.mass_lost == doctest::Approx(1.0 - kept_total).epsilon(1e-4));
  CHECK(report.mass_lost > 0.01);  // the shift carried some mass off this small grid
  // The hypotheses' weights are those of the kept mass, not re-equalised by the base model.
  const auto p = tacmap::hypothesis_posterior(g, out);
  CHECK(p[1] > 0.6);
}

TEST_CASE("latent_motion: one hypothesis is exactly the base model") {
  const tacmap::latent_grid<planar> g(small_grid(), {"only"});
  const tacmap::odometry_gaussian base({.sigma_mm = 1.5, .k = 24});
  const tacmap::latent_motion<tacmap::odometry_gaussian> motion(base);
  Eigen::ArrayXf in = Eigen::ArrayXf::LinSpaced(20, 1.0F, 2.0F);
  in /= in.sum();
  Eigen::ArrayXf a(20), b(20);
  motion.predict(g, in, a, {.dx_mm = 1.0, .dy_mm = 2.0});
  base.predict(g.base(), in, b, {.dx_mm = 1.0, .dy_mm = 2.0});
  CHECK((a == b).all());
}

TEST_CASE("latent_motion: a switch probability moves that share to the other hypotheses") {
  const latent g(small_grid(), {"a", "b", "c"});
  const tacmap::latent_motion<tacmap::odometry_gaussian> motion(
      tacmap::odometry_gaussian({.sigma_mm = 1.0, .k = 8}), {.switch_probability = 0.2});
  Eigen::ArrayXf in = Eigen::ArrayXf::Zero(60);
  in.segment(0, 20).setConstant(1.0F / 20.0F);  // all on hypothesis a
  Eigen::ArrayXf out(60);
  motion.predict(g, in, out, {.dx_mm = 0.0, .dy_mm = 0.0});
  const auto p = tacmap::hypothesis_posterior(g, out);
  CHECK(p[0] == doctest::Approx(0.8).epsilon(1e-5));
  CHECK(p[1] == doctest::Approx(0.1).epsilon(1e-5));
  CHECK(p[2] == doctest::Approx(0.1).epsilon(1e-5));
  // The position belief is the same in every block (the switch does not move the sensor).
  CHECK((out.segment(20, 20) / 0.1F - out.segment(0, 20) / 0.8F).abs().maxCoeff() < 1e-5F);
}

TEST_CASE("latent_motion: bad settings are refused, naming the value") {
  CHECK(message_of([] {
          tacmap::latent_motion<tacmap::odometry_gaussian>(tacmap::odometry_gaussian{},
                                                           {.switch_probability = 1.0});
        }).find("switch_probability = 1") != std::string::npos);
  CHECK(message_of([] {
          tacmap::latent_motion<tacmap::odometry_gaussian>(tacmap::odometry_gaussian{},
                                                           {.switch_probability = NAN});
        }).find("expected a probability in [0, 1)") != std::string::npos);
  // 0.6 with two hypotheses would favour changing over staying.
  const latent g(small_grid(), {"a", "b"});
  const tacmap::latent_motion<tacmap::odometry_gaussian> motion(tacmap::odometry_gaussian{},
                                                                {.switch_probability = 0.6});
  Eigen::ArrayXf in = Eigen::ArrayXf::Constant(40, 1.0F / 40.0F), out(40);
  CHECK(message_of([&] { motion.predict(g, in, out, {}); }).find("expected at most 0.5") !=
        std::string::npos);
}

TEST_CASE("latent_motion: a motion that leaves no mass in any block throws like the base") {
  const latent g(small_grid(), {"a", "b"});
  const tacmap::latent_motion<tacmap::odometry_gaussian> motion(tacmap::odometry_gaussian{});
  Eigen::ArrayXf in = Eigen::ArrayXf::Constant(40, 1.0F / 40.0F), out(40);
  CHECK_THROWS_AS(motion.predict(g, in, out, {.dx_mm = 30.0, .dy_mm = 0.0}), std::domain_error);
  CHECK_THROWS_AS(motion.predict(g, in, out, {.dx_mm = NAN, .dy_mm = 0.0}), std::invalid_argument);
}

TEST_CASE("bayes_filter over a latent grid: hypothesis posteriors and the position marginal") {
  tacmap::bayes_filter f(latent(small_grid(), {"a", "b"}),
                         tacmap::latent_motion<tacmap::odometry_gaussian>(
                             tacmap::odometry_gaussian({.sigma_mm = 1.0, .k = 8})),
                         table_likelihood{});
  // Uniform: both hypotheses 1/2, position entropy log 20 (not log 40: the hypothesis is
  // reported apart).
  auto e = f.estimate();
  REQUIRE(e.hypothesis_probability.size() == 2);
  CHECK(e.hypothesis_probability[0] == doctest::Approx(0.5));
  CHECK(e.entropy_nats == doctest::Approx(std::log(20.0)).epsilon(1e-5));

  // Hypothesis b explains the touch at state 7 by e^2 better than hypothesis a explains it
  // anywhere; a slightly prefers state 3.
  Eigen::ArrayXf ll = Eigen::ArrayXf::Zero(40);
  ll(3) = 1.5F;
  ll(7) = 1.0F;
  ll(20 + 7) = 3.0F;
  f.update(ll);
  e = f.estimate();
  const double za = 18.0 + std::exp(1.5) + std::exp(1.0);
  const double zb = 19.0 + std::exp(3.0);
  CHECK(e.hypothesis_probability[1] == doctest::Approx(zb / (za + zb)).epsilon(1e-5));
  CHECK(e.map_hypothesis == 1);
  // The MAP position is 7 (summed over hypotheses it beats 3), reported in hypothesis b's block.
  CHECK(e.map_index == 20 + 7);
  CHECK(e.map_mm == f.grid().base().state_mm(7));
  CHECK(e.map_probability ==
        doctest::Approx((std::exp(1.0) + std::exp(3.0)) / (za + zb)).epsilon(1e-5));
  // Mean and covariance are those of the marginal.
  const auto marginal = tacmap::marginal_belief(f.grid(), f.belief());
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (Eigen::Index i = 0; i < 20; ++i)
    mean += static_cast<double>(marginal(i)) * f.grid().base().state_mm(i);
  CHECK((e.mean_mm - mean).norm() < 1e-5);
}

TEST_CASE("appearance_transform: max + min - z flips every gradient, keeps the range") {
  tacmap::image<float> z(2, 3);
  z << 0.2F, 1.0F, 0.5F, 0.2F, 0.3F, 0.9F;
  const auto inv = tacmap::appearance_transform(z, tacmap::appearance::inverted);
  CHECK(inv.maxCoeff() == doctest::Approx(1.0));
  CHECK(inv.minCoeff() == doctest::Approx(0.2));
  CHECK(inv(0, 1) == doctest::Approx(0.2));
  CHECK(inv(0, 2) == doctest::Approx(0.7));
  CHECK((tacmap::appearance_transform(z, tacmap::appearance::as_photographed) == z).all());
}

TEST_CASE("appearance_likelihood: an inverted photograph is recognised and localized") {
  // The map is the photograph of an object whose raised parts are dark: the inverse of what the
  // touch shows. Touches are windows of the relief (bright = raised).
  const tacmap::image<float> relief = blob_map(60, 50, 11);
  const tacmap::image<float> photo = 1.0F - relief.array();
  const tacmap::pixel_size window{.width = 18, .height = 42};
  const planar positions({.width = 50, .height = 60}, 1.0, window);
  using model_t = tacmap::descriptor_likelihood<tacmap::sift_lite>;
  const tacmap::appearance_likelihood<model_t> appearance(model_t({}, photo, window));
  tacmap::bayes_filter f(latent(positions, appearance.hypothesis_names()),
                         tacmap::latent_motion<tacmap::odometry_gaussian>(
                             tacmap::odometry_gaussian({.sigma_mm = 1.0, .k = 8})),
                         appearance);
  CHECK(f.grid().hypothesis_name(1) == "inverted");
  const tacmap::grid_cell truth{9, 20};
  const tacmap::image<float> touch = relief.block(truth.row, truth.col, 42, 18);
  f.update(touch / touch.maxCoeff());
  auto e = f.estimate();
  CHECK(e.hypothesis_probability[1] > 0.6);  // one touch's evidence already leans the right way
  // Two touches more, 6 mm down and back (exact odometry): the evidence accumulates.
  const tacmap::image<float> lower = relief.block(truth.row + 6, truth.col, 42, 18);
  f.predict({.dx_mm = 0.0, .dy_mm = 6.0});
  f.update(lower / lower.maxCoeff());
  f.predict({.dx_mm = 0.0, .dy_mm = -6.0});
  f.update(touch / touch.maxCoeff());
  e = f.estimate();
  CHECK(e.hypothesis_probability[1] > 0.9);
  CHECK(e.map_hypothesis == 1);
  CHECK(e.map_index % positions.size() == positions.index(truth));

  // The same touch against the model without the inverted hypothesis prefers a wrong window.
  tacmap::bayes_filter plain(positions, tacmap::odometry_gaussian{}, model_t({}, photo, window));
  plain.update(touch / touch.maxCoeff());
  CHECK(plain.estimate().map_index != positions.index(truth));
}

TEST_CASE("appearance_likelihood: a map that cannot tell the appearances apart says so") {
  // A constant map: every window and both appearances explain a touch equally well. The filter
  // stays uniform over positions and 50 / 50 over appearances — no NaN, no false certainty.
  const tacmap::image<float> flat = tacmap::image<float>::Constant(50, 30, 0.5F);
  const tacmap::pixel_size window{.width = 18, .height = 42};
  const planar positions({.width = 30, .height = 50}, 1.0, window);
  using model_t = tacmap::descriptor_likelihood<tacmap::sift_lite>;
  const tacmap::appearance_likelihood<model_t> appearance(model_t({}, flat, window));
  tacmap::bayes_filter f(
      latent(positions, appearance.hypothesis_names()),
      tacmap::latent_motion<tacmap::odometry_gaussian>(tacmap::odometry_gaussian{}), appearance);
  tacmap::image<float> touch = blob_map(42, 18, 5);
  for (int k = 0; k < 3; ++k) f.update(touch);
  const auto e = f.estimate();
  CHECK(f.belief().allFinite());
  CHECK(e.hypothesis_probability[0] == doctest::Approx(0.5).epsilon(1e-4));
  CHECK(e.entropy_nats == doctest::Approx(std::log(double(positions.size()))).epsilon(1e-4));
}

TEST_CASE("appearance_likelihood: hypotheses must match the grid's, named in the error") {
  const tacmap::image<float> map = blob_map(50, 30, 2);
  const tacmap::pixel_size window{.width = 18, .height = 42};
  const planar positions({.width = 30, .height = 50}, 1.0, window);
  using model_t = tacmap::ncc_likelihood<float>;
  const tacmap::appearance_likelihood<model_t> two(model_t(map, window));
  const latent three(positions, {"a", "b", "c"});
  tacmap::belief_array<latent> out(three.size());
  const auto m = message_of([&] { two.log_likelihood(three, map.block(0, 0, 42, 18), out); });
  CHECK(m.find("the grid has 3 hypotheses but the model 2") != std::string::npos);
  // The right count in another order would report posteriors under the wrong names.
  const latent swapped(positions, {"inverted", "as photographed"});
  tacmap::belief_array<latent> out2(swapped.size());
  CHECK(message_of([&] {
          two.log_likelihood(swapped, map.block(0, 0, 42, 18), out2);
        }).find("hypothesis 0 is named 'inverted' but the model's is 'as photographed'") !=
        std::string::npos);
  CHECK(message_of([&] {
          (void)tacmap::marginal_belief(swapped, Eigen::ArrayXf(7));
        }).find("the belief has 7 values but the grid") != std::string::npos);
  CHECK(message_of([&] {
          tacmap::appearance_likelihood<model_t>(
              model_t(map, window), {tacmap::appearance::inverted, tacmap::appearance::inverted});
        }).find("both 'inverted'") != std::string::npos);
}

TEST_CASE("appearance_likelihood with NCC: the inverted hypothesis scores the true window +1") {
  const tacmap::image<float> relief = blob_map(50, 30, 4);
  const tacmap::image<float> photo = 0.9F - 0.7F * relief.array();
  const tacmap::pixel_size window{.width = 18, .height = 42};
  const planar positions({.width = 30, .height = 50}, 1.0, window);
  using model_t = tacmap::ncc_likelihood<float>;
  const tacmap::appearance_likelihood<model_t> appearance(model_t(photo, window));
  const latent g(positions, appearance.hypothesis_names());
  tacmap::belief_array<latent> ll(g.size());
  const tacmap::image<float> touch = relief.block(5, 7, 42, 18);
  appearance.log_likelihood(g, touch, ll);
  const Eigen::Index truth = positions.index({5, 7});
  Eigen::Index best = 0;
  ll.maxCoeff(&best);
  CHECK(best == positions.size() + truth);  // the inverted block, at the true window
  // As photographed, the true window is the worst of all (NCC near -1).
  CHECK(ll(truth) == doctest::Approx(ll.head(positions.size()).minCoeff()));
}

TEST_CASE("latent_motion: a hypothesis with a vanishing (denormal) mass keeps its share") {
  const latent g(small_grid(), {"a", "b"});
  const tacmap::latent_motion<tacmap::odometry_gaussian> motion(tacmap::odometry_gaussian{});
  Eigen::ArrayXf in = Eigen::ArrayXf::Zero(40);
  in.segment(0, 20).setConstant(1.0F / 20.0F);
  in.segment(20, 20).setConstant(1e-41F);  // 2e-40 in all: below float's normal range
  Eigen::ArrayXf out(40);
  motion.predict(g, in, out, {.dx_mm = 1.0, .dy_mm = 0.5});
  CHECK(out.allFinite());
  CHECK(out.sum() == doctest::Approx(1.0).epsilon(1e-5));
  const auto p = tacmap::hypothesis_posterior(g, out);
  CHECK(p[1] > 0.0);
  CHECK(p[1] < 1e-38);
}

TEST_CASE("dense_sift::contrast_permutation: the inverted image's descriptors, permuted") {
  const tacmap::image<float> img = blob_map(42, 18, 9);
  const tacmap::image<float> inv = tacmap::appearance_transform(img, tacmap::appearance::inverted);
  const auto check = [&](const auto& d) {
    const auto perm = d.contrast_permutation();
    const auto a = d.compute(img);
    const auto b = d.compute(inv);
    double worst = 0.0;
    for (Eigen::Index j = 0; j < a.values.cols(); ++j)
      for (Eigen::Index i = 0; i < a.values.rows(); ++i)
        worst =
            std::max(worst, std::abs(static_cast<double>(
                                b.values(i, j) - a.values(perm[static_cast<std::size_t>(i)], j))));
    CHECK(worst < 1e-5);
    // ... and the image's own descriptors differ from the inverted ones (the test sees a flip).
    CHECK((a.values - b.values).abs().maxCoeff() > 0.05F);
  };
  check(tacmap::sift_lite{});
  check(tacmap::classic_sift{});
}

TEST_CASE("descriptor_likelihood both_signs: one pass equals a pass per sign") {
  const tacmap::image<float> map = blob_map(60, 50, 21);
  const tacmap::pixel_size window{.width = 18, .height = 42};
  const planar grid({.width = 50, .height = 60}, 1.0, window);
  const tacmap::image<float> z = blob_map(42, 18, 3);
  const tacmap::image<float> z_inv = tacmap::appearance_transform(z, tacmap::appearance::inverted);
  for (const auto features :
       {tacmap::window_features::per_window, tacmap::window_features::shared_dense}) {
    CAPTURE(static_cast<int>(features));
    using model_t = tacmap::descriptor_likelihood<tacmap::classic_sift>;
    const model_t plain({}, map, window, {.features = features});
    const model_t one_pass({}, map, window, {.features = features, .both_signs = true});
    Eigen::ArrayXf a(grid.size()), b(grid.size()), both(2 * grid.size()), each(2 * grid.size());
    // The stored basis does not change a single touch's likelihood.
    plain.log_likelihood(grid, z, a);
    one_pass.log_likelihood(grid, z, b);
    CHECK((a - b).abs().maxCoeff() < 1e-3F * a.abs().maxCoeff());
    // Both signs in one pass = the touch and its inverse, each through the plain model.
    one_pass.log_likelihood_both_signs(grid, z, both.data());
    plain.log_likelihood(grid, z_inv, b);
    CHECK((both.head(grid.size()) - a).abs().maxCoeff() < 1e-3F * a.abs().maxCoeff());
    CHECK((both.tail(grid.size()) - b).abs().maxCoeff() < 1e-3F * b.abs().maxCoeff());
    // Without both_signs the same call takes a pass per sign, with the same result.
    plain.log_likelihood_both_signs(grid, z, each.data());
    CHECK((each - both).abs().maxCoeff() < 1e-3F * both.abs().maxCoeff());
    // The signs really differ (the test is not comparing a block with itself).
    CHECK((both.head(grid.size()) - both.tail(grid.size())).abs().maxCoeff() > 0.1F);
  }
}

TEST_CASE("descriptor_likelihood both_signs: settings that cannot work are refused") {
  const tacmap::image<float> map = blob_map(60, 50, 21);
  const tacmap::pixel_size window{.width = 18, .height = 42};
  using model_t = tacmap::descriptor_likelihood<tacmap::sift_lite>;
  CHECK(message_of([&] {
          model_t({}, map, window, {.pairs = tacmap::pairing::all_pairs, .both_signs = true});
        }).find("both_signs = true with pairs = all_pairs") != std::string::npos);
  CHECK(message_of([&] {
          model_t({}, map, window,
                  {.contrast = tacmap::contrast_sign::either_per_patch, .both_signs = true});
        }).find("both_signs = true with contrast = either_per_patch") != std::string::npos);
  // A descriptor without a contrast permutation (unsigned orientation is already invariant).
  using unsigned_t = tacmap::descriptor_likelihood<tacmap::unsigned_orientation<tacmap::sift_lite>>;
  CHECK(message_of([&] {
          unsigned_t({}, map, window, {.both_signs = true});
        }).find("has no contrast_permutation()") != std::string::npos);
}

TEST_CASE("appearance_likelihood: the one-pass path gives the generic path's likelihoods") {
  const tacmap::image<float> map = blob_map(60, 50, 13);
  const tacmap::pixel_size window{.width = 18, .height = 42};
  const planar positions({.width = 50, .height = 60}, 1.0, window);
  using model_t = tacmap::descriptor_likelihood<tacmap::sift_lite>;
  const tacmap::appearance_likelihood<model_t> fast(model_t({}, map, window, {.both_signs = true}));
  // A model without the one-pass hooks: the generic per-hypothesis loop.
  using plain_model = plain_model_of<model_t>;
  const tacmap::appearance_likelihood<plain_model> slow(plain_model{model_t({}, map, window)});
  const latent g(positions, fast.hypothesis_names());
  tacmap::belief_array<latent> a(g.size()), b(g.size());
  const tacmap::image<float> z = blob_map(42, 18, 8);
  fast.log_likelihood(g, z, a);
  slow.log_likelihood(g, z, b);
  CHECK((a - b).abs().maxCoeff() < 1e-3F * b.abs().maxCoeff());
}

TEST_CASE("appearance_likelihood: a pattern that is its own inverse keeps both appearances open") {
  // Stripes whose inverse is the same stripes half a period over: every touch fits a window
  // under either appearance, so the evidence cannot choose and the filter must not pretend to.
  tacmap::image<float> map(60, 48);
  for (Eigen::Index r = 0; r < map.rows(); ++r)
    for (Eigen::Index c = 0; c < map.cols(); ++c)
      map(r, c) = 0.5F + 0.4F * std::sin(2.0F * 3.14159265F * static_cast<float>(c) / 12.0F);
  const tacmap::pixel_size window{.width = 18, .height = 42};
  const planar positions({.width = 48, .height = 60}, 1.0, window);
  using model_t = tacmap::descriptor_likelihood<tacmap::sift_lite>;
  const tacmap::appearance_likelihood<model_t> appearance(
      model_t({}, map, window, {.both_signs = true}));
  tacmap::bayes_filter f(
      latent(positions, appearance.hypothesis_names()),
      tacmap::latent_motion<tacmap::odometry_gaussian>(tacmap::odometry_gaussian{}), appearance);
  const tacmap::image<float> touch = map.block(8, 14, 42, 18);
  for (int k = 0; k < 4; ++k) f.update(touch / touch.maxCoeff());
  const auto e = f.estimate();
  CHECK(f.belief().allFinite());
  CHECK(e.hypothesis_probability[0] > 0.2);
  CHECK(e.hypothesis_probability[1] > 0.2);
  // Positions: the stripes repeat every 12 px, so several columns stay possible.
  CHECK(e.map_probability < 0.6);
}

TEST_CASE("estimate(): the MAP position is the marginal's, not the joint state's") {
  tacmap::bayes_filter f(
      latent(small_grid(), {"a", "b"}),
      tacmap::latent_motion<tacmap::odometry_gaussian>(tacmap::odometry_gaussian{}),
      table_likelihood{});
  // Position 3 fits both hypotheses (2.9 each); the single best joint state is (b, 7) at 3.0.
  Eigen::ArrayXf ll = Eigen::ArrayXf::Zero(40);
  ll(3) = 2.9F;
  ll(20 + 3) = 2.9F;
  ll(20 + 7) = 3.0F;
  f.update(ll);
  const auto e = f.estimate();
  CHECK(e.map_hypothesis == 1);  // b holds more mass
  CHECK(e.map_index == 20 + 3);  // position 3 (summed over a and b), in b's block
  CHECK(e.map_mm == f.grid().base().state_mm(3));
  const double total = 37.0 + 2.0 * std::exp(2.9) + std::exp(3.0);
  CHECK(e.map_probability == doctest::Approx(2.0 * std::exp(2.9) / total).epsilon(1e-4));
}

TEST_CASE("latent_motion: one block's mass leaves the grid, another's stays") {
  const latent g(small_grid(), {"a", "b"});  // 5 columns x 4 rows of states, 2 mm apart
  const tacmap::latent_motion<tacmap::odometry_gaussian> motion(tacmap::odometry_gaussian{});
  Eigen::ArrayXf in = Eigen::ArrayXf::Zero(40);
  for (Eigen::Index r = 0; r < 4; ++r) {
    in(r * 5 + 0) = 0.3F / 4.0F;       // a: left column
    in(20 + r * 5 + 4) = 0.7F / 4.0F;  // b: right column
  }
  Eigen::ArrayXf out(40);
  const auto report = motion.predict(g, in, out, {.dx_mm = -4.0, .dy_mm = 0.0});
  CHECK(out.allFinite());
  CHECK(out.head(20).sum() == 0.0F);  // a left the grid
  CHECK(out.tail(20).sum() == doctest::Approx(1.0).epsilon(1e-5));
  // All of a, and what b alone loses over the top and bottom edges (the base model's figure).
  Eigen::ArrayXf b_in = in.tail(20) / 0.7F, b_out(20);
  const auto b_report =
      tacmap::odometry_gaussian{}.predict(g.base(), b_in, b_out, {.dx_mm = -4.0, .dy_mm = 0.0});
  CHECK(b_report.mass_lost < 0.2);
  CHECK(report.mass_lost == doctest::Approx(0.3 + 0.7 * b_report.mass_lost).epsilon(1e-4));
  CHECK((out.tail(20) - b_out).abs().maxCoeff() < 1e-6F);
}

}  // namespace test_latent
