// Tests of "which object, and where": library_grid, library_motion, library_likelihood and what
// bayes_filter reports over them (issue 15).
#include <doctest/doctest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "descriptor/blob_images.hpp"
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/grid/library_grid.hpp"
#include "tacmap/measurement/library_likelihood.hpp"
#include "tacmap/motion/library_motion.hpp"
#include "tacmap/tacmap.hpp"
#include "test_support.hpp"

namespace test_library {

using tacmap_test::message_of;

namespace {

using planar = tacmap::planar_grid<float>;
using library = tacmap::library_grid<planar>;

// Two objects of different sizes and scales: 5 x 4 states at 2 mm/px, 3 x 6 states at 1 mm/px.
library two_objects(std::vector<double> prior = {}) {
  return library({planar({.width = 7, .height = 5}, 2.0, {.width = 3, .height = 2}),
                  planar({.width = 8, .height = 4}, 1.0, {.width = 3, .height = 2})},
                 {"cup", "box"}, std::move(prior));
}

// A measurement whose value is the log-likelihood table of the object's own grid.
struct table_likelihood {
  using measurement_type = Eigen::ArrayXf;
  template <class G>
  void log_likelihood(const G&, const measurement_type& z, tacmap::belief_array<G>& out) const {
    out = z;
  }
};

tacmap::image<float> blob_map(int rows, int cols, unsigned seed) {
  std::mt19937 gen(seed);
  tacmap::image<float> m = tacmap::image<float>::Constant(rows, cols, 0.1F);
  tacmap_test::add_blobs(m, gen, rows * cols / 60, 3.0);
  return m / m.maxCoeff();
}

using sift_model = tacmap::descriptor_likelihood<tacmap::sift_lite>;
constexpr tacmap::pixel_size window{.width = 18, .height = 42};

tacmap::image<float> touch_of(const tacmap::image<float>& map, tacmap::grid_cell at) {
  const tacmap::image<float> t = map.block(at.row, at.col, window.height, window.width);
  return t / t.maxCoeff();
}

}  // namespace

TEST_CASE("library_grid: one block per object, each in its own map frame") {
  const library g = two_objects();
  CHECK(g.objects() == 2);
  CHECK(g.size() == 20 + 18);
  CHECK(g.rows() == 1);
  CHECK(g.cols() == g.size());
  CHECK(g.object_offset(0) == 0);
  CHECK(g.object_offset(1) == 20);
  CHECK(g.object_size(1) == 18);
  CHECK(g.object_of(19) == 0);
  CHECK(g.object_of(20) == 1);
  CHECK(g.object_of(37) == 1);
  CHECK(g.state_mm(0) == g.object(0).state_mm(0));
  CHECK(g.state_mm(20 + 7) == g.object(1).state_mm(7));
  CHECK(g.object_name(1) == "box");
  CHECK(g.object_prior() == std::vector<double>{0.5, 0.5});
  static_assert(tacmap::library_state_grid<library>);
  static_assert(!tacmap::latent_state_grid<library>);
  static_assert(tacmap::has_circular_coordinates<tacmap::library_grid<tacmap::pose_grid<float>>>);
}

TEST_CASE("library_grid: bad libraries are refused with the reason") {
  const planar a({.width = 7, .height = 5}, 2.0, {.width = 3, .height = 2});
  CHECK(message_of([&] { library({}, {}); }).find("library is empty") != std::string::npos);
  CHECK(message_of([&] {
          library({a, a}, {"x"});
        }).find("2 objects but 1 names") != std::string::npos);
  CHECK(message_of([&] {
          library({a, a}, {"x", "x"});
        }).find("both named 'x'") != std::string::npos);
  CHECK(message_of([&] { library({a}, {""}); }).find("empty name") != std::string::npos);
  CHECK(message_of([&] { two_objects({0.5, 0.6}); }).find("sums to 1.1") != std::string::npos);
  CHECK(message_of([&] { two_objects({1.0}); }).find("1 values for 2 objects") !=
        std::string::npos);
  CHECK(message_of([&] { two_objects({1.5, -0.5}); }).find("-0.5") != std::string::npos);
  CHECK(message_of([&] { two_objects({NAN, 1.0}); }).find("nan") != std::string::npos);
  CHECK(message_of([&] { (void)two_objects().object(2); }).find("expected 0 .. 1") !=
        std::string::npos);
}

TEST_CASE("bayes_filter over a library: the prior per object, spread over its states") {
  tacmap::bayes_filter f(
      two_objects({0.2, 0.8}), tacmap::library_motion(tacmap::odometry_gaussian({.sigma_mm = 1.0})),
      tacmap::library_likelihood<table_likelihood>(std::vector<table_likelihood>(2)));
  CHECK(f.belief().head(20).isApproxToConstant(0.2F / 20.0F));
  CHECK(f.belief().tail(18).isApproxToConstant(0.8F / 18.0F));
  const auto e = f.estimate();
  REQUIRE(e.object_probability.size() == 2);
  CHECK(e.object_probability[1] == doctest::Approx(0.8));
  CHECK(e.map_object == 1);
  CHECK(e.tied_objects.empty());
  // Uniform over the box's 18 positions, conditioned on the box.
  CHECK(e.entropy_nats == doctest::Approx(std::log(18.0)).epsilon(1e-5));
  CHECK(e.map_probability == doctest::Approx(0.8 / 18.0).epsilon(1e-5));
}

TEST_CASE("bayes_filter over a library: object posteriors are Bayes factors of the maps") {
  // Each object's evidence for one touch is its own filter's marginal likelihood from a uniform
  // belief; with a uniform prior the posterior odds of two objects are the ratio of these.
  const library g = two_objects();
  Eigen::ArrayXf ll_cup = Eigen::ArrayXf::LinSpaced(20, -3.0F, 1.0F);
  Eigen::ArrayXf ll_box = Eigen::ArrayXf::LinSpaced(18, 0.5F, -2.0F);
  ll_box(4) = 2.0F;
  tacmap::bayes_filter cup(g.object(0), tacmap::odometry_gaussian{}, table_likelihood{});
  tacmap::bayes_filter box(g.object(1), tacmap::odometry_gaussian{}, table_likelihood{});
  const double lml_cup = cup.update(ll_cup).log_marginal_likelihood();
  const double lml_box = box.update(ll_box).log_marginal_likelihood();

  tacmap::bayes_filter f(
      g, tacmap::library_motion(tacmap::odometry_gaussian{}),
      tacmap::library_likelihood<table_likelihood>(std::vector<table_likelihood>(2)));
  // The library's measurement model takes one view per object.
  (void)f.update(std::vector<Eigen::ArrayXf>{ll_cup, ll_box});
  auto e = f.estimate();
  const double odds = std::exp(lml_box - lml_cup);
  CHECK(e.object_probability[1] == doctest::Approx(odds / (1.0 + odds)).epsilon(1e-5));
  CHECK(e.map_object == 1);
  CHECK(e.map_index == 20 + 4);
  CHECK(e.map_mm == g.object(1).state_mm(4));
  // The pose is the box's belief conditioned on the box: its own filter's estimate.
  const auto eb = box.estimate();
  CHECK((e.mean_mm - eb.mean_mm).norm() < 1e-4);
  CHECK((e.covariance_mm2 - eb.covariance_mm2).norm() < 1e-4);
  CHECK(e.entropy_nats == doctest::Approx(eb.entropy_nats).epsilon(1e-4));
  CHECK(e.map_probability == doctest::Approx(eb.map_probability * e.object_probability[1]));
  // The conditional belief is the box's own filter's belief.
  CHECK(tacmap::object_belief(f.grid(), f.belief(), 1).isApprox(box.belief(), 1e-5F));
  // probability_within and most_probable_disc: the joint mass on the leading object.
  const Eigen::Vector2d c = g.object(1).state_mm(4);
  CHECK(f.probability_within(c, 1.5) ==
        doctest::Approx(box.probability_within(c, 1.5) * e.object_probability[1]).epsilon(1e-5));
  const auto [centre, mass] = f.most_probable_disc(1.5);
  const auto [centre_box, mass_box] = box.most_probable_disc(1.5);
  CHECK((centre - centre_box).norm() < 1e-6);
  CHECK(mass == doctest::Approx(mass_box * e.object_probability[1]).epsilon(1e-5));
}

TEST_CASE("library_motion: each object moves on its own grid and keeps its mass") {
  const library g = two_objects({0.3, 0.7});
  const tacmap::odometry_gaussian motion({.sigma_mm = 1.0, .k = 8});
  tacmap::bayes_filter f(
      g, tacmap::library_motion(motion),
      tacmap::library_likelihood<table_likelihood>(std::vector<table_likelihood>(2)));
  Eigen::ArrayXf ll = Eigen::ArrayXf::Zero(38);
  ll(6) = 3.0F;
  ll(20 + 9) = 2.0F;
  f.update(std::vector<Eigen::ArrayXf>{ll.head(20), ll.tail(18)});
  const auto before = tacmap::object_posterior(f.grid(), f.belief());
  const tacmap::odometry u{.dx_mm = 1.0, .dy_mm = 0.0};
  f.predict(u);
  // Per object: what the base model makes of that object's belief, on its own grid.
  tacmap::bayes_filter cup(g.object(0), motion, table_likelihood{});
  tacmap::bayes_filter box(g.object(1), motion, table_likelihood{});
  cup.update(Eigen::ArrayXf(ll.head(20)));
  box.update(Eigen::ArrayXf(ll.tail(18)));
  const double lost_cup = cup.predict(u).mass_lost, lost_box = box.predict(u).mass_lost;
  CHECK(tacmap::object_belief(f.grid(), f.belief(), 0).isApprox(cup.belief(), 1e-5F));
  CHECK(tacmap::object_belief(f.grid(), f.belief(), 1).isApprox(box.belief(), 1e-5F));
  // The objects' weights change only by the mass each lost off its own map.
  const auto after = tacmap::object_posterior(f.grid(), f.belief());
  const double kept_cup = before[0] * (1.0 - lost_cup), kept_box = before[1] * (1.0 - lost_box);
  CHECK(after[0] == doctest::Approx(kept_cup / (kept_cup + kept_box)).epsilon(1e-5));
}

TEST_CASE("library: touches on one of three photographed objects recognise it and localize") {
  // Three maps of different sizes; the touches are windows of the second.
  const std::vector<tacmap::image<float>> maps = {blob_map(70, 60, 3), blob_map(60, 50, 5),
                                                  blob_map(64, 72, 7)};
  std::vector<planar> grids;
  std::vector<sift_model> models;
  for (const auto& m : maps) {
    grids.emplace_back(tacmap::pixel_size{.width = m.cols(), .height = m.rows()}, 1.0, window);
    models.emplace_back(tacmap::sift_lite{}, m, window);
  }
  tacmap::bayes_filter f(library(grids, {"a", "b", "c"}),
                         tacmap::library_motion(tacmap::odometry_gaussian({.sigma_mm = 1.0})),
                         tacmap::library_likelihood<sift_model>(models));
  const tacmap::grid_cell truth{9, 20};
  f.update({touch_of(maps[1], truth)});
  f.predict({.dx_mm = 0.0, .dy_mm = 6.0});
  f.update({touch_of(maps[1], {truth.row + 6, truth.col})});
  f.predict({.dx_mm = 5.0, .dy_mm = -6.0});
  f.update({touch_of(maps[1], {truth.row, truth.col + 5})});
  const auto e = f.estimate();
  CHECK(e.map_object == 1);
  CHECK(e.object_probability[1] > 0.9);
  CHECK(e.map_index - f.grid().object_offset(1) == grids[1].index({truth.row, truth.col + 5}));
  // The measurement needs one view per object, or one for all.
  CHECK(message_of([&] {
          f.update(std::vector<tacmap::image<float>>(2, touch_of(maps[1], truth)));
        }).find("2 views for 3 objects") != std::string::npos);
}

TEST_CASE("library: two identical maps split their posterior evenly and say so") {
  const tacmap::image<float> m = blob_map(60, 50, 5), other = blob_map(60, 50, 9);
  const planar g({.width = 50, .height = 60}, 1.0, window);
  tacmap::bayes_filter f(
      library({g, g, g}, {"mug", "other", "mug copy"}),
      tacmap::library_motion(tacmap::odometry_gaussian({.sigma_mm = 1.0})),
      tacmap::library_likelihood<sift_model>(
          {sift_model({}, m, window), sift_model({}, other, window), sift_model({}, m, window)}));
  f.update({touch_of(m, {5, 12})});
  f.predict({.dx_mm = 4.0, .dy_mm = 3.0});
  f.update({touch_of(m, {8, 16})});
  const auto e = f.estimate();
  CHECK(e.object_probability[0] == doctest::Approx(e.object_probability[2]).epsilon(1e-6));
  CHECK(e.object_probability[0] > 0.45);
  CHECK(e.map_object == 0);
  CHECK(e.tied_objects == std::vector<Eigen::Index>{2});
}

TEST_CASE("library_likelihood: objects ruled out stop costing, the rest is the exact update") {
  // Object "b" is ruled out by the first touch (posterior ~e-40): the second touch does not
  // evaluate it, and the other posteriors are those of the exact update conditioned on "not b".
  const library g({planar({.width = 7, .height = 5}, 2.0, {.width = 3, .height = 2}),
                   planar({.width = 7, .height = 5}, 2.0, {.width = 3, .height = 2}),
                   planar({.width = 8, .height = 4}, 1.0, {.width = 3, .height = 2})},
                  {"a", "b", "c"});
  auto make = [&](double prune) {
    return tacmap::bayes_filter(
        g, tacmap::library_motion(tacmap::odometry_gaussian({.sigma_mm = 1.0})),
        tacmap::library_likelihood<table_likelihood>(std::vector<table_likelihood>(3),
                                                     {.prune_below = prune}));
  };
  auto pruned = make(1e-9);
  auto exact = make(0.0);
  const std::vector<Eigen::ArrayXf> first = {Eigen::ArrayXf::Zero(20),
                                             Eigen::ArrayXf::Constant(20, -90.0F),
                                             Eigen::ArrayXf::LinSpaced(18, -1.0F, 0.0F)};
  const std::vector<Eigen::ArrayXf> second = {Eigen::ArrayXf::LinSpaced(20, 0.0F, 1.0F),
                                              Eigen::ArrayXf::Constant(20, 50.0F),
                                              Eigen::ArrayXf::Zero(18)};
  for (auto* f : {&pruned, &exact}) f->update(first);
  CHECK(pruned.measurement_model().evaluated() == std::vector<bool>{true, true, true});
  for (auto* f : {&pruned, &exact}) f->update(second);
  CHECK(pruned.measurement_model().evaluated() == std::vector<bool>{true, false, true});
  CHECK(exact.measurement_model().evaluated() == std::vector<bool>{true, true, true});
  const auto p = pruned.estimate().object_probability, q = exact.estimate().object_probability;
  CHECK(p[1] == 0.0);
  CHECK(p[0] == doctest::Approx(q[0] / (q[0] + q[2])).epsilon(1e-5));
  CHECK(p[2] == doctest::Approx(q[2] / (q[0] + q[2])).epsilon(1e-5));
  CHECK(message_of([&] { make(0.5); }).find("prune_below = 0.5") != std::string::npos);
  CHECK(message_of([] {
          tacmap::library_likelihood<table_likelihood>(std::vector<table_likelihood>{});
        }).find("no models") != std::string::npos);
}

TEST_CASE("library of latent grids: each object has its own appearance hypotheses") {
  // Object "dark" is photographed with its raised parts dark: touches (bright = raised) are
  // recognised on it under "inverted"; the estimate's hypotheses are that object's.
  const tacmap::image<float> relief = blob_map(60, 50, 11), other = blob_map(60, 50, 4);
  const planar positions({.width = 50, .height = 60}, 1.0, window);
  using appearance_model = tacmap::appearance_likelihood<sift_model>;
  using latent = tacmap::latent_grid<planar>;
  const appearance_model dark(sift_model({}, 1.0F - relief.array(), window));
  const appearance_model light(sift_model({}, other, window));
  tacmap::bayes_filter f(
      tacmap::library_grid<latent>(
          {latent(positions, dark.hypothesis_names()), latent(positions, light.hypothesis_names())},
          {"light", "dark"}),
      tacmap::library_motion(tacmap::latent_motion(tacmap::odometry_gaussian({.sigma_mm = 1.0}))),
      tacmap::library_likelihood<appearance_model>({light, dark}));
  const tacmap::grid_cell truth{9, 20};
  f.update({touch_of(relief, truth)});
  f.predict({.dx_mm = 0.0, .dy_mm = 6.0});
  f.update({touch_of(relief, {truth.row + 6, truth.col})});
  f.predict({.dx_mm = 0.0, .dy_mm = -6.0});
  f.update({touch_of(relief, truth)});
  const auto e = f.estimate();
  CHECK(e.map_object == 1);
  CHECK(e.object_probability[1] > 0.9);
  REQUIRE(e.hypothesis_probability.size() == 2);
  CHECK(e.hypothesis_probability[1] > 0.9);
  CHECK(e.map_hypothesis == 1);
  CHECK((e.map_index - f.grid().object_offset(1)) % positions.size() == positions.index(truth));
}

TEST_CASE("library_likelihood: an evidence exponent raises the objects' Bayes factors only") {
  // With exponent beta the posterior odds of two objects are (E_box / E_cup)^beta; each
  // object's position belief stays its own filter's.
  const library g = two_objects();
  const Eigen::ArrayXf ll_cup = Eigen::ArrayXf::LinSpaced(20, -3.0F, 1.0F);
  Eigen::ArrayXf ll_box = Eigen::ArrayXf::LinSpaced(18, 0.5F, -2.0F);
  ll_box(4) = 2.0F;
  tacmap::bayes_filter cup(g.object(0), tacmap::odometry_gaussian{}, table_likelihood{});
  tacmap::bayes_filter box(g.object(1), tacmap::odometry_gaussian{}, table_likelihood{});
  const double lml_cup = cup.update(ll_cup).log_marginal_likelihood();
  const double lml_box = box.update(ll_box).log_marginal_likelihood();
  for (const double beta : {0.5, 1.0, 2.5}) {
    CAPTURE(beta);
    tacmap::bayes_filter f(g, tacmap::library_motion(tacmap::odometry_gaussian{}),
                           tacmap::library_likelihood<table_likelihood>(
                               std::vector<table_likelihood>(2), {.evidence_exponent = beta}));
    f.update(std::vector<Eigen::ArrayXf>{ll_cup, ll_box});
    const auto p = f.estimate().object_probability;
    const double odds = std::exp(beta * (lml_box - lml_cup));
    CHECK(p[1] == doctest::Approx(odds / (1.0 + odds)).epsilon(1e-5));
    CHECK(tacmap::object_belief(f.grid(), f.belief(), 0).isApprox(cup.belief(), 1e-5F));
    CHECK(tacmap::object_belief(f.grid(), f.belief(), 1).isApprox(box.belief(), 1e-5F));
  }
  CHECK(message_of([] {
          tacmap::library_likelihood<table_likelihood>(std::vector<table_likelihood>(1),
                                                       {.evidence_exponent = 0.0});
        }).find("evidence_exponent = 0") != std::string::npos);
}

TEST_CASE("library of pose grids: object, position and heading; the heading on the leader") {
  using pose = tacmap::pose_grid<float>;
  const pose a(planar({.width = 7, .height = 5}, 2.0, {.width = 3, .height = 2}), 4);
  const pose b(planar({.width = 8, .height = 4}, 1.0, {.width = 3, .height = 2}), 4);
  tacmap::bayes_filter f(
      tacmap::library_grid<pose>({a, b}, {"a", "b"}),
      tacmap::library_motion(tacmap::pose_odometry_gaussian{}),
      tacmap::library_likelihood<table_likelihood>(std::vector<table_likelihood>(2)));
  // Object b, heading layer 1 (90 degrees), state 5 of the layer: e^4 above everything else.
  Eigen::ArrayXf ll_a = Eigen::ArrayXf::Zero(a.size()), ll_b = Eigen::ArrayXf::Zero(b.size());
  ll_b(18 + 5) = 4.0F;
  f.update(std::vector<Eigen::ArrayXf>{ll_a, ll_b});
  const auto e = f.estimate();
  CHECK(e.map_object == 1);
  CHECK(e.map_index == a.size() + 18 + 5);
  CHECK(e.map_mm(2) == doctest::Approx(b.heading(1)));
  // The prior is uniform over objects, each object's half spread over its own states (80 in a,
  // 72 in b), so P(b) = E_b / (E_a + E_b) with E the mean likelihood over the object's states.
  const double e_a = 1.0;
  const double e_b =
      (static_cast<double>(b.size()) - 1.0 + std::exp(4.0)) / static_cast<double>(b.size());
  CHECK(e.object_probability[1] == doctest::Approx(e_b / (e_a + e_b)).epsilon(1e-5));
  CHECK(e.object_probability[0] == doctest::Approx(e_a / (e_a + e_b)).epsilon(1e-5));
  // Joint: object b and the heading within 0.1 rad of 90 degrees (layer 1 alone: 18 states).
  const double layer_b1 = (18.0 - 1.0 + std::exp(4.0)) / static_cast<double>(b.size());
  CHECK(f.heading_probability_within(b.heading(1), 0.1) ==
        doctest::Approx(layer_b1 / (e_a + e_b)).epsilon(1e-5));
}

}  // namespace test_library
