// tacmap: how sure the filter is — a verdict a robot can act on, from the belief itself.
//
// The belief's probability that the estimate lies within a radius of the truth is the mass of
// the states within that radius of the estimate (`bayes_filter::probability_within`). When the
// likelihood's scale is calibrated (tacmap-calibrate; README, "Confidence") that probability
// matches how often it is so, and a threshold on it is a decision rule with known error rates:
// "localized" when P(error <= radius) >= threshold, else "uncertain" (touch again). The
// entropy or the MAP state's own probability cannot serve: on a 1 mm grid a belief spread over
// a 3 mm disc has a MAP probability near 0.1 and is nevertheless right.
#pragma once

#include <cmath>
#include <numbers>
#include <tuple>

#include "tacmap/config.hpp"
#include "tacmap/filter/bayes_filter.hpp"

namespace tacmap {

/// What the belief says about its own estimate, and what a robot should do about it.
enum class verdict {
  uncertain,  ///< P(error <= radius) below the threshold: touch again before acting on it
  localized,  ///< P(error <= radius) at or above the threshold
  /// The last touch fits somewhere the filter did not expect much better than where it did
  /// (`update_report::log_prediction_support` below `confidence_params::contradiction`): an
  /// odometry outlier, a slip or a kidnap may have broken the track. Whatever the belief's
  /// spread, do not act on the estimate: touch again near here, or re-grasp.
  contradicted,
  /// The last frame was no touch (`preprocess` rejected it) and did not update the belief;
  /// the estimate is the prediction. Only `localizer` reports it.
  rejected_frame,
};

[[nodiscard]] inline const char* to_string(verdict v) {
  switch (v) {
    case verdict::uncertain:
      return "uncertain";
    case verdict::localized:
      return "localized";
    case verdict::contradicted:
      return "contradicted";
    case verdict::rejected_frame:
      return "rejected_frame";
  }
  return "?";
}

/// When the filter says "localized".
struct confidence_params {
  /// What "right" means: the estimate within this distance of the truth (mm). 5 mm: the
  /// paper's success criterion (Sec. IV-B) and tacmap-evaluate's.
  double radius_mm = 5.0;
  /// The belief's P(error <= radius_mm) at or above which the verdict is `localized`. 0.9 with
  /// the calibrated default scale: README, "Confidence", states the precision (how often
  /// "localized" is right) and recall (how often a right estimate is called so) it gives.
  double threshold = 0.9;
  /// Pose grids: what a right heading means (radians; 15 degrees).
  double heading_tolerance_rad = 15.0 * std::numbers::pi / 180.0;
  /// The touch's `update_report::log_prediction_support` below which the verdict is
  /// `contradicted`: the touch is that many nats more probable under "anywhere on the map" than
  /// under the prediction. -2 (7.4 times), measured (README, "When exploration goes wrong"):
  /// it fires at 1-2 % of ordinary touches and at 19-26 % of the touches right after an
  /// injected fault, and withdraws 8-19 % of the wrong "localized" claims under faults; -1
  /// withdraws about twice as many at about twice the false alarms. -infinity turns it off.
  double contradiction = -2.0;

  void validate() const {
    if (!(std::isfinite(radius_mm) && radius_mm > 0.0))
      detail::fail("confidence_params: radius_mm = ", radius_mm,
                   "; expected a finite distance > 0 (e.g. 5 mm, the paper's success radius)");
    if (!(std::isfinite(threshold) && threshold > 0.0 && threshold <= 1.0))
      detail::fail("confidence_params: threshold = ", threshold,
                   "; expected a probability in (0, 1] (e.g. 0.9)");
    if (!(std::isfinite(heading_tolerance_rad) && heading_tolerance_rad > 0.0))
      detail::fail("confidence_params: heading_tolerance_rad = ", heading_tolerance_rad,
                   "; expected a finite angle > 0");
    if (std::isnan(contradiction) || contradiction > 0.0)
      detail::fail("confidence_params: contradiction = ", contradiction,
                   "; expected a log Bayes factor <= 0 (e.g. -2: the touch 7.4 times more probable "
                   "elsewhere), or -infinity to turn the check off");
  }
};

/// The belief's confidence in its estimate.
struct confidence {
  /// The estimate the probabilities are about (map frame, mm): the centre of the disc of
  /// `radius_mm` that holds the most belief (`bayes_filter::most_probable_disc`) — the estimate
  /// most probably within `radius_mm` of the truth — or, for grids whose positions are not a
  /// regular lattice, the MAP position.
  Eigen::Vector2d centre_mm = Eigen::Vector2d::Zero();
  /// The belief's P(|position - centre_mm| <= radius_mm), whatever the heading and latent
  /// hypothesis.
  double probability_within = 0.0;
  /// Pose grids: P(|heading - estimated heading| <= heading_tolerance_rad); 1 otherwise.
  double heading_probability = 1.0;
  /// `localized` when both probabilities reach the threshold.
  tacmap::verdict verdict = tacmap::verdict::uncertain;
};

/// The confidence of `filter` in its estimate: the position of `confidence::centre_mm` and,
/// for pose grids, the MAP heading of `e` (its `estimate()`). Throws std::invalid_argument for
/// invalid `params`.
template <class Filter>
[[nodiscard]] confidence assess(const Filter& filter, const typename Filter::estimate_type& e,
                                const confidence_params& params = {}) {
  params.validate();
  confidence c;
  if (filter.positions_form_lattice()) {
    std::tie(c.centre_mm, c.probability_within) = filter.most_probable_disc(params.radius_mm);
  } else {
    c.centre_mm = e.map_mm.template head<2>();
    c.probability_within = filter.probability_within(c.centre_mm, params.radius_mm);
  }
  if constexpr (requires { filter.heading_probability_within(0.0, 0.0); })
    c.heading_probability =
        filter.heading_probability_within(e.map_mm(2), params.heading_tolerance_rad);
  c.verdict = c.probability_within >= params.threshold && c.heading_probability >= params.threshold
                  ? verdict::localized
                  : verdict::uncertain;
  return c;
}

/// As above, and `contradicted` when the touch that `report` describes contradicts the
/// prediction (`confidence_params::contradiction`), whatever the belief's spread after it.
template <class Filter>
[[nodiscard]] confidence assess(const Filter& filter, const typename Filter::estimate_type& e,
                                const update_report& report, const confidence_params& params) {
  confidence c = assess(filter, e, params);
  if (report.log_prediction_support < params.contradiction) c.verdict = verdict::contradicted;
  return c;
}

/// As above, with the filter's current estimate.
template <class Filter>
[[nodiscard]] confidence assess(const Filter& filter, const confidence_params& params = {}) {
  return assess(filter, filter.estimate(), params);
}

}  // namespace tacmap
