// tacmap: `bayes_filter` — THE recursive Bayes filter of the paper's Table 1, over a grid.
//
//   control update:      bel_bar(x_t) = sum_{x_{t-1}} p(x_t | u_t, x_{t-1}) bel(x_{t-1})
//   measurement update:  bel(x_t)     = eta p(z_t | x_t) bel_bar(x_t)
//
// The grid, the motion model and the measurement model are policies (configured values) that
// act on the whole belief at once. The initial belief is uniform: the paper assumes no prior
// knowledge of where the sensor is (Sec. III-A); `set_prior` takes a user prior instead.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <span>
#include <stdexcept>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "tacmap/angle.hpp"
#include "tacmap/detail/mass_sum.hpp"
#include "tacmap/executor/concept.hpp"
#include "tacmap/filter/detail/changed_cells.hpp"
#include "tacmap/filter/detail/position_statistics.hpp"
#include "tacmap/filter/detail/posterior_kernel.hpp"
#include "tacmap/filter/detail/support.hpp"
#include "tacmap/filter/state_estimate.hpp"
#include "tacmap/grid/concept.hpp"
#include "tacmap/grid/latent_grid.hpp"
#include "tacmap/grid/library_grid.hpp"
#include "tacmap/image.hpp"
#include "tacmap/measurement/concept.hpp"
#include "tacmap/motion/concept.hpp"

namespace tacmap {

/// Which states a measurement update evaluated (`bayes_filter::set_tracking`).
enum class update_path {
  full,     ///< the whole grid: tracking off, or the model has no tracking hook or bound
  tracked,  ///< only the predicted belief's support (all but epsilon of its mass)
  /// Tracking on, but the support held more than `tracking_params::max_support` of the states
  /// (a spread belief, e.g. the first touch): the whole grid.
  full_wide,
  /// Tracking on, but the touch's evidence inside the support was too weak for the bound
  /// (rho > `tracking_params::tolerance`: it may fit better outside, e.g. after a kidnap): the
  /// whole grid.
  full_contradicted,
  /// Tracking on, but `tracking_params::recheck_every` tracked updates ran since the last
  /// whole-grid one: the whole grid, so that a touch that fits elsewhere (a kidnap, a slip
  /// beyond the motion's reach) is found even when nothing inside the support doubts it.
  full_recheck,
};

[[nodiscard]] inline const char* to_string(update_path p) {
  switch (p) {
    case update_path::full:
      return "full";
    case update_path::tracked:
      return "tracked";
    case update_path::full_wide:
      return "full (wide support)";
    case update_path::full_contradicted:
      return "full (contradicted)";
    case update_path::full_recheck:
      return "full (scheduled re-check)";
  }
  return "?";
}

/// Tracking mode of `bayes_filter` (issue 14): once the predicted belief is concentrated, the
/// likelihood is evaluated only on its support S, the fewest states (up to a threshold's
/// granularity) holding >= 1 - epsilon of the predicted mass. The states outside S are given a
/// log-likelihood no higher than the best inside S (any value up to the model's bound keeps the
/// guarantee below): after a whole-grid search for S, the smallest found inside S, which
/// shrinks their mass; after a windowed predict (below), the inside's mean under the
/// prediction, which leaves their values as they are. With L the model's
/// upper bound on the log-likelihood
/// (`log_likelihood_bound()`), m the mass outside S and Z = sum_{x in S} bel_bar(x) p(z | x),
///   rho = m exp(L) / Z
/// bounds what the states outside could have added to the evidence, relative to the inside,
/// and the total-variation distance between the tracked posterior and the full update's:
///   TV(tracked, full) <= rho <= tolerance
/// (both posteriors put mass <= rho outside S and are proportional inside it). When rho exceeds
/// `tolerance` — the touch fits the prediction so badly that a state outside might explain it
/// better — the update falls back to the whole grid. The MAP state is always inside S.
///
/// What the tracked path cannot give: the likelihood's maximum and the evidence under a
/// uniform prediction over the whole grid. `update_report::log_likelihood_max` is then the
/// maximum inside S, `log_evidence` inside S (within log(1 + rho) of the full value), and
/// `log_prediction_support` an upper bound (the uniform evidence of S alone): a contradiction
/// is recognised by the fallback, not by that figure. Hence off by default.
///
/// No pass over the whole grid once tracking has settled: after a tracked update the filter
/// keeps boxes on the belief image (every layer) around S's clusters (up to 32; states within
/// 4 cells share a box) and a bound on the mass outside them; a `predict` with a motion model
/// that `moves_box` moves only those boxes (`windowed`); the next update searches S only among
/// the states where that mass landed, with the budget epsilon less the mass left outside, and
/// leaves the outside's values in place. While that outside holds more than epsilon / 2 (or
/// after any other change of the belief) the search takes the whole grid again, and the outside
/// is rescaled. On a 640 x 480 px map at 36 headings (9.8 million poses) a tracked touch then
/// costs about 1.7 ms instead of 57-66 ms (README, "Tracking mode").
///
/// With a uniform floor in the motion model (`has_uniform_floor`: `robust_motion`'s
/// lost_probability lambda, the localizer's default) every prediction puts lambda / N on every
/// state, so no support holds all but epsilon of the mass. The floor's share is then carried as
/// one number: the mass m outside the support may be up to A = 2 lambda + epsilon (the floor and
/// as much again for what earlier floors left), and the states outside keep their values through
/// tracked updates and windowed predicts (their likelihood taken as the inside's mean under the
/// prediction, as above). What the floor's states would have added to the evidence cannot be
/// bounded by exp(L) (lambda exp(L - top) is in the thousands for real touches), so the tracked
/// path estimates it instead, with F_ref the uniform evidence (1/N) sum_x p(z | x) of the last
/// whole-grid update:
///   log_prediction_support ~ log(Z_in / F_ref + m),
///   TV(tracked, full) ~ m max(1, F_ref (1 - m) / Z_in)   (`update_report::tracking_error_bound`)
/// (both posteriors are proportional on the support; they differ by the outside's share, m in
/// the tracked one, m F_out / Z in the full one). F_ref belongs to another touch, and a touch
/// after a slip that fits near the old place too was estimated several nats too well supported;
/// with `sample_every` the touch's own F and Z_out are estimated instead, from the support
/// (exact) and a sample of rows outside it (each standing for its share of the outside, with
/// the floor's lambda / N added to its prediction). The whole grid is checked when that estimated
/// support falls below `doubt` (the touch fits the prediction no better than the map at large:
/// a kidnap, a slip), and every `recheck_every` tracked touches in any case, which bounds how
/// long a kidnap that the estimate misses goes unnoticed. Windowed predicts leave the floor out
/// (the outside keeps the last whole-grid posterior's values): a whole-grid update that follows
/// them first puts it back, b <- (1 - lambda) b + lambda / N, as the whole grid's predict would
/// have, so that a kidnapped sensor's new place starts from the floor as in the untracked
/// filter (without it, kidnaps found the old place kept). `default_tracking()` gives the values
/// chosen by measurement for the localizer's default filter.
struct tracking_params {
  /// Mass left outside the support: 0 turns tracking off (the default); else in (0, 0.5). With
  /// a motion floor (`robust_motion`'s lost_probability) the predicted belief has at least that
  /// mass spread over every state: a smaller epsilon then selects the whole grid. Take 1e-9 for
  /// real touches: rho grows with exp(L - best log-likelihood), which a noisy touch puts in
  /// the thousands, so with 1e-6 the bound fails and every update falls back to the whole grid
  /// (measured at 640 x 480, README "Tracking mode"); the support grows only slowly as epsilon
  /// shrinks.
  double epsilon = 0.0;
  /// The largest bound rho accepted on the tracked path (see above), in (0, 1).
  double tolerance = 1e-3;
  /// The whole grid is evaluated when the support holds more than this fraction of the states
  /// (in (0, 1]): restricting the evaluation would save little.
  double max_support = 0.25;
  /// The whole grid every this many tracked updates in a row (`update_path::full_recheck`): a
  /// touch that fits elsewhere is found within that many touches even when nothing inside the
  /// support doubts it. 0: never.
  int recheck_every = 0;
  /// The estimated `log_prediction_support` of a tracked update (see above) below which the
  /// whole grid is evaluated instead (`update_path::full_contradicted`): the touch fits the
  /// prediction hardly better than the map at large. -infinity: never.
  double doubt = -std::numeric_limits<double>::infinity();
  /// Each tracked update also evaluates every this many-th row of the belief image (in every
  /// layer; the rows shift by one each tracked update) outside the support: a sample of the
  /// whole grid for this very touch. The estimated `log_prediction_support` and the outside's
  /// share are then taken from it (the sampled states standing for the outside, the support
  /// exact) instead of from the last whole-grid update's uniform evidence, which belongs to
  /// another touch. 0: no sample (the last whole-grid update's evidence).
  int sample_every = 0;
  /// The sample holds at most this many layers' worth of rows (0: every `sample_every`-th row of
  /// every layer). A grid with more layers (an (x, y, theta) grid's headings, times the
  /// appearance hypotheses) samples every `sample_every`-th row of one layer in k,
  /// k = ceil(layers / sample_layers), another each touch (`detail::sample_rows`); the sampled
  /// states stand for the outside as before (each for its share). 2 (`default_tracking()`): a
  /// known heading's two appearance blocks keep every 8th row of both; 36 headings sample one
  /// heading of each block a touch, as many states as a known heading's sample. Every 8th row of
  /// every heading cost as much as the whole grid (paper's grid, 36 headings, camera_bench:
  /// 13.5 against 13.1 ms a touch); one row in 288 spread over every heading 2.2 ms (the touch
  /// described at a dozen more headings); one heading 1.9 ms, and as many kidnaps and slips
  /// recovered (`localizer_config::tracking_headings`).
  int sample_layers = 0;

  void validate() const {
    if (!(std::isfinite(epsilon) && epsilon >= 0.0 && epsilon < 0.5))
      detail::fail("tracking_params: epsilon = ", epsilon,
                   "; expected the predicted mass left outside the evaluated states, in [0, 0.5) "
                   "(e.g. 1e-9; 0 turns tracking off)");
    if (!(std::isfinite(tolerance) && tolerance > 0.0 && tolerance < 1.0))
      detail::fail("tracking_params: tolerance = ", tolerance,
                   "; expected the largest accepted bound on the posterior's total-variation "
                   "error, in (0, 1) (e.g. 1e-3)");
    if (!(std::isfinite(max_support) && max_support > 0.0 && max_support <= 1.0))
      detail::fail("tracking_params: max_support = ", max_support,
                   "; expected a fraction of the states in (0, 1] (e.g. 0.25)");
    if (recheck_every < 0)
      detail::fail("tracking_params: recheck_every = ", recheck_every,
                   "; expected a number of tracked updates >= 0 (e.g. 8; 0 = never)");
    if (std::isnan(doubt) || doubt == std::numeric_limits<double>::infinity())
      detail::fail("tracking_params: doubt = ", doubt,
                   "; expected a log Bayes factor (e.g. 1), or -infinity to turn the check off");
    if (sample_every < 0)
      detail::fail("tracking_params: sample_every = ", sample_every,
                   "; expected a row stride >= 0 (e.g. 8; 0 = no sample)");
    if (sample_layers < 0)
      detail::fail("tracking_params: sample_layers = ", sample_layers,
                   "; expected a number of layers >= 0 (e.g. 2; 0 = every layer)");
  }
};

/// What `bayes_filter::update` throws when a touch gives zero probability to every state the
/// predicted belief still allows (the measurement contradicts the prediction): the belief is
/// unchanged and starting again from a uniform belief (`reset()`) is a sound response, which
/// `basic_localizer` takes. A std::domain_error, as every failed update; the other failures (a
/// likelihood that is NaN, +infinity or -infinity everywhere) are the model's, not the
/// prediction's, and are not of this type: a restart would not cure them.
class contradiction_error : public std::domain_error {
 public:
  using std::domain_error::domain_error;
};

/// Tracking for the localizer's default filter (latent appearance, `robust_motion` with its
/// floor and wide component): what `localizer_config::tracking` holds by default. Chosen by
/// measurement (tacmap-evaluate --scenario realistic --touches 12, the gecko and eight
/// photographs, seeds 1-3, against --no-tracking in the same run): epsilon 1e-9 as for any
/// real touch; the whole grid when the estimated prediction support falls below 3 nats (1 and
/// 5-8 nats recovered fewer kidnaps); a sample of every 8th row, without which slips at touch 7
/// came back within 5 touches in 356 of 437 sequences against 365 of 432 untracked (every 8th:
/// 369 of 436; every 16th 368, every 32nd 362); and the whole grid every 64 tracked touches as a
/// backstop against a kidnap both miss (12-touch sequences never reach it; every 16, the
/// earlier choice, made the re-checks most of a localized touch's mean cost at 640 x 480).
/// At most 2 layers' worth of sampled rows (`sample_layers`): a known heading's two appearance
/// blocks whole, one heading of each a touch with headings.
[[nodiscard]] constexpr tracking_params default_tracking() {
  tracking_params p;
  p.epsilon = 1e-9;
  p.recheck_every = 64;
  p.doubt = 3.0;
  p.sample_every = 8;
  p.sample_layers = 2;
  return p;
}

/// What one measurement update reports.
struct update_report {
  /// log of the normaliser eta^-1 = sum_x p(z | x) bel_bar(x), relative to the likelihood's
  /// maximum: 0 when the prediction put all its mass on the best-matching states, very negative
  /// when the measurement contradicts the prediction (a hint of a bad touch or bad odometry).
  double log_evidence = 0.0;
  /// The largest log-likelihood of the touch, max_x log p(z | x), in the model's own units.
  double log_likelihood_max = 0.0;
  /// log p(z_t | z_1..t-1) = log sum_x p(z | x) bel_bar(x) in the model's units: the evidence of
  /// the whole touch. Summed over a sequence it is the log marginal likelihood of the data under
  /// the filter, so two filters whose models share a likelihood scale (the same descriptor and
  /// tau, e.g. on two different maps) are compared by the difference of their sums: the log
  /// Bayes factor. Meaningful as a probability only with a calibrated scale (tacmap-calibrate).
  [[nodiscard]] double log_marginal_likelihood() const { return log_likelihood_max + log_evidence; }
  /// How much better the prediction explains the touch than not knowing where the sensor is:
  /// log [ sum_x p(z | x) bel_bar(x) / (1/N sum_x p(z | x)) ], the log Bayes factor of the
  /// predicted belief against a uniform one over the N states. 0 when the prediction is
  /// uniform (the first touch), up to log N when the prediction sits exactly on the best
  /// matches, negative when the touch fits somewhere the filter did not expect better than
  /// where it did: the signal that odometry, a slip or a kidnap broke the prediction. Unlike
  /// `log_evidence` it needs no reference level: it is a ratio of two evidences of one touch
  /// (`confidence_params::contradiction` in filter/confidence.hpp turns it into a verdict).
  double log_prediction_support = 0.0;
  /// Which states were evaluated (`bayes_filter::set_tracking`). On the tracked path the three
  /// figures above are over the evaluated states only (see `tracking_params`).
  update_path path = update_path::full;
  /// How many states the likelihood was evaluated at (the grid's size on a full path).
  Eigen::Index evaluated_states = 0;
  /// Tracked path: rho, the bound on the total-variation distance between this posterior and
  /// the full update's (<= `tracking_params::tolerance`); 0 on a full path.
  double tracking_error_bound = 0.0;
};

namespace detail {
// The grid whose positions the filter's statistics describe: an object's grid for a library
// (each object's block separately), else the filter's grid itself.
template <class G>
struct statistics_grid {
  using type = G;
};
template <library_state_grid G>
struct statistics_grid<G> {
  using type = typename G::object_grid_type;
};

// Measurement models that use the predicted belief (library_likelihood: objects it has ruled
// out are not evaluated).
template <class M, class G>
concept measures_given_prediction = requires(const M& m, const G& g,
                                             const typename M::measurement_type& z,
                                             belief_array<G>& out,
                                             const belief_array<G>& predicted) {
  m.log_likelihood(g, z, out, predicted);
};
}  // namespace detail

namespace detail {
/// What `bayes_filter` does that does not depend on its measurement model: the belief, the
/// prediction, the estimate and its statistics, applying a log-likelihood and tracking's
/// search. A base of its own, so that one instantiation serves every measurement model over
/// the same grid and motion: `tacmap::precompiled` holds the localizers' (precompiled.hpp), and
/// a localizer with a user's descriptor compiles only what depends on that descriptor. Its
/// public members are `bayes_filter`'s (documented here).
template <state_grid Grid, motion_model<Grid> Motion>
class filter_core {
 public:
  using grid_type = Grid;
  using motion_type = Motion;
  using scalar_type = typename Grid::scalar_type;
  using belief_type = belief_array<Grid>;
  using control_type = typename Motion::control_type;
  using estimate_type = state_estimate<Grid::dimension>;

  /// A filter with a uniform initial belief.
  filter_core(Grid grid, Motion motion);

  /// Back to the uniform belief (no knowledge of where the sensor is). Over a `library_grid`:
  /// each object's prior (`object_prior()`) spread evenly over its states.
  void reset() {
    region_.reset();
    changed_all();
    if constexpr (library_state_grid<Grid>) {
      for (Eigen::Index k = 0; k < grid_.objects(); ++k)
        belief_.segment(grid_.object_offset(k), grid_.object_size(k))
            .setConstant(
                static_cast<scalar_type>(grid_.object_prior()[static_cast<std::size_t>(k)] /
                                         static_cast<double>(grid_.object_size(k))));
    } else {
      belief_.setConstant(scalar_type(1) / static_cast<scalar_type>(grid_.size()));
    }
  }

 protected:
  // Tracking: after a tracked update, boxes on the belief image (every layer's states united)
  // holding its support, and a bound on the mass outside them (what the next predict may leave
  // in place); after a windowed predict (`moved`), the boxes where that mass now is, which the
  // next tracked update searches instead of the whole grid. Empty once the belief changed any
  // other way.
  struct tracked_region {
    std::vector<grid_box> boxes;  // pairwise disjoint
    double outside = 0.0;
    bool moved = false;
  };

 public:
  /// What `predict`, `update` and `reset` change: the belief and tracking's bookkeeping (the
  /// motion and measurement models keep no state between calls). `save_state` then
  /// `restore_state` make a step of several calls all or nothing: the localizers save before
  /// each touch and restore when any part of it throws (a touch with motion whose update then
  /// fails must not leave the motion applied). The first save into `s` copies the whole belief;
  /// saving again into the same `s` copies only the cells of the belief image (in every layer)
  /// that changed since the previous save — after a tracked touch, the boxes the windowed
  /// predict and the tracked update wrote, a few percent of a pose belief — and nothing else
  /// changes between saves, so `s` then holds the belief bit for bit as a whole copy would.
  /// (That relies on the motion model's `predict_boxes` writing only inside the boxes and the
  /// rectangles it reports in `landed`, as `moves_box` requires.) A copy or move of the filter
  /// or of `s`, a `restore_state`, or a save into `s` by another filter makes the next save a
  /// whole copy again. No allocation after the first save.
  class saved_state {
    friend class filter_core;

   public:
    /// The belief as it was saved (e.g. before a touch's prediction).
    const belief_type& belief() const noexcept { return belief_; }

   private:
    belief_type belief_;
    std::optional<tracked_region> region_;
    double reference_log_uniform_ = std::numeric_limits<double>::quiet_NaN();
    int tracked_run_ = 0;
    detail::save_link source_;  // the filter whose belief `belief_` holds (as of its last save)
  };
  void save_state(saved_state& s) {
    const bool incremental = s.source_.other == this && last_saved_.other == &s &&
                             !since_save_.all() && s.belief_.size() == belief_.size();
    if (incremental) {
      const Eigen::Index cols = grid_.cols(), plane = grid_.rows() * cols;
      for (const Eigen::Index r : since_save_.touched_rows()) {
        const Eigen::Index lo = since_save_.lo(r), width = since_save_.hi(r) - lo;
        for (Eigen::Index at = r * cols + lo; at < belief_.size(); at += plane)
          s.belief_.segment(at, width) = belief_.segment(at, width);
      }
    } else {
      s.belief_.resize(belief_.size());
      s.belief_ = belief_;
    }
    since_save_.clear();
    s.source_.other = this;
    last_saved_.other = &s;
    s.region_ = region_;
    s.reference_log_uniform_ = reference_log_uniform_;
    s.tracked_run_ = tracked_run_;
  }
  /// Puts back what `save_state(s)` saved (`s` is left holding the discarded state).
  void restore_state(saved_state& s) noexcept {
    belief_.swap(s.belief_);
    region_.swap(s.region_);
    std::swap(reference_log_uniform_, s.reference_log_uniform_);
    std::swap(tracked_run_, s.tracked_run_);
    changed_all();
    s.source_.other = nullptr;
    last_saved_.other = nullptr;
  }

  /// Replaces the belief by a user prior: either a flat array of `size()` values or an image of
  /// `rows() x cols()` (single-layer grids). Values must be finite and >= 0 with a positive
  /// sum; they are normalised. Throws std::invalid_argument otherwise, belief unchanged.
  template <class Derived>
  void set_prior(const Eigen::DenseBase<Derived>& prior) {
    const Eigen::Index n = grid_.size();
    if (prior.rows() == n && prior.cols() == 1) {
      scratch_ = prior.derived().template cast<scalar_type>();
    } else if (prior.rows() == grid_.rows() && prior.cols() == grid_.cols() &&
               n == grid_.rows() * grid_.cols()) {
      Eigen::Map<image<scalar_type>>(scratch_.data(), grid_.rows(), grid_.cols()) =
          prior.derived().template cast<scalar_type>();
    } else {
      detail::fail("bayes_filter::set_prior: prior is ", prior.rows(), " x ", prior.cols(),
                   "; expected ", n, " x 1 (one value per state) or the belief image ",
                   grid_.rows(), " x ", grid_.cols());
    }
    for (Eigen::Index i = 0; i < n; ++i)
      if (!(std::isfinite(scratch_(i)) && scratch_(i) >= 0))
        detail::fail("bayes_filter::set_prior: prior value ", scratch_(i), " at state ", i,
                     "; expected finite probabilities >= 0");
    const double total = detail::mass_sum(scratch_);
    if (!(total > 0.0 && std::isfinite(total)))
      detail::fail("bayes_filter::set_prior: the prior sums to ", total,
                   "; expected a positive, finite total (it is normalised for you)");
    normalise(scratch_, total);
    changed_all();
    belief_.swap(scratch_);
    region_.reset();
  }

  /// Control update with odometry `u`. If the motion model throws (invalid odometry, all mass
  /// off the grid) the exception propagates and the belief is unchanged. In tracking mode, right
  /// after a tracked update and with a motion model that `moves_box` (odometry_gaussian,
  /// pose_odometry_gaussian: the boxes in every heading layer), only the mass inside the boxes
  /// around that update's support is moved; the states outside keep their values (their mass
  /// r <= epsilon up to float rounding, see `tracking_params`). Mass moved off the grid is
  /// dropped and given back to the moved states (`predict` renormalises every state):
  ///   TV(this prediction, the whole grid's) <= r + dropped
  /// (the report's `windowed`, `mass_lost` and `tracking_error_bound`). The whole grid moves
  /// otherwise, and when the motion model cannot move the boxes alone (e.g. `off_grid::clamp`
  /// at the grid's edge).
  prediction_report predict(const control_type& u);

  /// Turns tracking mode on (epsilon > 0) or off (epsilon = 0): see `tracking_params` for what
  /// it evaluates and the bound on the error it guarantees. Throws std::invalid_argument for
  /// parameters out of range (naming the value), the filter unchanged. Models without the
  /// tracking hook accept it and always update the whole grid.
  void set_tracking(const tracking_params& params) {
    params.validate();
    tracking_ = params;
    region_.reset();
  }
  [[nodiscard]] const tracking_params& tracking() const { return tracking_; }

  /// The belief, one probability per state (sums to 1).
  [[nodiscard]] const belief_type& belief() const { return belief_; }

  /// One layer of the belief as a `rows() x cols()` image (row-major), e.g. for a heat map.
  [[nodiscard]] Eigen::Map<const image<scalar_type>> belief_image(Eigen::Index layer = 0) const {
    const Eigen::Index plane = grid_.rows() * grid_.cols();
    TACMAP_ASSERT(layer >= 0 && (layer + 1) * plane <= grid_.size(), "belief layer out of range");
    return {belief_.data() + layer * plane, grid_.rows(), grid_.cols()};
  }

  /// MAP state, mean, covariance and entropy of the belief, in the map frame (mm); over a
  /// latent grid, of the position marginal, with each hypothesis's posterior (see
  /// `state_estimate`). Uses the filter's scratch: not for concurrent calls on one filter.
  [[nodiscard]] estimate_type estimate() const;

  /// The belief's probability that the sensor's position (x, y) lies within `radius_mm` of
  /// `center_mm` (map frame, mm), whatever its heading or latent hypothesis: the mass of the
  /// states whose centres are at most `radius_mm` away. With `center_mm` the estimate, this is
  /// the belief's own claim that the estimate is within `radius_mm` of the truth — calibrated
  /// when it matches how often that is so (README, "Confidence"). Over a `library_grid`:
  /// positions on the most probable object (`center_mm` in its map frame), and the joint
  /// probability — that object and within the radius. Throws std::invalid_argument for a
  /// non-finite centre or a radius that is negative or not finite.
  [[nodiscard]] double probability_within(const Eigen::Vector2d& center_mm, double radius_mm) const
      requires(Grid::dimension >= 2);

  /// The position whose disc of `radius_mm` holds the most belief (x, y; whatever the heading
  /// or latent hypothesis: the belief's mean inside the best disc of the lattice), and the mass
  /// of its disc: the estimate most probably within `radius_mm` of the truth, and the belief's
  /// probability that it is. Where the MAP state is one sharp peak the
  /// two agree; where the belief is spread over a region (a smooth map, a repeated texture)
  /// the disc's centre sits where most of the mass is, not on the highest single state. The
  /// grid's positions must form a regular lattice (planar_grid, pose_grid: one state per map
  /// pixel); throws std::logic_error otherwise, std::invalid_argument for a radius that is
  /// negative or not finite. Over a `library_grid`: on the most probable object's map, with the
  /// joint probability (that object and within the radius). Uses scratch kept in the filter:
  /// not for concurrent calls on one filter (like every other member).
  [[nodiscard]] std::pair<Eigen::Vector2d, double> most_probable_disc(double radius_mm) const
      requires(Grid::dimension >= 2);

  /// True when the grid's positions form an axis-aligned regular lattice (planar_grid,
  /// pose_grid): what `most_probable_disc` needs. Library grids: the most probable object's.
  [[nodiscard]] bool positions_form_lattice() const {
    return stats_[static_cast<std::size_t>(leading_block())].positions_form_lattice();
  }

  /// Grids with a heading (pose_grid): the belief's probability that the heading is within
  /// `tolerance_rad` of `heading_rad`, the angle difference wrapped into [-pi, pi) (library
  /// grids: on the most probable object, joint). Throws std::invalid_argument for a non-finite
  /// heading or a negative or non-finite tolerance.
  [[nodiscard]] double heading_probability_within(double heading_rad, double tolerance_rad) const
      requires(Grid::dimension == 3 && has_circular_coordinates<Grid>) {
    if (!std::isfinite(heading_rad))
      detail::fail("bayes_filter::heading_probability_within: heading ", heading_rad,
                   " rad; expected a finite angle");
    if (!(std::isfinite(tolerance_rad) && tolerance_rad >= 0.0))
      detail::fail("bayes_filter::heading_probability_within: tolerance ", tolerance_rad,
                   " rad; expected a finite angle >= 0");
    if constexpr (summary_grid)
      if (summarised())
        return stats_[0].heading_probability_summarised(grid_, heading_rad, tolerance_rad);
    const Eigen::Index k = leading_block();
    return stats_[static_cast<std::size_t>(k)].heading_probability_within(block(k), heading_rad,
                                                                          tolerance_rad);
  }

  [[nodiscard]] const Grid& grid() const { return grid_; }
  [[nodiscard]] const Motion& motion() const { return motion_; }
  [[nodiscard]] Motion& motion() { return motion_; }

 protected:
  using statistics_grid_type = typename detail::statistics_grid<Grid>::type;
  using statistics_type = detail::position_statistics<statistics_grid_type>;

  // The block the position statistics describe: the most probable object's (library grids;
  // the lowest index among equals), else the whole belief (0).
  Eigen::Index leading_block() const {
    if constexpr (library_state_grid<Grid>) {
      const std::vector<double> p = object_posterior(grid_, belief_);
      return static_cast<Eigen::Index>(std::max_element(p.begin(), p.end()) - p.begin());
    } else {
      return 0;
    }
  }
  typename statistics_type::view_type block(Eigen::Index k) const {
    if constexpr (library_state_grid<Grid>)
      return {belief_.data() + grid_.object_offset(k), grid_.object_size(k)};
    else
      return {belief_.data(), belief_.size()};
  }
  const statistics_grid_type& statistics_grid(Eigen::Index k) const {
    if constexpr (library_state_grid<Grid>)
      return grid_.object(k);
    else
      return grid_;
  }
  // True when the position statistics come from their row summary (pose grids and planar
  // lattices: position_statistics::summarises), brought up to date here with the rows changed
  // since the last call: a tracked touch's estimate and verdict then cost the rows its boxes
  // touched (at known heading on the paper's grid the whole-grid passes of the estimate and
  // the disc were a third of a localized touch).
  static constexpr bool summary_grid =
      !library_state_grid<Grid> && ((Grid::dimension == 3 && has_circular_coordinates<Grid>) ||
                                    (Grid::dimension == 2 && !has_circular_coordinates<Grid>));
  bool summarised() const {
    if constexpr (summary_grid) {
      if (!stats_[0].summarises()) return false;
      stats_[0].refresh(grid_, block(0), since_stats_);
      since_stats_.clear();
      return true;
    } else {
      return false;
    }
  }
  static std::vector<statistics_type> make_statistics(const Grid& grid) {
    std::vector<statistics_type> out;
    if constexpr (library_state_grid<Grid>) {
      for (Eigen::Index k = 0; k < grid.objects(); ++k) out.emplace_back(grid.object(k));
    } else {
      out.emplace_back(grid);
    }
    return out;
  }

  // bel = eta * exp(ll - max ll) * bel_bar. Subtracting the maximum first means the best state's
  // factor is exactly 1, so no likelihood underflows to an all-zero posterior by itself.
  update_report apply_log_likelihood(const belief_type& ll, const char* source);

  // The tracked update (see tracking_params), or the reason it did not run (the caller then
  // updates the whole grid): update_path::tracked with the report filled, else the fallback.
  // `bound`: the model's `log_likelihood_bound()`; `evaluate` runs its `log_likelihood_on`
  // into `log_likelihood_` (one call per update: the model's type stays out of this member).
  // `region`: where a windowed predict left the mass (searched instead of the whole grid).
  struct evaluate_on {
    void (*run)(const void* context, belief_type& out, std::span<const state_range> states);
    const void* context;
  };
  update_path tracked_update(double bound, evaluate_on evaluate, update_report& report,
                             const tracked_region* region);

  // b /= total (b's sum, > 0). When 1 / total overflows the belief's precision (a float sum
  // below ~3e-39: a sharp touch far from where the prediction put its mass) the factor would
  // be +infinity and 0 * infinity NaN; b is then divided by its largest value first (which
  // becomes exactly 1) and by its new sum after.
  static void normalise(belief_type& b, double total) {
    const double inverse = 1.0 / total;
    if (inverse < static_cast<double>(std::numeric_limits<scalar_type>::max())) {
      b *= static_cast<scalar_type>(inverse);
      return;
    }
    b /= b.maxCoeff();
    b *= static_cast<scalar_type>(1.0 / detail::mass_sum(b));
  }

  Grid grid_;
  Motion motion_;
  belief_type belief_;
  belief_type scratch_;
  belief_type log_likelihood_;
  tracking_params tracking_;
  std::vector<state_range> support_;  // tracking: the states evaluated
  std::optional<tracked_region> region_;
  std::vector<grid_box> landed_;         // predict_boxes' windows
  std::vector<state_range> candidates_;  // the region's states (tracked_update)
  // tracked_update's sample (tracking_params::sample_every): its rows, those outside the
  // support, and the support and them together (what the model evaluates).
  std::vector<state_range> sample_rows_, sample_out_, evaluated_;
  static constexpr std::size_t max_region_boxes = 32;
  // Tracking with a uniform floor (see `tracking_params`): the uniform evidence log F_ref of the
  // last whole-grid `update` (NaN before the first), and the tracked updates since.
  double reference_log_uniform_ = std::numeric_limits<double>::quiet_NaN();
  int tracked_run_ = 0;
  // The motion's uniform floor lambda (`has_uniform_floor`), else 0.
  [[nodiscard]] double uniform_floor() const {
    if constexpr (has_uniform_floor<Motion>)
      return static_cast<double>(motion_.uniform_floor());
    else
      return 0.0;
  }
  // The mass the states outside a tracked support may hold beyond epsilon: 2 lambda with a
  // motion floor, else 0.
  [[nodiscard]] double floor_allowance() const { return 2.0 * uniform_floor(); }
  // Before a whole-grid update that follows windowed predicts: the floor those predicts left
  // out, b <- (1 - lambda) b + lambda / N, as the whole grid's predict would have put it. The
  // states outside the tracked boxes otherwise still hold the last whole-grid posterior's
  // values (the touches before, which a kidnapped sensor's new place did not fit), not the
  // fresh lambda / N that lets the untracked filter find the new place at once.
  // The belief before it stays in scratch_ until the update writes there, which it does only
  // once nothing can fail (its checks come first, and with the floor on every state the
  // posterior's sum is positive): `unrestore_floor` puts it back after a failed update.
  void restore_floor() {
    const double lambda = uniform_floor();
    scratch_ = belief_ * static_cast<scalar_type>(1.0 - lambda) +
               static_cast<scalar_type>(lambda / static_cast<double>(grid_.size()));
    changed_all();
    belief_.swap(scratch_);
  }
  void unrestore_floor() {
    changed_all();
    belief_.swap(scratch_);
  }
  [[nodiscard]] Eigen::Index layers() const { return grid_.size() / (grid_.rows() * grid_.cols()); }
  // The cells of the belief image (every layer) changed since the last save_state (what the
  // next one copies) and since the position statistics last summarised the belief. Every write
  // to belief_ marks what it may change first; library grids (blocks of different images) mark
  // everything.
  detail::changed_cells since_save_;
  mutable detail::changed_cells since_stats_;
  detail::save_link last_saved_;  // the saved_state the last save_state wrote
  void changed_all() {
    since_save_.mark_all();
    since_stats_.mark_all();
  }
  template <class Cells>
  void changed(const Cells& cells) {
    if constexpr (library_state_grid<Grid>) {
      changed_all();
    } else {
      for (const auto& c : cells) {
        since_save_.mark(c);
        since_stats_.mark(c);
      }
    }
  }
  // Position statistics (coordinates cached once): one per object for library grids.
  std::vector<statistics_type> stats_;
};
}  // namespace detail

/// The recursive Bayes filter over `Grid`, with the `Motion` and `Measurement` policies.
/// The belief's precision is `Grid::scalar_type` (float or double). What does not depend on
/// the measurement model (the belief, `predict`, `estimate`, the statistics) is its base
/// `detail::filter_core<Grid, Motion>`.
template <state_grid Grid, motion_model<Grid> Motion, measurement_model<Grid> Measurement>
class bayes_filter : public detail::filter_core<Grid, Motion> {
  using core = detail::filter_core<Grid, Motion>;

 public:
  using typename core::belief_type;
  using typename core::control_type;
  using typename core::estimate_type;
  using typename core::grid_type;
  using typename core::motion_type;
  using typename core::scalar_type;
  using measurement_model_type = Measurement;
  using measurement_type = typename Measurement::measurement_type;

  /// A filter with a uniform initial belief.
  bayes_filter(Grid grid, Motion motion, Measurement measurement);

  /// Measurement update with measurement `z`, through the measurement model. With tracking on
  /// (`set_tracking`) and a model with the tracking hook (measurement/concept.hpp), only the
  /// predicted belief's support is evaluated when that is exact to the stated tolerance; the
  /// report's `path` says which ran.
  update_report update(const measurement_type& z);

  /// Runs the measurement model's whole-grid operations on the executor `e`
  /// (tacmap/executor/concept.hpp): `thread_pool_executor`, `tbb_executor` or the user's own,
  /// which must outlive its use; an empty `executor_ref` goes back to sequential. For models
  /// that accept one (`descriptor_likelihood::set_executor`: the same values bit for bit).
  void set_executor(executor_ref e) requires requires(Measurement& m) { m.set_executor(e); }
  { measurement_.set_executor(e); }

  /// Measurement update with a log-likelihood computed elsewhere: a flat array of `size()`
  /// values, or an image of `rows() x cols()` for single-layer grids.
  template <class Derived>
  update_report update_log_likelihood(const Eigen::DenseBase<Derived>& log_likelihood) {
    const Eigen::Index n = this->grid_.size();
    if (log_likelihood.rows() == n && log_likelihood.cols() == 1) {
      this->log_likelihood_ = log_likelihood.derived().template cast<scalar_type>();
    } else if (log_likelihood.rows() == this->grid_.rows() &&
               log_likelihood.cols() == this->grid_.cols() &&
               n == this->grid_.rows() * this->grid_.cols()) {
      Eigen::Map<image<scalar_type>>(this->log_likelihood_.data(), this->grid_.rows(),
                                     this->grid_.cols()) =
          log_likelihood.derived().template cast<scalar_type>();
    } else {
      detail::fail("bayes_filter::update_log_likelihood: log-likelihood is ", log_likelihood.rows(),
                   " x ", log_likelihood.cols(), "; expected ", n,
                   " x 1 (one value per state) or the belief image ", this->grid_.rows(), " x ",
                   this->grid_.cols());
    }
    return this->apply_log_likelihood(this->log_likelihood_, "the given log-likelihood");
  }

  /// Predict with `u`, then update with `z` (one step of Table 1).
  update_report step(const control_type& u, const measurement_type& z) {
    this->predict(u);
    return update(z);
  }

  [[nodiscard]] const Measurement& measurement_model() const { return measurement_; }
  [[nodiscard]] Measurement& measurement_model() { return measurement_; }

 private:
  using core::belief_;
  using core::grid_;
  using core::log_likelihood_;
  using core::reference_log_uniform_;
  using core::region_;
  using core::tracked_run_;
  using core::tracking_;
  using typename core::tracked_region;

  update_path tracked_update(const measurement_type& z, update_report& report,
                             const tracked_region* region);
  update_report update_full(const measurement_type& z);

  Measurement measurement_;
};

// The heavy members, defined out of the class: not inline, so that where tacmap::precompiled
// declares an instantiation `extern template` (tacmap/precompiled.hpp) the compiler does not
// instantiate them again for inlining. (Not being inline, an instantiation on a type local to a
// translation unit that leaves one unused would be reported by -Wunused-function.)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"

namespace detail {
template <state_grid Grid, motion_model<Grid> Motion>
filter_core<Grid, Motion>::filter_core(Grid grid, Motion motion)
    : grid_(std::move(grid)),
      motion_(std::move(motion)),
      belief_(grid_.size()),
      scratch_(grid_.size()),
      log_likelihood_(grid_.size()),
      since_save_(grid_.rows(), grid_.cols()),
      since_stats_(grid_.rows(), grid_.cols()),
      // State coordinates are fixed for the filter's life: cached once (relative to the first
      // state, which keeps them small) so estimate() is passes over the belief, not N grid calls.
      stats_(make_statistics(grid_)) {
  TACMAP_ASSERT(grid_.size() > 0 && grid_.size() % (grid_.rows() * grid_.cols()) == 0,
                "a state_grid's size must be a positive multiple of rows * cols");
  reset();
}

template <state_grid Grid, motion_model<Grid> Motion>
prediction_report filter_core<Grid, Motion>::predict(const control_type& u) {
  if constexpr (moves_box<Motion, Grid>) {
    // The states outside the boxes hold r <= epsilon (tracked_update): moving only the boxes
    // keeps the prediction within TV r of the whole grid's (the outside's exact prediction and
    // its value left in place both have mass <= r), for a few hundred states per layer instead
    // of all of them. Boxes that together cover more than max_support of the belief image
    // would cost more than the whole grid's passes.
    const auto small = [&](const std::vector<grid_box>& boxes) {  // in every layer
      double area = 0.0;
      for (const grid_box& b : boxes) area += static_cast<double>(b.rows * b.cols);
      return area <= tracking_.max_support * static_cast<double>(grid_.rows() * grid_.cols());
    };
    if (region_ && !region_->moved &&
        region_->outside <= (tracking_.epsilon + floor_allowance()) * (1.0 + 1e-4) &&
        small(region_->boxes)) {
      const std::span<const grid_box> old(region_->boxes);
      const double before =
          detail::mass_in(belief_.data(), old, grid_.rows(), grid_.cols(), layers());
      double dropped = 0.0;
      // The motion writes inside the old boxes and the rectangles it reports in `landed_`
      // (moves_box); what it wrote before an exception is unknown.
      changed(old);
      bool moved = false;
      try {
        moved = motion_.predict_boxes(grid_, belief_, old, u, landed_, dropped);
      } catch (...) {
        changed_all();
        throw;
      }
      if (moved) {
        changed(landed_);
        // Where the mass now is: the windows, overlapping ones united (disjoint boxes, so that
        // the next update counts each state once). The states outside them kept their values;
        // so did the states of the new region that were outside the old boxes: their mass
        // leaves the outside's bound (in double over the region's few states; the moved mass
        // is the boxes' less what was dropped, up to rounding).
        region_->boxes = landed_;
        detail::merge_boxes(region_->boxes, 0);
        const std::span<const grid_box> now(region_->boxes);
        const double after =
            detail::mass_in(belief_.data(), now, grid_.rows(), grid_.cols(), layers());
        if (!(std::isfinite(after) && after >= 0.0 && std::isfinite(dropped) && dropped >= 0.0)) {
          // A user's motion model that breaks its contract: the belief is already changed.
          reset();
          detail::fail<std::logic_error>(
              "bayes_filter::predict: the motion model's predict_boxes left mass ", after,
              " in its boxes and dropped ", dropped,
              "; expected finite values >= 0. The belief was reset to uniform; check the "
              "motion model");
        }
        region_->outside =
            std::max(0.0, region_->outside - std::max(0.0, after - (before - dropped)));
        // Mass carried off the grid: `predict` renormalises every state; here the region's
        // states take it back (the outside's share of it, at most its mass times the dropped
        // fraction, is what the bound adds).
        if (dropped > 0.0 && after > 0.0) {
          const auto factor = static_cast<scalar_type>((after + dropped) / after);
          for (const grid_box& b : now)
            for (Eigen::Index a = 0; a < layers(); ++a)
              Eigen::Map<image<scalar_type>>(belief_.data() + a * grid_.rows() * grid_.cols(),
                                             grid_.rows(), grid_.cols())
                  .block(b.row, b.col, b.rows, b.cols) *= factor;
        }
        region_->moved = true;
        return {.mass_lost = dropped,
                .windowed = true,
                .tracking_error_bound = region_->outside + dropped};
      }
    }
  }
  region_.reset();
  const prediction_report report = motion_.predict(grid_, belief_, scratch_, u);
  // A user's motion model that breaks its contract must not poison the belief.
  // In double over short float chunks (mass_sum.hpp), as every sum of a whole belief.
  const double total = detail::mass_sum(scratch_);
  if (!(std::isfinite(total) && total > 0.0) || scratch_.minCoeff() < 0)
    detail::fail<std::logic_error>(
        "bayes_filter::predict: the motion model returned a belief summing to ", total,
        " (or with negative values); expected finite probabilities >= 0 with a positive sum. "
        "The belief is unchanged; check the motion model");
  normalise(scratch_, total);
  changed_all();
  belief_.swap(scratch_);
  return report;
}

template <state_grid Grid, motion_model<Grid> Motion>
update_path filter_core<Grid, Motion>::tracked_update(double bound, evaluate_on evaluate,
                                                      update_report& report,
                                                      const tracked_region* region) {
  if (!(bound < std::numeric_limits<double>::infinity())) return update_path::full;
  const Eigen::Index n = grid_.size();
  const auto max_states = static_cast<Eigen::Index>(tracking_.max_support * static_cast<double>(n));
  // The support S = {p >= t}. After a windowed predict with room left in the budget (the
  // mass outside the region at most epsilon / 2), only the region's states are searched: S
  // holds all of its mass but epsilon - outside, and the states outside it keep their values
  // (below). Otherwise the whole grid: one pass for every candidate threshold's mass below
  // it, one for the ranges (no sort), and the outside is rescaled.
  // With a motion floor the outside may hold up to A more (see tracking_params).
  const double allowance = floor_allowance();
  const double budget = tracking_.epsilon + allowance;
  const bool in_region =
      region != nullptr && region->outside <= 0.5 * tracking_.epsilon + allowance;
  double held_out = 0.0;  // mass outside the searched states
  detail::support_summary s;
  if (in_region) {
    detail::box_ranges(std::span<const grid_box>(region->boxes), grid_.rows(), grid_.cols(),
                       layers(), candidates_);
    const std::span<const state_range> c(candidates_);
    held_out = region->outside;
    const scalar_type t = detail::support_threshold_on(belief_.data(), c, budget - held_out);
    s = detail::support_ranges_on(belief_.data(), c, t, max_states, support_);
  } else {
    const scalar_type t = detail::support_threshold(belief_.data(), n, budget);
    s = detail::support_ranges(belief_.data(), n, t, max_states, support_);
  }
  if (s.too_wide) return update_path::full_wide;
  const bool sampling = tracking_.sample_every > 0;
  // With a floor and no sample, the outside's share is estimated against the last whole-grid
  // update: none yet (a prior set by the user), the whole grid.
  if (allowance > 0.0 && !sampling && !std::isfinite(reference_log_uniform_))
    return update_path::full_contradicted;
  const std::span<const state_range> in(support_);
  std::span<const state_range> sampled;
  if (sampling) {
    // The sample's rows outside S, evaluated with S in one call (the model prepares the touch
    // once). The rows shift each tracked update, so that a narrow peak missed by one is met
    // by the next.
    detail::sample_rows(grid_.rows(), grid_.cols(), layers(), tracking_.sample_every,
                        static_cast<Eigen::Index>(tracked_run_), sample_rows_,
                        tracking_.sample_layers);
    detail::ranges_minus(std::span<const state_range>(sample_rows_), in, sample_out_);
    sampled = std::span<const state_range>(sample_out_);
    detail::ranges_union(in, sampled, evaluated_);
    evaluate.run(evaluate.context, log_likelihood_, std::span<const state_range>(evaluated_));
  } else {
    evaluate.run(evaluate.context, log_likelihood_, in);
  }
  // The NaN and +infinity guards of apply_log_likelihood, on the states evaluated.
  scalar_type top = -std::numeric_limits<scalar_type>::infinity();
  for (const state_range& r : in) {
    const auto scan =
        detail::scan_log_likelihood(log_likelihood_.data() + r.begin, r.end - r.begin);
    if (scan.first_nan >= 0)
      detail::fail<std::domain_error>(
          "bayes_filter::update: the measurement model is NaN at state ", r.begin + scan.first_nan,
          "; expected finite log-likelihoods (or -infinity for "
          "excluded states). The belief is unchanged");
    top = std::max(top, scan.max);
  }
  if (top == std::numeric_limits<scalar_type>::infinity())
    detail::fail<std::domain_error>(
        "bayes_filter::update: the measurement model contains "
        "+infinity; expected finite log-likelihoods. The belief is "
        "unchanged");
  // Every state of S excluded: the whole grid decides (and reports it if all are).
  if (top == -std::numeric_limits<scalar_type>::infinity()) return update_path::full_contradicted;
  // Z (relative to exp(top)) and the inside's uniform evidence; scratch_ = bel_bar * exp(ll -
  // top) on S.
  detail::weight_sums sums;
  for (const state_range& r : in) {
    const detail::weight_sums w =
        detail::weight_by_likelihood(belief_.data() + r.begin, log_likelihood_.data() + r.begin,
                                     top, scratch_.data() + r.begin, r.end - r.begin);
    sums.posterior += w.posterior;
    sums.likelihood += w.likelihood;
  }
  // rho = m exp(L) / Z, with Z = exp(top) * sums.posterior and m the predicted mass outside
  // S (held out of the search, and the searched states below t); in logs (exp(L - top) may
  // overflow). m is inflated by 1e-5 for its float summation. With a motion floor, only the
  // mass beyond the floor's allowance A is bounded so; the rest is estimated below.
  const double unheld = held_out + s.outside;
  const double outside = unheld * (1.0 + 1e-5);
  const double bounded = std::max(0.0, outside - allowance);
  const double rho = bounded > 0.0
                         ? std::exp(std::log(bounded) + (bound - static_cast<double>(top)) -
                                    std::log(sums.posterior))
                         : 0.0;
  if (!(sums.posterior > 0.0 && std::isfinite(sums.posterior)) || !(rho <= tracking_.tolerance))
    return update_path::full_contradicted;
  // The prediction support against the last whole-grid update's uniform evidence F_ref:
  // log(Z_in / F_ref + m), and the outside's estimated share of the full posterior,
  // m F_ref (1 - m) / Z_in (see tracking_params).
  const double log_inside = static_cast<double>(top) + std::log(sums.posterior);
  double estimated_support = std::numeric_limits<double>::quiet_NaN();
  double floor_error = 0.0;
  Eigen::Index sample_states = 0;
  for (const state_range& r : sampled) sample_states += r.end - r.begin;
  if (sample_states > 0) {
    // This touch's evidence outside S from the sample: each sampled state stands for
    // (N - |S|) / |sample| of the outside. Z_out ~ that times sum bel_bar p over the sample,
    // the uniform evidence F ~ (sum_S p + that times sum p over the sample) / N; then
    //   log_prediction_support ~ log((Z_in + Z_out) / F),  outside share ~ Z_out / (Z_in + Z_out)
    // (the full update's own figures, up to the sample's error).
    scalar_type sample_top = -std::numeric_limits<scalar_type>::infinity();
    for (const state_range& r : sampled) {
      const auto scan =
          detail::scan_log_likelihood(log_likelihood_.data() + r.begin, r.end - r.begin);
      if (scan.first_nan >= 0)
        detail::fail<std::domain_error>(
            "bayes_filter::update: the measurement model is NaN at state ",
            r.begin + scan.first_nan,
            "; expected finite log-likelihoods (or -infinity for excluded states). The belief is "
            "unchanged");
      sample_top = std::max(sample_top, scan.max);
    }
    if (sample_top == std::numeric_limits<scalar_type>::infinity())
      detail::fail<std::domain_error>(
          "bayes_filter::update: the measurement model contains +infinity; expected finite "
          "log-likelihoods. The belief is unchanged");
    double log_outside = -std::numeric_limits<double>::infinity();  // log Z_out
    double log_uniform_outside = -std::numeric_limits<double>::infinity();
    if (sample_top > -std::numeric_limits<scalar_type>::infinity()) {
      detail::weight_sums w;
      for (const state_range& r : sampled) {
        const detail::weight_sums k =
            detail::weight_by_likelihood(belief_.data() + r.begin, log_likelihood_.data() + r.begin,
                                         sample_top, scratch_.data() + r.begin, r.end - r.begin);
        w.posterior += k.posterior;
        w.likelihood += k.likelihood;
      }
      const double log_scale = std::log(static_cast<double>(n - s.states)) -
                               std::log(static_cast<double>(sample_states));
      const auto top_p = static_cast<double>(sample_top);
      // The outside's prediction as the whole grid's predict gives it: its values (what the
      // last whole-grid update left, moved or not) and the floor's lambda / N on every state,
      // which windowed predicts leave out (restore_floor).
      const double lambda = uniform_floor();
      const double weighted =
          (1.0 - lambda) * w.posterior + lambda / static_cast<double>(n) * w.likelihood;
      if (weighted > 0.0) log_outside = log_scale + top_p + std::log(weighted);
      log_uniform_outside = log_scale + top_p + std::log(w.likelihood);
    }
    const auto log_add = [](double a, double b) {
      const double hi = std::max(a, b), lo = std::min(a, b);
      return hi == -std::numeric_limits<double>::infinity() ? hi
                                                            : hi + std::log1p(std::exp(lo - hi));
    };
    const double log_uniform =
        log_add(static_cast<double>(top) + std::log(sums.likelihood), log_uniform_outside) -
        std::log(static_cast<double>(n));
    const double log_total = log_add(log_inside, log_outside);
    estimated_support = log_total - log_uniform;
    const double share = std::exp(log_outside - log_total);
    if (!(estimated_support >= tracking_.doubt)) return update_path::full_contradicted;
    floor_error = std::max(outside, share);
  } else if (std::isfinite(reference_log_uniform_)) {
    const double ratio = std::exp(log_inside - reference_log_uniform_);  // Z_in / F_ref
    estimated_support = std::log(ratio + outside);
    if (!(estimated_support >= tracking_.doubt)) return update_path::full_contradicted;
    if (allowance > 0.0)
      floor_error = outside * std::max(1.0, (1.0 - std::min(outside, 1.0)) / ratio);
  }
  double outside_after = 0.0;  // a bound on the posterior's mass outside S
  if (in_region || allowance > 0.0) {
    // Outside S the states keep their values: the outside's likelihood is taken as the
    // inside's mean under the prediction, Z_in / (1 - m) <= exp(top) <= exp(L), so
    // TV <= rho as for any value up to the bound. No pass over the grid; the outside's mass
    // stays m while the region is tracked (its epsilon / 2 budget checked above). With a
    // motion floor after a whole-grid search too: the floor's states keep their share, which
    // the estimate above accounts for (tracking_params).
    const double inverse = (1.0 - unheld) / sums.posterior;
    if (!(unheld < 1.0) ||
        !(inverse < static_cast<double>(std::numeric_limits<scalar_type>::max())))
      return update_path::full_contradicted;
    const auto scale = static_cast<scalar_type>(inverse);
    changed(in);
    for (const state_range& r : in)
      belief_.segment(r.begin, r.end - r.begin) =
          scratch_.segment(r.begin, r.end - r.begin) * scale;
    outside_after = outside;
  } else {
    // Outside S: the smallest log-likelihood found inside S. Any value up to the bound keeps
    // TV <= rho; this one shrinks the outside's mass (by the inside's worst factor), which
    // gives the region searches that follow their budget, and keeps it positive where the
    // prediction was.
    scalar_type low = top;
    for (const state_range& r : in)
      low = std::min(low, log_likelihood_.segment(r.begin, r.end - r.begin).minCoeff());
    const double outside_factor = std::exp(static_cast<double>(low) - static_cast<double>(top));
    const double total = sums.posterior + s.outside * outside_factor;
    const double inverse = 1.0 / total;
    if (!(inverse < static_cast<double>(std::numeric_limits<scalar_type>::max())))
      return update_path::full_contradicted;  // the normaliser would overflow: the full path
    const auto scale = static_cast<scalar_type>(inverse);
    changed_all();
    belief_ *= static_cast<scalar_type>(outside_factor * inverse);
    for (const state_range& r : in)
      belief_.segment(r.begin, r.end - r.begin) =
          scratch_.segment(r.begin, r.end - r.begin) * scale;
    outside_after = outside * outside_factor * inverse;
  }
  {
    // Boxes holding S for the next predict (on the belief image, every layer's states
    // united; clusters more than 4 cells apart in boxes of their own), and the mass outside
    // them: S's outside less the boxes' states outside S. Boxes wider together than
    // max_support of the image would not be moved alone: no region then.
    std::vector<grid_box> boxes =
        detail::cluster_boxes(in, grid_.rows(), grid_.cols(), 4, max_region_boxes);
    double area = 0.0;
    for (const grid_box& b : boxes) area += static_cast<double>(b.rows * b.cols);
    if (!boxes.empty() &&
        area <= tracking_.max_support * static_cast<double>(grid_.rows() * grid_.cols())) {
      detail::box_ranges(std::span<const grid_box>(boxes), grid_.rows(), grid_.cols(), layers(),
                         candidates_);
      const double kept =
          detail::mass_outside_of(belief_.data(), std::span<const state_range>(candidates_), in);
      region_ = tracked_region{std::move(boxes), std::max(0.0, outside_after - kept), false};
    }
  }
  const double log_evidence = std::log(sums.posterior);
  report = {.log_evidence = log_evidence,
            .log_likelihood_max = static_cast<double>(top),
            .log_prediction_support = allowance > 0.0 ? estimated_support
                                                      : log_evidence - std::log(sums.likelihood) +
                                                            std::log(static_cast<double>(n)),
            .path = update_path::tracked,
            .evaluated_states = s.states,
            .tracking_error_bound = rho + floor_error};
  return update_path::tracked;
}
template <state_grid Grid, motion_model<Grid> Motion>
update_report filter_core<Grid, Motion>::apply_log_likelihood(const belief_type& ll,
                                                              const char* source) {
  const auto scan = detail::scan_log_likelihood(ll.data(), ll.size());
  if (scan.first_nan >= 0)
    detail::fail<std::domain_error>("bayes_filter::update: ", source, " is NaN at state ",
                                    scan.first_nan,
                                    "; expected finite log-likelihoods (or -infinity for "
                                    "excluded states). The belief is unchanged");
  const scalar_type top = scan.max;
  if (top == std::numeric_limits<scalar_type>::infinity())
    detail::fail<std::domain_error>("bayes_filter::update: ", source,
                                    " contains +infinity; expected finite log-likelihoods. "
                                    "The belief is unchanged");
  if (top == -std::numeric_limits<scalar_type>::infinity())
    detail::fail<std::domain_error>("bayes_filter::update: ", source,
                                    " is -infinity everywhere (it rules out every state); "
                                    "expected at least one finite value. The belief is "
                                    "unchanged");
  const detail::weight_sums sums =
      detail::weight_by_likelihood(belief_.data(), ll.data(), top, scratch_.data(), ll.size());
  const double total = sums.posterior;
  if (!(total > 0.0) || !std::isfinite(total))
    detail::fail<contradiction_error>(
        "bayes_filter::update: ", source, " gives zero probability to every state the belief ",
        "still allows (posterior sum ", total,
        "); the measurement contradicts the prediction. "
        "The belief is unchanged; call reset() to start again from a uniform belief");
  normalise(scratch_, total);
  changed_all();
  belief_.swap(scratch_);
  region_.reset();
  // sums.likelihood >= 1 (the maximum's own factor), so the logarithm is finite.
  const double log_evidence = std::log(total);
  return {.log_evidence = log_evidence,
          .log_likelihood_max = static_cast<double>(top),
          .log_prediction_support =
              log_evidence - std::log(sums.likelihood) + std::log(static_cast<double>(ll.size())),
          .evaluated_states = ll.size()};
}

template <state_grid Grid, motion_model<Grid> Motion>
double filter_core<Grid, Motion>::probability_within(const Eigen::Vector2d& center_mm,
                                                     double radius_mm) const
    requires(Grid::dimension >= 2) {
  if (!center_mm.allFinite())
    detail::fail("bayes_filter::probability_within: centre (", center_mm(0), ", ", center_mm(1),
                 ") mm; expected finite map coordinates");
  if (!(std::isfinite(radius_mm) && radius_mm >= 0.0))
    detail::fail("bayes_filter::probability_within: radius ", radius_mm,
                 " mm; expected a finite radius >= 0");
  const Eigen::Index k = leading_block();
  return stats_[static_cast<std::size_t>(k)].probability_within(block(k), center_mm, radius_mm);
}
template <state_grid Grid, motion_model<Grid> Motion>
std::pair<Eigen::Vector2d, double> filter_core<Grid, Motion>::most_probable_disc(
    double radius_mm) const requires(Grid::dimension >= 2) {
  if (!(std::isfinite(radius_mm) && radius_mm >= 0.0))
    detail::fail("bayes_filter::most_probable_disc: radius ", radius_mm,
                 " mm; expected a finite radius >= 0");
  if constexpr (summary_grid)
    if (summarised()) return stats_[0].most_probable_disc_summarised(grid_, radius_mm);
  const Eigen::Index k = leading_block();
  return stats_[static_cast<std::size_t>(k)].most_probable_disc(statistics_grid(k), block(k),
                                                                radius_mm);
}
}  // namespace detail

template <state_grid Grid, motion_model<Grid> Motion, measurement_model<Grid> Measurement>
bayes_filter<Grid, Motion, Measurement>::bayes_filter(Grid grid, Motion motion,
                                                      Measurement measurement)
    : core(std::move(grid), std::move(motion)), measurement_(std::move(measurement)) {}

template <state_grid Grid, motion_model<Grid> Motion, measurement_model<Grid> Measurement>
update_report bayes_filter<Grid, Motion, Measurement>::update(const measurement_type& z) {
  const std::optional<tracked_region> region = std::move(region_);
  region_.reset();
  update_path fallback = update_path::full;
  if constexpr (measures_on_states<Measurement, Grid> &&
                !detail::measures_given_prediction<Measurement, Grid>) {
    if (tracking_.epsilon > 0.0) {
      if (tracking_.recheck_every > 0 && tracked_run_ >= tracking_.recheck_every) {
        fallback = update_path::full_recheck;
      } else {
        update_report report;
        fallback = tracked_update(z, report, region && region->moved ? &*region : nullptr);
        if (fallback == update_path::tracked) {
          ++tracked_run_;
          return report;
        }
      }
    }
  }
  // After windowed predicts, the floor they left out (see restore_floor).
  const bool floor_left_out =
      tracking_.epsilon > 0.0 && region && region->moved && this->uniform_floor() > 0.0;
  if (floor_left_out) this->restore_floor();
  update_report report;
  try {
    report = update_full(z);
  } catch (...) {
    if (floor_left_out) this->unrestore_floor();
    throw;
  }
  report.path = fallback;
  // The reference for the tracked updates that follow: log (1/N) sum_x p(z | x).
  reference_log_uniform_ = report.log_marginal_likelihood() - report.log_prediction_support;
  tracked_run_ = 0;
  return report;
}

template <state_grid Grid, motion_model<Grid> Motion, measurement_model<Grid> Measurement>
update_path bayes_filter<Grid, Motion, Measurement>::tracked_update(const measurement_type& z,
                                                                    update_report& report,
                                                                    const tracked_region* region) {
  // Whole-class instantiations (explicit, or extern in tacmap::precompiled) compile this for
  // models without the hook too: it is never called for them.
  if constexpr (!measures_on_states<Measurement, Grid>) {
    (void)z;
    (void)report;
    (void)region;
    return update_path::full;
  } else {
    // The model's log_likelihood_on behind a function pointer, so that the search itself is
    // the core's (one indirect call per update).
    struct call {
      const Measurement* model;
      const Grid* grid;
      const measurement_type* z;
    };
    const call c{&measurement_, &grid_, &z};
    const typename core::evaluate_on evaluate{
        [](const void* context, belief_type& out, std::span<const state_range> states) {
          const call& k = *static_cast<const call*>(context);
          k.model->log_likelihood_on(*k.grid, *k.z, out, states);
        },
        &c};
    return core::tracked_update(static_cast<double>(measurement_.log_likelihood_bound()), evaluate,
                                report, region);
  }
}

template <state_grid Grid, motion_model<Grid> Motion, measurement_model<Grid> Measurement>
update_report bayes_filter<Grid, Motion, Measurement>::update_full(const measurement_type& z) {
  if constexpr (detail::measures_given_prediction<Measurement, Grid>)
    measurement_.log_likelihood(grid_, z, log_likelihood_, std::as_const(belief_));
  else
    measurement_.log_likelihood(grid_, z, log_likelihood_);
  if (log_likelihood_.size() != grid_.size()) {
    const Eigen::Index got = log_likelihood_.size();
    log_likelihood_.resize(grid_.size());
    detail::fail("bayes_filter::update: the measurement model resized its output to ", got,
                 " values; expected ", grid_.size(), " (one per state). The belief is unchanged");
  }
  return this->apply_log_likelihood(log_likelihood_, "the measurement model");
}

namespace detail {
template <state_grid Grid, motion_model<Grid> Motion>
auto filter_core<Grid, Motion>::estimate() const -> estimate_type {
  if constexpr (library_state_grid<Grid>) {
    // Positions of different objects are in different maps: the estimate is that of the most
    // probable object's position belief, conditioned on that object.
    std::vector<double> p = object_posterior(grid_, belief_);
    const auto k = static_cast<Eigen::Index>(std::max_element(p.begin(), p.end()) - p.begin());
    const double mass = p[static_cast<std::size_t>(k)];
    const Eigen::Index at = grid_.object_offset(k), n = grid_.object_size(k);
    const belief_array<statistics_grid_type> conditional =
        (belief_.segment(at, n).template cast<double>() / mass).template cast<scalar_type>();
    estimate_type e = stats_[static_cast<std::size_t>(k)].estimate(
        grid_.object(k), typename statistics_type::view_type(conditional.data(), n));
    e.map_index += at;
    e.map_probability *= mass;
    e.map_object = k;
    for (Eigen::Index j = 0; j < grid_.objects(); ++j)
      if (j != k && std::abs(p[static_cast<std::size_t>(j)] - mass) <= 1e-6 * mass)
        e.tied_objects.push_back(j);
    e.object_probability = std::move(p);
    return e;
  } else {
    if constexpr (summary_grid)
      if (summarised()) return stats_[0].estimate_summarised(grid_);
    return stats_[0].estimate(grid_, block(0));
  }
}
}  // namespace detail

#pragma GCC diagnostic pop
}  // namespace tacmap
