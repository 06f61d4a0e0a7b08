// Tracking mode (issue 14, item 3): the measurement models' hook against their full
// log-likelihood, and the filter's tracked update against its full update.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/localizer.hpp"
#include "tacmap/measurement/appearance_likelihood.hpp"
#include "tacmap/measurement/descriptor_likelihood.hpp"
#include "tacmap/measurement/ncc_likelihood.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"
#include "tacmap/testing/conformance.hpp"
#include "test_support.hpp"
#include "tracking_support.hpp"

namespace test_tracking {

using grid_t = tacmap::planar_grid<float>;
using tacmap::state_range;
using tacmap::update_path;

namespace {

constexpr double mm_per_px = 0.2;
constexpr tacmap::pixel_size window{.width = 18, .height = 42};

const tacmap::image<float>& test_map() {
  static const tacmap::image<float> map = tacmap::testing::conformance_image(96, 84, 7);
  return map;
}

grid_t test_grid() {
  const auto& map = test_map();
  return grid_t({.width = map.cols(), .height = map.rows()}, mm_per_px, window);
}

// The window at `cell` with a little deterministic noise: a realistic touch, not an exact cut.
tacmap::image<float> touch_at(const tacmap::grid_cell& cell, unsigned seed = 1) {
  return tacmap_test::noisy_window(test_map(), cell.row, cell.col, window, seed);
}

using tacmap_test::total_variation;

// A prior concentrated around `cell`: a Gaussian of `sigma` px (what a localized filter's
// prediction looks like).
Eigen::ArrayXf blob(const grid_t& grid, const tacmap::grid_cell& cell, double sigma) {
  Eigen::ArrayXf p(grid.size());
  for (Eigen::Index i = 0; i < grid.size(); ++i) {
    const auto c = grid.cell(i);
    const double r2 = static_cast<double>((c.row - cell.row) * (c.row - cell.row) +
                                          (c.col - cell.col) * (c.col - cell.col));
    p(i) = static_cast<float>(std::exp(-0.5 * r2 / (sigma * sigma)));
  }
  return p / p.sum();
}

// A model with a fixed table of log-likelihoods and the tracking hook: for the filter's own
// arithmetic, independent of any descriptor.
struct table_model {
  struct measurement_type {
    Eigen::ArrayXf ll;
    double bound = 0.0;
  };
  template <class G>
  void log_likelihood(const G&, const measurement_type& z, tacmap::belief_array<G>& out) const {
    out = z.ll;
  }
  double last_bound = 0.0;
  mutable double bound = 0.0;
  [[nodiscard]] double log_likelihood_bound() const { return bound; }
  template <class G>
  void log_likelihood_on(const G&, const measurement_type& z, tacmap::belief_array<G>& out,
                         std::span<const state_range> states) const {
    for (const state_range& r : states)
      out.segment(r.begin, r.end - r.begin) = z.ll.segment(r.begin, r.end - r.begin);
  }
};

// The minimal conforming type of measurement/concept.hpp.
struct uninformative_tracked {
  struct measurement_type {};
  template <class G>
  void log_likelihood(const G&, const measurement_type&, tacmap::belief_array<G>& out) const {
    out.setZero();
  }
  [[nodiscard]] double log_likelihood_bound() const { return 0.0; }
  template <class G>
  void log_likelihood_on(const G&, const measurement_type&, tacmap::belief_array<G>& out,
                         std::span<const state_range> states) const {
    for (const state_range& r : states) out.segment(r.begin, r.end - r.begin).setZero();
  }
};
static_assert(tacmap::measures_on_states<uninformative_tracked, grid_t>);
static_assert(tacmap::measures_on_states<table_model, grid_t>);
static_assert(!tacmap::measures_on_states<tacmap::ncc_likelihood<float>, grid_t>);
static_assert(
    tacmap::measures_on_states<tacmap::descriptor_likelihood<tacmap::classic_sift>, grid_t>);

}  // namespace

TEST_CASE_TEMPLATE(
    "the descriptor model's tracking hook writes its full log-likelihood, bit for bit", D,
    tacmap::sift_lite, tacmap::classic_sift) {
  const grid_t grid = test_grid();
  const tacmap::image<float> z = touch_at({20, 31});
  struct named {
    const char* name;
    tacmap::descriptor_likelihood_params p;
  };
  std::vector<named> configs = {
      {"per window, aligned, exponential (default)", {}},
      {"per window, all pairs, exponential", {.pairs = tacmap::pairing::all_pairs}},
      {"per window, aligned, inverse", {.shape = tacmap::likelihood_shape::inverse}},
      {"paper: all pairs, inverse", tacmap::descriptor_likelihood_params::paper()},
      {"both_signs basis", {.both_signs = true}},
      {"tempering 0.5, tau 0.3", {.tau = 0.3, .tempering = 0.5}},
      {"shared dense (whole grid)", {.features = tacmap::window_features::shared_dense}},
      {"either_per_patch (whole grid)", {.contrast = tacmap::contrast_sign::either_per_patch}},
  };
  for (const auto& c : configs) {
    CAPTURE(c.name);
    const tacmap::descriptor_likelihood<D> model(D{}, test_map(), window, c.p);
    tacmap::testing::check_log_likelihood_on(model, grid, z);
  }
  SUBCASE("both signs in one pass: each block, restricted, equals the whole pass") {
    for (const auto shape :
         {tacmap::likelihood_shape::exponential, tacmap::likelihood_shape::inverse}) {
      const tacmap::descriptor_likelihood<D> model(D{}, test_map(), window,
                                                   {.shape = shape, .both_signs = true});
      const Eigen::Index n = grid.size();
      Eigen::ArrayXf full(2 * n), part = Eigen::ArrayXf::Constant(2 * n, NAN);
      model.log_likelihood_both_signs(grid, z, full.data());
      const std::vector<state_range> states = {{3, 4}, {40, 95}, {n - 13, n}};
      model.log_likelihood_both_signs_on(grid, z, part.data(), states);
      for (Eigen::Index sign = 0; sign < 2; ++sign)
        for (const state_range& r : states)
          for (Eigen::Index i = r.begin; i < r.end; ++i)
            REQUIRE(part(sign * n + i) == full(sign * n + i));
    }
  }
}

TEST_CASE("the localizer's model (latent appearance, both signs) keeps the hook's promise") {
  tacmap::localizer_config config;  // the defaults: classic_sift, per window, aligned, latent
  config.lost_probability = 0.0;
  auto filter = tacmap::make_planar_filter(config, test_map(), mm_per_px, window);
  const auto& model = filter.measurement_model();
  tacmap::testing::check_log_likelihood_on(model, filter.grid(), touch_at({11, 40}));
  CHECK(model.log_likelihood_bound() == 0.0);
  // NCC has no hook: the configured model reports no bound (the filter then takes the grid).
  config.model = tacmap::measurement_kind::ncc;
  const tacmap::configured_measurement ncc(config, test_map(), window);
  CHECK(std::isinf(ncc.log_likelihood_bound()));
}

TEST_CASE("a tracked update equals the full update within its stated bound, same estimate") {
  const grid_t grid = test_grid();
  using model_t = tacmap::descriptor_likelihood<tacmap::sift_lite>;
  tacmap::bayes_filter full(grid, tacmap::odometry_gaussian({.sigma_mm = 0.6, .k = 8}),
                            model_t(tacmap::sift_lite{}, test_map(), window));
  // Localize with full updates on a walk, then compare every further step from the same
  // predicted belief: tracked against full. (SIFT-lite on this small map leaves the first
  // touches' beliefs spread: those steps take the whole grid, full_wide.)
  tacmap::grid_cell at{30, 20};
  full.update(touch_at(at));
  int tracked_steps = 0;
  for (int step = 0; step < 10; ++step) {
    CAPTURE(step);
    const int dc = step % 4 < 2 ? 3 : -3, dr = step % 2 == 0 ? 2 : -1;
    at = {at.row + dr, at.col + dc};
    const tacmap::odometry u{.dx_mm = dc * mm_per_px, .dy_mm = dr * mm_per_px};
    auto tracked = full;
    tracked.set_tracking({.epsilon = 1e-6});
    tracked.predict(u);
    full.predict(u);
    const auto z = touch_at(at, static_cast<unsigned>(step + 2));
    const tacmap::update_report rt = tracked.update(z);
    const tacmap::update_report rf = full.update(z);
    CHECK(rf.path == update_path::full);
    CHECK(rf.evaluated_states == grid.size());
    if (rt.path != update_path::tracked) {
      CHECK(total_variation(tracked.belief(), full.belief()) == 0.0);
      continue;
    }
    ++tracked_steps;
    CHECK(rt.evaluated_states < grid.size() / 4);
    CHECK(rt.tracking_error_bound <= tracked.tracking().tolerance);
    // The bound, plus float rounding of two normalisations.
    CHECK(total_variation(tracked.belief(), full.belief()) <= rt.tracking_error_bound + 1e-5);
    CHECK(tracked.estimate().map_index == full.estimate().map_index);
    CHECK(rt.log_likelihood_max <= rf.log_likelihood_max);
    CHECK(rt.log_marginal_likelihood() ==
          doctest::Approx(rf.log_marginal_likelihood()).epsilon(1e-4));
    CHECK(static_cast<double>(tracked.belief().sum()) == doctest::Approx(1.0).epsilon(1e-5));
  }
  CHECK(tracked_steps >= 6);
}

TEST_CASE("a touch that contradicts the prediction (a kidnap) falls back to the whole grid") {
  const grid_t grid = test_grid();
  using model_t = tacmap::descriptor_likelihood<tacmap::sift_lite>;
  tacmap::bayes_filter full(grid, tacmap::odometry_gaussian({.sigma_mm = 0.6, .k = 8}),
                            model_t(tacmap::sift_lite{}, test_map(), window));
  full.set_prior(blob(grid, {8, 8}, 2.0));
  auto tracked = full;
  tracked.set_tracking({.epsilon = 1e-6});
  // The sensor is far from where the prior puts it.
  const auto z = touch_at({48, 56});
  const tacmap::update_report rt = tracked.update(z);
  full.update(z);
  CHECK(rt.path == update_path::full_contradicted);
  CHECK(rt.evaluated_states == grid.size());
  CHECK(rt.tracking_error_bound == 0.0);
  CHECK((tracked.belief() == full.belief()).all());
}

TEST_CASE("the bound holds where the outside matches best (adversarial table)") {
  const grid_t grid = test_grid();
  const Eigen::Index n = grid.size();
  tacmap::bayes_filter f(grid, tacmap::odometry_gaussian{}, table_model{});
  const Eigen::ArrayXf prior = blob(grid, {25, 30}, 1.5);
  // Every state outside a few px of the blob matches perfectly (log-likelihood 0 = the bound),
  // the blob's states at -2: the worst case for the states that were not evaluated.
  table_model::measurement_type z{Eigen::ArrayXf::Constant(n, -2.0F), 0.0};
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto c = grid.cell(i);
    if (std::abs(c.row - 25) + std::abs(c.col - 30) > 12) z.ll(i) = 0.0F;
  }
  for (const double tolerance : {1e-3, 1e-2, 0.3}) {
    CAPTURE(tolerance);
    tacmap::bayes_filter full = f;
    full.set_prior(prior);
    auto tracked = full;
    tracked.set_tracking({.epsilon = 1e-4, .tolerance = tolerance});
    const auto rt = tracked.update(z);
    full.update(z);
    const double tv = total_variation(tracked.belief(), full.belief());
    if (rt.path == update_path::tracked) {
      CHECK(rt.tracking_error_bound <= tolerance);
      CHECK(tv <= rt.tracking_error_bound + 1e-6);
    } else {
      CHECK(rt.path == update_path::full_contradicted);
      CHECK(tv == 0.0);
    }
  }
}

TEST_CASE(
    "tracking: a uniform belief, a model without the hook and the paper's floor take the grid") {
  const grid_t grid = test_grid();
  SUBCASE("uniform: the support is every state") {
    tacmap::bayes_filter f(
        grid, tacmap::odometry_gaussian{},
        tacmap::descriptor_likelihood<tacmap::sift_lite>(tacmap::sift_lite{}, test_map(), window));
    f.set_tracking({.epsilon = 1e-6});
    const auto r = f.update(touch_at({5, 5}));
    CHECK(r.path == update_path::full_wide);
    CHECK(r.evaluated_states == grid.size());
  }
  SUBCASE("NCC has no hook: tracking on, full updates") {
    tacmap::bayes_filter f(grid, tacmap::odometry_gaussian{},
                           tacmap::ncc_likelihood<float>(test_map(), window));
    f.set_prior(blob(grid, {20, 20}, 1.0));
    f.set_tracking({.epsilon = 1e-6});
    CHECK(f.update(touch_at({20, 20})).path == update_path::full);
  }
  SUBCASE("the localizer's default filter after one touch on this small map: a wide support") {
    // (Its motion floor no longer forces the whole grid: test_default_tracking.cpp.)
    auto f = tacmap::make_planar_filter(tacmap::localizer_config{}, test_map(), mm_per_px, window);
    f.set_tracking({.epsilon = 1e-6});
    f.update(touch_at({30, 30}));
    f.predict(tacmap::odometry{.dx_mm = 0.4});
    CHECK(f.update(touch_at({30, 32})).path == update_path::full_wide);
  }
}

TEST_CASE("the localizer's filter without the floor tracks, within the bound of its full update") {
  tacmap::localizer_config config;
  config.lost_probability = 0.0;
  config.wide_probability = 0.0;
  // The map as photographed: on this small synthetic map, blurred by the default half pitch
  // (pad_spread_mm), every touch after the first is too weak inside the support for the bound
  // (update_path::full_contradicted), so nothing here would be tracked to check.
  config.pad_spread_mm = 0.0;
  auto full = tacmap::make_planar_filter(config, test_map(), mm_per_px, window);
  tacmap::grid_cell at{22, 25};
  full.update(touch_at(at));
  int tracked_steps = 0;
  for (int step = 0; step < 5; ++step) {
    CAPTURE(step);
    at = {at.row + 1, at.col + 3};
    auto tracked = full;
    tracked.set_tracking({.epsilon = 1e-6});
    const tacmap::odometry u{.dx_mm = 3 * mm_per_px, .dy_mm = mm_per_px};
    tracked.predict(u);
    full.predict(u);
    const auto z = touch_at(at, static_cast<unsigned>(step + 11));
    const auto rt = tracked.update(z);
    full.update(z);
    if (rt.path != update_path::tracked) continue;
    ++tracked_steps;
    CHECK(total_variation(tracked.belief(), full.belief()) <= rt.tracking_error_bound + 1e-5);
    const auto et = tracked.estimate(), ef = full.estimate();
    CHECK(et.map_index == ef.map_index);
    CHECK(et.hypothesis_probability[0] ==
          doctest::Approx(ef.hypothesis_probability[0]).epsilon(1e-3));
  }
  CHECK(tracked_steps >= 3);
}

TEST_CASE("tracking refuses bad parameters and keeps the NaN and infinity guards") {
  const grid_t grid = test_grid();
  tacmap::bayes_filter f(grid, tacmap::odometry_gaussian{}, table_model{});
  for (const double eps : {-1e-3, 0.7, std::numeric_limits<double>::quiet_NaN()}) {
    const std::string msg = tacmap_test::message_of([&] { f.set_tracking({.epsilon = eps}); });
    CHECK(msg.find("epsilon = ") != std::string::npos);
    CHECK(msg.find("expected") != std::string::npos);
  }
  CHECK(tacmap_test::message_of([&] { f.set_tracking({.epsilon = 0.7}); }).find("0.7") !=
        std::string::npos);
  CHECK(tacmap_test::message_of([&] {
          f.set_tracking({.epsilon = 1e-6, .tolerance = 0.0});
        }).find("tolerance = 0") != std::string::npos);
  CHECK(tacmap_test::message_of([&] {
          f.set_tracking({.epsilon = 1e-6, .max_support = 1.5});
        }).find("max_support = 1.5") != std::string::npos);
  CHECK(f.tracking().epsilon == 0.0);  // unchanged by the refused calls

  f.set_prior(blob(grid, {20, 30}, 1.5));
  f.set_tracking({.epsilon = 1e-6});
  const auto before = f.belief();
  const Eigen::Index inside = grid.index({20, 30});
  table_model::measurement_type z{Eigen::ArrayXf::Zero(grid.size()), 0.0};
  z.ll(inside) = NAN;
  const std::string nan_msg = tacmap_test::message_of<std::domain_error>([&] { f.update(z); });
  CHECK(nan_msg.find("NaN at state " + std::to_string(inside)) != std::string::npos);
  z.ll(inside) = std::numeric_limits<float>::infinity();
  CHECK(tacmap_test::message_of<std::domain_error>([&] { f.update(z); }).find("+infinity") !=
        std::string::npos);
  CHECK((f.belief() == before).all());
  // The filter still works afterwards, on the tracked path.
  z.ll(inside) = 0.0F;
  CHECK(f.update(z).path == update_path::tracked);
  CHECK(f.estimate().map_index == inside);
}

TEST_CASE("predict_box moves a box's mass as predict moves it, and drops what leaves the grid") {
  const grid_t grid = test_grid();
  const tacmap::grid_box box{.row = 30, .col = 35, .rows = 9, .cols = 7};
  // Mass only inside the box: the windowed prediction is then the whole grid's.
  Eigen::ArrayXf p = blob(grid, {34, 38}, 2.0);
  Eigen::Map<tacmap::image<float>> img(p.data(), grid.rows(), grid.cols());
  tacmap::image<float> kept = img.block(box.row, box.col, box.rows, box.cols);
  img.setZero();
  img.block(box.row, box.col, box.rows, box.cols) = kept;
  p /= p.sum();
  for (const int k : {8, 12, 24}) {
    const tacmap::odometry_gaussian motion({.sigma_mm = 0.5, .k = k});
    for (const tacmap::odometry u : {tacmap::odometry{0.8, 0.0}, tacmap::odometry{-1.37, 0.55},
                                     tacmap::odometry{0.0, -2.1}, tacmap::odometry{0.3, 0.3}}) {
      CAPTURE(k);
      CAPTURE(u.dx_mm);
      Eigen::ArrayXf whole(p.size()), windowed = p;
      motion.predict(grid, p, whole, u);
      REQUIRE(motion.predict_box(grid, windowed, box, u));
      CHECK((windowed - whole).abs().maxCoeff() <= 1e-6F * whole.maxCoeff());
      CHECK(static_cast<double>(windowed.sum()) == doctest::Approx(1.0).epsilon(1e-6));
    }
    // Moved past the edge: predict drops that mass and renormalises; predict_boxes drops it
    // and reports it (its belief is predict's times 1 - dropped). With off_grid::clamp (mass
    // piled onto the edge) it refuses, the belief unchanged; so it does for NaN odometry.
    const tacmap::odometry off{-7.0, 0.0};
    tacmap::prediction_report report;
    Eigen::ArrayXf whole(p.size());
    report = motion.predict(grid, p, whole, off);
    REQUIRE(report.mass_lost > 1e-3);
    Eigen::ArrayXf at_edge = p;
    std::vector<tacmap::grid_box> landed;
    double dropped = 0.0;
    REQUIRE(motion.predict_boxes(grid, at_edge, std::span<const tacmap::grid_box>(&box, 1), off,
                                 landed, dropped));
    CHECK(dropped == doctest::Approx(report.mass_lost).epsilon(1e-5));
    CHECK((at_edge - whole * static_cast<float>(1.0 - dropped)).abs().maxCoeff() <=
          1e-6F * whole.maxCoeff());
    REQUIRE(landed.size() == 1);
    CHECK(landed[0].col == 0);
    at_edge = p;
    const tacmap::odometry_gaussian clamped(
        {.sigma_mm = 0.5, .k = k, .boundary = tacmap::off_grid::clamp});
    CHECK_FALSE(clamped.predict_box(grid, at_edge, box, off));
    CHECK_FALSE(motion.predict_box(grid, at_edge, box, tacmap::odometry{std::nan(""), 0.0}));
    CHECK((at_edge == p).all());
  }
  {
    // Two boxes whose moved windows overlap the other box: every box is read before any window
    // is added, so the result is predict's.
    const std::vector<tacmap::grid_box> two{{.row = 20, .col = 20, .rows = 5, .cols = 4},
                                            {.row = 22, .col = 25, .rows = 4, .cols = 6}};
    Eigen::ArrayXf q = Eigen::ArrayXf::Zero(p.size());
    Eigen::Map<tacmap::image<float>> qi(q.data(), grid.rows(), grid.cols());
    for (const tacmap::grid_box& b : two)
      for (Eigen::Index r = b.row; r < b.row + b.rows; ++r)
        for (Eigen::Index c = b.col; c < b.col + b.cols; ++c)
          qi(r, c) = 1.0F + static_cast<float>((r * 3 + c) % 7);
    q /= q.sum();
    const tacmap::odometry_gaussian motion({.sigma_mm = 0.5, .k = 8});
    const tacmap::odometry u{0.9, -0.3};
    Eigen::ArrayXf whole(q.size()), windowed = q;
    motion.predict(grid, q, whole, u);
    std::vector<tacmap::grid_box> landed;
    double dropped = -1.0;
    REQUIRE(motion.predict_boxes(grid, windowed, std::span<const tacmap::grid_box>(two), u, landed,
                                 dropped));
    CHECK(dropped == 0.0);
    CHECK((windowed - whole).abs().maxCoeff() <= 1e-6F * whole.maxCoeff());
    CHECK(landed.size() == 2);
  }
  static_assert(tacmap::moves_box<tacmap::odometry_gaussian, grid_t>);
}

TEST_CASE("a windowed predict stays within its bound of the whole grid's prediction") {
  const grid_t grid = test_grid();
  using model_t = tacmap::descriptor_likelihood<tacmap::sift_lite>;
  tacmap::bayes_filter tracked(grid, tacmap::odometry_gaussian({.sigma_mm = 0.6, .k = 8}),
                               model_t(tacmap::sift_lite{}, test_map(), window));
  // Localized: SIFT-lite alone leaves this small map's belief on several repeats of its texture
  // (a support box as wide as the grid: the whole grid moves), so start from a concentrated
  // prior, as a filter that has localized has.
  tacmap::grid_cell at{30, 20};
  tracked.set_prior(blob(grid, at, 1.5));
  auto full = tracked;
  tracked.set_tracking({.epsilon = 1e-6});
  int windowed = 0;
  for (int step = 0; step < 12; ++step) {
    CAPTURE(step);
    const int dc = step % 4 < 2 ? 3 : -3, dr = step % 2 == 0 ? 2 : -1;
    at = {at.row + dr, at.col + dc};
    const tacmap::odometry u{.dx_mm = dc * mm_per_px, .dy_mm = dr * mm_per_px};
    // The whole grid's prediction of the same belief (set_tracking forgets the support box).
    auto reference = tracked;
    reference.set_tracking({});
    reference.predict(u);
    const tacmap::prediction_report pr = tracked.predict(u);
    if (pr.windowed) {
      ++windowed;
      CHECK(pr.tracking_error_bound <= 1e-6 * (1.0 + 1e-4));
      CHECK(total_variation(tracked.belief(), reference.belief()) <=
            pr.tracking_error_bound + 1e-6);
      CHECK(static_cast<double>(tracked.belief().sum()) == doctest::Approx(1.0).epsilon(1e-5));
    } else {
      CHECK(total_variation(tracked.belief(), reference.belief()) == 0.0);
    }
    full.predict(u);
    const auto z = touch_at(at, static_cast<unsigned>(step + 5));
    tracked.update(z);
    full.update(z);
    CHECK(tracked.estimate().map_index == full.estimate().map_index);
    CHECK(total_variation(tracked.belief(), full.belief()) <= 1e-2);
  }
  CHECK(windowed >= 6);
}

TEST_CASE("two clusters far apart are tracked in boxes of their own, within the bound") {
  // A belief on two places of the map (a repeated texture): their bounding box is wider than
  // max_support of the grid, so only boxes of their own keep the predicts windowed and the
  // updates searching the region. The table favours both places alike, so both stay.
  const grid_t grid = test_grid();
  const Eigen::Index n = grid.size();
  const tacmap::grid_cell a{12, 12}, b{42, 55};
  REQUIRE(static_cast<double>((b.row - a.row + 1) * (b.col - a.col + 1)) >
          0.25 * static_cast<double>(n));
  Eigen::ArrayXf prior = blob(grid, a, 1.5) + blob(grid, b, 1.5);
  table_model::measurement_type z{Eigen::ArrayXf(n), 0.0};
  tacmap::bayes_filter tracked(grid, tacmap::odometry_gaussian({.sigma_mm = 0.3, .k = 8}),
                               table_model{});
  tracked.set_prior(prior);
  auto full = tracked;
  tracked.set_tracking({.epsilon = 1e-6});
  int windowed = 0, tracked_updates = 0;
  double dx = 0.0;
  for (int step = 0; step < 16; ++step) {
    CAPTURE(step);
    const double move = step % 2 == 0 ? 0.6 : -0.6;  // mm: 3 px right, then back
    dx += move;
    const tacmap::odometry u{.dx_mm = move, .dy_mm = 0.0};
    // The table peaks where the two places now are.
    const auto shift = static_cast<Eigen::Index>(std::lround(dx / mm_per_px));
    for (Eigen::Index i = 0; i < n; ++i) {
      const auto c = grid.cell(i);
      const auto d2 = [&](const tacmap::grid_cell& p) {
        const double dr = static_cast<double>(c.row - p.row);
        const double dc = static_cast<double>(c.col - p.col - shift);
        return dr * dr + dc * dc;
      };
      z.ll(i) = static_cast<float>(-0.5 * std::min(d2(a), d2(b)));
    }
    const tacmap::prediction_report pr = tracked.predict(u);
    full.predict(u);
    if (pr.windowed) {
      ++windowed;
      CHECK(pr.tracking_error_bound <= 1e-6 * (1.0 + 1e-4));
    }
    const tacmap::update_report rt = tracked.update(z);
    full.update(z);
    if (rt.path == update_path::tracked) {
      ++tracked_updates;
      CHECK(rt.evaluated_states < n / 4);
    }
    // The two bounds of the step (predict and update), plus float rounding.
    CHECK(total_variation(tracked.belief(), full.belief()) <=
          pr.tracking_error_bound + rt.tracking_error_bound + 1e-5);
    CHECK(static_cast<double>(tracked.belief().sum()) == doctest::Approx(1.0).epsilon(1e-5));
    // Both places keep their share.
    const Eigen::Map<const tacmap::image<float>> img(tracked.belief().data(), grid.rows(),
                                                     grid.cols());
    CHECK(static_cast<double>(img.block(0, 0, grid.rows(), 34).sum()) ==
          doctest::Approx(0.5).epsilon(0.05));
  }
  CHECK(windowed >= 12);
  CHECK(tracked_updates >= 12);
}

TEST_CASE("the region helpers: thresholds over ranges, clusters in disjoint boxes, masses") {
  namespace d = tacmap::detail;
  // A belief image of 3 layers of 40 x 50 with mass in a few places and a faint floor.
  const Eigen::Index rows = 40, cols = 50, layers = 3, plane = rows * cols;
  Eigen::ArrayXf p = Eigen::ArrayXf::Constant(layers * plane, 1e-9F);
  const auto put = [&](Eigen::Index a, Eigen::Index r, Eigen::Index c, float v) {
    p(a * plane + r * cols + c) = v;
  };
  for (Eigen::Index r = 5; r < 9; ++r)
    for (Eigen::Index c = 3; c < 8; ++c) put(0, r, c, 0.01F * static_cast<float>(1 + r + c));
  put(1, 30, 40, 0.2F);
  put(2, 31, 44, 0.1F);  // 4 columns from (30, 40): the same cluster
  put(2, 0, 49, 0.05F);  // the last column, next to row 1's first: split, not joined
  put(1, 39, 0, 0.05F);
  p /= p.sum();
  std::vector<state_range> support;
  const float t = 1e-4F;
  const d::support_summary s = d::support_ranges(p.data(), p.size(), t, p.size(), support);
  CHECK(s.states == 20 + 4);
  // Boxes: every support state inside one, the boxes pairwise more than 4 cells apart.
  const std::vector<tacmap::grid_box> boxes = d::cluster_boxes(support, rows, cols, 4, 32);
  CHECK(boxes.size() == 4);
  for (const state_range& r : support)
    for (Eigen::Index i = r.begin; i < r.end; ++i) {
      const Eigen::Index within = i % plane, row = within / cols, col = within % cols;
      int inside = 0;
      for (const tacmap::grid_box& b : boxes)
        inside += row >= b.row && row < b.row + b.rows && col >= b.col && col < b.col + b.cols;
      CHECK(inside == 1);
    }
  for (std::size_t i = 0; i < boxes.size(); ++i)
    for (std::size_t j = i + 1; j < boxes.size(); ++j)
      CHECK_FALSE(d::boxes_meet(boxes[i], boxes[j], 4));
  // More boxes than allowed: their bounding box.
  const std::vector<tacmap::grid_box> one = d::cluster_boxes(support, rows, cols, 4, 3);
  REQUIRE(one.size() == 1);
  CHECK(one[0].rows == rows);
  CHECK(one[0].cols == cols);
  // The boxes' states in every layer, as sorted ranges; their mass and the mass outside S.
  std::vector<state_range> region;
  d::box_ranges(boxes, rows, cols, layers, region);
  Eigen::Index count = 0;
  double in_region = 0.0;
  for (std::size_t k = 0; k < region.size(); ++k) {
    if (k > 0) CHECK(region[k - 1].end < region[k].begin);  // sorted, joined when adjacent
    count += region[k].end - region[k].begin;
    for (Eigen::Index i = region[k].begin; i < region[k].end; ++i)
      in_region += static_cast<double>(p(i));
  }
  Eigen::Index area = 0;
  for (const tacmap::grid_box& b : boxes) area += b.rows * b.cols;
  CHECK(count == area * layers);
  CHECK(d::mass_in(p.data(), std::span<const tacmap::grid_box>(boxes), rows, cols, layers) ==
        doctest::Approx(in_region).epsilon(1e-12));
  double in_s = 0.0;
  for (const state_range& r : support)
    for (Eigen::Index i = r.begin; i < r.end; ++i) in_s += static_cast<double>(p(i));
  CHECK(d::mass_outside_of(p.data(), std::span<const state_range>(region),
                           std::span<const state_range>(support)) ==
        doctest::Approx(in_region - in_s).epsilon(1e-9));
  // Thresholds over the region: its candidates' masses below, as the whole-array function
  // gives them range by range.
  const auto cand = d::support_candidate_thresholds<float>(count, 1e-6);
  const auto below = d::mass_below_on(p.data(), std::span<const state_range>(region), cand);
  for (std::size_t k = 0; k < cand.size(); ++k) {
    double expected = 0.0;
    for (const state_range& r : region)
      expected += d::mass_below(p.data() + r.begin, r.end - r.begin, cand)[k];
    CHECK(below[k] == doctest::Approx(expected).epsilon(1e-6));
  }
  std::vector<state_range> within;
  const d::support_summary sr =
      d::support_ranges_on(p.data(), std::span<const state_range>(region), t, p.size(), within);
  CHECK(within == support);  // every support state is in the region
  CHECK(sr.outside == doctest::Approx(in_region - in_s).epsilon(1e-5));
}

namespace {
// A motion model that moves boxes as odometry_gaussian does, then breaks its contract: a NaN
// in the first box.
struct nan_boxes {
  using control_type = tacmap::odometry;
  tacmap::odometry_gaussian inner{{.sigma_mm = 0.3, .k = 8}};
  template <class G>
  tacmap::prediction_report predict(const G& g, const tacmap::belief_array<G>& in,
                                    tacmap::belief_array<G>& out, const control_type& u) const {
    return inner.predict(g, in, out, u);
  }
  template <class G>
  bool predict_boxes(const G& g, tacmap::belief_array<G>& b,
                     std::span<const tacmap::grid_box> boxes, const control_type& u,
                     std::vector<tacmap::grid_box>& landed, double& dropped) const {
    if (!inner.predict_boxes(g, b, boxes, u, landed, dropped)) return false;
    b(boxes[0].row * g.cols() + boxes[0].col) = std::numeric_limits<float>::quiet_NaN();
    return true;
  }
};
static_assert(tacmap::moves_box<nan_boxes, grid_t>);
}  // namespace

TEST_CASE("a motion model whose predict_boxes breaks its contract: an error, never a NaN belief") {
  const grid_t grid = test_grid();
  tacmap::bayes_filter f(grid, nan_boxes{}, table_model{});
  f.set_prior(blob(grid, {25, 30}, 1.5));
  f.set_tracking({.epsilon = 1e-9});
  table_model::measurement_type z{Eigen::ArrayXf(grid.size()), 0.0};
  for (Eigen::Index i = 0; i < grid.size(); ++i) {
    const auto c = grid.cell(i);
    z.ll(i) = static_cast<float>(
        -0.1 * static_cast<double>((c.row - 25) * (c.row - 25) + (c.col - 30) * (c.col - 30)));
  }
  REQUIRE(f.update(z).path == update_path::tracked);
  const std::string msg =
      tacmap_test::message_of<std::logic_error>([&] { (void)f.predict({.dx_mm = 0.2}); });
  CHECK(msg.find("predict_boxes") != std::string::npos);
  CHECK(msg.find("reset to uniform") != std::string::npos);
  CHECK(f.belief().allFinite());
  CHECK(static_cast<double>(f.belief().sum()) == doctest::Approx(1.0).epsilon(1e-5));
}

}  // namespace test_tracking
