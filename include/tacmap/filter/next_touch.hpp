// tacmap: choosing where to touch next — candidate moves ranked by what the touch after each is
// expected to decide.
//
// The paper explores in a fixed or random order (Sec. IV); a touch on a flat part of the object
// decides nothing, one on a distinctive part may decide everything. `basic_localizer::next_touch`
// and `basic_library_localizer::next_touch` rank candidate moves (relative motions of the
// sensor, map frame, mm) by the belief's own expectation of what the next touch will tell:
//
//  1. K hypotheses from the belief over (object,) position, by systematic resampling (no random
//     numbers: the same belief ranks the same way), duplicates merged with their counts as
//     weights w_i. K = `next_touch_params::hypotheses`.
//  2. For a move u, hypothesis i's sensor lands at x_i + u. Those on the map get the touch a
//     noiseless sensor would read there: the map's prepared descriptors of that window (the
//     measurement model's `window_descriptors` hook). Those off the map would have their frame
//     rejected: the touch tells nothing (their share is 1 - P_on).
//  3. The model's own log-likelihood of each predicted touch z_a at every landed hypothesis b
//     (`predicted_log_likelihoods`, eq. (1)-(2) with the model's tau and tempering), times
//     `likelihood_scale` s, gives the posterior over the hypotheses had z_a been read:
//     q_a(b) ∝ w_b p(z_a | x_b + u)^s.
//  4. The objective (`next_touch_objective`), w restricted to the landed hypotheses and
//     renormalised:
//       verdict: sum_a w_a P_r(q_a) — the expected probability that the verdict's disc of
//                `confidence_params::radius_mm` holds the truth after the touch, P_r(q) = max
//                over hypotheses c of the mass of q within the radius of c (default);
//       entropy: H(w) - sum_a w_a H(q_a) — the expected entropy reduction, nats.
//     Given that the touch lands on the object (the candidates are reachable places on it);
//     `weigh_by_landing` weighs by P_on instead, the rest of the mass telling nothing.
//
// Why the verdict and s = 0.3 by default, measured (tacmap-evaluate --touch-order active,
// docs/tools.md; harsh scenario, gecko and horse): the entropy objective rewards telling apart
// every one of 64 scattered hypotheses, which the camera's texture seems to allow anywhere,
// and took the sensor to places the relief does not back (6 of 44 localized by touch 3, the
// random order 18); the verdict asks only that one disc hold the mass. A noiseless prediction
// (s = 1) trusts a touch beside the previous one to tell what the previous could not, though
// both misread alike (9 of 44 even with the candidates kept 20 mm away); s = 0.3: 26 of 44.
//
// What it leaves out, knowingly: the motion noise between touches (the hypotheses move exactly
// by u), the sensor's noise (the predicted touch is the map's own window, so the scores are
// optimistic alike for every move), and the appearance hypotheses (a noiseless touch has the
// map's sign under either, and the model's distances do not change when both sides invert).
// Known heading only.
//
// Cost: one matrix product of K x K descriptor pairs per move (whole-matrix, Eigen), no pass
// over the grid: 100 moves on the paper's grid in about 5-6 ms of CPU (bench/next_touch_bench).
#pragma once

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <limits>
#include <numeric>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/image.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"

namespace tacmap {

/// What `next_touch` ranks moves by (see the file comment).
enum class next_touch_objective {
  entropy,  ///< expected reduction of the belief's entropy, nats
  verdict,  ///< expected probability within the verdict's radius after the touch (default)
};

[[nodiscard]] inline const char* to_string(next_touch_objective o) {
  return o == next_touch_objective::entropy ? "entropy" : "verdict";
}

/// Configuration of `next_touch`.
struct next_touch_params {
  /// Hypotheses drawn from the belief (K): the cost grows as K^2 per move. 64: on the paper's
  /// grid 100 moves rank in about 5-6 ms of CPU (bench/next_touch_bench.cpp).
  int hypotheses = 64;
  /// What to maximise. `verdict`, measured (tacmap-evaluate --touch-order active, harsh
  /// scenario, gecko and horse, seed 1, 44 sequences): localized by touch 3 in 26 against 6
  /// with `entropy` (random order: 18).
  next_touch_objective objective = next_touch_objective::verdict;
  /// Scores within this of each other (nats, or probability for `verdict`) make the candidates
  /// "equally uninformative" (`next_touch_ranking::uninformative`).
  double tolerance = 1e-3;
  /// Hypotheses a move would carry off the map: false (default) scores each move given that the
  /// touch lands on the object (the candidates are reachable places on it: those hypotheses
  /// are left out, the rest renormalised); true weighs the score by the belief's probability
  /// P_on that it lands, the rest of the mass telling nothing (a rejected frame).
  bool weigh_by_landing = false;
  /// A factor on the predicted log-likelihoods, in (0, 1]: below 1 the predicted touches decide
  /// less than a noiseless sensor's would (a real touch is noisy, and the photograph is not the
  /// relief), so that a move is not chosen for differences between windows that a real touch
  /// would not see.
  /// 0.3, measured as `objective`: by touch 3 26 of 44 (1: 9 with candidates kept 20 mm from
  /// the previous touch, 3 without; 0.1: 22).
  double likelihood_scale = 0.3;

  void validate() const {
    if (hypotheses < 1 || hypotheses > 4096)
      detail::fail("next_touch_params: hypotheses = ", hypotheses,
                   "; expected 1 to 4096 hypotheses drawn from the belief (the default is 64; the "
                   "cost grows as its square)");
    if (!(likelihood_scale > 0.0 && likelihood_scale <= 1.0))
      detail::fail("next_touch_params: likelihood_scale = ", likelihood_scale,
                   "; expected a factor in (0, 1] on the predicted log-likelihoods (1: the "
                   "model's own)");
    if (!(std::isfinite(tolerance) && tolerance >= 0.0))
      detail::fail("next_touch_params: tolerance = ", tolerance,
                   "; expected a finite score difference >= 0 (the default is 1e-3)");
  }
};

/// A rectangle of moves the arm can make (relative to where the sensor is now, map frame, mm),
/// sampled on a lattice of `step_mm`: `candidates()` lists them row by row (y, then x), the
/// move (0, 0) included when the rectangle holds it.
struct touch_region {
  double x_min_mm = 0.0;
  double x_max_mm = 0.0;
  double y_min_mm = 0.0;
  double y_max_mm = 0.0;
  double step_mm = 1.0;

  [[nodiscard]] std::vector<odometry> candidates() const {
    const double v[] = {x_min_mm, x_max_mm, y_min_mm, y_max_mm};
    for (const double x : v)
      if (!std::isfinite(x))
        detail::fail("touch_region: the rectangle (", x_min_mm, " .. ", x_max_mm, ", ", y_min_mm,
                     " .. ", y_max_mm, ") mm is not finite; expected finite millimetres");
    if (x_min_mm > x_max_mm || y_min_mm > y_max_mm)
      detail::fail("touch_region: x ", x_min_mm, " .. ", x_max_mm, " mm, y ", y_min_mm, " .. ",
                   y_max_mm, " mm; expected min <= max on both axes");
    if (!(std::isfinite(step_mm) && step_mm > 0.0))
      detail::fail("touch_region: step_mm = ", step_mm,
                   "; expected a finite lattice step > 0 mm (e.g. the map's mm per px)");
    const double nx = std::floor((x_max_mm - x_min_mm) / step_mm + 1e-9) + 1.0;
    const double ny = std::floor((y_max_mm - y_min_mm) / step_mm + 1e-9) + 1.0;
    if (nx * ny > 1e6)
      detail::fail("touch_region: ", nx, " x ", ny, " lattice points at step_mm = ", step_mm,
                   "; expected at most a million candidates — use a larger step");
    std::vector<odometry> out;
    out.reserve(static_cast<std::size_t>(nx * ny));
    for (double j = 0; j < ny; ++j)
      for (double i = 0; i < nx; ++i)
        out.push_back({.dx_mm = x_min_mm + i * step_mm, .dy_mm = y_min_mm + j * step_mm});
    return out;
  }
};

/// What `next_touch` gives: each candidate's score (input order) and the candidates best first.
struct next_touch_ranking {
  std::vector<odometry> candidates;  ///< the moves ranked (input order)
  /// Each candidate's expected value of the touch after it (`objective`; input order).
  std::vector<double> score;
  /// Each candidate's probability, under the belief, that the sensor lands on the map.
  std::vector<double> on_map;
  /// Candidate indices, best first; equal scores keep the input order.
  std::vector<std::size_t> order;
  /// Every score within `next_touch_params::tolerance` of every other: no candidate is expected
  /// to decide more than another (e.g. the belief is already concentrated, or every move lands
  /// on flat parts of the object). `order` is then the input order.
  bool uninformative = false;
  next_touch_objective objective = next_touch_objective::entropy;
  double entropy_nats = 0.0;   ///< the hypotheses' entropy before the touch
  std::size_t hypotheses = 0;  ///< distinct hypotheses drawn from the belief
  [[nodiscard]] std::size_t best() const { return order.front(); }
  [[nodiscard]] const odometry& best_move() const { return candidates[order.front()]; }
};

/// The measurement-model hooks `next_touch` needs (descriptor_likelihood, ncc_likelihood and
/// configured_measurement have them): `m.window_descriptors(states, f)` fills one column per
/// state with what a noiseless touch there would give, and `m.predicted_log_likelihoods(t, s,
/// out)` sets out(a, b) = log p(touch of column a of t | window of column b of s).
template <class M>
concept predicts_touches = requires(const M& m, std::span<const Eigen::Index> states,
                                    Eigen::ArrayXXf& f, const Eigen::ArrayXXf& c) {
  m.window_descriptors(states, f);
  m.predicted_log_likelihoods(c, c, f);
};

namespace detail {

/// Hypotheses drawn from a belief over the positions of one or more objects.
struct touch_hypotheses {
  std::vector<Eigen::Index> object;  ///< the object (block) of each
  std::vector<grid_cell> cell;       ///< its position on that object's grid
  Eigen::ArrayXd weight;             ///< sums to 1
};

/// Systematic resampling of `k` hypotheses from the position masses `mass[o]` (object o's
/// positions, row-major over a grid of `cols[o]` columns; any positive total): the k points
/// (j + 1/2) / k of the cumulative mass, consecutive equal draws merged.
inline touch_hypotheses sample_hypotheses(std::span<const Eigen::ArrayXd> mass,
                                          std::span<const Eigen::Index> cols, int k) {
  double total = 0.0;
  for (const auto& m : mass) total += m.sum();
  if (!(std::isfinite(total) && total > 0.0))
    fail("next_touch: the belief's mass is ", total,
         "; expected a normalised belief (touch first, or reset())");
  touch_hypotheses h;
  std::vector<double> counts;
  const double step = total / k;
  double next = 0.5 * step, acc = 0.0;
  int drawn = 0;
  for (std::size_t o = 0; o < mass.size() && drawn < k; ++o) {
    const auto& m = mass[o];
    for (Eigen::Index q = 0; q < m.size() && drawn < k; ++q) {
      acc += m(q);
      bool first = true;
      while (drawn < k && next < acc) {
        if (first) {
          h.object.push_back(static_cast<Eigen::Index>(o));
          h.cell.push_back({q / cols[o], q % cols[o]});
          counts.push_back(0.0);
          first = false;
        }
        counts.back() += 1.0;
        ++drawn;
        next += step;
      }
    }
  }
  if (drawn < k && !counts.empty()) counts.back() += k - drawn;  // rounding at the very end
  h.weight =
      Eigen::Map<const Eigen::ArrayXd>(counts.data(), static_cast<Eigen::Index>(counts.size())) /
      static_cast<double>(k);
  return h;
}

/// -sum w log w of a distribution.
inline double entropy_of(const Eigen::ArrayXd& w) {
  double h = 0.0;
  for (Eigen::Index i = 0; i < w.size(); ++i)
    if (w(i) > 0.0) h -= w(i) * std::log(w(i));
  return h;
}

/// max over hypotheses c of the mass of `q` (row-wise: one distribution per row) within
/// `radius_mm` of c, on c's object: `near(b, c)` is 1 when b is within the radius of c.
inline Eigen::ArrayXd mass_within(const Eigen::MatrixXd& q, const Eigen::MatrixXd& near) {
  return (q * near).rowwise().maxCoeff().array();
}

/// Checks the candidates: at least one, finite, and each a move that can keep the sensor on at
/// least one of the maps (|dx| and |dy| within the range the sensor's centre has there).
template <class GridOf>
void check_candidates(std::span<const odometry> candidates, Eigen::Index objects, GridOf&& grid_of,
                      const char* who) {
  if (candidates.empty())
    fail(who, ": no candidate moves; expected at least one (a list of moves, or a touch_region)");
  double reach_x = 0.0, reach_y = 0.0;
  for (Eigen::Index o = 0; o < objects; ++o) {
    const planar_grid<float>& g = grid_of(o);
    reach_x = std::max(reach_x, static_cast<double>(g.cols() - 1) * g.mm_per_px());
    reach_y = std::max(reach_y, static_cast<double>(g.rows() - 1) * g.mm_per_px());
  }
  const double half_px = 0.5 * grid_of(0).mm_per_px();
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const odometry& c = candidates[i];
    if (!(std::isfinite(c.dx_mm) && std::isfinite(c.dy_mm)))
      fail(who, ": candidate ", i, " moves (", c.dx_mm, ", ", c.dy_mm,
           ") mm, not finite; expected finite millimetres in the map's frame");
    if (std::abs(c.dx_mm) > reach_x + half_px || std::abs(c.dy_mm) > reach_y + half_px)
      fail(who, ": candidate ", i, " moves (", c.dx_mm, ", ", c.dy_mm,
           ") mm, off the map from anywhere on it: the sensor's centre can move at most ", reach_x,
           " mm along x and ", reach_y,
           " mm along y and stay on the map; expected moves within the object");
  }
}

/// The ranking of `candidates` for hypotheses `h` (see the file comment): `grid_of(o)` is object
/// o's planar grid, `model_of(o)` its measurement model (with the `predicts_touches` hooks; the
/// objects' models of one configuration), `radius_mm` the verdict's radius.
template <class GridOf, class ModelOf>
[[nodiscard]] next_touch_ranking rank_touches(const touch_hypotheses& h,
                                              std::span<const odometry> candidates,
                                              GridOf&& grid_of, ModelOf&& model_of,
                                              double radius_mm, const next_touch_params& params) {
  next_touch_ranking r;
  r.objective = params.objective;
  r.candidates.assign(candidates.begin(), candidates.end());
  r.hypotheses = h.cell.size();
  r.entropy_nats = entropy_of(h.weight);
  const auto n_all = static_cast<Eigen::Index>(h.cell.size());
  // Positions (mm) of the hypotheses; a move shifts them all alike, so "within the radius"
  // is decided once.
  const double s = grid_of(0).mm_per_px();
  Eigen::MatrixXd near_all = Eigen::MatrixXd::Zero(n_all, n_all);
  for (Eigen::Index b = 0; b < n_all; ++b)
    for (Eigen::Index c = 0; c < n_all; ++c) {
      const auto bb = static_cast<std::size_t>(b), cc = static_cast<std::size_t>(c);
      const double dx = static_cast<double>(h.cell[bb].col - h.cell[cc].col) * s;
      const double dy = static_cast<double>(h.cell[bb].row - h.cell[cc].row) * s;
      near_all(b, c) = h.object[bb] == h.object[cc] && dx * dx + dy * dy <= radius_mm * radius_mm;
    }
  const double p_before = mass_within(h.weight.matrix().transpose(), near_all)(0);

  std::vector<Eigen::Index> landed, states;
  Eigen::ArrayXXf features, block, loglik;
  r.score.resize(candidates.size());
  r.on_map.resize(candidates.size());
  for (std::size_t ci = 0; ci < candidates.size(); ++ci) {
    const auto du = static_cast<Eigen::Index>(std::lround(candidates[ci].dx_mm / s));
    const auto dv = static_cast<Eigen::Index>(std::lround(candidates[ci].dy_mm / s));
    landed.clear();
    for (Eigen::Index i = 0; i < n_all; ++i) {
      const auto ii = static_cast<std::size_t>(i);
      if (grid_of(h.object[ii]).contains({h.cell[ii].row + dv, h.cell[ii].col + du}))
        landed.push_back(i);
    }
    const auto n = static_cast<Eigen::Index>(landed.size());
    double p_on = 0.0;
    for (const Eigen::Index i : landed) p_on += h.weight(i);
    r.on_map[ci] = p_on;
    const bool verdict = params.objective == next_touch_objective::verdict;
    if (n == 0 || !(p_on > 0.0)) {
      r.score[ci] = verdict ? p_before : 0.0;
      continue;
    }
    // The predicted touches: each landed hypothesis's window, object by object (hypotheses come
    // in object order).
    features.resize(0, 0);
    for (Eigen::Index a = 0; a < n;) {
      const Eigen::Index o =
          h.object[static_cast<std::size_t>(landed[static_cast<std::size_t>(a)])];
      Eigen::Index e = a;
      states.clear();
      for (; e < n && h.object[static_cast<std::size_t>(landed[static_cast<std::size_t>(e)])] == o;
           ++e) {
        const grid_cell c = h.cell[static_cast<std::size_t>(landed[static_cast<std::size_t>(e)])];
        states.push_back(grid_of(o).index({c.row + dv, c.col + du}));
      }
      model_of(o).window_descriptors(std::span<const Eigen::Index>(states), block);
      if (features.size() == 0) features.resize(block.rows(), n);
      features.middleCols(a, e - a) = block;
      a = e;
    }
    model_of(h.object[static_cast<std::size_t>(landed[0])])
        .predicted_log_likelihoods(features, features, loglik);
    Eigen::ArrayXd w(n);
    for (Eigen::Index a = 0; a < n; ++a)
      w(a) = h.weight(landed[static_cast<std::size_t>(a)]) / p_on;
    const Eigen::ArrayXd log_w = w.log();
    // Row a: the posterior over the landed hypotheses had touch a been read.
    Eigen::ArrayXXd logits = loglik.cast<double>() * params.likelihood_scale;
    logits.rowwise() += log_w.transpose();
    const Eigen::ArrayXd peak = logits.rowwise().maxCoeff();
    logits.colwise() -= peak;
    Eigen::ArrayXXd q = logits.exp();
    const Eigen::ArrayXd z = q.rowwise().sum();
    q.colwise() /= z;
    const double landing = params.weigh_by_landing ? p_on : 1.0;
    if (!verdict) {
      // H(q_a) = log Z_a - sum_b q_a(b) (logit_ab - peak_a).
      const Eigen::ArrayXd h_post = z.log() - (q * logits).rowwise().sum();
      r.score[ci] = landing * (entropy_of(w) - (w * h_post).sum());
    } else {
      Eigen::MatrixXd near(n, n);
      for (Eigen::Index b = 0; b < n; ++b)
        for (Eigen::Index c = 0; c < n; ++c)
          near(b, c) =
              near_all(landed[static_cast<std::size_t>(b)], landed[static_cast<std::size_t>(c)]);
      r.score[ci] = landing * (w * mass_within(q.matrix(), near)).sum() +
                    (params.weigh_by_landing ? (1.0 - p_on) * p_before : 0.0);
    }
    if (!std::isfinite(r.score[ci]))
      fail("next_touch: candidate ", ci, " (", candidates[ci].dx_mm, ", ", candidates[ci].dy_mm,
           ") mm scored ", r.score[ci],
           "; the measurement model's predicted log-likelihoods are not finite");
  }
  const auto [lo, hi] = std::minmax_element(r.score.begin(), r.score.end());
  r.uninformative = *hi - *lo <= params.tolerance;
  r.order.resize(candidates.size());
  std::iota(r.order.begin(), r.order.end(), std::size_t{0});
  if (!r.uninformative)
    std::stable_sort(r.order.begin(), r.order.end(),
                     [&](std::size_t a, std::size_t b) { return r.score[a] > r.score[b]; });
  return r;
}

/// `next_touch` of a planar filter (positions x appearance hypotheses, `latent_grid` over a
/// `planar_grid`, measurement `appearance_likelihood` of a model with the hooks).
template <class Filter>
[[nodiscard]] next_touch_ranking rank_planar_touches(const Filter& filter,
                                                     std::span<const odometry> candidates,
                                                     double radius_mm,
                                                     const next_touch_params& params,
                                                     const char* who) {
  using model_type = std::remove_cvref_t<decltype(filter.measurement_model().base())>;
  static_assert(predicts_touches<model_type>,
                "next_touch needs a measurement model with the window_descriptors and "
                "predicted_log_likelihoods hooks (filter/next_touch.hpp)");
  params.validate();
  const auto& grid = filter.grid().base();
  const auto grid_of = [&](Eigen::Index) -> const planar_grid<float>& { return grid; };
  check_candidates(candidates, 1, grid_of, who);
  const Eigen::Index plane = grid.size();
  Eigen::ArrayXd mass = Eigen::ArrayXd::Zero(plane);
  const auto& belief = filter.belief();
  for (Eigen::Index k = 0; k * plane < belief.size(); ++k)
    mass += belief.segment(k * plane, plane).template cast<double>();
  const Eigen::Index cols[] = {grid.cols()};
  const touch_hypotheses h =
      sample_hypotheses(std::span<const Eigen::ArrayXd>(&mass, 1), cols, params.hypotheses);
  const auto& model = filter.measurement_model().base();
  return rank_touches(
      h, candidates, grid_of, [&](Eigen::Index) -> const model_type& { return model; }, radius_mm,
      params);
}

/// `next_touch` of a library filter (objects of `latent_grid`s over `planar_grid`s, measurement
/// `library_likelihood` of `appearance_likelihood`s): hypotheses over (object, position), so
/// moves whose touch separates the objects rank high too.
template <class Filter>
[[nodiscard]] next_touch_ranking rank_library_touches(const Filter& filter,
                                                      std::span<const odometry> candidates,
                                                      double radius_mm,
                                                      const next_touch_params& params,
                                                      const char* who) {
  using model_type =
      std::remove_cvref_t<decltype(filter.measurement_model().object_model(0).base())>;
  static_assert(predicts_touches<model_type>,
                "next_touch needs a measurement model with the window_descriptors and "
                "predicted_log_likelihoods hooks (filter/next_touch.hpp)");
  params.validate();
  const auto& lib = filter.grid();
  const auto grid_of = [&](Eigen::Index o) -> const planar_grid<float>& {
    return lib.object(o).base();
  };
  check_candidates(candidates, lib.objects(), grid_of, who);
  std::vector<Eigen::ArrayXd> mass;
  std::vector<Eigen::Index> cols;
  const auto& belief = filter.belief();
  for (Eigen::Index o = 0; o < lib.objects(); ++o) {
    const Eigen::Index plane = lib.object(o).base().size();
    Eigen::ArrayXd m = Eigen::ArrayXd::Zero(plane);
    const auto block = belief.segment(lib.object_offset(o), lib.object_size(o));
    for (Eigen::Index k = 0; k * plane < block.size(); ++k)
      m += block.segment(k * plane, plane).template cast<double>();
    mass.push_back(std::move(m));
    cols.push_back(lib.object(o).base().cols());
  }
  const touch_hypotheses h = sample_hypotheses(mass, cols, params.hypotheses);
  return rank_touches(
      h, candidates, grid_of,
      [&](Eigen::Index o) -> const model_type& {
        return filter.measurement_model().object_model(o).base();
      },
      radius_mm, params);
}

}  // namespace detail
}  // namespace tacmap
