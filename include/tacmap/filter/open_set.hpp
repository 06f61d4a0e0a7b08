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
// The model of an unknown surface, p(z | U). A touch on a surface we hold no map of is modelled
// as a window drawn at random, independently at each touch, from the population of windows of
// surfaces in general; that population is fitted as the empirical distribution of the windows
// the filter holds (every state of every map, each equally, the appearance hypotheses by their
// prior), with the measurement model's own kernel:
//
//   p(z | U) = (1 / N) sum_x p(z | x),
//
// the touch's likelihood at a uniformly drawn state — the same scale as the maps' likelihoods
// (one descriptor, one tau), nothing tuned to a case. Its log is what the filter already computes
// as the reference of `update_report::log_prediction_support`, so the per-touch log Bayes factor
// is that support:
//
//   log p(z_t | K, z_1..t-1) - log p(z_t | U) = log_prediction_support_t,
//
// and U costs no extra pass over the grid. What distinguishes the two is memory: under K the
// touches must fit one surface along the arm's motions, under U each touch is new. On the first
// touch (a uniform prediction) the factor is exactly 1 and P(U) stays at its prior; each later
// touch that lands where the prediction expected it (support > 0) lowers P(U), each that fits the
// map at large better than where the motion says it should be raises it. A touch on a known
// object soon gives supports of several nats (up to log N); on an unknown one the prediction is a
// chance fit, and the supports hover around or below zero.
//
// Where the filter evaluates only part of its states (a library's pruned objects, the tracked
// path), the population is the states evaluated (`library_likelihood` prunes objects the touches
// have ruled out; the caller gives the fraction of the states evaluated, see `observe`). A
// restart of the filter from a uniform belief (localizer.hpp, `predict_and_update`) restarts the
// question too: P(U) goes back to its prior.
//
// The prior P(U) is a configured value (`open_set_params::prior_unknown`), what the robot
// believes before touching: the default 0.5 says "as likely something we never photographed as
// one of the photographs" — the most ignorant split between the two, not a value fitted to an
// evaluation. The verdict (confidence.hpp) then needs P(K) x P(right position | K) >= threshold:
// the object and the position must beat the unknown (`with_open_set`).
#pragma once

#include <cmath>
#include <limits>
#include <optional>

#include "tacmap/config.hpp"
#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/filter/confidence.hpp"

namespace tacmap {

/// Configuration of the open-set hypothesis (see the file comment).
struct open_set_params {
  /// P(U): the prior probability that the touched surface is none of the maps, in (0, 1). 0.5:
  /// as likely unknown as known (the most ignorant split). Smaller trusts the library more: the
  /// touches then need less support before "localized", and an unknown object needs more to
  /// be called one.
  double prior_unknown = 0.5;

  void validate() const {
    if (!(std::isfinite(prior_unknown) && prior_unknown > 0.0 && prior_unknown < 1.0))
      detail::fail("open_set_params: prior_unknown = ", prior_unknown,
                   "; expected a probability in (0, 1) that the touched surface is none of the "
                   "maps (e.g. 0.5: as likely unknown as known)");
  }
};

/// P(U | touches so far) beside a filter: the log odds of "none of the maps" against "one of
/// them", updated by each touch's log Bayes factor (see the file comment).
class open_set {
 public:
  /// Throws std::invalid_argument for an invalid prior.
  explicit open_set(const open_set_params& params = {}) : params_(params) {
    params_.validate();
    reset();
  }

  /// Back to the prior (a new exploration, or the filter restarted from a uniform belief).
  void reset() { log_odds_ = std::log(params_.prior_unknown) - std::log1p(-params_.prior_unknown); }

  /// One touch of the filter, as its update reported it. `evaluated_fraction`: the fraction of
  /// the filter's states its likelihood was evaluated at (in (0, 1]; 1 unless a library pruned
  /// objects): the unknown surface's population is those states (see the file comment).
  void observe(const update_report& report, double evaluated_fraction = 1.0) {
    if (!(evaluated_fraction > 0.0 && evaluated_fraction <= 1.0))
      detail::fail("open_set::observe: evaluated_fraction = ", evaluated_fraction,
                   "; expected the fraction of the states evaluated, in (0, 1]");
    // support = log [Z / ((1/N) sum_{evaluated} p)]; over the evaluated states only the uniform
    // reference is (1/N_e) sum_{evaluated} p, larger by N / N_e.
    observe_log_factor(report.log_prediction_support + std::log(evaluated_fraction));
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
/// restarts the question (back to the prior; the restarted update's prediction was uniform, a
/// factor of 1); otherwise an update (none for a rejected frame) adds its factor.
inline void follow_touch(open_set& unknown, bool restarted,
                         const std::optional<update_report>& report,
                         double evaluated_fraction = 1.0) {
  if (restarted)
    unknown.reset();
  else if (report)
    unknown.observe(*report, evaluated_fraction);
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
