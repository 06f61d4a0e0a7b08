// Tracking mode over (x, y, theta) (issue 14, item 3): rotated_descriptor_likelihood's hook
// against its full log-likelihood, and a pose filter's tracked update against its full update.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "pose_test_support.hpp"
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/grid/pose_grid.hpp"
#include "tacmap/localizer.hpp"
#include "tacmap/measurement/rotated_descriptor_likelihood.hpp"
#include "tacmap/motion/pose_odometry_gaussian.hpp"
#include "tacmap/sim/tactile_simulator.hpp"
#include "tacmap/testing/conformance.hpp"
#include "test_support.hpp"

namespace test_pose_tracking {

using tacmap::state_range;
using tacmap::update_path;
using pose_grid_t = tacmap::pose_grid<float>;

static_assert(tacmap::measures_on_states<tacmap::rotated_descriptor_likelihood<tacmap::sift_lite>,
                                         pose_grid_t>);
static_assert(tacmap::measures_on_states<
              tacmap::rotated_descriptor_likelihood<tacmap::classic_sift>, pose_grid_t>);

namespace {

// The paper's window and scale on a 64 x 64 px textured map (as test_rotated_descriptor_
// likelihood.cpp): 47 x 23 positions per heading; near the left and right edges, patches turned
// by about 90 degrees fall off the map (the off-map mean of the file comment).
const tacmap::image<float>& map64() {
  static const tacmap::image<float> map = pose_test::textured_map(64, 64, 5);
  return map;
}
pose_grid_t grid64(int angles) {
  return pose_grid_t(tacmap::planar_grid<float>({.width = 64, .height = 64}, 3.4 / 3.0,
                                                {.width = 18, .height = 42}),
                     angles);
}

// Random sorted disjoint ranges of [0, n), plus the awkward ones: the first and last state,
// single states, ranges across heading boundaries (layer a's last row into layer a + 1).
std::vector<state_range> random_ranges(Eigen::Index n, Eigen::Index plane, std::uint32_t seed) {
  std::uint32_t state = seed * 2654435761U + 99U;
  const auto next = [&state](Eigen::Index bound) {
    state ^= state << 13U;
    state ^= state >> 17U;
    state ^= state << 5U;
    return static_cast<Eigen::Index>(state % static_cast<std::uint32_t>(bound));
  };
  std::vector<state_range> raw = {{0, 1}, {n - 1, n}};
  for (Eigen::Index a = 1 + next(2); a * plane < n; a += 2 + next(5))
    raw.push_back({a * plane - 1 - next(30), a * plane + 1 + next(30)});
  for (int k = 0; k < 12; ++k) {
    const Eigen::Index b = next(n);
    raw.push_back({b, std::min(n, b + (k % 3 == 0 ? 1 : 1 + next(70)))});
  }
  std::sort(raw.begin(), raw.end(),
            [](const state_range& x, const state_range& y) { return x.begin < y.begin; });
  // Disjoint, and not touching (the filter's ranges are maximal runs).
  std::vector<state_range> out;
  for (const state_range& r : raw) {
    if (!out.empty() && r.begin <= out.back().end) {
      out.back().end = std::max(out.back().end, r.end);
      continue;
    }
    out.push_back(r);
  }
  return out;
}

// True when state i (of `grid`) has a patch that falls off the map for `model`.
template <class Model>
bool has_off_map_patch(const Model& model, const pose_grid_t& grid, Eigen::Index i) {
  const Eigen::Index plane = grid.rows() * grid.cols();
  const Eigen::Index a = i / plane;
  const Eigen::Index row = (i % plane) / grid.cols();
  const Eigen::Index col = i % grid.cols();
  const Eigen::Index p = model.descriptor().patch_size();
  for (Eigen::Index m = 0; m < model.patches_per_window(); ++m) {
    const tacmap::grid_cell o = model.patch_offset(a, m);
    if (row + o.row < 0 || col + o.col < 0 || row + o.row + p > map64().rows() ||
        col + o.col + p > map64().cols())
      return true;
  }
  return false;
}

template <class Model>
void check_ranges_bit_for_bit(const Model& model, const pose_grid_t& grid,
                              const tacmap::image<float>& z, std::uint32_t seed) {
  const Eigen::Index n = grid.size();
  Eigen::ArrayXf full(n);
  model.log_likelihood(grid, z, full);
  const auto states = random_ranges(n, grid.rows() * grid.cols(), seed);
  Eigen::ArrayXf part = Eigen::ArrayXf::Constant(n, std::numeric_limits<float>::quiet_NaN());
  model.log_likelihood_on(grid, z, part, states);
  Eigen::Index compared = 0, off_map = 0, crossing = 0;
  for (const state_range& r : states) {
    if (r.begin / (grid.rows() * grid.cols()) != (r.end - 1) / (grid.rows() * grid.cols()))
      ++crossing;
    for (Eigen::Index i = r.begin; i < r.end; ++i) {
      if (!(part(i) == full(i))) {
        FAIL_CHECK(std::setprecision(9)
                   << "state " << i << " (layer " << i / (grid.rows() * grid.cols())
                   << "): log_likelihood_on wrote " << part(i) << ", log_likelihood wrote "
                   << full(i));
        return;
      }
      ++compared;
      if (has_off_map_patch(model, grid, i)) ++off_map;
    }
  }
  CHECK(compared > 40);
  CHECK(crossing >= 3);  // the test exercises ranges across heading boundaries
  CHECK(off_map > 0);    // ... and poses whose turned patch leaves the map
}

// The tracking filters' scenario: a 36-heading classic SIFT filter on map64 and a sensor
// walking on the map, localized with two full updates at its start.
struct walking_sensor {
  using model_t = tacmap::rotated_descriptor_likelihood<tacmap::classic_sift>;
  pose_grid_t grid = grid64(36);
  double theta = 1.0;  // rad; the sensor's true heading
  double cx = 31.0;    // sensor centre, map px
  double cy = 30.0;

  [[nodiscard]] tacmap::image<float> touch() const {
    return pose_test::render(map64(), cx, cy, theta, grid.window_size());
  }
  [[nodiscard]] auto localized_filter() const {
    tacmap::bayes_filter f(grid, tacmap::pose_odometry_gaussian({.sigma_mm = 0.4}),
                           model_t(tacmap::classic_sift{}, map64(), grid));
    f.update(touch());
    f.update(touch());
    return f;
  }
  // Step `step` of the walk (sensor frame, px; a turn of `turn` rad at step 3): moves the sensor
  // and returns the odometry in mm.
  tacmap::sensor_odometry walk(int step, double turn) {
    const double du = step % 2 == 0 ? 2.0 : -1.0;
    const double dv = step % 3 == 0 ? 1.0 : -2.0;
    const double dtheta = step == 3 ? turn : 0.0;
    cx += std::cos(theta) * du - std::sin(theta) * dv;
    cy += std::sin(theta) * du + std::cos(theta) * dv;
    theta += dtheta;
    const double mm = grid.mm_per_px();
    return {.du_mm = du * mm, .dv_mm = dv * mm, .dtheta_rad = dtheta};
  }
};

}  // namespace

TEST_CASE_TEMPLATE("the rotated model's tracking hook writes its full log-likelihood, bit for bit",
                   D, tacmap::sift_lite, tacmap::classic_sift) {
  const pose_grid_t grid = grid64(36);
  const tacmap::image<float> z = pose_test::render(map64(), 30.0, 27.0, 1.1, grid.window_size());
  struct named {
    const char* name;
    tacmap::rotated_likelihood_params p;
  };
  const std::vector<named> configs = {
      {"aligned, exponential (default)", {}},
      {"all pairs, exponential", {.pairs = tacmap::pairing::all_pairs}},
      {"aligned, inverse", {.shape = tacmap::likelihood_shape::inverse}},
      {"paper: all pairs, inverse",
       {.pairs = tacmap::pairing::all_pairs, .shape = tacmap::likelihood_shape::inverse}},
      {"tempering 0.5, tau 0.3", {.tau = 0.3, .tempering = 0.5}},
      {"tempering 0 (flat)", {.tempering = 0.0}},
      {"spacing 4 (more patches)", {.spacing = 4}},
      // Off-map means exact (maps up to off_map_exact_positions; none by default), and over a
      // sparser lattice than the default's.
      {"exact off-map means, aligned", {.off_map_exact_positions = 1 << 20}},
      {"exact off-map means, all pairs",
       {.pairs = tacmap::pairing::all_pairs, .off_map_exact_positions = 1 << 20}},
      {"off-map means on a lattice, aligned",
       {.off_map_exact_positions = 0, .off_map_sample = 200}},
      {"off-map means on a lattice, all pairs",
       {.pairs = tacmap::pairing::all_pairs, .off_map_exact_positions = 0, .off_map_sample = 200}},
  };
  std::uint32_t seed = 1;
  for (const auto& c : configs) {
    const std::string name = c.name;
    CAPTURE(name);
    const tacmap::rotated_descriptor_likelihood<D> model(D{}, map64(), grid, c.p);
    check_ranges_bit_for_bit(model, grid, z, seed++);
    tacmap::testing::check_log_likelihood_on(model, grid, z);
  }
}

TEST_CASE("off-map means on a lattice: only poses with a patch off the map change, a little") {
  // The lattice rule (every map of more than off_map_exact_positions field positions: every map
  // by default) against the exact mean on the same map: the same values wherever every patch
  // lands; near the edges, where a turned patch falls off, the lattice's mean estimates the
  // exact one. The default lattice (off_map_sample 512: every 3rd row and column, 256 of this map's
  // 2,209 field positions) and a sparser one (every 4th, 144).
  const pose_grid_t grid = grid64(36);
  const tacmap::image<float> z = pose_test::render(map64(), 30.0, 27.0, 1.1, grid.window_size());
  using model_t = tacmap::rotated_descriptor_likelihood<tacmap::classic_sift>;
  const model_t exact(tacmap::classic_sift{}, map64(), grid, {.off_map_exact_positions = 1 << 20});
  Eigen::ArrayXf de(grid.size()), ds(grid.size());
  exact.distances(grid, z, de);
  for (const Eigen::Index sample : {Eigen::Index{512}, Eigen::Index{200}}) {
    CAPTURE(sample);
    const model_t sampled(tacmap::classic_sift{}, map64(), grid,
                          sample == 512
                              ? tacmap::rotated_likelihood_params{}
                              : tacmap::rotated_likelihood_params{.off_map_exact_positions = 0,
                                                                  .off_map_sample = sample});
    sampled.distances(grid, z, ds);
    Eigen::Index changed = 0;
    for (Eigen::Index i = 0; i < grid.size(); ++i) {
      if (de(i) == ds(i)) continue;
      ++changed;
      // Only a pose with a patch off the map: one patch's mean replaced by an estimate of it,
      // within a few percent of the distance.
      CHECK(has_off_map_patch(sampled, grid, i));
      CHECK(std::abs(ds(i) - de(i)) <= 0.05F * de(i));
    }
    CHECK(changed > 0);                // the rule ran
    CHECK(changed < grid.size() / 2);  // ... only near the edges
  }
  // Bad parameters are refused, naming them.
  CHECK_THROWS_WITH_AS(model_t(tacmap::classic_sift{}, map64(), grid, {.off_map_sample = 0}),
                       doctest::Contains("off_map_sample = 0"), std::invalid_argument);
}

TEST_CASE("the rotated model's hook on 12 headings, a touch that fits one pose exactly") {
  const pose_grid_t g12 = grid64(12);
  const tacmap::rotated_descriptor_likelihood<tacmap::classic_sift> model(tacmap::classic_sift{},
                                                                          map64(), g12);
  const Eigen::Index best = g12.index(3, {11, 20});
  const tacmap::image<float> z = pose_test::render_state(map64(), g12, best);
  check_ranges_bit_for_bit(model, g12, z, 7);
  check_ranges_bit_for_bit(model, g12, z, 8);
  Eigen::ArrayXf part = Eigen::ArrayXf::Constant(g12.size(), NAN);
  Eigen::ArrayXf full(g12.size());
  model.log_likelihood(g12, z, full);
  const std::vector<state_range> one = {{best, best + 1}};
  model.log_likelihood_on(g12, z, part, one);
  CHECK(part(best) == full(best));
  CHECK(part(best) == full.maxCoeff());
}

TEST_CASE("the rotated model's bound holds, also where the touch matches exactly") {
  const pose_grid_t grid = grid64(12);
  const Eigen::Index best = grid.index(2, {10, 22});
  const tacmap::image<float> z = pose_test::render_state(map64(), grid, best);
  for (const auto shape :
       {tacmap::likelihood_shape::exponential, tacmap::likelihood_shape::inverse})
    for (const double epsilon : {1e-3, 1e-6}) {
      const tacmap::rotated_descriptor_likelihood<tacmap::sift_lite> model(
          tacmap::sift_lite{}, map64(), grid, {.shape = shape, .epsilon = epsilon});
      Eigen::ArrayXf full(grid.size());
      model.log_likelihood(grid, z, full);
      const double bound = model.log_likelihood_bound();
      CAPTURE(epsilon);
      CHECK(static_cast<double>(full.maxCoeff()) <= bound);
      if (shape == tacmap::likelihood_shape::exponential) {
        CHECK(bound == 0.0);
      } else {
        // -log(epsilon), a hair higher: tight enough to be useful.
        CHECK(bound == doctest::Approx(-std::log(epsilon)).epsilon(1e-4));
      }
    }
}

TEST_CASE("a tracked pose filter equals its full update within the bound, same MAP state") {
  // 36 headings, classic SIFT; localized with full updates from a prior around the sensor
  // (what a few touches give), then every step compared: tracked against full from the same
  // predicted belief.
  walking_sensor sensor;
  const pose_grid_t& grid = sensor.grid;
  auto full = sensor.localized_filter();
  int tracked_steps = 0;
  for (int step = 0; step < 6; ++step) {
    CAPTURE(step);
    const tacmap::sensor_odometry u = sensor.walk(step, grid.angle_step_rad());
    auto tracked = full;
    tracked.set_tracking({.epsilon = 1e-6});
    tracked.predict(u);
    full.predict(u);
    const auto z = sensor.touch();
    const tacmap::update_report rt = tracked.update(z);
    const tacmap::update_report rf = full.update(z);
    CHECK(rf.path == update_path::full);
    if (rt.path != update_path::tracked) {
      CHECK((tracked.belief() == full.belief()).all());
      continue;
    }
    ++tracked_steps;
    CHECK(rt.evaluated_states < grid.size() / 4);
    CHECK(rt.tracking_error_bound <= tracked.tracking().tolerance);
    const double tv =
        0.5 * (tracked.belief().cast<double>() - full.belief().cast<double>()).abs().sum();
    // The bound, plus float rounding of two normalisations.
    CHECK(tv <= rt.tracking_error_bound + 1e-5);
    CHECK(tracked.estimate().map_index == full.estimate().map_index);
    CHECK(static_cast<double>(tracked.belief().sum()) == doctest::Approx(1.0).epsilon(1e-5));
  }
  CHECK(tracked_steps >= 4);
  // Still where the sensor is.
  const auto e = full.estimate();
  CHECK(std::abs(e.map_mm(0) / grid.mm_per_px() - sensor.cx) <= 2.0);
  CHECK(std::abs(e.map_mm(1) / grid.mm_per_px() - sensor.cy) <= 2.0);
}

TEST_CASE("the default pose filter tracks with a one-heading sample: the whole grid's belief") {
  // The localizer's default (x, y, theta) filter (latent appearance: 72 layers; the robust
  // motion's floor) with default_tracking(): each tracked touch evaluates the support and every
  // 8th row of one heading of each appearance block (sample_layers), the next heading the next
  // touch; the sampled rows span whole layer rows, so at turned headings they hold poses whose
  // patches fall off the map (lattice means). Walked touch by touch beside the same filter
  // untracked: the same MAP state, beliefs within the tracked path's error, and the estimated
  // prediction support (from the sample, each sampled state standing for its share of the
  // outside) near the whole grid's. A sample that stood for the wrong share would be off by
  // log 36 nats.
  walking_sensor sensor;
  const pose_grid_t& grid = sensor.grid;
  tacmap::localizer_config c;
  c.headings = 36;
  REQUIRE(c.tracking_headings);  // on by default
  auto full = tacmap::make_pose_filter(c, map64(), grid.mm_per_px(), grid.window_size());
  (void)full.update(sensor.touch());
  (void)full.update(sensor.touch());
  auto tracked = full;
  tracked.set_tracking(tacmap::default_tracking());
  int tracked_steps = 0;
  for (int step = 0; step < 10; ++step) {
    CAPTURE(step);
    const tacmap::sensor_odometry u = sensor.walk(step, 0.5 * grid.angle_step_rad());
    (void)tracked.predict(u);
    (void)full.predict(u);
    const auto z = sensor.touch();
    const tacmap::update_report rt = tracked.update(z);
    const tacmap::update_report rf = full.update(z);
    CHECK(rf.path == update_path::full);
    CHECK(tracked.estimate().map_index == full.estimate().map_index);
    const double tv =
        0.5 * (tracked.belief().cast<double>() - full.belief().cast<double>()).abs().sum();
    CHECK(tv <= 1e-2);
    if (rt.path != update_path::tracked) continue;
    ++tracked_steps;
    CHECK(rt.evaluated_states < grid.size() / 4);
    CHECK(std::abs(rt.log_prediction_support - rf.log_prediction_support) <= 1.0);
  }
  CHECK(tracked_steps >= 5);
  // The sampled headings after the first (heading 0, then 1, 2, ...) turn a patch off the map
  // at the ends of every row: the sample met the lattice's means.
  const tacmap::rotated_descriptor_likelihood<tacmap::classic_sift> model(tacmap::classic_sift{},
                                                                          map64(), grid);
  const Eigen::Index plane = grid.rows() * grid.cols();
  for (Eigen::Index heading = 1; heading < 3; ++heading)
    for (Eigen::Index row = 0; row < grid.rows(); row += 8)
      CHECK(has_off_map_patch(model, grid, heading * plane + row * grid.cols()));
}

TEST_CASE("a tracked pose filter's windowed predicts stay within their bound of the whole grid's") {
  // One filter tracking touch after touch (predict right after a tracked update moves only the
  // support's box, in every heading layer), each prediction compared with the whole grid's
  // prediction of the same belief, and the filter with a full-grid twin at every update.
  walking_sensor sensor;
  auto tracked = sensor.localized_filter();
  auto full = tracked;
  tracked.set_tracking({.epsilon = 1e-6});
  int windowed = 0;
  for (int step = 0; step < 8; ++step) {
    CAPTURE(step);
    const tacmap::sensor_odometry u = sensor.walk(step, 0.5 * sensor.grid.angle_step_rad());
    auto reference = tracked;
    reference.set_tracking({});  // forgets the support box: the whole grid moves
    reference.predict(u);
    const tacmap::prediction_report pr = tracked.predict(u);
    const double tv_predict =
        0.5 * (tracked.belief().cast<double>() - reference.belief().cast<double>()).abs().sum();
    if (pr.windowed) {
      ++windowed;
      CHECK(pr.tracking_error_bound <= 1e-6 * (1.0 + 1e-4));
      CHECK(tv_predict <= pr.tracking_error_bound + 1e-5);
      CHECK(static_cast<double>(tracked.belief().sum()) == doctest::Approx(1.0).epsilon(1e-5));
    } else {
      CHECK(tv_predict == 0.0);
    }
    full.predict(u);
    const auto z = sensor.touch();
    tracked.update(z);
    full.update(z);
    CHECK(tracked.estimate().map_index == full.estimate().map_index);
    CHECK(0.5 * (tracked.belief().cast<double>() - full.belief().cast<double>()).abs().sum() <=
          1e-2);
  }
  // This scenario's touches contradict the prediction now and then (full updates, rho above
  // the tolerance), after which the next predict moves the whole grid: 3 of 8 are windowed.
  CHECK(windowed >= 3);
}

namespace {
// The per-state reference statistics of `f`'s belief, from a fresh position_statistics (no
// summary, no cache): estimate_per_state, most_probable_disc, heading_probability_within.
template <class Filter>
void check_summary_against_passes(const Filter& f, double tolerance) {
  using G = typename Filter::grid_type;
  const tacmap::detail::position_statistics<G> reference(f.grid());
  const typename tacmap::detail::position_statistics<G>::view_type b(f.belief().data(),
                                                                     f.belief().size());
  const auto ref = reference.estimate_per_state(f.grid(), b);
  const auto got = f.estimate();
  CHECK(got.map_index == ref.map_index);
  CHECK(got.map_probability == ref.map_probability);
  // The mean heading is atan2 of the resultant (sum p sin, sum p cos): where that is ~0 (a
  // belief spread evenly over the headings) it is rounding noise in both, and so is every
  // deviation from it. Compared where the resultant is not small.
  double sum_cos = 0.0, sum_sin = 0.0;
  for (Eigen::Index i = 0; i < f.grid().size(); ++i) {
    const double a = f.grid().state_mm(i)(2);
    sum_cos += static_cast<double>(f.belief()(i)) * std::cos(a);
    sum_sin += static_cast<double>(f.belief()(i)) * std::sin(a);
  }
  const Eigen::Index compared = std::hypot(sum_cos, sum_sin) > 1e-3 ? 3 : 2;
  CHECK((got.mean_mm - ref.mean_mm).head(compared).cwiseAbs().maxCoeff() <= tolerance);
  CHECK((got.covariance_mm2 - ref.covariance_mm2)
            .topLeftCorner(compared, compared)
            .cwiseAbs()
            .maxCoeff() <= tolerance * (1.0 + ref.covariance_mm2.cwiseAbs().maxCoeff()));
  CHECK(got.entropy_nats == doctest::Approx(ref.entropy_nats).epsilon(1e-6));
  REQUIRE(got.hypothesis_probability.size() == ref.hypothesis_probability.size());
  for (std::size_t h = 0; h < ref.hypothesis_probability.size(); ++h)
    CHECK(got.hypothesis_probability[h] == doctest::Approx(ref.hypothesis_probability[h]));
  const auto disc = f.most_probable_disc(5.0);
  const auto ref_disc = reference.most_probable_disc(f.grid(), b, 5.0);
  CHECK(disc.first == ref_disc.first);  // the same marginal, summed in the same order
  CHECK(disc.second == ref_disc.second);
  for (const double tol : {0.05, 0.2, 1.0}) {
    const double heading = ref.map_mm(2);
    CHECK(f.heading_probability_within(heading, tol) ==
          doctest::Approx(reference.heading_probability_within(b, heading, tol)).epsilon(1e-9));
  }
}
}  // namespace

TEST_CASE("a pose filter's estimate and verdict from its row summary equal the per-state passes") {
  // The filter keeps a summary of its belief row by row and recomputes only the rows a tracked
  // touch changed (position_statistics::summarises): after every predict and update of a
  // tracking walk (windowed predicts, tracked updates, full ones), compared with the per-state
  // passes over the whole belief. A row the filter failed to mark as changed would keep its
  // old sums, and the mean, MAP or disc would drift from the reference.
  walking_sensor sensor;
  auto f = sensor.localized_filter();
  f.set_tracking({.epsilon = 1e-6});
  check_summary_against_passes(f, 1e-9);
  int windowed = 0, tracked = 0;
  for (int step = 0; step < 8; ++step) {
    CAPTURE(step);
    windowed += f.predict(sensor.walk(step, 0.5 * sensor.grid.angle_step_rad())).windowed ? 1 : 0;
    check_summary_against_passes(f, 1e-9);
    tracked += f.update(sensor.touch()).path == update_path::tracked ? 1 : 0;
    check_summary_against_passes(f, 1e-9);
  }
  CHECK(windowed >= 3);
  CHECK(tracked >= 3);
  // A prior that is not one peak: spread over the whole grid, half on one heading.
  Eigen::ArrayXf prior = Eigen::ArrayXf::LinSpaced(f.grid().size(), 1.0F, 2.0F);
  prior.head(f.grid().rows() * f.grid().cols()) *= 40.0F;
  f.set_prior(prior);
  check_summary_against_passes(f, 1e-9);
  f.reset();
  check_summary_against_passes(f, 1e-9);
}

TEST_CASE("a summary refreshed where cells changed equals one computed afresh, bit for bit") {
  // position_statistics::refresh recomputes only the rows a change touched (changed_cells).
  // After random boxes of a latent pose belief change (each marked, in every layer, as the
  // filter marks it), the refreshed summary's statistics must equal those of a summary computed
  // from scratch exactly: a touched row left out, or a figure that depended on what was there
  // before, would keep a stale value. A wide map and a narrow one; boxes of a few columns and,
  // in the last round, up to the whole row.
  for (const int width : {190, 60}) {
    CAPTURE(width);
    const tacmap::latent_grid<pose_grid_t> grid(
        pose_grid_t(tacmap::planar_grid<float>({.width = width, .height = 64}, 3.4 / 3.0,
                                               {.width = 18, .height = 42}),
                    6),
        {"as_photographed", "inverted"});
    using G = std::decay_t<decltype(grid)>;
    const Eigen::Index n = grid.size(), rows = grid.rows(), cols = grid.cols();
    const Eigen::Index plane = rows * cols, layers = grid.hypothesis_size() / plane * 2;
    tacmap_test::lcg next(12345U);
    Eigen::ArrayXf b(n);
    for (Eigen::Index i = 0; i < n; ++i) b(i) = 1e-3F + static_cast<float>(next(1000)) * 1e-6F;
    b /= b.sum();
    const tacmap::detail::position_statistics<G> kept(grid);
    REQUIRE(kept.summarises());
    tacmap::detail::changed_cells changed(rows, cols);
    kept.refresh(grid, {b.data(), n}, changed);  // the first refresh: everything
    changed.clear();
    for (int round = 0; round < 6; ++round) {
      CAPTURE(round);
      for (int box = 0; box < 3; ++box) {
        const tacmap::grid_box g{.row = next(rows),
                                 .col = next(cols),
                                 .rows = 1 + next(6),
                                 .cols = 1 + next(round == 5 ? cols : 12)};
        changed.mark(g);
        for (Eigen::Index l = 0; l < layers; ++l)
          for (Eigen::Index r = g.row; r < std::min(rows, g.row + g.rows); ++r)
            for (Eigen::Index c = g.col; c < std::min(cols, g.col + g.cols); ++c)
              b(l * plane + r * cols + c) *= 0.1F * static_cast<float>(1 + next(20 + round * 4));
      }
      // Not renormalised: a renormalisation changes every cell (the filter's tracked update
      // scales only the states it marks); the statistics take unnormalised beliefs.
      kept.refresh(grid, {b.data(), n}, changed);
      changed.clear();
      const tacmap::detail::position_statistics<G> fresh(grid);
      tacmap::detail::changed_cells everything(rows, cols);
      fresh.refresh(grid, {b.data(), n}, everything);
      const auto got = kept.estimate_summarised(grid);
      const auto ref = fresh.estimate_summarised(grid);
      CHECK(got.map_index == ref.map_index);
      CHECK(got.mean_mm == ref.mean_mm);
      CHECK(got.covariance_mm2 == ref.covariance_mm2);
      CHECK(got.entropy_nats == ref.entropy_nats);
      CHECK(got.hypothesis_probability == ref.hypothesis_probability);
      CHECK(kept.most_probable_disc_summarised(grid, 5.0) ==
            fresh.most_probable_disc_summarised(grid, 5.0));
      // And the summary against the per-state passes (its figures, not only its refresh).
      const typename tacmap::detail::position_statistics<G>::view_type v(b.data(), n);
      const auto per_state = fresh.estimate_per_state(grid, v);
      CHECK(got.map_index == per_state.map_index);
      CHECK((got.mean_mm - per_state.mean_mm).head(2).cwiseAbs().maxCoeff() <= 1e-9 * 100.0);
      CHECK(got.entropy_nats == doctest::Approx(per_state.entropy_nats).epsilon(1e-6));
    }
  }
}

TEST_CASE("a pose grid's statistics from one layer's coordinates: each state's own coordinates") {
  // position_statistics keeps a pose grid's first layer of positions and one angle per layer
  // (every layer repeats the positions by construction). Its per-state statistics must be those
  // of every state's own coordinates (grid.state_mm): the mass within a disc, the mass within
  // a heading tolerance, the mean position — summed here state by state from state_mm. An
  // offset taken from the wrong layer or position would move them.
  const tacmap::latent_grid<pose_grid_t> grid(grid64(12), {"as_photographed", "inverted"});
  using G = std::decay_t<decltype(grid)>;
  const Eigen::Index n = grid.size();
  Eigen::ArrayXf b(n);
  for (Eigen::Index i = 0; i < n; ++i)
    b(i) = std::exp(-0.002F * static_cast<float>((i * 7919) % 4001)) *
           (1.0F + static_cast<float>((i / (grid.rows() * grid.cols())) % 5));
  b /= b.sum();
  const tacmap::detail::position_statistics<G> stats(grid);
  const typename tacmap::detail::position_statistics<G>::view_type v(b.data(), n);
  const Eigen::Vector2d centre(20.0, 30.0);
  double in_disc = 0.0, in_heading = 0.0, mx = 0.0, my = 0.0, mass = 0.0;
  const double heading = grid.state_mm(5 * grid.rows() * grid.cols())(2);
  // The mean as estimate sums it: the origin plus the belief-weighted offsets from it.
  const auto origin = grid.state_mm(0);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto s = grid.state_mm(i);
    const auto p = static_cast<double>(b(i));
    if ((s.head<2>() - centre).norm() <= 6.0) in_disc += p;
    if (std::abs(tacmap::wrap_angle(s(2) - heading)) <= 0.6) in_heading += p;
    mx += p * (s(0) - origin(0));
    my += p * (s(1) - origin(1));
    mass += p;
  }
  CHECK(stats.probability_within(v, centre, 6.0) == doctest::Approx(in_disc).epsilon(1e-9));
  CHECK(stats.heading_probability_within(v, heading, 0.6) ==
        doctest::Approx(in_heading).epsilon(1e-9));
  CHECK(in_heading < 0.5 * mass);  // the tolerance leaves out most headings
  const auto e = stats.estimate_per_state(grid, v);
  CHECK(e.mean_mm(0) == doctest::Approx(origin(0) + mx).epsilon(1e-9));
  CHECK(e.mean_mm(1) == doctest::Approx(origin(1) + my).epsilon(1e-9));
  CHECK(mass == doctest::Approx(1.0).epsilon(1e-6));
}

TEST_CASE("the front door's pose filter, tracking with the motion floor: summary against passes") {
  // The default models (latent appearance: two hypothesis blocks; the robust motion's floor on
  // every state), through tacmap::localizer with tracking: each touch's statistics against the
  // per-state passes over the filter's belief.
  tacmap::localizer_config c;
  c.headings = 12;
  c.tracking = tacmap::default_tracking();
  c.tracking_headings = true;  // off by default with headings
  const double mm_per_px = 3.4 / 3.0;
  tacmap::localizer loc(map64(), mm_per_px, c);
  tacmap::tactile_simulator sim(map64() * 4.0F, {.width = 64, .height = 64}, mm_per_px,
                                {.seed = 7});
  REQUIRE(loc.pose_filter() != nullptr);
  // Round a 4 mm square near the map's centre (right, down, left, up).
  constexpr double square[4][2] = {{0.0, 0.0}, {4.0, 0.0}, {4.0, 4.0}, {0.0, 4.0}};
  const double x0 = 30.0, y0 = 32.0;
  for (int step = 0; step < 12; ++step) {
    CAPTURE(step);
    const int k = step % 4, prev = (step + 3) % 4;
    const tacmap::tactile_frame frame =
        sim.render({.x_mm = x0 + square[k][0], .y_mm = y0 + square[k][1]});
    const tacmap::touch_result r =
        step == 0
            ? loc.touch(frame)
            : loc.touch(frame, tacmap::sensor_odometry{.du_mm = square[k][0] - square[prev][0],
                                                       .dv_mm = square[k][1] - square[prev][1]});
    const auto& f = *loc.pose_filter();
    check_summary_against_passes(f, 1e-9);
    // The verdict's figure is the reference's.
    using G = typename std::decay_t<decltype(f)>::grid_type;
    const tacmap::detail::position_statistics<G> reference(f.grid());
    const auto ref_disc = reference.most_probable_disc(
        f.grid(), {f.belief().data(), f.belief().size()}, tacmap::confidence_params{}.radius_mm);
    CHECK(r.probability_within == ref_disc.second);
  }
}

TEST_CASE("saving a tracking pose filter again copies only what changed, bit for bit") {
  // save_state into the same saved state copies only the cells changed since the previous save
  // (a tracked touch: the boxes its windowed predict and tracked update wrote). After every
  // save, the saved belief must equal the belief bit for bit; restoring after a predict and an
  // update must give the saved belief back bit for bit. A cell the filter failed to mark would
  // keep the saved state's older value.
  walking_sensor sensor;
  auto f = sensor.localized_filter();
  f.set_tracking({.epsilon = 1e-6});
  typename decltype(f)::saved_state saved;
  int windowed = 0;
  for (int step = 0; step < 10; ++step) {
    CAPTURE(step);
    f.save_state(saved);
    const Eigen::ArrayXf before = f.belief();
    REQUIRE((saved.belief() == before).all());
    const tacmap::sensor_odometry u = sensor.walk(step, 0.5 * sensor.grid.angle_step_rad());
    windowed += f.predict(u).windowed ? 1 : 0;
    (void)f.update(sensor.touch());
    CHECK((saved.belief() == before).all());  // what the slip re-check reads
    if (step % 3 == 2) {
      // A refused touch: back to the saved state, then the same touch again.
      const Eigen::ArrayXf after = f.belief();
      f.restore_state(saved);
      CHECK((f.belief() == before).all());
      f.save_state(saved);  // a whole copy (the restore swapped the buffers)
      CHECK((saved.belief() == before).all());
      (void)f.predict(u);
      (void)f.update(sensor.touch());
      CHECK((f.belief() == after).all());
    }
  }
  CHECK(windowed >= 3);
  // A copy of the filter saving into the same state: a whole copy, still bit for bit.
  auto g = f;
  (void)g.update(sensor.touch());
  g.save_state(saved);
  CHECK((saved.belief() == g.belief()).all());
  f.save_state(saved);
  CHECK((saved.belief() == f.belief()).all());
}

}  // namespace test_pose_tracking
