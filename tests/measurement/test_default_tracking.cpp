// Tracking under the default (issue 36, item 2): the localizer's default filter — latent
// appearance, robust motion's floor and wide component — tracks once localized, within its
// stated estimate of the full update, keeps the verdict's probabilities, and still finds the
// sensor after a kidnap. Every tracked result is compared with the full filter on the same inputs.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/filter/confidence.hpp"
#include "tacmap/grid/latent_grid.hpp"
#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/grid/pose_grid.hpp"
#include "tacmap/localizer.hpp"
#include "tacmap/motion/latent_motion.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"
#include "tacmap/motion/pose_odometry_gaussian.hpp"
#include "tacmap/motion/robust_motion.hpp"
#include "tracking_support.hpp"

namespace test_default_tracking {

using tacmap::update_path;

namespace {

// The paper's pitch: the wide component's 3 mm is a few cells, so its windows stay small.
constexpr double mm_per_px = 3.4 / 3.0;
constexpr tacmap::pixel_size window{.width = 18, .height = 42};

// A textured map: random bars (edges both ways) over a slanted sine, in [0, 1]; 120 x 150 px.
const tacmap::image<float>& test_map() {
  static const tacmap::image<float> map = [] {
    constexpr Eigen::Index rows = 120, cols = 150;
    std::mt19937 rng(9);
    tacmap::image<float> m = tacmap::image<float>::Zero(rows, cols);
    for (int bar = 0; bar < 26; ++bar)
      m.block(static_cast<Eigen::Index>(rng() % (rows - 20)),
              static_cast<Eigen::Index>(rng() % (cols - 20)),
              static_cast<Eigen::Index>(3 + rng() % 17), static_cast<Eigen::Index>(3 + rng() % 17))
          .array() += 1.0F;
    for (Eigen::Index r = 0; r < rows; ++r)
      for (Eigen::Index c = 0; c < cols; ++c)
        m(r, c) += 0.2F * std::sin(0.2F * static_cast<float>(r + 2 * c));
    m -= m.minCoeff();
    return tacmap::image<float>(m / m.maxCoeff());
  }();
  return map;
}

// The window at (row, col) with a little deterministic noise: a touch, not an exact cut.
tacmap::image<float> touch_at(Eigen::Index row, Eigen::Index col, unsigned seed) {
  return tacmap_test::noisy_window(test_map(), row, col, window, seed);
}

using tacmap_test::total_variation;

tacmap::planar_localizer_filter default_filter() {
  return tacmap::make_planar_filter(tacmap::localizer_config{}, test_map(), mm_per_px, window);
}

// A walk of small moves (in px) around (row, col).
struct walk {
  Eigen::Index row = 40, col = 50;
  int step = 0;
  tacmap::odometry next() {
    const Eigen::Index dc = step % 4 < 2 ? 2 : -2, dr = step % 2 == 0 ? 1 : -1;
    ++step;
    row += dr;
    col += dc;
    return {.dx_mm = static_cast<double>(dc) * mm_per_px,
            .dy_mm = static_cast<double>(dr) * mm_per_px};
  }
};

Eigen::Vector2d true_mm(const tacmap::planar_localizer_filter& f, Eigen::Index row,
                        Eigen::Index col) {
  const Eigen::Index cell = row * f.grid().cols() + col;
  const auto s = f.grid().state_mm(cell);
  return {s(0), s(1)};
}

}  // namespace

TEST_CASE("default_tracking: the chosen parameters are valid and turn the floor's path on") {
  constexpr tacmap::tracking_params p = tacmap::default_tracking();
  CHECK_NOTHROW(p.validate());
  CHECK(p.epsilon > 0.0);
  CHECK(p.recheck_every > 0);
  CHECK(std::isfinite(p.doubt));
  static_assert(tacmap::has_uniform_floor<tacmap::robust_motion<tacmap::odometry_gaussian>>);
  static_assert(!tacmap::has_uniform_floor<tacmap::odometry_gaussian>);
  static_assert(
      tacmap::moves_box<tacmap::robust_motion<tacmap::latent_motion<tacmap::odometry_gaussian>>,
                        tacmap::latent_grid<tacmap::planar_grid<float>>>);
  tacmap::tracking_params bad = p;
  bad.recheck_every = -1;
  CHECK_THROWS_AS(bad.validate(), std::invalid_argument);
  bad = p;
  bad.doubt = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_AS(bad.validate(), std::invalid_argument);
  bad = p;
  bad.sample_every = -2;
  CHECK_THROWS_WITH_AS(bad.validate(), doctest::Contains("sample_every = -2"),
                       std::invalid_argument);
  // The localizer tracks by default, with these values; the paper's configuration does not.
  REQUIRE(tacmap::localizer_config{}.tracking.has_value());
  CHECK(tacmap::localizer_config{}.tracking->sample_every == p.sample_every);
  CHECK(p.sample_every > 0);
  CHECK_FALSE(tacmap::localizer_config::paper().tracking.has_value());
}

TEST_CASE("the doubt's sample: every k-th row of every layer, outside the support") {
  std::vector<tacmap::state_range> rows;
  // 5 rows x 4 columns, 2 layers, every 2nd row from row 1: rows 1 and 3 of each layer.
  tacmap::detail::sample_rows(5, 4, 2, 2, 1, rows);
  CHECK(rows == std::vector<tacmap::state_range>{{4, 8}, {12, 16}, {24, 28}, {32, 36}});
  // The offset wraps; every = 0 samples nothing.
  tacmap::detail::sample_rows(5, 4, 1, 2, 3, rows);
  CHECK(rows == std::vector<tacmap::state_range>{{4, 8}, {12, 16}});
  tacmap::detail::sample_rows(5, 4, 1, 0, 0, rows);
  CHECK(rows.empty());
  // max_layers at or above the layers: the same rule.
  tacmap::detail::sample_rows(5, 4, 2, 2, 1, rows, 2);
  CHECK(rows == std::vector<tacmap::state_range>{{4, 8}, {12, 16}, {24, 28}, {32, 36}});
  // Less the support: ranges cut where the support overlaps them, kept whole elsewhere.
  const std::vector<tacmap::state_range> sample{{0, 10}, {20, 30}, {40, 50}};
  const std::vector<tacmap::state_range> support{{5, 7}, {9, 22}, {28, 31}, {60, 70}};
  std::vector<tacmap::state_range> out;
  tacmap::detail::ranges_minus(sample, support, out);
  CHECK(out == std::vector<tacmap::state_range>{{0, 5}, {7, 9}, {22, 28}, {40, 50}});
  // The union of the support and the sample outside it: sorted, touching ranges joined.
  std::vector<tacmap::state_range> both;
  tacmap::detail::ranges_union(support, out, both);
  CHECK(both == std::vector<tacmap::state_range>{{0, 31}, {40, 50}, {60, 70}});
}

TEST_CASE("the doubt's sample over many layers: one heading of each block a touch, all in turn") {
  // 36 headings x 2 appearance blocks of 7 rows x 5 columns, every 2nd row, at most 2 layers'
  // worth: k = 36, so each touch samples layers c and c + 36 (heading c of both blocks), rows
  // r = first (mod 2): the number of states 2 layers would give. The next touch takes the next
  // heading; after 36 touches the next row. Over 72 touches every row of every layer is sampled
  // exactly once.
  const Eigen::Index rows = 7, cols = 5, layers = 72, every = 2;
  std::vector<tacmap::state_range> sample;
  std::vector<int> seen(static_cast<std::size_t>(layers * rows), 0);
  for (Eigen::Index touch = 0; touch < 72; ++touch) {
    CAPTURE(touch);
    tacmap::detail::sample_rows(rows, cols, layers, every, touch, sample, 2);
    const Eigen::Index heading = touch % 36, first = touch / 36;
    std::vector<tacmap::state_range> want;
    for (const Eigen::Index a : {heading, heading + 36})
      for (Eigen::Index r = first; r < rows; r += every)
        want.push_back({(a * rows + r) * cols, (a * rows + r + 1) * cols});
    REQUIRE(sample == want);  // sorted, disjoint, whole rows
    for (const tacmap::state_range& r : sample) ++seen[static_cast<std::size_t>(r.begin / cols)];
  }
  CHECK(std::all_of(seen.begin(), seen.end(), [](int n) { return n == 1; }));
  // Offsets beyond k every (a long tracked run) and negative ones wrap.
  std::vector<tacmap::state_range> again;
  tacmap::detail::sample_rows(rows, cols, layers, every, 5, sample, 2);
  tacmap::detail::sample_rows(rows, cols, layers, every, 5 + 72 * 1000, again, 2);
  CHECK(sample == again);
  tacmap::detail::sample_rows(rows, cols, layers, every, 5 - 72, again, 2);
  CHECK(sample == again);
  // Layers not a multiple of k: 5 layers at most 2 of them, k = 3: layers 1 and 4.
  tacmap::detail::sample_rows(3, 2, 5, 1, 1, sample, 2);
  CHECK(sample ==
        std::vector<tacmap::state_range>{{6, 8}, {8, 10}, {10, 12}, {24, 26}, {26, 28}, {28, 30}});
  // Bad sample_layers is refused, naming it.
  tacmap::tracking_params bad = tacmap::default_tracking();
  bad.sample_layers = -1;
  CHECK_THROWS_WITH_AS(bad.validate(), doctest::Contains("sample_layers = -1"),
                       std::invalid_argument);
  CHECK(tacmap::default_tracking().sample_layers == 2);
}

TEST_CASE("the default motion's windowed predict moves a box as its whole-grid predict does") {
  // A belief whose mass is all inside one box: predict_boxes (base move, the appearance switch
  // on the landed window, the wide blur on it grown by its reach) must give, renormalised, what
  // the whole grid's predict gives less its floor — float rounding apart.
  auto f = default_filter();
  const auto& grid = f.grid();
  const Eigen::Index rows = grid.rows(), cols = grid.cols(), n = grid.hypothesis_size();
  const tacmap::grid_box box{30, 40, 5, 7};
  tacmap::belief_array<tacmap::latent_grid<tacmap::planar_grid<float>>> b(grid.size());
  b.setZero();
  for (Eigen::Index h = 0; h < 2; ++h)
    for (Eigen::Index r = box.row; r < box.row + box.rows; ++r)
      for (Eigen::Index c = box.col; c < box.col + box.cols; ++c)
        b(h * n + r * cols + c) =
            static_cast<float>((h == 0 ? 3.0 : 1.0) + 0.1 * static_cast<double>(r + 2 * c));
  b /= b.sum();
  const tacmap::odometry u{.dx_mm = 2.6, .dy_mm = -1.7};
  // Without the floor, so that the whole grid's prediction has no uniform part to subtract.
  const tacmap::robust_motion motion(
      f.motion().base(), {.lost_probability = 0.0, .wide_probability = 0.1, .wide_sigma_mm = 3.0});
  decltype(b) whole(grid.size());
  motion.predict(grid, b, whole, u);
  auto moved = b;
  std::vector<tacmap::grid_box> landed;
  double dropped = -1.0;
  REQUIRE(motion.predict_boxes(grid, moved, std::span<const tacmap::grid_box>(&box, 1), u, landed,
                               dropped));
  CHECK(dropped == doctest::Approx(0.0).epsilon(1e-6));
  REQUIRE(landed.size() == 1);
  // Every state the mass reached is inside the landed window.
  double inside = 0.0;
  for (Eigen::Index h = 0; h < 2; ++h)
    for (Eigen::Index r = landed[0].row; r < landed[0].row + landed[0].rows; ++r)
      for (Eigen::Index c = landed[0].col; c < landed[0].col + landed[0].cols; ++c)
        inside += static_cast<double>(moved(h * n + r * cols + c));
  CHECK(inside == doctest::Approx(static_cast<double>(moved.sum())).epsilon(1e-6));
  moved /= moved.sum();
  CHECK(total_variation(moved, whole) <= 1e-5);
  // The switch moved mass between the hypotheses as the whole grid's predict does.
  CHECK(static_cast<double>(moved.head(n).sum()) ==
        doctest::Approx(static_cast<double>(whole.head(n).sum())).epsilon(1e-5));
  // The floor is the caller's: uniform_floor reports it, predict_boxes never adds it.
  CHECK(f.motion().uniform_floor() == tacmap::localizer_config::default_lost_probability);
  CHECK(rows > 0);
}

TEST_CASE("the default pose motion's windowed predict moves a box as its whole-grid predict does") {
  // 36 headings and both appearances: the turn carries each heading layer's window into its
  // neighbours, the switch mixes the hypotheses' blocks, the blur spreads every plane.
  tacmap::localizer_config config;
  config.headings = 36;
  const auto f = tacmap::make_pose_filter(config, test_map(), mm_per_px, window);
  const auto& grid = f.grid();
  const Eigen::Index cols = grid.cols(), plane = grid.rows() * cols, n = grid.hypothesis_size();
  const tacmap::grid_box box{25, 50, 4, 6};
  tacmap::belief_array<tacmap::latent_grid<tacmap::pose_grid<float>>> b(grid.size());
  b.setZero();
  for (Eigen::Index h = 0; h < 2; ++h)
    for (Eigen::Index a = 0; a < 36; a += 5)
      for (Eigen::Index r = box.row; r < box.row + box.rows; ++r)
        for (Eigen::Index c = box.col; c < box.col + box.cols; ++c)
          b(h * n + a * plane + r * cols + c) =
              static_cast<float>((h == 0 ? 2.0 : 1.0) + 0.1 * static_cast<double>(a + r + c));
  b /= b.sum();
  const tacmap::sensor_odometry u{.du_mm = 2.2, .dv_mm = 1.3, .dtheta_rad = 0.12};
  const tacmap::robust_motion motion(
      f.motion().base(), {.lost_probability = 0.0, .wide_probability = 0.1, .wide_sigma_mm = 3.0});
  decltype(b) whole(grid.size());
  motion.predict(grid, b, whole, u);
  auto moved = b;
  std::vector<tacmap::grid_box> landed;
  double dropped = -1.0;
  REQUIRE(motion.predict_boxes(grid, moved, std::span<const tacmap::grid_box>(&box, 1), u, landed,
                               dropped));
  CHECK(dropped == doctest::Approx(0.0).epsilon(1e-6));
  moved /= moved.sum();
  CHECK(total_variation(moved, whole) <= 1e-5);
  CHECK(static_cast<double>(moved.head(n).sum()) ==
        doctest::Approx(static_cast<double>(whole.head(n).sum())).epsilon(1e-5));
}

TEST_CASE("the default filter tracks once localized, within its estimate of the full update") {
  auto full = default_filter();
  walk w;
  for (int k = 0; k < 3; ++k) {
    full.predict(w.next());
    full.update(touch_at(w.row, w.col, static_cast<unsigned>(k + 1)));
  }
  REQUIRE((full.estimate().map_mm.head<2>() - true_mm(full, w.row, w.col)).norm() < 3.0);
  // Each step from the same belief: the tracked update against the full one (the tracked
  // copy's whole-grid predict carries the floor on every state; its update keeps the floor's
  // states as they are, its share estimated against the last whole-grid update).
  int tracked_steps = 0;
  for (int step = 0; step < 8; ++step) {
    CAPTURE(step);
    auto tracked = full;
    tracked.set_tracking(tacmap::default_tracking());
    const tacmap::odometry u = w.next();
    tracked.predict(u);
    full.predict(u);
    const auto z = touch_at(w.row, w.col, static_cast<unsigned>(step + 20));
    const tacmap::update_report rt = tracked.update(z);
    const tacmap::update_report rf = full.update(z);
    CHECK(rf.path == update_path::full);
    if (rt.path != update_path::tracked) {
      CHECK(total_variation(tracked.belief(), full.belief()) == 0.0);
      continue;
    }
    ++tracked_steps;
    CHECK(rt.evaluated_states < full.grid().size() / 4);
    const double tv = total_variation(tracked.belief(), full.belief());
    CHECK(tv <= rt.tracking_error_bound + 1e-5);
    // The estimate is about the floor's share: a few lambda while the touch fits.
    CHECK(rt.tracking_error_bound <= 4.0 * tacmap::localizer_config::default_lost_probability);
    CHECK(rt.log_prediction_support == doctest::Approx(rf.log_prediction_support).epsilon(0.2));
    const auto et = tracked.estimate(), ef = full.estimate();
    CHECK(et.map_index == ef.map_index);
    // The verdict's probability moves by no more than the posteriors differ.
    const auto ct = tacmap::assess(tracked, et), cf = tacmap::assess(full, ef);
    CHECK(std::abs(ct.probability_within - cf.probability_within) <= tv + 1e-5);
    CHECK(ct.verdict == cf.verdict);
    CHECK(tracked.belief().template cast<double>().sum() == doctest::Approx(1.0).epsilon(1e-5));
  }
  CHECK(tracked_steps >= 6);
}

TEST_CASE(
    "the default filter tracking along a walk stays with the full filter, predicts windowed") {
  auto full = default_filter();
  walk w;
  for (int k = 0; k < 3; ++k) {
    full.predict(w.next());
    full.update(touch_at(w.row, w.col, static_cast<unsigned>(k + 1)));
  }
  auto tracked = full;
  tracked.set_tracking(tacmap::default_tracking());
  int tracked_steps = 0, windowed = 0, rechecks = 0;
  // Two re-check periods.
  const int steps = 2 * (tacmap::default_tracking().recheck_every + 1);
  for (int step = 0; step < steps; ++step) {
    CAPTURE(step);
    const tacmap::odometry u = w.next();
    windowed += tracked.predict(u).windowed ? 1 : 0;
    full.predict(u);
    const auto z = touch_at(w.row, w.col, static_cast<unsigned>(step + 40));
    const tacmap::update_report rt = tracked.update(z);
    full.update(z);
    tracked_steps += rt.path == update_path::tracked ? 1 : 0;
    rechecks += rt.path == update_path::full_recheck ? 1 : 0;
    // Windowed predicts and tracked updates compound, each within its estimate; the floor's
    // share (lambda = 1e-3 on every state's prediction) is what they leave in place.
    CHECK(total_variation(tracked.belief(), full.belief()) <= 0.01);
    const auto et = tracked.estimate(), ef = full.estimate();
    CHECK((et.map_mm - ef.map_mm).norm() <= mm_per_px * 1.5);
    CHECK(std::abs(et.hypothesis_probability[0] - ef.hypothesis_probability[0]) <= 0.01);
    const auto ct = tacmap::assess(tracked, et), cf = tacmap::assess(full, ef);
    CHECK(std::abs(ct.probability_within - cf.probability_within) <= 0.01);
    CHECK(tracked.belief().template cast<double>().sum() == doctest::Approx(1.0).epsilon(1e-5));
  }
  CHECK(tracked_steps >= 16);
  CHECK(windowed >= 12);
  // Every recheck_every tracked touches the whole grid: two periods hold at least two.
  CHECK(rechecks >= 2);
}

TEST_CASE("a kidnap under tracking: the whole grid is checked and the new place found") {
  auto full = default_filter();
  walk w;
  for (int k = 0; k < 3; ++k) {
    full.predict(w.next());
    full.update(touch_at(w.row, w.col, static_cast<unsigned>(k + 1)));
  }
  auto tracked = full;
  tracked.set_tracking(tacmap::default_tracking());
  for (int step = 0; step < 6; ++step) {
    const tacmap::odometry u = w.next();
    tracked.predict(u);
    full.predict(u);
    const auto z = touch_at(w.row, w.col, static_cast<unsigned>(step + 60));
    tracked.update(z);
    full.update(z);
  }
  // Kidnapped: the sensor is put down far away while the odometry says it moved 2 px.
  Eigen::Index row = 10, col = 90;
  int whole_grid = 0, found_tracked = -1, found_full = -1;
  for (int step = 0; step < 12; ++step) {
    CAPTURE(step);
    const tacmap::odometry u{.dx_mm = 2.0 * mm_per_px};
    col += 2;
    tracked.predict(u);
    full.predict(u);
    const auto z = touch_at(row, col, static_cast<unsigned>(step + 80));
    const auto rt = tracked.update(z);
    full.update(z);
    whole_grid += rt.path != update_path::tracked ? 1 : 0;
    const auto truth = true_mm(full, row, col);
    if (found_tracked < 0 &&
        (tracked.estimate().map_mm.head<2>() - truth).norm() <= 3.0 * mm_per_px)
      found_tracked = step;
    if (found_full < 0 && (full.estimate().map_mm.head<2>() - truth).norm() <= 3.0 * mm_per_px)
      found_full = step;
  }
  REQUIRE(found_full >= 0);
  CHECK(whole_grid >= 1);
  // Found as soon as the full filter finds it: the doubt sends the touch to the whole grid,
  // and the floor the windowed predicts left out is put back first (without it the new place
  // started from the last whole-grid posterior's values and the old place was kept).
  REQUIRE(found_tracked >= 0);
  CHECK(found_tracked <= found_full);
  CHECK((tracked.estimate().map_mm - full.estimate().map_mm).norm() <= mm_per_px * 1.5);
}

TEST_CASE("a whole-grid update after windowed predicts puts the floor back first") {
  // Tracked along a walk (windowed predicts), then a touch that the doubt sends to the whole
  // grid: the belief it starts from is (1 - lambda) b + lambda / N, as the whole grid's predict
  // would have left it, so the posterior agrees with the full filter's far from the old place.
  auto full = default_filter();
  walk w;
  for (int k = 0; k < 3; ++k) {
    full.predict(w.next());
    full.update(touch_at(w.row, w.col, static_cast<unsigned>(k + 1)));
  }
  auto tracked = full;
  tracked.set_tracking(tacmap::default_tracking());
  int windowed = 0;
  for (int step = 0; step < 4; ++step) {
    const tacmap::odometry u = w.next();
    windowed += tracked.predict(u).windowed ? 1 : 0;
    full.predict(u);
    const auto z = touch_at(w.row, w.col, static_cast<unsigned>(step + 90));
    CHECK(tracked.update(z).path == update_path::tracked);
    full.update(z);
  }
  REQUIRE(windowed >= 3);
  const tacmap::odometry u = w.next();
  REQUIRE(tracked.predict(u).windowed);
  full.predict(u);
  // The reference: an untracked filter whose prediction is the windowed one with the floor
  // put back, (1 - lambda) b + lambda / N.
  auto reference = full;
  const double lambda = tacmap::localizer_config::default_lost_probability;
  const auto n = static_cast<double>(tracked.grid().size());
  reference.set_prior((tracked.belief().template cast<double>() * (1.0 - lambda) + lambda / n)
                          .template cast<float>());
  // Far from the walk: the doubt fires.
  const auto z = touch_at(10, 110, 95);
  const auto rt = tracked.update(z);
  full.update(z);
  reference.update(z);
  REQUIRE(rt.path == update_path::full_contradicted);
  CHECK(total_variation(tracked.belief(), reference.belief()) <= 1e-5);
  // Without the floor put back the new place started from the last whole-grid posterior's
  // values; with it, its mass is the full filter's, up to what tracking left elsewhere.
  const Eigen::Index cell = 10 * full.grid().cols() + 110;
  const double p_tracked = static_cast<double>(tracked.belief()(cell));
  const double p_full = static_cast<double>(full.belief()(cell));
  REQUIRE(p_full > 0.0);
  CHECK(p_tracked / p_full == doctest::Approx(1.0).epsilon(0.5));
  CHECK(total_variation(tracked.belief(), full.belief()) <= 0.1);
}

}  // namespace test_default_tracking
