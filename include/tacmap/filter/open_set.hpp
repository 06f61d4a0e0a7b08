// tacmap: `open_set` — "none of these": the hypothesis that the touched surface is not one the
// filter holds a map of.
//
// A filter over one map (or over a library of maps) answers "where on which of these" — its
// posterior sums to one over the states it holds, so a touch on another object is always
// explained as *somewhere* on a known map, and a chance fit of a few touches can end in a
// confident, wrong "localized". The open-set hypothesis U weighs that alternative by the touches'
// evidence, like the objects are weighed against each other (library_grid.hpp):
//
//   P(U | z_1..t) / P(K | z_1..t) = P(U) / (1 - P(U)) * prod_t p(z_t | U) / p(z_t | K, z_1..t-1)
//
// where K is "one of the maps" (the filter's own hypothesis space) and p(z_t | K, z_1..t-1) =
// sum_x p(z_t | x) bel_bar(x) the filter's evidence of the touch (`update_report::
// log_marginal_likelihood`). The filter's belief over its own states is untouched: U is one
// number beside it, and the filter's posterior is the posterior given K.
//
// The model of an unknown surface, p(z | U). What separates a known surface from an unknown one
// is memory: on the object, the touches fit one surface along the arm's motions; on a surface
// we hold no map of, each touch fits the maps only by chance. The unknown surface is modelled
// against the population of windows the filter holds (a touch on a surface we hold no map of
// looks like a window drawn at random from surfaces in general, and the maps are our sample of
// those): with S_t the touch's `update_report::log_prediction_support`, log [p(z_t | K, past) /
// ((1/N_e) sum_x p(z_t | x))] over the N_e states the update evaluated, the per-touch log Bayes
// factor is
//
//   log p(z_t | K, z_1..t-1) - log p(z_t | U) = a * (S_t - d),                          (1)
//
// computed from the update's own report: no extra pass. a = 1, d = 0 is the memoryless model,
// p(z | U) = (1/N_e) sum_x p(z | x) afresh at each touch: its factor is the support itself. That
// model is too easily convinced, for a measured reason: a chance fit persists. A touch near the
// last one fits near the last fit, so supports of a nat or two on an unknown surface are
// neither rare nor independent draws, and a few of them looked like a known object. Model (1)
// answers with two numbers. d: an unknown surface explains a touch e^d times better than a
// random window of the maps (its touches follow their own chance fits), so a touch must support
// the prediction by more than d nats to count for the maps; every first touch (S = 0, a uniform
// prediction) raises P(U) a little. a < 1: each touch's support is discounted for the
// dependence between touches.
//
// a and d are fitted, not chosen: maximum likelihood of "known" against "unknown" at every
// touch of simulated sequences (logistic regression on the cumulative sums of S and of the
// touches; tacmap-evaluate's --library-mode closed and own-map for "known", left-out and
// wrong-object for "unknown"; realistic scenario; the evaluation photographs, seeds 1-3; the
// classes weighed equally, so that the fit's prior is 0.5), with the shipped measurement model
// and the map blurred as the sensor sees it (the default `localizer_config::pad_spread_mm`; the
// fit on the unblurred maps, a = 0.645 and d = 0.769, is off by more than the seeds' spread
// under the blur: docs/open_set.md).
// S is a ratio of one model's likelihoods, with no reference level, so the fit carries over to
// other descriptors better than a fitted likelihood level would (a fitted level of the maps'
// mean likelihood, tried beside S, helped a little on the evaluation photographs, not on the
// held-out ones, and is 8 nats off for SIFT-lite); a model whose likelihood is much sharper or
// flatter than the shipped one's changes the scale of S and deserves its own fit (the script
// scripts/fit_open_set.py reads tacmap-evaluate's CSVs and prints a and d).
//
// A model with memory: the shadow filter (`unknown_model::shadow`). Eq. 1 weighs each touch
// alone against a population level; what it cannot see is that an unknown surface's chance fits
// also persist along the arm's motions, so that on a surface we hold no map of a filter over
// *any* maps of that kind gains predictive evidence by chance as the library's filter does. The
// shadow model runs a second filter, over surrogate maps (each map mirrored left to right:
// the same textures, contrasts and scale, but no surface the touches come from), with the same
// motions and touches and the same restarts, and weighs the library's predictive evidence L_t
// = log p(z_t | K, z_1..t-1) against the shadow's L'_t:
//
//   log p(z_t | K, z_1..t-1) - log p(z_t | U, z_1..t-1) = b (L_t - L'_t) + c S_t - m,      (2)
//
// with b = 1, c = 0, m = 0 the Bayes factor of the library against "a surface like these,
// mirrored" (p(z | U) estimated by the shadow's mixture over the surrogates), and b, c, m fitted
// as a and d are (scripts/fit_open_set.py --model shadow). The shadow costs a second filter: its
// maps' preparation, memory and every touch's update. Both front doors run it where
// `open_set_params::model` says so (the single-map `localizer` on its mirrored map, with a known
// heading; with headings it weighs eq. 1).
//
// The prior P(U) is a configured value (`open_set_params::prior_unknown`), what the robot
// believes before touching: the default 0.5 says "as likely something we never photographed as
// one of the photographs" — the most ignorant split between the two, not a value fitted to an
// evaluation. The verdict (confidence.hpp) then needs P(K) x P(right position | K) >= threshold:
// the object and the position must beat the unknown (`with_open_set`). Where the filter evaluates
// only part of its states (a library's pruned objects, the tracked path), S is over the states
// evaluated, as in the fit. A restart of the filter from a uniform belief
// (localizer.hpp, `predict_and_update`) restarts the question too: P(U) goes back to its prior.
#pragma once

#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

#include "tacmap/config.hpp"
#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/filter/confidence.hpp"

namespace tacmap {

/// How a touch on an unknown surface is modelled (see the file comment).
enum class unknown_model {
  /// Eq. 1: a (S - d) from the filter's own prediction support S; no extra cost, no memory.
  support,
  /// Eq. 2: b (L - L') + c S - m from the touch's predictive evidence L under the maps, L'
  /// under a shadow filter over surrogate maps (each map mirrored) run along with the same
  /// motions and touches, and the support S.
  shadow,
};

/// Configuration of the open-set hypothesis (see the file comment, eqs. 1 and 2).
struct open_set_params {
  /// P(U): the prior probability that the touched surface is none of the maps, in (0, 1). 0.5:
  /// as likely unknown as known (the most ignorant split). Smaller trusts the library more: the
  /// touches then need less support before "localized", and an unknown object needs more to
  /// be called one.
  double prior_unknown = 0.5;
  /// a in eq. 1, in (0, 1]: how much of each touch's support counts, a discount for touches
  /// that are not independent (a chance fit persists). 1: the memoryless model.
  double evidence_weight = 0.551;
  /// d in eq. 1, in [0, 20] nats: the support a touch needs before it counts for the maps (an
  /// unknown surface's own chance fits). 0: the memoryless model.
  double support_margin = 0.927;
  /// Which model weighs the touches: `shadow` runs the shadow filter beside the library's or
  /// the single map's (known heading; a `localizer` with headings weighs `support`).
  unknown_model model = unknown_model::support;
  /// b in eq. 2, in (0, 1]: the weight on each touch's evidence against the shadow's; fitted.
  double shadow_weight = 0.538;
  /// c in eq. 2, in [0, 1]: the weight on each touch's support beside it; fitted.
  double shadow_support_weight = 0.241;
  /// m in eq. 2, in [-20, 20] nats: what each touch must earn before it counts for the maps;
  /// fitted.
  double shadow_margin = 0.618;

  void validate() const {
    if (!(std::isfinite(prior_unknown) && prior_unknown > 0.0 && prior_unknown < 1.0))
      detail::fail("open_set_params: prior_unknown = ", prior_unknown,
                   "; expected a probability in (0, 1) that the touched surface is none of the "
                   "maps (e.g. 0.5: as likely unknown as known)");
    if (!(std::isfinite(evidence_weight) && evidence_weight > 0.0 && evidence_weight <= 1.0))
      detail::fail("open_set_params: evidence_weight = ", evidence_weight,
                   "; expected a weight in (0, 1] on each touch's evidence (1: every touch "
                   "independent; the fitted default is 0.551)");
    if (!(std::isfinite(support_margin) && support_margin >= 0.0 && support_margin <= 20.0))
      detail::fail("open_set_params: support_margin = ", support_margin,
                   "; expected nats in [0, 20] a touch's prediction support needs before it "
                   "counts for the maps (0: the memoryless model; the fitted default is 0.927)");
    if (model != unknown_model::support && model != unknown_model::shadow)
      detail::fail("open_set_params: model = ", static_cast<int>(model),
                   "; expected unknown_model::support or unknown_model::shadow");
    if (!(std::isfinite(shadow_weight) && shadow_weight > 0.0 && shadow_weight <= 1.0))
      detail::fail("open_set_params: shadow_weight = ", shadow_weight,
                   "; expected a weight in (0, 1] on each touch's evidence against the shadow "
                   "filter's (1: the Bayes factor itself; the fitted default is 0.538)");
    if (!(std::isfinite(shadow_support_weight) && shadow_support_weight >= 0.0 &&
          shadow_support_weight <= 1.0))
      detail::fail("open_set_params: shadow_support_weight = ", shadow_support_weight,
                   "; expected a weight in [0, 1] on each touch's prediction support beside its "
                   "evidence against the shadow filter's (0: the evidence alone; the fitted "
                   "default is 0.241)");
    if (!(std::isfinite(shadow_margin) && shadow_margin >= -20.0 && shadow_margin <= 20.0))
      detail::fail("open_set_params: shadow_margin = ", shadow_margin,
                   "; expected nats in [-20, 20] each touch must earn before it counts for the "
                   "maps (the fitted default is 0.618)");
  }
};

/// P(U | touches so far) beside a filter: the log odds of "none of the maps" against "one of
/// them", updated by each touch's log Bayes factor (see the file comment).
class open_set {
 public:
  /// Throws std::invalid_argument for invalid parameters.
  explicit open_set(const open_set_params& params = {}) : params_(params) {
    params_.validate();
    reset();
  }

  /// Back to the prior (a new exploration, or the filter restarted from a uniform belief).
  void reset() { log_odds_ = std::log(params_.prior_unknown) - std::log1p(-params_.prior_unknown); }

  /// The log Bayes factor of one touch (eq. 1) from its update's report (the support over the
  /// states the update evaluated); -infinity for a touch that contradicted the prediction.
  [[nodiscard]] double log_factor(const update_report& report) const {
    return params_.evidence_weight * (report.log_prediction_support - params_.support_margin);
  }

  /// The log Bayes factor of one touch (eq. 2) from the filter's report and the shadow
  /// filter's report of the same touch.
  [[nodiscard]] double log_factor(const update_report& report, const update_report& shadow) const {
    return params_.shadow_weight *
               (report.log_marginal_likelihood() - shadow.log_marginal_likelihood()) +
           params_.shadow_support_weight * report.log_prediction_support - params_.shadow_margin;
  }

  /// One touch of the filter, as its update reported it (eq. 1).
  void observe(const update_report& report) { observe_log_factor(log_factor(report)); }
  /// One touch of the filter and of its shadow (eq. 2).
  void observe(const update_report& report, const update_report& shadow) {
    observe_log_factor(log_factor(report, shadow));
  }

  /// One touch given directly as log p(z | K, past) - log p(z | U) (finite, or -infinity when
  /// the touch ruled out every state the prediction allowed).
  void observe_log_factor(double log_known_over_unknown) {
    if (std::isnan(log_known_over_unknown) ||
        log_known_over_unknown == std::numeric_limits<double>::infinity())
      detail::fail("open_set::observe: the touch's log Bayes factor is ", log_known_over_unknown,
                   "; expected a finite value (or -infinity: the touch contradicts the maps)");
    log_odds_ -= log_known_over_unknown;
  }

  /// P(U | touches so far), in [0, 1].
  [[nodiscard]] double probability_unknown() const {
    // The logistic, written so that neither tail overflows.
    if (log_odds_ >= 0.0) return 1.0 / (1.0 + std::exp(-log_odds_));
    const double e = std::exp(log_odds_);
    return e / (1.0 + e);
  }
  /// log P(U | ...) - log P(K | ...).
  [[nodiscard]] double log_odds() const { return log_odds_; }
  [[nodiscard]] const open_set_params& params() const { return params_; }

 private:
  open_set_params params_;
  double log_odds_ = 0.0;
};

namespace detail {
/// A front door's touch seen by its open set: a filter that restarted from a uniform belief
/// restarts the question (back to the prior; the touch that restarted it is not weighed, its
/// report describes the prediction that failed); otherwise an update (none for a rejected frame)
/// adds its factor: eq. 2 against the shadow filter's report where one is given, else eq. 1.
inline void follow_touch(open_set& unknown, bool restarted,
                         const std::optional<update_report>& report,
                         const std::optional<update_report>& shadow = std::nullopt) {
  if (restarted)
    unknown.reset();
  else if (report && shadow)
    unknown.observe(*report, *shadow);
  else if (report)
    unknown.observe(*report);
}

/// The open set's shadow filter through one touch of the filter it shadows (eq. 2): the same
/// motion (none on a first touch), the same frame (none when it was rejected), and a restart
/// from uniform when the filter restarted. A motion or a touch that rules out every state the
/// shadow allowed restarts the shadow alone (an unknown surface's chance fits need not follow
/// the odometry): its evidence is then the touch's under a uniform belief. Returns the shadow's
/// report of the touch (none for a rejected frame).
template <class Filter, class Motion, class Measurement>
std::optional<update_report> shadow_step(Filter& shadow, const std::optional<Motion>& moved,
                                         const Measurement* z, bool restarted) {
  if (restarted) {
    shadow.reset();
  } else if (moved) {
    try {
      shadow.predict(*moved);
    } catch (const std::domain_error&) {
      shadow.reset();
    }
  }
  if (z == nullptr) return std::nullopt;
  try {
    return shadow.update(*z);
  } catch (const contradiction_error&) {
    shadow.reset();
    return shadow.update(*z);
  }
}
}  // namespace detail

/// The verdict with the open-set hypothesis: `probability_within` becomes P(K) x P(within | K)
/// (the maps' hypothesis and the position right), and "localized" needs that joint probability
/// at the threshold; `contradicted` and the other verdicts stay as they are.
[[nodiscard]] inline confidence with_open_set(confidence c, double probability_unknown,
                                              const confidence_params& params) {
  c.probability_within *= 1.0 - probability_unknown;
  if (c.verdict == verdict::localized && !(c.probability_within >= params.threshold))
    c.verdict = verdict::uncertain;
  return c;
}

}  // namespace tacmap
