// tacmap: the front door — one object that turns a map image, tactile frames and the arm's
// motion into an estimate of where the sensor touches, with a verdict a robot can act on.
//
// `localizer` is a thin composition of the library's pieces, not a second filter: the map's
// `planar_grid` (or a `pose_grid` when the heading is unknown) with the latent appearance
// (`latent_grid`), the measurement model `localizer_config` chooses (`configured_measurement`),
// the odometry model behind `robust_motion`, `preprocess` for raw frames (Sec. IV-A) and
// `assess` for the verdict. Each `touch` is one step of the paper's Table 1: predict with the
// motion since the previous touch, update with the frame. `localization_experiment`
// (sim/experiment.hpp) builds its filters with the same `make_filter` functions, so what
// tacmap-evaluate measures is what a localizer runs.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <limits>
#include <numbers>
#include <optional>
#include <span>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/descriptor/unsigned_orientation.hpp"
#include "tacmap/detail/memory_budget.hpp"
#include "tacmap/detail/setting_ranges.hpp"
#include "tacmap/detail/type_name.hpp"
#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/filter/confidence.hpp"
#include "tacmap/filter/next_touch.hpp"
#include "tacmap/filter/open_set.hpp"
#include "tacmap/grid/latent_grid.hpp"
#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/grid/pose_grid.hpp"
#include "tacmap/image.hpp"
#include "tacmap/measurement/appearance_likelihood.hpp"
#include "tacmap/measurement/descriptor_likelihood.hpp"
#include "tacmap/measurement/ncc_likelihood.hpp"
#include "tacmap/measurement/rotated_descriptor_likelihood.hpp"
#include "tacmap/motion/latent_motion.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"
#include "tacmap/motion/pose_odometry_gaussian.hpp"
#include "tacmap/motion/robust_motion.hpp"
#include "tacmap/tactile/burst.hpp"
#include "tacmap/tactile/frame.hpp"
#include "tacmap/tactile/preprocess.hpp"
#include "tacmap/tactile/self_calibration.hpp"

namespace tacmap {

/// Which measurement model localizes.
enum class measurement_kind {
  lite,  ///< "sift_lite": the paper's 2 x 2 x 8 dense SIFT with eq. (1)-(2) (descriptor_likelihood)
  classic,  ///< "classic_sift": 4 x 4 x 8 dense SIFT, same eq. (1)-(2)
  ncc,      ///< "ncc": normalised cross-correlation baseline (ncc_likelihood)
};

/// How the filter relates the map's brightness to the object's height (README, "The photo is
/// not the touch").
enum class appearance_handling {
  /// "fixed": raised parts are assumed to look bright (the paper's gecko; every model before
  /// the appearance hypotheses). Fails completely on objects whose raised parts are darker.
  fixed,
  /// "latent": both relations are hypotheses of the filter (`appearance_likelihood` over a
  /// `latent_grid`), weighed by the touches' evidence; nothing needs to be known of the object.
  latent,
  /// "unsigned": descriptors of unsigned gradient orientation (`unsigned_orientation<D>`,
  /// opposite orientations folded together, as unsigned-gradient HOG): invariant to the sign
  /// of contrast at half the orientation resolution. Descriptor models, known orientation.
  unsigned_gradients,
  /// "per_patch": each tactile patch matched with whichever sign fits its window patch better
  /// (`contrast_sign::either_per_patch`): handles a relation that changes across the object, at
  /// the price of more chance matches. Descriptor models with aligned pairing, known
  /// orientation.
  per_patch,
};

[[nodiscard]] inline const char* to_string(appearance_handling a) {
  switch (a) {
    case appearance_handling::fixed:
      return "fixed";
    case appearance_handling::latent:
      return "latent";
    case appearance_handling::unsigned_gradients:
      return "unsigned";
    case appearance_handling::per_patch:
      return "per_patch";
  }
  return "?";
}

[[nodiscard]] inline const char* to_string(measurement_kind k) {
  switch (k) {
    case measurement_kind::lite:
      return "sift_lite";
    case measurement_kind::classic:
      return "classic_sift";
    case measurement_kind::ncc:
      return "ncc";
  }
  return "?";
}
[[nodiscard]] inline const char* to_string(pairing p) {
  return p == pairing::all_pairs ? "all_pairs" : "aligned";
}
[[nodiscard]] inline const char* to_string(likelihood_shape s) {
  return s == likelihood_shape::inverse ? "inverse" : "exponential";
}
[[nodiscard]] inline const char* to_string(window_features f) {
  return f == window_features::per_window ? "per_window" : "shared_dense";
}

/// Everything that configures the filter a `localizer` (or a simulated experiment) runs: the
/// measurement model, the motion model, the latent appearance, preprocessing and the verdict.
/// Defaults: the best measured (README, "Localization results", "The photo is not the touch",
/// "Confidence", "When exploration goes wrong"); the paper's own configuration is
/// `localizer_config::paper()`.
struct localizer_config {
  // Defaults: the best descriptor configuration measured (README, "Localization results").
  measurement_kind model = measurement_kind::classic;
  pairing pairs = pairing::aligned;                        ///< descriptor models only
  likelihood_shape shape = likelihood_shape::exponential;  ///< descriptor models only
  window_features features = window_features::per_window;  ///< descriptor models only
  /// How the planar descriptor model stores its per-window descriptors (issue 14); the
  /// descriptor model's default. The paper: float32.
  descriptor_storage storage = descriptor_likelihood_params{}.storage;
  /// Temperature: exponential shape (descriptor distance units) or NCC (log p = ncc / tau).
  /// Empty: `default_classic_tau` for the planar classic_sift model with the exponential shape
  /// (the default), else the model's own default (descriptor 0.15, NCC 0.1); see `planar_tau()`.
  /// In [1e-6, 1e6] (detail::min_tau, max_tau): the float log-likelihood stays finite.
  std::optional<double> tau;
  /// Pixels between the tactile image's descriptor patches (descriptor models). Empty:
  /// `default_classic_spacing` for the planar classic_sift model (the default), else the
  /// paper's 9 (`descriptor_likelihood_params::spacing`); see `planar_patch_spacing()`.
  std::optional<Eigen::Index> patch_spacing;
  double tempering = 1.0;             ///< exponent on the likelihood, in [0, 1e3]
  double motion_sigma_mm = 1.0;       ///< odometry_gaussian sigma (Sec. III-B), [1e-3, 1e6] mm
  int motion_k = 8;                   ///< odometry_gaussian neighbours (paper: 8)
  preprocess_params preprocessing{};  ///< frame thresholds; mm_per_px is replaced by the map's
  /// When the verdict is "localized" or "contradicted" (`assess`).
  confidence_params confidence{};
  /// "None of these": the prior that the touched surface is not the map (a library: none of
  /// its maps), weighed by the touches against the map (filter/open_set.hpp); the verdict needs
  /// the map and the position to beat it.
  open_set_params open_set{};
  /// Unknown orientation (issue 6): 0 localizes over (x, y) with the heading known (the paper);
  /// N >= 1 localizes over (x, y, theta) with a `pose_grid` of N headings, the
  /// `rotated_descriptor_likelihood` (descriptor models only) and sensor-frame odometry.
  int headings = 0;
  double turn_sigma_rad = 0.0873;  ///< pose motion: turn noise (headings > 0), [1e-6, 1e6] rad
  /// How the map's brightness relates to height (see `appearance_handling`).
  /// Default: latent, the best measured (README, "The photo is not the touch").
  appearance_handling appearance = appearance_handling::latent;
  /// `latent` only: probability that the appearance hypothesis changes between touches
  /// (`latent_motion_params::switch_probability`); 0 = a property of the whole object. Empty:
  /// `default_appearance_switch`.
  std::optional<double> appearance_switch;
  /// 0.05: measured equal to 0 on objects of one relation and better on objects whose parts
  /// differ (README, "The photo is not the touch"); 0.2 lost on the former.
  static constexpr double default_appearance_switch = 0.05;
  /// The probability that a move lands the sensor anywhere (`robust_motion`): the floor that
  /// lets the filter recover from odometry outliers, slips and kidnaps. Empty:
  /// `default_lost_probability`; 0: the paper's motion model.
  std::optional<double> lost_probability;
  /// 0.001: measured equal to 0 without faults (realistic, seeds 1-3: 578 of 594 both) and
  /// better with every fault (README, "When exploration goes wrong"); 0.01 recovers more after
  /// slips and kidnaps but loses 4 sequences without faults.
  static constexpr double default_lost_probability = 0.001;
  [[nodiscard]] double lost() const { return lost_probability.value_or(default_lost_probability); }
  /// The tracking the localizer's filter runs: `tracking`, unless the heading is localized
  /// (headings > 0) and `tracking_headings` is off.
  [[nodiscard]] std::optional<tracking_params> tracking_for_filter() const {
    if (headings > 0 && !tracking_headings) return std::nullopt;
    return tracking;
  }
  /// The probability that a move is off by more than `motion_sigma_mm`, and that wider
  /// component's spread (`robust_motion`): odometry outliers, noise larger than configured.
  /// Empty: `default_wide_probability`; 0: none.
  std::optional<double> wide_probability;
  /// 0.1 of 3 mm, measured (realistic, 9 maps, seeds 1-3; README, "When exploration goes
  /// wrong"): 10 % outliers of 8 mm 453 -> 496 of 594 localized, 3x the configured noise
  /// 345 -> 420, kidnaps recovered 412 -> 428 of 528, "localized" precision 92-96 % under
  /// those faults (84-93 % without it); without faults 578 -> 575 localized, the position
  /// claims' ECE 4.3-6.3 points (3.5-5.8) and recall at touch 6 90-95 % (92-96 %). 0.2 of 5 mm
  /// gains more under faults and loses more calibration without. Pose grids (36 headings,
  /// random heading, 216 sequences): 144 -> 152 localized with outliers, 120 -> 133 with 3x
  /// noise, 168 -> 172 without faults; the blur runs per heading layer, 1.16x a pose touch.
  static constexpr double default_wide_probability = 0.1;
  double wide_sigma_mm = 3.0;
  [[nodiscard]] double wide() const { return wide_probability.value_or(default_wide_probability); }
  /// The probability that a move is off by centimetres (the object slipped in the grasp) and
  /// that broad component's spread (`robust_motion`). Empty: `default_broad_probability`; 0:
  /// none.
  std::optional<double> broad_probability;
  /// Off by default. 0.05 of 10 mm, measured (realistic, seeds 1-3; README, "When exploration
  /// goes wrong"): 20 mm slips recovered 232 -> 262 of 315, kidnaps 421 -> 442 of 499, 10 %
  /// outliers of 8 mm 510 -> 517 of 594 localized, 3x the configured noise 441 -> 455, without
  /// faults 581 -> 580; but it adds about 16 us to a predict on the paper's grid (one density
  /// per predict, one more pass per plane): a touch of this filter 147 -> 165 us, 1.32x the
  /// same filter without robust motion, above the 1.2x issue 13 allows; and the verdict hedges
  /// more without faults. Turn it on where objects slip in the grasp.
  static constexpr double default_broad_probability = 0.0;
  double broad_sigma_mm = 10.0;
  /// A touch that doubts its prediction is looked at again as a slip (`slip_recheck_params`):
  /// its update is done again from the belief before the move, predicted with a broad
  /// component. Empty (the default): off. Off by measurement: without faults it loses
  /// sequences on photographs it was not tuned on (tacmap-evaluate, realistic, seed 1, 198
  /// sequences each: held-out photographs 175 -> 169 localized, 172 with `doubt` -1.5; the
  /// unknown-object scenario 168 -> 153, 156 with -1.5). Turn it on where objects slip in the
  /// grasp. Measured (tacmap-evaluate, realistic, 9 maps, seeds 1-3, 594
  /// sequences; a 20 mm slip before touch 6 of 7): "localized" claims at touch 7 right 157 of
  /// 276 -> 254 of 319, sequences localized 78 -> 237, the claims' ECE 16-18 -> 7.5-9.7
  /// points; slips at touch 6 of 12 back below 5 mm within 5 touches 352 of 406 -> 367 of
  /// 407; without faults 573 -> 570 localized, recall at touch 6 92.7 -> 91.0 % (touch 7
  /// 93.8 % both), ECE 2.0-3.7 -> 2.6-4.0 points. It costs a copy of the belief per touch,
  /// and a second predict and update at a doubting touch (about 1 % of touches without
  /// faults). Needs `robust_motion` (the planar and pose filters; not a library's
  /// per-object motion, whose copies it cannot reach).
  std::optional<slip_recheck_params> slip_recheck;
  /// The longest preparing a map may take, seconds (infinity: no limit). Applies where a
  /// descriptor's per-window features cost one `compute()` per window (no `describes_windows`
  /// hook, descriptor/concept.hpp H4: a user's descriptor, `appearance = unsigned`): the time is
  /// measured on a few windows and extrapolated first, and a preparation above the budget is
  /// refused (`preparation_over_budget`) with the figures and what to change. 10 s: a simple
  /// descriptor on a 600 x 512 px photograph would otherwise take about a minute, silently.
  double preparation_budget_s = 10.0;
  /// How a press given as a burst of frames is combined into one (`combine_burst`,
  /// tactile/burst.hpp): the `touch` and `touch_at` overloads that take a span of frames. The
  /// paper averaged 20 readings per press; the default drops a press's settling frames and
  /// outlier frames, then takes each taxel's median.
  burst_params burst{};
  /// A sensor that calibrates itself (`self_calibration`, tactile/self_calibration.hpp): when
  /// set, every frame is first seen by an online estimate of each taxel's gain and offset and
  /// of dead or stuck taxels, and localized corrected (dead and stuck taxels filled in from
  /// their neighbours: they never vote). The estimate outlives `reset()` (the sensor is the
  /// same on the next object); `reset_sensor_calibration()` starts it again. Empty (the
  /// default): frames are used as read. Measured on simulated worn sensors it localizes more
  /// (harsh scenario, gecko and horse: 35 -> 39 of 44 sequences) and changes nothing a healthy
  /// sensor localizes, but costs about 0.15 ms a touch, as much as an update on the paper's
  /// grid: turn it on for a sensor that has seen use.
  std::optional<self_calibration_params> calibrate_sensor;
  /// Tracking (`bayes_filter::set_tracking`): once the belief is concentrated, a touch evaluates
  /// the likelihood only where the belief is and on a sample of every 8th row of the rest, and
  /// the whole grid when the touch doubts the prediction and every 64 touches
  /// (`default_tracking()`, the default; `touch_result::path` says which a touch took). With
  /// headings too, unless `tracking_headings` is off. Empty: every touch evaluates the whole grid
  /// (the default before, and the paper's). Measured against empty in the same runs
  /// (tacmap-evaluate --scenario realistic, the gecko and 8 photographs, seeds 1-3): without
  /// faults the same 573 of 594 localized, ECE 2.0 / 3.7 / 3.4 points against 2.0 / 3.7 / 3.3;
  /// 12 touches with a kidnap at touch 7, back within 3 touches 434 of 558 against 429 of 553,
  /// within 5 507 of 558 against 501 of 553; a 20 mm slip at touch 7, within 3 293 of 436
  /// against 286 of 432, within 5 369 of 436 against 365 of 432. A localized touch on the
  /// paper's grid (camera_bench, CPU time) 137 against 234 us. A belief spread over more than a
  /// quarter of the states (the first touches, a small map) takes the whole grid anyway: no grid
  /// size needs a rule of its own.
  std::optional<tracking_params> tracking = default_tracking();
  /// Whether `tracking` applies to the (x, y, theta) filter (headings > 0) as well. On by
  /// default, measured (tacmap-evaluate --scenario realistic --headings 36, the gecko and 8
  /// photographs, seeds 1-3, 594 sequences, against --no-tracking in the same runs): without
  /// faults the same 539 of 594 localized, ECE 5.3 / 3.6 / 6.0 points against 5.2 / 3.6 / 5.9;
  /// 12 touches with a kidnap at touch 7, back below 5 mm within 3 touches 378 of
  /// 528 against 373 of 527, within 5 457 against 455; a 20 mm slip at touch 7, within
  /// 3 235 of 406 against 218 of 401, within 5 310 against 305. A localized touch (camera_bench,
  /// CPU-time medians, two interleaved rounds against the untracked default): paper's grid
  /// 2.0-2.1 against 11.4-12.1 ms; 640 x 480 at 0.28 mm/px 4.2-4.3 against 15.4-15.9 ms. It pays
  /// once the tracked sample holds one heading a touch
  /// (`tracking_params::sample_layers`) and a patch turned off the map takes its mean over a
  /// lattice (`rotated_likelihood_params::off_map_exact_positions`): before, a tracked touch
  /// cost what the whole grid costs (13.5 against 13.1 ms on the paper's grid).
  bool tracking_headings = true;
  /// The map as the sensor sees it: the standard deviation, mm, of a Gaussian by which the map
  /// is blurred before the measurement model describes it (0: the map as photographed). A touch
  /// is not a picture at the map's resolution: each taxel integrates the load over its cell and
  /// the elastic pad spreads it to the neighbours, and preprocessing interpolates the counts
  /// between taxel centres; the map's fine detail, which no touch can show, only adds mismatch
  /// to its descriptors. Empty (the default): `default_pad_spread_pitches` of the sensor's
  /// pitch (`pad_spread()`).
  std::optional<double> pad_spread_mm;
  /// Half the pitch (1.7 mm for the paper's array): a cell's box (variance pitch^2 / 12) and the
  /// interpolation between taxel centres (a triangle, pitch^2 / 6) together have sigma
  /// pitch / 2. The pad's own spread is not added: measured, the photograph's blur and the
  /// descriptors' gradient filters already cover it. Measured (tacmap-evaluate, random order,
  /// seeds 1-3, 594 sequences per set, evaluation / held-out photographs): realistic 573 -> 577
  /// / 532 -> 546 localized, ideal 594 -> 594 / 591 -> 594, harsh 258 -> 257 / 190 -> 190; 2.5
  /// mm (the realistic sensor's pad) 576 / 552 but 3.4 mm (the harsh one's) 563 / 543.
  static constexpr double default_pad_spread_pitches = 0.5;
  /// The spread the map is blurred by for `sensor`, mm: `pad_spread_mm`, else
  /// `default_pad_spread_pitches` x its pitch.
  [[nodiscard]] double pad_spread(const taxel_geometry& sensor) const {
    return pad_spread_mm.value_or(default_pad_spread_pitches * sensor.pitch_mm);
  }
  /// The working resolution, mm per px: the scale the map is matched at. A photograph finer
  /// than it is resampled to it (area-averaged) before the map is prepared, so that what a
  /// touch and a map's preparation cost is set by the object's area and the sensor's
  /// resolution, not by the camera's pixel count; positions are reported in the photograph's
  /// own millimetres either way (the map frame's origin is the photograph's top-left corner).
  /// A photograph at or coarser than it is used as it is (coarser: with a warning, see
  /// `basic_localizer::warnings()`). Empty (the default): the sensor's pitch /
  /// `default_px_per_taxel` (3.4 / 3 mm per px for the paper's array, the scale the models'
  /// defaults were fitted at). Set it to the photograph's own scale (or finer) to match at full
  /// resolution. At most the pitch / `min_px_per_taxel`.
  std::optional<double> working_mm_per_px;
  /// Map pixels per taxel at the default working resolution: 3, measured against matching at
  /// full resolution on held-out photographs (docs/photographs.md, "Working resolution").
  static constexpr double default_px_per_taxel = 3.0;
  /// The fewest map pixels per taxel a map may have: below it the touch's image has fewer
  /// pixels than its taxels and the descriptors' patches no longer fit the sensor's window.
  static constexpr double min_px_per_taxel = 2.0;
  /// The working resolution for `sensor` (mm per px): `working_mm_per_px`, else the pitch /
  /// `default_px_per_taxel`.
  [[nodiscard]] double working_scale(const taxel_geometry& sensor) const {
    // The default never leaves the range the models stay finite in (a pitch above 3 m): the
    // photograph's own scale is the one checked and named, not a derived one.
    return working_mm_per_px.value_or(
        std::min(sensor.pitch_mm / default_px_per_taxel, detail::max_mm_per_px));
  }
  [[nodiscard]] double broad() const {
    return broad_probability.value_or(default_broad_probability);
  }

  /// The paper's configuration (Sec.\ III-C, IV): SIFT-lite, every patch against every patch
  /// (eq.\ (1)), the inverse likelihood (eq.\ (2)), per-window features, a fixed appearance
  /// (raised parts bright) and the Gaussian motion model alone: no floor, no wide component.
  [[nodiscard]] static localizer_config paper() {
    localizer_config c;
    c.model = measurement_kind::lite;
    c.pairs = pairing::all_pairs;
    c.shape = likelihood_shape::inverse;
    c.features = window_features::per_window;
    c.storage = descriptor_storage::float32;
    c.appearance = appearance_handling::fixed;
    c.lost_probability = 0.0;
    c.wide_probability = 0.0;
    c.broad_probability = 0.0;
    c.tracking.reset();     // the paper evaluated the whole grid at every touch
    c.pad_spread_mm = 0.0;  // the paper described the map as photographed
    return c;
  }

  /// The planar classic_sift model's patch spacing when `patch_spacing` is empty: its three
  /// 16 px patches spread over the whole 42 px touch (at the evaluation's 1.13 mm per px). With
  /// the paper's 9 the last 8 rows of the touch are never described. Measured (README,
  /// "Confidence"): more sequences localized on the evaluation maps and on held-out photographs.
  static constexpr Eigen::Index default_classic_spacing = 13;
  /// The planar classic_sift model's temperature (exponential shape) when `tau` is empty: fitted
  /// by tacmap-calibrate with `default_classic_spacing` on 8 photographs the evaluation does not
  /// use (0.120; with the paper's spacing the fit was 0.15, the descriptor models' default).
  /// Checked with the map blurred by the default `pad_spread_mm`: the same data (realistic, seed
  /// 101, 1,207 touches) fits 0.122, mean log score of the truth -1.746 at both.
  static constexpr double default_classic_tau = 0.12;

  /// The temperature the planar (known heading) model runs with: `tau`, else
  /// `default_classic_tau` for classic_sift with the exponential shape, else empty (the
  /// model's own default). The (x, y, theta) model uses `tau` or its own default: the fit was
  /// made on the planar model only.
  [[nodiscard]] std::optional<double> planar_tau() const {
    if (tau) return tau;
    if (model == measurement_kind::classic && shape == likelihood_shape::exponential)
      return default_classic_tau;
    return std::nullopt;
  }
  /// The patch spacing the planar model runs with: `patch_spacing`, else
  /// `default_classic_spacing` for classic_sift, else empty (the paper's 9).
  [[nodiscard]] std::optional<Eigen::Index> planar_patch_spacing() const {
    if (patch_spacing) return patch_spacing;
    if (model == measurement_kind::classic) return default_classic_spacing;
    return std::nullopt;
  }

  /// The switch probability the filter uses (0 unless the appearance is latent).
  [[nodiscard]] double switch_probability() const {
    if (appearance != appearance_handling::latent) return 0.0;
    return appearance_switch.value_or(default_appearance_switch);
  }

  /// Throws std::invalid_argument for settings that contradict each other, naming both, and for
  /// every numeric setting outside the range in which its model stays finite (the range named:
  /// tacmap/detail/setting_ranges.hpp), before anything is prepared.
  void validate() const {
    confidence.validate();
    open_set.validate();
    if (slip_recheck) {
      slip_recheck->validate();
      if (!(slip_recheck->broad_probability + wide() + lost() < 1.0))
        detail::fail(
            "localizer_config: slip_recheck.broad_probability = ", slip_recheck->broad_probability,
            " with wide_probability ", wide(), " and lost_probability ", lost(),
            "; expected the three to sum to less than 1 (e.g. 0.3 with 0.1 and 0.001)");
    }
    detail::check_range("localizer_config", "motion_sigma_mm", motion_sigma_mm,
                        detail::min_sigma_mm, detail::max_sigma_mm, " mm",
                        "the odometry's noise per axis", "the paper uses 1");
    if (motion_k <= 0)
      detail::fail("localizer_config: motion_k = ", motion_k,
                   "; expected a number of neighbours > 0 (the paper: 8)");
    (void)odometry_gaussian({.sigma_mm = motion_sigma_mm, .k = motion_k});  // k: a whole disc
    if (headings < 0)
      detail::fail("localizer_config: headings = ", headings,
                   "; expected 0 (known orientation) or the number of headings of a pose grid");
    if (headings > 0)
      detail::check_range("localizer_config", "turn_sigma_rad", turn_sigma_rad,
                          detail::min_sigma_rad, detail::max_sigma_rad, " rad",
                          "the turn noise per move", "the default is 0.0873 (5 degrees)");
    if (tau)
      detail::check_range("localizer_config", "tau", *tau, detail::min_tau, detail::max_tau,
                          " (descriptor distance units; NCC: log p = ncc / tau)",
                          "the likelihood's temperature",
                          "leave it empty for the model's fitted default");
    detail::check_range("localizer_config", "tempering", tempering, 0.0, detail::max_tempering, "",
                        "an exponent on the likelihood",
                        "1 is the likelihood itself, 0 ignores the touches");
    if (patch_spacing && *patch_spacing <= 0)
      detail::fail("localizer_config: patch_spacing = ", *patch_spacing,
                   "; expected a positive number of pixels between tactile patches (paper: 9), "
                   "or empty for the model's default");
    burst.validate();
    if (calibrate_sensor) calibrate_sensor->validate();
    if (tracking) tracking->validate();
    if (pad_spread_mm)
      detail::check_range("localizer_config", "pad_spread_mm", *pad_spread_mm, 0.0,
                          detail::max_pad_spread_mm, " mm",
                          "the sensor's spread on the map (a Gaussian's standard deviation)",
                          "leave it empty for half the sensor's pitch, or 0 to match the map as "
                          "photographed");
    if (working_mm_per_px)
      detail::check_range("localizer_config", "working_mm_per_px", *working_mm_per_px,
                          detail::min_mm_per_px, detail::max_mm_per_px, " mm per px",
                          "the scale to match at", "leave it empty for the sensor's pitch / 3");
    {
      preprocess_params p = preprocessing;  // mm_per_px is replaced by the map's
      p.mm_per_px = 1.0;
      p.validate();
    }
    robust_motion_params{.lost_probability = lost(),
                         .wide_probability = wide(),
                         .wide_sigma_mm = wide_sigma_mm,
                         .broad_probability = broad(),
                         .broad_sigma_mm = broad_sigma_mm}
        .validate();
    if (appearance_switch && appearance != appearance_handling::latent)
      detail::fail("localizer_config: appearance_switch = ", *appearance_switch,
                   " needs appearance = latent (it switches between appearance hypotheses), but "
                   "appearance = ",
                   to_string(appearance), "; set appearance to latent or the switch to 0");
    const bool descriptor_level = appearance == appearance_handling::unsigned_gradients ||
                                  appearance == appearance_handling::per_patch;
    if (descriptor_level && model == measurement_kind::ncc)
      detail::fail("localizer_config: appearance = ", to_string(appearance),
                   " changes the descriptors, but model = ncc has none; use sift_lite or "
                   "classic_sift, or appearance = latent (which works with NCC)");
    if (descriptor_level && headings > 0)
      detail::fail("localizer_config: appearance = ", to_string(appearance),
                   " is implemented for a known orientation only, but headings = ", headings,
                   "; use appearance = latent with a pose grid, or headings = 0");
    if (appearance == appearance_handling::per_patch && pairs == pairing::all_pairs)
      detail::fail(
          "localization_config: appearance = per_patch matches patch m against patch m, "
          "but pairs = all_pairs; use pairs = aligned");
    if (appearance_switch && !(std::isfinite(*appearance_switch) && *appearance_switch >= 0.0 &&
                               *appearance_switch <= 0.5))
      detail::fail("localizer_config: appearance_switch = ", *appearance_switch,
                   "; expected a probability in [0, 0.5] (two hypotheses)");
  }

  /// The appearance hypotheses this configuration's filter holds.
  [[nodiscard]] std::vector<tacmap::appearance> appearances() const {
    if (appearance == appearance_handling::latent) return both_appearances();
    return {tacmap::appearance::as_photographed};
  }

  /// A short name for tables: "sift_lite/all_pairs/inverse/per_window", with "/tau=0.5" when
  /// `tau` is set.
  [[nodiscard]] std::string name() const {
    std::string out = model == measurement_kind::ncc
                          ? std::string("ncc")
                          : std::string(to_string(model)) + "/" + to_string(pairs) + "/" +
                                to_string(shape) + "/" + to_string(features);
    if (headings > 0)
      out = std::string(to_string(model)) + "/" + to_string(pairs) + "/" + to_string(shape) +
            "/headings=" + std::to_string(headings);
    if (tau) {
      std::ostringstream t;
      t << *tau;
      out += "/tau=" + t.str();
    }
    if (patch_spacing && model != measurement_kind::ncc)
      out += "/spacing=" + std::to_string(*patch_spacing);
    if (storage != descriptor_likelihood_params{}.storage && model != measurement_kind::ncc &&
        headings == 0)
      out += storage == descriptor_storage::int8 ? "/int8" : "/float32";
    if (appearance != appearance_handling::fixed) out += std::string("/") + to_string(appearance);
    if (appearance_switch) {
      std::ostringstream t;
      t << *appearance_switch;
      out += "/switch=" + t.str();
    }
    if (lost_probability) {
      std::ostringstream t;
      t << *lost_probability;
      out += "/lost=" + t.str();
    }
    if (wide_probability) {
      std::ostringstream t;
      t << *wide_probability << "x" << wide_sigma_mm << "mm";
      out += "/wide=" + t.str();
    }
    if (broad_probability) {
      std::ostringstream t;
      t << *broad_probability << "x" << broad_sigma_mm << "mm";
      out += "/broad=" + t.str();
    }

    return out;
  }
};

/// Thrown when preparing a map would take longer than `localizer_config::preparation_budget_s`
/// (per-window features of a descriptor without the `describes_windows` fast path, H4). The
/// message names the descriptor, both figures, the memory it would take and what to change; the
/// figures are fields.
class preparation_over_budget : public std::runtime_error {
 public:
  preparation_over_budget(const std::string& message, double estimated, double budget)
      : std::runtime_error(message), estimated_seconds(estimated), budget_seconds(budget) {}
  double estimated_seconds;  ///< the extrapolated time of describing every window
  double budget_seconds;     ///< localizer_config::preparation_budget_s
};

namespace detail {

/// One touch from a press read as a burst: `combine_burst` first (it throws before anything
/// changes), then `touch_one` with the combined frame; the result says how many frames it kept.
template <class Touch>
auto touch_with_burst(std::span<const tactile_frame> burst, const burst_params& params,
                      Touch&& touch_one) {
  const combined_burst combined = combine_burst(burst, params);
  auto r = std::forward<Touch>(touch_one)(combined.frame);
  r.frames_combined = combined.used;
  return r;
}

/// The scale a photograph at `photo_mm_per_px` is matched at (`localizer_config::
/// working_mm_per_px`) and what that costs, said in words (`basic_localizer::warnings()`).
struct working_resolution {
  double mm_per_px = 0.0;  ///< the scale matched at
  bool resampled = false;  ///< the photograph was resampled to it
  std::vector<std::string> warnings;
};

/// Chooses the working resolution for a photograph at `photo_mm_per_px` and a sensor of
/// `sensor` (messages start with `who`):
///  * finer than the working scale W: resampled to W, W adjusted so that the photograph's
///    longer side is a whole number of pixels (`working_map`: positions are the photograph's
///    millimetres exactly);
///  * at W or coarser, down to pitch / `min_px_per_taxel`: used as it is; coarser than W with
///    a warning of the accuracy it costs;
///  * coarser than pitch / `min_px_per_taxel`: std::invalid_argument naming the scale and the
///    minimum. So is a `working_mm_per_px` coarser than that.
/// `longer_side_px`: the photograph's longer side.
inline constexpr const char* coarse_photo_cost =
    "Measured on held-out photographs of a 180 mm object (tacmap-working-resolution): at 2.7 px "
    "per taxel 102 of 108 sequences localized against 105 of 108 at 3; below 2.67 px per taxel "
    "the default classic_sift model's 16 px patches no longer fit across the array's 6 taxels. "
    "Photograph the object at a finer scale where you can";
[[nodiscard]] inline working_resolution choose_working_resolution(const localizer_config& config,
                                                                  const taxel_geometry& sensor,
                                                                  double photo_mm_per_px,
                                                                  Eigen::Index longer_side_px,
                                                                  const std::string& who) {
  sensor.validate();
  // The scale's own range first (as checked_tactile_window does later): a scale outside it is
  // the input's fault, whatever the sensor.
  check_map_scale(who.c_str(), photo_mm_per_px);
  const double pitch = sensor.pitch_mm;
  const double coarsest = pitch / localizer_config::min_px_per_taxel;
  constexpr double slack = 1e-9;  // 3.4 / 3 given as 1.1333 is the same scale
  const double wanted = config.working_scale(sensor);
  if (!(std::isfinite(wanted) && wanted > 0.0))
    fail(who, ": localizer_config::working_mm_per_px = ", wanted,
         "; expected a finite value > 0 mm per px");
  if (wanted > coarsest * (1.0 + slack))
    fail(who, ": localizer_config::working_mm_per_px = ", wanted, " mm per px gives the sensor's ",
         pitch, " mm taxels ", pitch / wanted, " px each; expected at most ", coarsest,
         " mm per px (", localizer_config::min_px_per_taxel,
         " px per taxel), e.g. empty for the default pitch / ",
         localizer_config::default_px_per_taxel);
  if (photo_mm_per_px > coarsest * (1.0 + slack))
    fail(who, ": the photograph's scale is ", photo_mm_per_px, " mm per px, so the sensor's ",
         pitch, " mm taxels cover ", pitch / photo_mm_per_px, " px each; expected at most ",
         coarsest, " mm per px (", localizer_config::min_px_per_taxel,
         " px per taxel; the default working resolution is ",
         pitch / localizer_config::default_px_per_taxel,
         " mm per px) — photograph the object at a finer scale (closer, or more pixels)");
  working_resolution out;
  if (photo_mm_per_px >= wanted * (1.0 - slack)) {
    out.mm_per_px = photo_mm_per_px;
    if (photo_mm_per_px > wanted * (1.0 + slack)) {
      std::ostringstream text;
      text.precision(3);
      text << who << ": the photograph's " << photo_mm_per_px
           << " mm per px is coarser than the working resolution " << wanted << " mm per px ("
           << pitch / wanted << " px per taxel); it is used as it is, at "
           << pitch / photo_mm_per_px << " px per taxel. " << coarse_photo_cost;
      out.warnings.push_back(text.str());
    }
    return out;
  }
  // The longer side at a whole number of working pixels: that side's scale is exact.
  const double side_mm = static_cast<double>(longer_side_px) * photo_mm_per_px;
  const double pixels = std::max(1.0, std::round(side_mm / wanted));
  out.mm_per_px = side_mm / pixels;
  out.resampled = true;
  return out;
}

/// `map` (at `photo_mm_per_px`) resampled to `r.mm_per_px` by area (every working pixel the
/// mean of the photograph's pixels it covers), or `map` itself. One exact scale on both axes:
/// along the shorter side the last fraction of a working pixel is left out (a crop of less
/// than `r.mm_per_px`), so that every position is the photograph's millimetres exactly.
[[nodiscard]] inline image<float> working_map(image<float> map, double photo_mm_per_px,
                                              const working_resolution& r) {
  if (!r.resampled) return map;
  const double per_px = r.mm_per_px / photo_mm_per_px;  // photograph px per working px
  const auto side = [&](Eigen::Index px) {  // whole working pixels (1e-9: the exact side)
    return std::max<Eigen::Index>(
        1, static_cast<Eigen::Index>(std::floor(static_cast<double>(px) / per_px + 1e-9)));
  };
  return resize_area_by(map, side(map.rows()), side(map.cols()), per_px, per_px);
}

/// The localizers' optional self-calibrating sensor (`localizer_config::calibrate_sensor`).
class sensor_correction {
 public:
  sensor_correction(const std::optional<self_calibration_params>& params,
                    const taxel_geometry& geometry)
      : params_(params), geometry_(geometry) {
    reset();
  }
  /// The frame to localize: `frame` itself, or corrected once the estimate has seen it. Throws
  /// (before anything changes) for a frame the estimate cannot take.
  const tactile_frame& apply(const tactile_frame& frame) {
    if (!estimate_) return frame;
    estimate_->observe(frame);
    corrected_ = estimate_->correct(frame).frame;
    return corrected_;
  }
  [[nodiscard]] const tacmap::self_calibration* estimate() const {
    return estimate_ ? &*estimate_ : nullptr;
  }
  void reset() {
    estimate_.reset();
    if (params_) estimate_.emplace(geometry_, *params_);
  }

 private:
  std::optional<self_calibration_params> params_;
  taxel_geometry geometry_;
  std::optional<tacmap::self_calibration> estimate_;
  tactile_frame corrected_;
};

/// Issue 33, "cost guard": per-window features of a descriptor D without H4 cost one
/// `compute()` per window of the map (120 x 120 px: 8,000 windows; 600 x 512 px: 260,000, about
/// a minute for a simple descriptor). Before any of it, this times `compute()` on up to 32
/// windows spread over the map (stopping after 50 ms), extrapolates to every window and refuses
/// above `budget_s` (infinity: never) with the figures and what to do. Descriptors with H4 do
/// not come here (they share the work between windows).
template <descriptor D>
void guard_window_preparation(const D& d, const image<float>& map, pixel_size window,
                              Eigen::Index spacing, double budget_s) {
  if (!(budget_s > 0.0))
    fail("localizer_config: preparation_budget_s = ", budget_s,
         "; expected the longest a map's preparation may take, in seconds, > 0 (infinity: no "
         "limit; the default is 10)");
  if (std::isinf(budget_s)) return;
  // The model's own checks first (window, patch, finite map): their messages, not compute()'s.
  const auto offsets =
      checked_patch_offsets(type_name<D>().c_str(), map, window, d.patch_size(), spacing);
  const Eigen::Index rows = map.rows() - window.height + 1, cols = map.cols() - window.width + 1;
  const Eigen::Index windows = rows * cols;
  using T = typename D::scalar_type;
  using clock = std::chrono::steady_clock;
  image<T> cut(window.height, window.width);
  const auto start = clock::now();
  double elapsed = 0.0;
  Eigen::Index timed = 0;
  for (Eigen::Index k = 0; k < std::min<Eigen::Index>(windows, 32); ++k) {
    const Eigen::Index i = (k * 7919) % windows;  // spread over the map
    cut = map.block(i / cols, i % cols, window.height, window.width).template cast<T>();
    const auto f = d.compute(cut);
    ++timed;
    elapsed = std::chrono::duration<double>(clock::now() - start).count();
    if (f.values.size() == 0 || (elapsed > 0.05 && timed >= 2)) break;
  }
  const double estimate = elapsed / static_cast<double>(timed) * static_cast<double>(windows);
  if (estimate <= budget_s) return;
  const std::uint64_t bytes = saturating_product(windows, offsets.size(), d.dimension(), sizeof(T));
  std::ostringstream text;
  text.precision(3);
  text << "preparing the map with descriptor " << type_name<D>() << " would take about " << estimate
       << " s (" << windows << " windows of " << window.width << " x " << window.height
       << " px, one compute() each, " << elapsed / static_cast<double>(timed) * 1e3
       << " ms per window measured on " << timed << ") and " << bytes_text(bytes)
       << " of per-window descriptors; the budget is localizer_config::preparation_budget_s = "
       << budget_s
       << " s. Use window_features::shared_dense (one dense field, shared by all windows), give "
          "the descriptor the describe_windows hook (descriptor/concept.hpp, H4), use a coarser "
          "map (tacmap::rescale), or raise preparation_budget_s";
  throw preparation_over_budget(text.str(), estimate, budget_s);
}

/// `descriptor_likelihood<D>(d, map, window, p)`, after the cost guard where it applies
/// (per-window features without H4).
template <descriptor D>
[[nodiscard]] descriptor_likelihood<D> guarded_descriptor_likelihood(
    D d, const image<float>& map, pixel_size window, const descriptor_likelihood_params& p,
    double budget_s) {
  if constexpr (!describes_windows<D>) {
    if (p.features == window_features::per_window)
      guard_window_preparation(d, map, window, p.spacing, budget_s);
  }
  return descriptor_likelihood<D>(std::move(d), map, window, p);
}

}  // namespace detail

/// A measurement model chosen at run time from `localizer_config::model`: the three shipped
/// models behind one `log_likelihood`, so one filter type serves every configuration.
class configured_measurement {
 public:
  using measurement_type = image<float>;

  configured_measurement(const localizer_config& config, const image<float>& map, pixel_size window)
      : model_(make(config, map, window)) {}

  template <class G>
  void log_likelihood(const G& grid, const measurement_type& z, belief_array<G>& out) const {
    std::visit([&](const auto& m) { m.log_likelihood(grid, z, out); }, model_);
  }

  /// Tracking hook (measurement/concept.hpp): the chosen model's bound, +infinity for one
  /// without the hook (NCC: the filter then always updates the whole grid).
  [[nodiscard]] double log_likelihood_bound() const {
    return std::visit(
        [](const auto& m) -> double {
          if constexpr (requires { m.log_likelihood_bound(); })
            return static_cast<double>(m.log_likelihood_bound());
          else
            return std::numeric_limits<double>::infinity();
        },
        model_);
  }

  /// Tracking hook: the chosen model's `log_likelihood_on`, or its whole grid.
  template <class G>
  void log_likelihood_on(const G& grid, const measurement_type& z, belief_array<G>& out,
                         std::span<const state_range> states) const {
    std::visit(
        [&](const auto& m) {
          if constexpr (measures_on_states<std::remove_cvref_t<decltype(m)>, G>)
            m.log_likelihood_on(grid, z, out, states);
          else
            m.log_likelihood(grid, z, out);
        },
        model_);
  }

  /// Tracking hook of `log_likelihood_both_signs`: the chosen model's restricted version, or
  /// the whole grid.
  template <class G>
  void log_likelihood_both_signs_on(const G& grid, const measurement_type& z,
                                    typename G::scalar_type* out,
                                    std::span<const state_range> states) const {
    std::visit(
        [&](const auto& m) {
          if constexpr (requires { m.log_likelihood_both_signs_on(grid, z, out, states); })
            m.log_likelihood_both_signs_on(grid, z, out, states);
          else
            log_likelihood_both_signs(grid, z, out);
        },
        model_);
  }

  /// A touch and its inverted contrast (blocks 0 and 1 of `out`): the model's one-pass version
  /// where it has one, else two calls.
  template <class G>
  void log_likelihood_both_signs(const G& grid, const measurement_type& z,
                                 typename G::scalar_type* out) const {
    std::visit(
        [&](const auto& m) {
          if constexpr (measures_both_signs<std::remove_cvref_t<decltype(m)>, G>) {
            m.log_likelihood_both_signs(grid, z, out);
          } else {
            const measurement_type images[2] = {z, appearance_transform(z, appearance::inverted)};
            log_likelihood_each(grid, std::span<const measurement_type>(images), out);
          }
        },
        model_);
  }

  /// Several measurements at once (block k of `out` for zs[k]): the model's own one-pass
  /// version where it has one (descriptor models), else one call each.
  template <class G>
  void log_likelihood_each(const G& grid, std::span<const measurement_type> zs,
                           typename G::scalar_type* out) const {
    std::visit(
        [&](const auto& m) {
          if constexpr (measures_each<std::remove_cvref_t<decltype(m)>, G>) {
            m.log_likelihood_each(grid, zs, out);
          } else {
            belief_array<G> block(grid.size());
            for (std::size_t k = 0; k < zs.size(); ++k) {
              m.log_likelihood(grid, zs[k], block);
              Eigen::Map<belief_array<G>>(out + static_cast<Eigen::Index>(k) * grid.size(),
                                          grid.size()) = block;
            }
          }
        },
        model_);
  }

  /// Next-touch hooks (filter/next_touch.hpp): the chosen model's.
  void window_descriptors(std::span<const Eigen::Index> states, Eigen::ArrayXXf& out) const {
    std::visit([&](const auto& m) { m.window_descriptors(states, out); }, model_);
  }
  void predicted_log_likelihoods(const Eigen::ArrayXXf& touched, const Eigen::ArrayXXf& at,
                                 Eigen::ArrayXXf& out) const {
    std::visit([&](const auto& m) { m.predicted_log_likelihoods(touched, at, out); }, model_);
  }

 private:
  using variant_type = std::variant<ncc_likelihood<float>, descriptor_likelihood<sift_lite>,
                                    descriptor_likelihood<classic_sift>,
                                    descriptor_likelihood<unsigned_orientation<sift_lite>>,
                                    descriptor_likelihood<unsigned_orientation<classic_sift>>>;

  static variant_type make(const localizer_config& config, const image<float>& map,
                           pixel_size window) {
    if (config.model == measurement_kind::ncc) {
      ncc_params p;
      if (config.tau) p.tau = *config.tau;
      p.tempering = config.tempering;
      return variant_type(std::in_place_index<0>, map, window, p);
    }
    descriptor_likelihood_params p;
    p.pairs = config.pairs;
    p.shape = config.shape;
    p.features = config.features;
    p.storage = config.storage;
    if (const auto tau = config.planar_tau()) p.tau = *tau;
    if (const auto spacing = config.planar_patch_spacing()) p.spacing = *spacing;
    p.tempering = config.tempering;
    if (config.appearance == appearance_handling::per_patch)
      p.contrast = contrast_sign::either_per_patch;
    // Latent appearance: both contrast signs in one pass (dense SIFT's contrast permutation).
    p.both_signs = config.appearance == appearance_handling::latent && p.pairs == pairing::aligned;
    const bool lite = config.model == measurement_kind::lite;
    if (config.appearance == appearance_handling::unsigned_gradients) {
      // No describe_windows (H4): per-window features go through the cost guard.
      if (lite)
        return variant_type(std::in_place_index<3>, detail::guarded_descriptor_likelihood(
                                                        unsigned_orientation<sift_lite>{}, map,
                                                        window, p, config.preparation_budget_s));
      return variant_type(std::in_place_index<4>, detail::guarded_descriptor_likelihood(
                                                      unsigned_orientation<classic_sift>{}, map,
                                                      window, p, config.preparation_budget_s));
    }
    if (lite) return variant_type(std::in_place_index<1>, sift_lite{}, map, window, p);
    return variant_type(std::in_place_index<2>, classic_sift{}, map, window, p);
  }

  variant_type model_;
};

/// The (x, y, theta) counterpart of `configured_measurement`: the rotated descriptor models.
class configured_rotated_measurement {
 public:
  using measurement_type = image<float>;

  /// Throws std::invalid_argument for NCC (no rotated NCC model ships) or bad parameters.
  configured_rotated_measurement(const localizer_config& config, const image<float>& map,
                                 const pose_grid<float>& grid)
      : model_(make(config, map, grid)) {}

  template <class G>
  void log_likelihood(const G& grid, const measurement_type& z, belief_array<G>& out) const {
    std::visit([&](const auto& m) { m.log_likelihood(grid, z, out); }, model_);
  }

  /// Tracking hook (measurement/concept.hpp): the chosen rotated model's bound.
  [[nodiscard]] double log_likelihood_bound() const {
    return std::visit([](const auto& m) { return static_cast<double>(m.log_likelihood_bound()); },
                      model_);
  }

  /// Tracking hook: the chosen rotated model's `log_likelihood_on`.
  template <class G>
  void log_likelihood_on(const G& grid, const measurement_type& z, belief_array<G>& out,
                         std::span<const state_range> states) const {
    std::visit([&](const auto& m) { m.log_likelihood_on(grid, z, out, states); }, model_);
  }

 private:
  using variant_type = std::variant<rotated_descriptor_likelihood<sift_lite>,
                                    rotated_descriptor_likelihood<classic_sift>>;

  static variant_type make(const localizer_config& config, const image<float>& map,
                           const pose_grid<float>& grid) {
    if (config.model == measurement_kind::ncc)
      detail::fail("localizer_config: headings = ", config.headings,
                   " (unknown orientation) needs a descriptor model; got ncc. Use sift_lite or "
                   "classic_sift, or headings = 0 for NCC with a known orientation");
    rotated_likelihood_params p;
    p.pairs = config.pairs;
    p.shape = config.shape;
    if (config.tau) p.tau = *config.tau;
    if (config.patch_spacing) p.spacing = *config.patch_spacing;
    p.tempering = config.tempering;
    if (config.model == measurement_kind::lite)
      return variant_type(std::in_place_index<0>, sift_lite{}, map, grid, p);
    return variant_type(std::in_place_index<1>, classic_sift{}, map, grid, p);
  }

  variant_type model_;
};

// ---------------------------------------------------------------------------------------------
// The generic front door: `basic_localizer<Measurement>` over a measurement policy.
//
// A measurement policy P says how a localizer builds its measurement models from (config, map,
// window); everything else a localizer does (the latent appearance, the robust motion, restarts,
// the calibrated verdict, tracking, preprocessing) is the same for every policy. A type P models
// `localizer_measurement` when, for a `const P p`, a `localizer_config c`, a map `image<float>`
// and the sensor's window `pixel_size w`:
//  1. `typename P::planar_model` is a `measurement_model` over `planar_grid<float>` whose
//     `measurement_type` is `image<float>` (the preprocessed touch at map scale);
//  2. `p.planar(c, map, w)` returns one, prepared for `map` (throws std::invalid_argument for a
//     configuration it cannot honour, naming the setting).
// Optional hooks:
//  P1. `typename P::pose_model` and `p.pose(c, map, pose_grid)`: a model over `pose_grid<float>`;
//      without them a `basic_localizer<P>` refuses `headings` > 0 at construction.
//  P2. `p.check_touch(c, z)`: checks a touch before the filter moves (throws, the belief
//      unchanged), for models whose failures should not cost the prediction.
// Two policies ship: `configured_models` (the run-time choice of `localizer_config::model`, what
// `tacmap::localizer`, the tools and Python run) and `descriptor_measurement<D>` (any
// `descriptor` D: `descriptor_localizer<D>`). Minimal conforming policy: `descriptor_measurement`
// without P2.
// ---------------------------------------------------------------------------------------------

/// Requirements 1-2 above.
template <class P>
concept localizer_measurement = requires(const P& p, const localizer_config& c,
                                         const image<float>& map, pixel_size w) {
  typename P::planar_model;
  { p.planar(c, map, w) } -> std::same_as<typename P::planar_model>;
}
&&measurement_model<typename P::planar_model, planar_grid<float>>&&
    std::same_as<typename P::planar_model::measurement_type, image<float>>;

/// P1 above: the policy can localize the heading too.
template <class P>
concept localizes_headings = localizer_measurement<P> &&
    requires(const P& p, const localizer_config& c, const image<float>& map,
             const pose_grid<float>& g) {
  typename P::pose_model;
  { p.pose(c, map, g) } -> std::same_as<typename P::pose_model>;
};

/// The shipped models chosen at run time from `localizer_config::model` (lite, classic, ncc):
/// the policy of `tacmap::localizer`, `tacmap::library_localizer`, the tools and the Python
/// module. A C++ user with a descriptor of their own uses `descriptor_measurement` instead.
struct configured_models {
  using planar_model = configured_measurement;
  using pose_model = configured_rotated_measurement;
  [[nodiscard]] planar_model planar(const localizer_config& c, const image<float>& map,
                                    pixel_size window) const {
    return configured_measurement(c, map, window);
  }
  [[nodiscard]] pose_model pose(const localizer_config& c, const image<float>& map,
                                const pose_grid<float>& grid) const {
    return configured_rotated_measurement(c, map, grid);
  }
};

/// The planar filter a localizer with policy `M` runs (known heading): positions x appearance
/// hypotheses, the robust motion, the policy's model under `appearance_likelihood`.
template <class M>
using planar_filter_for =
    bayes_filter<latent_grid<planar_grid<float>>, robust_motion<latent_motion<odometry_gaussian>>,
                 appearance_likelihood<typename M::planar_model>>;
namespace detail {
struct no_pose_filter {
  struct saved_state {};
};
template <class M>
struct pose_filter_of {
  using type = no_pose_filter;
};
template <localizes_headings M>
struct pose_filter_of<M> {
  using type = bayes_filter<latent_grid<pose_grid<float>>,
                            robust_motion<latent_motion<pose_odometry_gaussian>>,
                            appearance_likelihood<typename M::pose_model>>;
};
}  // namespace detail
/// The (x, y, theta) filter a localizer with policy `M` runs (unknown heading); an empty struct
/// for a policy without P1.
template <class M>
using pose_filter_for = typename detail::pose_filter_of<M>::type;

/// The filter a planar `localizer` runs (known heading): positions x appearance hypotheses.
using planar_localizer_filter = planar_filter_for<configured_models>;
/// The filter a `localizer` with unknown heading runs: (x, y, theta) x appearance hypotheses.
using pose_localizer_filter = pose_filter_for<configured_models>;

namespace detail {

inline robust_motion_params robust_params(const localizer_config& c) {
  return {.lost_probability = c.lost(),
          .wide_probability = c.wide(),
          .wide_sigma_mm = c.wide_sigma_mm,
          .broad_probability = c.broad(),
          .broad_sigma_mm = c.broad_sigma_mm};
}

/// `slip_recheck_params`: the belief becomes `before` (the belief before the move) predicted by
/// `predict` with the recheck's broad component on top of the filter's own motion model, then
/// updated by `update` — the doubting touch's update done again under the slip hypothesis. The
/// motion model's parameters are restored whatever happens. False, the filter unchanged, for
/// motion models without a broad component to set (a library's per-object copies).
template <class Filter, class Predict, class Update>
bool recheck_as_slip(Filter& filter, const typename Filter::belief_type& before, Predict& predict,
                     Update&& update, const slip_recheck_params& recheck) {
  if constexpr (requires(robust_motion_params p) { filter.motion().set_params(p); }) {
    auto& motion = filter.motion();
    const robust_motion_params own = motion.params();
    robust_motion_params slip = own;
    slip.broad_probability = std::max(own.broad_probability, recheck.broad_probability);
    slip.broad_sigma_mm = recheck.broad_sigma_mm;
    filter.set_prior(before);
    motion.set_params(slip);
    try {
      predict();
    } catch (...) {
      motion.set_params(own);
      throw;
    }
    motion.set_params(own);
    std::forward<Update>(update)();
    return true;
  } else {
    return false;
  }
}

/// The filter half of a localizer's touch: `predict()` (the caller's motion step, or nothing),
/// then the update with `z` when the frame was accepted (`z` not null), counting it in
/// `touches`. The filter starts again from a uniform belief, and `restarted` says so, for two
/// causes only, both possible without the motion floor (lost_probability = 0):
///  * the motion carried every state the belief allowed off the map (the motion model's
///    std::domain_error);
///  * the touch ruled out every state the prediction still allowed (`contradiction_error`);
///    the restarted update's `log_prediction_support` is then -inf (the prediction had no
///    support).
/// Any other failure is the model's (a likelihood NaN, +inf or -inf everywhere, a degenerate
/// model's domain_error) and propagates: a restart would hide it, and the same touch would fail
/// again from uniform. (`localizer_step` then puts the state before the prediction back.)
/// With `recheck`, a touch whose `log_prediction_support` is below `recheck->doubt` is updated
/// again as a slip (`recheck_as_slip`, from a copy of the belief before `predict`); the report
/// stays the first update's.
template <class Filter, class Predict, class Measurement>
std::optional<update_report> predict_and_update(
    Filter& filter, Predict&& predict, const Measurement* z, std::size_t& touches, bool& restarted,
    const std::optional<slip_recheck_params>& recheck = std::nullopt,
    const typename Filter::belief_type* saved_before = nullptr) {
  // The belief before the move, for a second look at a touch that doubts its prediction: the
  // caller's saved copy (localizer_step's) where there is one, else a copy made here.
  std::optional<typename Filter::belief_type> own_copy;
  const typename Filter::belief_type* before = nullptr;
  if (recheck && z != nullptr && touches > 0) {
    if (saved_before == nullptr) saved_before = &own_copy.emplace(filter.belief());
    before = saved_before;
  }
  try {
    predict();
  } catch (const std::domain_error&) {
    filter.reset();
    restarted = true;
  }
  if (z == nullptr) return std::nullopt;
  std::optional<update_report> report;
  try {
    report = filter.update(*z);
  } catch (const contradiction_error&) {
    if (touches == 0 && !restarted) throw;  // a uniform belief cannot be contradicted
    filter.reset();
    restarted = true;
    report = filter.update(*z);
    report->log_prediction_support = -std::numeric_limits<double>::infinity();
  }
  // The report stays the first update's: what the touch said of the odometry's prediction.
  if (before && !restarted && report->log_prediction_support < recheck->doubt)
    recheck_as_slip(
        filter, *before, predict, [&] { (void)filter.update(*z); }, *recheck);
  ++touches;
  return report;
}

/// What the shared step gives a localizer: the update's report (none for a rejected frame), the
/// filter's estimate, the verdict's assessment and whether the filter restarted.
template <class Filter>
struct step_outcome {
  std::optional<update_report> report;
  decltype(std::declval<const Filter&>().estimate()) estimate;
  tacmap::confidence assessment;
  bool restarted = false;
};

/// THE step of both front doors (`basic_localizer`, `basic_library_localizer`; the paper's
/// Table 1 with the verdict): predict, update, restart from uniform on one of the two
/// documented causes (`predict_and_update`, counted in `restarts`), assess. All or nothing:
/// the filter's state is saved into `saved` first and, when any part throws (a model's
/// domain_error after the motion was applied, a contradiction from uniform, an allocation),
/// the belief, tracking's bookkeeping and both counters are put back before the exception
/// propagates, so a refused touch leaves the localizer exactly as it was.
template <class Filter, class Predict, class Measurement>
step_outcome<Filter> localizer_step(
    Filter& filter, Predict&& predict, const Measurement* z, const confidence_params& params,
    std::size_t& touches, std::size_t& restarts, typename Filter::saved_state& saved,
    const std::optional<slip_recheck_params>& recheck = std::nullopt) {
  filter.save_state(saved);
  const std::size_t touches_before = touches, restarts_before = restarts;
  try {
    bool restarted = false;
    std::optional<update_report> report = predict_and_update(
        filter, std::forward<Predict>(predict), z, touches, restarted, recheck, &saved.belief());
    if (restarted) ++restarts;
    auto est = filter.estimate();
    const tacmap::confidence conf =
        report ? assess(filter, est, *report, params) : assess(filter, est, params);
    return {std::move(report), std::move(est), conf, restarted};
  } catch (...) {
    filter.restore_state(saved);
    touches = touches_before;
    restarts = restarts_before;
    throw;
  }
}

/// The map the measurement model describes: `map` (at `mm_per_px`) blurred by
/// `config.pad_spread(sensor)` (`localizer_config::pad_spread_mm`), or `map` itself for 0.
[[nodiscard]] inline image<float> map_as_sensor_sees(const localizer_config& config,
                                                     const image<float>& map, double mm_per_px,
                                                     const taxel_geometry& sensor) {
  const double spread = config.pad_spread(sensor);
  if (!(spread > 0.0)) return map;
  const double sigma_px = spread / mm_per_px;
  if (!(sigma_px <= max_blur_px))
    fail("localizer_config: the sensor's spread on the map (pad_spread_mm) ", spread, " mm is ",
         sigma_px, " px on a map of ", mm_per_px, " mm per px; expected at most ", max_blur_px,
         " px — check the map's scale (mm per px), or set pad_spread_mm to half the sensor's "
         "pitch");
  return gaussian_blurred(map, sigma_px);
}

}  // namespace detail

/// The planar filter `config` describes for `map` (intensities) at `mm_per_px`, with a sensor
/// window of `window` px and the policy `measurement`'s model: what `basic_localizer<M>` runs.
/// Throws std::invalid_argument for an invalid configuration or a map smaller than the window.
template <localizer_measurement M>
[[nodiscard]] planar_filter_for<M> make_planar_filter(const M& measurement,
                                                      const localizer_config& config,
                                                      const image<float>& map, double mm_per_px,
                                                      pixel_size window,
                                                      const taxel_geometry& sensor = {}) {
  config.validate();
  const planar_grid<float> positions({.width = map.cols(), .height = map.rows()}, mm_per_px,
                                     window);
  const auto appearances = config.appearances();
  const image<float> seen = detail::map_as_sensor_sees(config, map, mm_per_px, sensor);
  return planar_filter_for<M>(
      latent_grid<planar_grid<float>>(positions, appearance_names(appearances)),
      robust_motion(
          latent_motion<odometry_gaussian>(
              odometry_gaussian({.sigma_mm = config.motion_sigma_mm, .k = config.motion_k}),
              {.switch_probability = config.switch_probability()}),
          detail::robust_params(config)),
      appearance_likelihood<typename M::planar_model>(measurement.planar(config, seen, window),
                                                      appearances));
}

/// The shipped models' planar filter (`configured_models`): what `localizer` and
/// `localization_experiment` run.
[[nodiscard]] inline planar_localizer_filter make_planar_filter(const localizer_config& config,
                                                                const image<float>& map,
                                                                double mm_per_px, pixel_size window,
                                                                const taxel_geometry& sensor = {}) {
  return make_planar_filter(configured_models{}, config, map, mm_per_px, window, sensor);
}

/// The (x, y, theta) filter for `config.headings` > 0, as `make_planar_filter`.
template <localizes_headings M>
[[nodiscard]] pose_filter_for<M> make_pose_filter(const M& measurement,
                                                  const localizer_config& config,
                                                  const image<float>& map, double mm_per_px,
                                                  pixel_size window,
                                                  const taxel_geometry& sensor = {}) {
  config.validate();
  if (config.headings <= 0)
    detail::fail("make_pose_filter: headings = ", config.headings,
                 "; expected the number of headings of a pose grid (> 0), e.g. 36");
  const pose_grid<float> grid(
      planar_grid<float>({.width = map.cols(), .height = map.rows()}, mm_per_px, window),
      config.headings);
  const auto appearances = config.appearances();
  const image<float> seen = detail::map_as_sensor_sees(config, map, mm_per_px, sensor);
  return pose_filter_for<M>(
      latent_grid<pose_grid<float>>(grid, appearance_names(appearances)),
      robust_motion(latent_motion<pose_odometry_gaussian>(
                        pose_odometry_gaussian({.sigma_mm = config.motion_sigma_mm,
                                                .k = config.motion_k,
                                                .sigma_rad = config.turn_sigma_rad}),
                        {.switch_probability = config.switch_probability()}),
                    detail::robust_params(config)),
      appearance_likelihood<typename M::pose_model>(measurement.pose(config, seen, grid),
                                                    appearances));
}

/// The shipped models' (x, y, theta) filter.
[[nodiscard]] inline pose_localizer_filter make_pose_filter(const localizer_config& config,
                                                            const image<float>& map,
                                                            double mm_per_px, pixel_size window,
                                                            const taxel_geometry& sensor = {}) {
  return make_pose_filter(configured_models{}, config, map, mm_per_px, window, sensor);
}

/// The belief over positions as a `rows() x cols()` image of the grid's positions: summed over
/// the latent hypotheses and, for pose grids, over the headings.
template <class Filter>
[[nodiscard]] image<float> position_belief(const Filter& filter) {
  const auto& grid = filter.grid();
  const auto marginal = marginal_belief(grid, filter.belief());
  const Eigen::Index plane = grid.rows() * grid.cols();
  image<float> out = Eigen::Map<const image<float>>(marginal.data(), grid.rows(), grid.cols());
  for (Eigen::Index layer = 1; layer * plane < marginal.size(); ++layer)
    out +=
        Eigen::Map<const image<float>>(marginal.data() + layer * plane, grid.rows(), grid.cols());
  return out;
}

/// Where the arm says the sensor is, in the arm's own frame (mm, radians): what `touch_at`
/// takes. With a known heading (`headings` = 0) the arm's x and y axes must be parallel to the
/// map's (x to the right along columns, y down along rows); with unknown heading any frame
/// will do, because only motion relative to the sensor is used.
struct arm_pose {
  double x_mm = 0.0;
  double y_mm = 0.0;
  double theta_rad = 0.0;  ///< the sensor's yaw in the arm's frame
};

namespace detail {
/// `touch_at`'s motion between two finite arm poses: finite poses can still be too far apart
/// for their difference (+DBL_MAX to -DBL_MAX overflows to infinity), which is no motion the
/// filter can apply. Says so, naming both poses, instead of letting the motion model blame the
/// position source for an infinite odometry.
inline void check_arm_motion(const arm_pose& from, const arm_pose& to, double dx_mm, double dy_mm) {
  if (!(std::isfinite(dx_mm) && std::isfinite(dy_mm)))
    fail("localizer::touch_at: the arm moved from (", from.x_mm, ", ", from.y_mm, ") mm to (",
         to.x_mm, ", ", to.y_mm, ") mm since the previous touch; the motion (", dx_mm, ", ", dy_mm,
         ") mm overflows a double. Expected poses on one object, a few metres apart at "
         "most — a coordinate is corrupt or in the wrong unit");
}

/// `touch_at`'s motion between two finite arm poses for a known heading (a planar localizer or
/// a library): the difference of the positions (`check_arm_motion`), refused when the yaw turned
/// by more than 5 degrees, which breaks the planar model. `who` names the caller and `turned`
/// finishes the refusal's sentence (why the heading is known, and what to do).
inline odometry known_heading_arm_motion(const arm_pose& from, const arm_pose& to, const char* who,
                                         const char* turned) {
  const double dx = to.x_mm - from.x_mm, dy = to.y_mm - from.y_mm;
  check_arm_motion(from, to, dx, dy);
  const double turn = pose_grid<float>::wrap_angle(to.theta_rad - from.theta_rad);
  if (std::abs(turn) > 5.0 * std::numbers::pi / 180.0)
    fail(who, ": the arm's yaw changed by ", turn * 180.0 / std::numbers::pi,
         " degrees since the previous touch, but ", turned);
  return odometry{.dx_mm = dx, .dy_mm = dy};
}
}  // namespace detail

/// What one touch gave: the estimate, how sure the filter is of it, and what to do.
struct touch_result {
  /// localized: act on `position_mm`; uncertain: touch again; contradicted: this touch fits
  /// elsewhere much better than where the filter expected it (slip, outlier, kidnap?) — touch
  /// again near here or re-grasp; rejected_frame: the frame was no touch (the arm's motion was
  /// still applied).
  tacmap::verdict verdict = tacmap::verdict::uncertain;
  /// The estimate (map frame, mm): the centre of the disc of `confidence.radius_mm` that holds
  /// the most belief, the position most probably within that radius of the truth.
  Eigen::Vector2d position_mm = Eigen::Vector2d::Zero();
  /// The sensor's heading on the map (most probable heading); 0 when it is known (planar).
  double heading_rad = 0.0;
  /// The belief's P(|position - position_mm| <= radius): calibrated with the default scale
  /// (README, "Confidence").
  double probability_within = 0.0;
  /// P(|heading - heading_rad| <= heading tolerance); 1 when the heading is known.
  double heading_probability = 1.0;
  /// P(not this object): the touches come from a surface other than the map's, weighed against
  /// the map from `localizer_config::open_set`'s prior (filter/open_set.hpp). The two
  /// probabilities above are given this object; "localized" needs P(this object) x
  /// `probability_within` at the threshold.
  double probability_other_object = 0.0;
  /// The single most probable state's position (mm) and the belief's covariance of position
  /// (mm^2), entropy over positions (nats).
  Eigen::Vector2d most_probable_mm = Eigen::Vector2d::Zero();
  Eigen::Matrix2d covariance_mm2 = Eigen::Matrix2d::Zero();
  double entropy_nats = 0.0;
  /// Posterior of each appearance hypothesis (`localizer_config::appearances()` order: as
  /// photographed, inverted), or {1} for a fixed appearance.
  std::vector<double> appearance_probability;
  /// This touch's `update_report::log_prediction_support` and `log_marginal_likelihood()`;
  /// 0 for a rejected frame.
  double log_prediction_support = 0.0;
  double log_marginal_likelihood = 0.0;
  /// Which states this touch's update evaluated (`localizer_config::tracking`): `tracked` once
  /// the belief is concentrated, else the whole grid and why; `full` for a rejected frame.
  tacmap::update_path path = tacmap::update_path::full;
  /// Why the frame was rejected (none when it was used).
  frame_rejection rejection = frame_rejection::none;
  /// The filter started again from a uniform belief at this touch, for one of two causes only
  /// (both possible without the motion floor, `lost_probability` = 0): the motion carried every
  /// state the belief allowed off the map, or the touch ruled out every one of them
  /// (`contradiction_error`). Counted by the localizer's `restarts()`. A model that fails (a
  /// NaN likelihood, -inf everywhere) throws instead: a restart would not cure it.
  bool restarted = false;
  /// Touches used since construction or `reset()`, this one included.
  std::size_t touches = 0;
  /// Frames combined into this touch: 1 for a single frame; for a burst, the frames
  /// `combine_burst` kept (the settling head and outlier frames dropped).
  std::size_t frames_combined = 1;

  [[nodiscard]] bool accepted() const { return rejection == frame_rejection::none; }
};

/// The measurement policy of a `descriptor` D of the user's own: `descriptor_likelihood<D>` in
/// the plane and `rotated_descriptor_likelihood<D>` over headings, configured from
/// `localizer_config` like the shipped models (`pairs`, `shape`, `features`, `storage`, `tau`,
/// `patch_spacing`, `tempering`). The descriptor is the model: `config.model` is not read;
/// `tau` defaults to the descriptor models' 0.15 and `patch_spacing` to the paper's 9 (fit your
/// own tau with `tacmap::fit_tau`, sim/calibration.hpp). What the localizer gives D:
///  * the latent appearance: with H3 (`contrast_permutation`, descriptor/concept.hpp) both
///    signs in one pass, else the inverted touch described as a second image;
///  * robust motion, restarts, the verdict, tracking (descriptor_likelihood has the hooks), the
///    pose grid (`headings` > 0, any descriptor: the touch is turned, then described);
///  * `appearance = per_patch` (aligned pairing); `appearance = unsigned` is refused (it needs
///    dense SIFT's orientation channels: `unsigned_orientation`).
/// Checks: each touch is described once more before the filter moves (P2), so that a descriptor
/// returning NaN or a wrong shape is refused, naming it, with the belief unchanged; preparing a
/// map with per-window features and no H4 is refused above `preparation_budget_s`.
/// C++ only: the Python module offers the shipped models (`configured_models`).
template <descriptor D>
class descriptor_measurement {
 public:
  using descriptor_type = D;
  using planar_model = descriptor_likelihood<D>;
  using pose_model = rotated_descriptor_likelihood<D>;

  descriptor_measurement() requires std::default_initializable<D>
  = default;
  /// Implicit: `descriptor_localizer<D> loc(map, 0.2, config, sensor, D{...})`.
  descriptor_measurement(D d) : descriptor_(std::move(d)) {}  // NOLINT(google-explicit-constructor)

  [[nodiscard]] const D& descriptor() const { return descriptor_; }

  /// The planar model's parameters `config` gives.
  [[nodiscard]] static descriptor_likelihood_params planar_params(const localizer_config& c) {
    descriptor_likelihood_params p;
    p.pairs = c.pairs;
    p.shape = c.shape;
    p.features = c.features;
    p.storage = c.storage;
    if (c.tau) p.tau = *c.tau;
    if (c.patch_spacing) p.spacing = *c.patch_spacing;
    p.tempering = c.tempering;
    if (c.appearance == appearance_handling::per_patch)
      p.contrast = contrast_sign::either_per_patch;
    if constexpr (contrast_symmetric_descriptor<D>)
      p.both_signs = c.appearance == appearance_handling::latent && p.pairs == pairing::aligned;
    return p;
  }

  [[nodiscard]] planar_model planar(const localizer_config& c, const image<float>& map,
                                    pixel_size window) const {
    check_appearance(c);
    return detail::guarded_descriptor_likelihood(descriptor_, map, window, planar_params(c),
                                                 c.preparation_budget_s);
  }

  [[nodiscard]] pose_model pose(const localizer_config& c, const image<float>& map,
                                const pose_grid<float>& grid) const {
    check_appearance(c);
    rotated_likelihood_params p;
    p.pairs = c.pairs;
    p.shape = c.shape;
    if (c.tau) p.tau = *c.tau;
    if (c.patch_spacing) p.spacing = *c.patch_spacing;
    p.tempering = c.tempering;
    return pose_model(descriptor_, map, grid, p);
  }

  /// P2: the touch `z` (and, for the latent or per-patch appearance of a descriptor without
  /// H3, its inversion) described and checked before the filter moves: the right shape and
  /// finite values, else std::invalid_argument naming D and the value.
  void check_touch(const localizer_config& c, const image<float>& z) const {
    using T = typename D::scalar_type;
    const image<T> zt = z.template cast<T>();
    detail::check_field(descriptor_, descriptor_.compute(zt), zt.rows(), zt.cols(), "the touch");
    if constexpr (!contrast_symmetric_descriptor<D>) {
      if (c.appearance == appearance_handling::latent ||
          c.appearance == appearance_handling::per_patch) {
        const image<T> inverted = detail::inverted_contrast(zt);
        detail::check_field(descriptor_, descriptor_.compute(inverted), zt.rows(), zt.cols(),
                            "the inverted touch (the 'inverted' appearance hypothesis)");
      }
    }
  }

 private:
  static void check_appearance(const localizer_config& c) {
    if (c.appearance == appearance_handling::unsigned_gradients)
      detail::fail("descriptor_measurement<", detail::type_name<D>(),
                   ">: appearance = unsigned folds dense SIFT's orientation channels "
                   "(unsigned_orientation) and has no meaning for another descriptor; use "
                   "appearance = latent (the default: both contrast signs as hypotheses) or "
                   "per_patch");
  }

  D descriptor_{};
};

/// Whether a `basic_localizer` is compiled with the (x, y, theta) filter, so that
/// `localizer_config::headings` > 0 (unknown heading) can be chosen at run time. A compile-time
/// choice because that filter (the policy's rotated model, the pose motion, every step over
/// them) is compiled in every translation unit that builds the localizer, used or not:
/// `tacmap::precompiled` holds it for `localizer`, and for a descriptor of your own the part
/// that does not depend on it (the filter's `detail::filter_core`), not the rotated model: with
/// it linked, the translation unit takes about a fifth more (g++ 12 -O2, CPU, medians of 3 on a
/// loaded machine: 17.8 s planar only, 21.5 s with it; bench/compile_time/).
enum class heading_support {
  known,      ///< the planar filter only; `headings` > 0 is refused, naming this setting
  localized,  ///< both filters (the policy needs P1: a pose model); `headings` at run time
};

/// `localized` for a policy with a pose model (P1), else `known`: `basic_localizer<M>`'s default.
template <class M>
inline constexpr heading_support default_heading_support =
    localizes_headings<M> ? heading_support::localized : heading_support::known;

/// One object from map to estimate, generic over its measurement policy (`localizer_measurement`
/// above): `localizer` runs the shipped models, `descriptor_localizer<D>` a descriptor of your
/// own, with the same appearance hypotheses, robust motion, restarts, verdict and pose grid.
/// Build it from the map image (intensities, any range, row 0 at the top), the map's scale and
/// the sensor's geometry; call `touch` for every frame with the arm's motion since the previous
/// call (or `touch_at` with the arm's pose).
///
///     tacmap::localizer loc(map, 0.2);                        // defaults: the best measured
///     auto r = loc.touch(frame);                              // first touch
///     r = loc.touch(frame, tacmap::odometry{.dx_mm = 4.0});   // moved 4 mm to the right
///     if (r.verdict == tacmap::verdict::localized) use(r.position_mm);
///
///     tacmap::descriptor_localizer<my_descriptor> mine(map, 0.2, config, sensor, my_descriptor{});
///
/// `Headings` (`heading_support`): whether the (x, y, theta) filter is compiled in; by default
/// when the policy has a pose model (P1).
///
/// Preparing the map (the measurement model's descriptors of every window) happens once, in
/// the constructor; `reset()` starts a new exploration on the same map. Not thread-safe: one
/// localizer per thread.
template <localizer_measurement Measurement,
          heading_support Headings = default_heading_support<Measurement>>
class basic_localizer {
 public:
  using measurement_policy = Measurement;
  static constexpr bool has_headings = Headings == heading_support::localized;
  static_assert(!has_headings || localizes_headings<Measurement>,
                "heading_support::localized needs the measurement policy's (x, y, theta) model: "
                "typename P::pose_model and p.pose(config, map, pose_grid) (localizer.hpp, P1)");
  using planar_filter_type = planar_filter_for<Measurement>;
  /// `detail::no_pose_filter` without the (x, y, theta) filter (`Headings`).
  using pose_filter_type =
      std::conditional_t<has_headings, pose_filter_for<Measurement>, detail::no_pose_filter>;

  /// `map` is the photograph at `mm_per_px`; it is matched at the working resolution
  /// (`localizer_config::working_mm_per_px`: resampled when finer), positions in its own mm.
  /// Throws std::invalid_argument for an empty or non-finite map, a scale that is not a finite
  /// positive number or gives the sensor fewer than `localizer_config::min_px_per_taxel` px per
  /// taxel, a map smaller than the sensor's footprint, or an invalid configuration
  /// (each named with what was expected); `preparation_over_budget` and `insufficient_memory`
  /// for a preparation that would take too long or too much memory.
  basic_localizer(image<float> map, double mm_per_px, localizer_config config = {},
                  taxel_geometry sensor = {}, Measurement measurement = Measurement{})
      : photo_mm_per_px_(checked_photo(map, mm_per_px)),
        resolution_(detail::choose_working_resolution(
            config, sensor, mm_per_px, std::max(map.rows(), map.cols()), "localizer")),
        map_(detail::working_map(std::move(map), mm_per_px, resolution_)),
        mm_per_px_(resolution_.mm_per_px),
        config_(std::move(config)),
        sensor_(sensor),
        window_(
            checked_tactile_window(sensor_, mm_per_px_, {map_.cols(), map_.rows()}, "localizer")),
        measurement_(std::move(measurement)) {
    config_.validate();
    config_.preprocessing.mm_per_px = mm_per_px_;
    if (config_.headings == 0) {
      planar_.emplace(
          make_planar_filter(measurement_, config_, map_, mm_per_px_, window_, sensor_));
      // The open set's shadow (filter/open_set.hpp, eq. 2): the map mirrored left to right.
      if (config_.open_set.model == unknown_model::shadow)
        shadow_.emplace(make_planar_filter(measurement_, config_, map_.rowwise().reverse().eval(),
                                           mm_per_px_, window_, sensor_));
    } else if constexpr (has_headings) {
      pose_.emplace(make_pose_filter(measurement_, config_, map_, mm_per_px_, window_, sensor_));
    } else if constexpr (localizes_headings<Measurement>) {
      detail::fail("localizer: headings = ", config_.headings, ", but this localizer of ",
                   detail::type_name<Measurement>(),
                   " was compiled without the (x, y, theta) filter (heading_support::known, "
                   "descriptor_localizer's default: it saves compiling that filter); use "
                   "descriptor_localizer<D, tacmap::heading_support::localized> (or "
                   "basic_localizer<P, tacmap::heading_support::localized>), or headings = 0");
    } else {
      detail::fail("localizer: headings = ", config_.headings, ", but the measurement policy ",
                   detail::type_name<Measurement>(),
                   " has no (x, y, theta) model (pose_model and pose(), localizer.hpp P1); use "
                   "headings = 0 or give the policy a pose model");
    }
    if (const auto t = config_.tracking_for_filter())
      with_filter([&](auto& f) { f.set_tracking(*t); });
  }

  /// The first touch of an exploration (or one without motion since the previous touch).
  touch_result touch(const tactile_frame& frame) { return step(frame, std::nullopt); }

  /// A touch after the sensor moved by `moved` (map frame, mm) since the previous call. Known
  /// heading only (for unknown heading the map frame's motion is unknown: give `sensor_odometry`
  /// in the sensor's frame, or use `touch_at`). The motion of the first call after
  /// construction or `reset()` is ignored: there is nothing to move yet.
  touch_result touch(const tactile_frame& frame, const odometry& moved) {
    check_finite(moved.dx_mm, moved.dy_mm, 0.0, "touch");
    if (!planar_)
      detail::fail("localizer::touch: odometry (", moved.dx_mm, ", ", moved.dy_mm,
                   ") mm is in the map's frame, but this localizer does not know the heading "
                   "(headings = ",
                   config_.headings,
                   "); give the motion in the sensor's frame (sensor_odometry) or the arm's pose "
                   "(touch_at)");
    return step(frame, sensor_odometry{.du_mm = moved.dx_mm, .dv_mm = moved.dy_mm});
  }

  /// A touch after the sensor moved by `moved` in its own frame (u along its columns, v along
  /// its rows, mm) and turned by `moved.dtheta_rad`. With a known heading the sensor's frame is
  /// the map's and the turn must be 0.
  touch_result touch(const tactile_frame& frame, const sensor_odometry& moved) {
    check_finite(moved.du_mm, moved.dv_mm, moved.dtheta_rad, "touch");
    if (planar_ && moved.dtheta_rad != 0.0)
      detail::fail("localizer::touch: the sensor turned by ", moved.dtheta_rad,
                   " rad, but this localizer assumes a known, fixed heading (headings = 0); "
                   "set localizer_config::headings (e.g. 36) to localize the heading too");
    return step(frame, moved);
  }

  /// A touch with the arm's pose (its own frame, see `arm_pose`): the motion since the previous
  /// `touch_at` becomes the odometry. With a known heading the yaw may not change by more than
  /// 5 degrees between touches (a turned sensor breaks the planar model).
  touch_result touch_at(const tactile_frame& frame, const arm_pose& where) {
    check_finite(where.x_mm, where.y_mm, where.theta_rad, "touch_at");
    std::optional<sensor_odometry> moved;
    if (last_pose_ && planar_) {
      const odometry m = detail::known_heading_arm_motion(
          *last_pose_, where, "localizer::touch_at",
          "this localizer assumes a known, fixed heading (headings = 0); set "
          "localizer_config::headings (e.g. 36) to localize the heading too");
      moved = sensor_odometry{.du_mm = m.dx_mm, .dv_mm = m.dy_mm};
    } else if (last_pose_) {
      const double dx = where.x_mm - last_pose_->x_mm, dy = where.y_mm - last_pose_->y_mm;
      detail::check_arm_motion(*last_pose_, where, dx, dy);
      const double turn = pose_grid<float>::wrap_angle(where.theta_rad - last_pose_->theta_rad);
      // The motion in the sensor's frame at the previous touch: R(-theta) (dx, dy).
      const double c = std::cos(last_pose_->theta_rad), s = std::sin(last_pose_->theta_rad);
      moved =
          sensor_odometry{.du_mm = c * dx + s * dy, .dv_mm = -s * dx + c * dy, .dtheta_rad = turn};
    }
    touch_result r = step(frame, moved);
    last_pose_ = where;
    return r;
  }

  /// The same four touches with a press given as a burst of frames (the paper averaged 20
  /// readings): combined by `combine_burst` with `config().burst` into one frame first, so a
  /// frame still settling or an outlier frame does not vote. Throws std::invalid_argument for
  /// an empty burst or frames of different geometry (naming them) before anything changes.
  touch_result touch(std::span<const tactile_frame> burst) {
    return detail::touch_with_burst(burst, config_.burst,
                                    [&](const tactile_frame& f) { return touch(f); });
  }
  touch_result touch(std::span<const tactile_frame> burst, const odometry& moved) {
    return detail::touch_with_burst(burst, config_.burst,
                                    [&](const tactile_frame& f) { return touch(f, moved); });
  }
  touch_result touch(std::span<const tactile_frame> burst, const sensor_odometry& moved) {
    return detail::touch_with_burst(burst, config_.burst,
                                    [&](const tactile_frame& f) { return touch(f, moved); });
  }
  touch_result touch_at(std::span<const tactile_frame> burst, const arm_pose& where) {
    return detail::touch_with_burst(burst, config_.burst,
                                    [&](const tactile_frame& f) { return touch_at(f, where); });
  }

  /// Starts a new exploration on the same map: a uniform belief, no previous pose.
  void reset() {
    with_filter([](auto& f) { f.reset(); });
    if (shadow_) shadow_->reset();
    calls_ = 0;
    touches_ = 0;
    restarts_ = 0;
    last_pose_.reset();
    other_object_.reset();
  }

  /// The sensor's self-calibration (`localizer_config::calibrate_sensor`): each taxel's gain,
  /// offset and status (`self_calibration::status`, `reason`), or nullptr when it is off.
  [[nodiscard]] const self_calibration* sensor_calibration() const {
    return correction_.estimate();
  }
  /// Forgets what the self-calibration learnt (a new or repaired sensor); `reset()` keeps it.
  void reset_sensor_calibration() { correction_.reset(); }

  /// Ranks candidate moves (map frame, mm, from where the sensor is now) by what the touch after
  /// each is expected to decide (filter/next_touch.hpp): scores in input order, the order best
  /// first (ties keep the input order), `uninformative` when none is expected to decide more
  /// than another. The belief is unchanged. Throws std::invalid_argument for no candidates, a
  /// non-finite one or one off the map from anywhere on it (naming it and the map's extent), and
  /// for an unknown heading (`headings` > 0: the descriptors cannot be rotated, see the message).
  [[nodiscard]] next_touch_ranking next_touch(std::span<const odometry> candidates,
                                              const next_touch_params& params = {}) const {
    if (!planar_)
      detail::fail("localizer::next_touch: headings = ", config_.headings,
                   "; ranking moves needs a known heading (headings = 0): the map's descriptors "
                   "are of windows at the map's own orientation, and a touch predicted at "
                   "another heading would have to be rendered and described again for every "
                   "pair of hypotheses and move. Rank with a localizer of known heading (the "
                   "arm's axes parallel to the map's), or choose the moves yourself");
    return detail::rank_planar_touches(*planar_, candidates, config_.confidence.radius_mm, params,
                                       "localizer::next_touch");
  }
  /// The moves of a reachable rectangle (`touch_region::candidates()`), ranked.
  [[nodiscard]] next_touch_ranking next_touch(const touch_region& region,
                                              const next_touch_params& params = {}) const {
    const std::vector<odometry> c = region.candidates();
    return next_touch(std::span<const odometry>(c), params);
  }

  /// The belief over positions (summed over headings and appearances): one value per position
  /// of the sensor's centre, `positions().rows() x positions().cols()`; the position of element
  /// (r, c) is `positions().state_mm(r * cols + c)`.
  [[nodiscard]] image<float> belief() const {
    return with_filter([](const auto& f) { return position_belief(f); });
  }
  /// Unknown heading: the belief per heading (summed over appearances), one image per heading
  /// `heading_rad(k)`. Known heading: one image, `belief()`.
  [[nodiscard]] std::vector<image<float>> heading_belief() const {
    if (planar_) return {belief()};
    std::vector<image<float>> out;
    if constexpr (has_headings) {
      const auto& g = pose_->grid();
      const auto marginal = marginal_belief(g, pose_->belief());
      const Eigen::Index plane = g.rows() * g.cols();
      for (Eigen::Index k = 0; k < config_.headings; ++k)
        out.emplace_back(
            Eigen::Map<const image<float>>(marginal.data() + k * plane, g.rows(), g.cols()));
    }
    return out;
  }
  /// The heading of layer k of `heading_belief()` (radians, map frame).
  [[nodiscard]] double heading_rad(Eigen::Index k) const {
    if (planar_) return 0.0;
    TACMAP_ASSERT(k >= 0 && k < config_.headings, "heading_rad: layer out of range");
    if constexpr (has_headings) return pose_->grid().base().heading(k);
    return 0.0;
  }

  /// The sensor centre's candidate positions (the grid of `belief()`).
  [[nodiscard]] const planar_grid<float>& positions() const {
    if constexpr (has_headings)
      if (pose_) return pose_->grid().base().positions();
    return planar_->grid().base();
  }
  /// The map as matched: the photograph at the working resolution (`mm_per_px()`).
  [[nodiscard]] const image<float>& map() const { return map_; }
  /// The scale the map is matched at, mm per px (`localizer_config::working_mm_per_px`): the
  /// scale of `map()`, `positions()` and `belief()`. Positions are millimetres either way.
  [[nodiscard]] double mm_per_px() const { return mm_per_px_; }
  /// The photograph's own scale, as given to the constructor.
  [[nodiscard]] double photo_mm_per_px() const { return photo_mm_per_px_; }
  /// What the localizer could not do as well as it should, in words, from construction: e.g. a
  /// photograph coarser than the working resolution, and what that costs in accuracy. Empty
  /// when nothing is amiss. The library prints nothing: show them to the user.
  [[nodiscard]] const std::vector<std::string>& warnings() const { return resolution_.warnings; }
  [[nodiscard]] const taxel_geometry& sensor() const { return sensor_; }
  /// The sensor's footprint on the map, px.
  [[nodiscard]] pixel_size window() const { return window_; }
  /// The configuration, with `preprocessing.mm_per_px` set to the map's scale.
  [[nodiscard]] const localizer_config& config() const { return config_; }
  /// The measurement policy (e.g. `descriptor_measurement<D>::descriptor()`).
  [[nodiscard]] const Measurement& measurement() const { return measurement_; }
  /// Touches used (accepted frames) since construction or `reset()`.
  [[nodiscard]] std::size_t touches() const { return touches_; }
  /// Restarts from a uniform belief since construction or `reset()` (see
  /// `touch_result::restarted` for the two causes).
  [[nodiscard]] std::size_t restarts() const { return restarts_; }
  /// The underlying filter, for what the localizer does not expose: the planar one (nullptr
  /// when the heading is unknown) and the (x, y, theta) one (nullptr when it is known).
  [[nodiscard]] const planar_filter_type* planar_filter() const {
    return planar_ ? &*planar_ : nullptr;
  }
  [[nodiscard]] const pose_filter_type* pose_filter() const { return pose_ ? &*pose_ : nullptr; }

 private:
  // f(the filter this localizer runs).
  template <class F>
  decltype(auto) with_filter(F&& f) {
    if constexpr (has_headings)
      if (pose_) return std::forward<F>(f)(*pose_);
    return std::forward<F>(f)(*planar_);
  }
  template <class F>
  decltype(auto) with_filter(F&& f) const {
    if constexpr (has_headings)
      if (pose_) return std::forward<F>(f)(*pose_);
    return std::forward<F>(f)(*planar_);
  }

  touch_result step(const tactile_frame& frame, const std::optional<sensor_odometry>& moved) {
    if (frame.geometry != sensor_)
      detail::fail("localizer::touch: the frame is ", frame.geometry.rows, " x ",
                   frame.geometry.cols, " taxels at ", frame.geometry.pitch_mm,
                   " mm, but this localizer was built for ", sensor_.rows, " x ", sensor_.cols,
                   " at ", sensor_.pitch_mm,
                   " mm (the footprint on the map depends on it); build the localizer with the "
                   "frame's geometry");
    // Preprocess (and let the policy check the touch, P2) first: a malformed frame or a
    // descriptor that fails on it throws before anything changes.
    // The self-calibration learns from every frame it sees: a refused touch must not teach it
    // (the filter's half is made all or nothing by localizer_step).
    std::optional<detail::sensor_correction> calibration_before;
    if (correction_.estimate()) calibration_before = correction_;
    try {
      const preprocessed_frame pre = preprocess(correction_.apply(frame), config_.preprocessing);
      if constexpr (requires { measurement_.check_touch(config_, pre.pixels); })
        if (pre.accepted()) measurement_.check_touch(config_, pre.pixels);
      touch_result r = with_filter([&](auto& f) { return run(f, pre, moved); });
      ++calls_;
      return r;
    } catch (...) {
      if (calibration_before) correction_ = std::move(*calibration_before);
      throw;
    }
  }

  // The saved filter state of localizer_step (one belief's storage, reused every touch).
  template <class Filter>
  typename Filter::saved_state& saved_state_for() {
    if constexpr (std::is_same_v<Filter, planar_filter_type>)
      return planar_saved_;
    else
      return pose_saved_;
  }

  template <class Filter>
  touch_result run(Filter& filter, const preprocessed_frame& pre,
                   const std::optional<sensor_odometry>& moved) {
    constexpr bool pose = Filter::grid_type::dimension == 3;
    const std::size_t touches_before = touches_, restarts_before = restarts_;
    const auto out = detail::localizer_step(
        filter,
        [&] {
          if (calls_ == 0 || !moved) return;
          if constexpr (pose)
            filter.predict(*moved);
          else
            filter.predict(odometry{.dx_mm = moved->du_mm, .dy_mm = moved->dv_mm});
        },
        pre.accepted() ? &pre.pixels : nullptr, config_.confidence, touches_, restarts_,
        saved_state_for<Filter>(), config_.slip_recheck);
    touch_result r;
    r.restarted = out.restarted;
    r.rejection = pre.rejection;
    const auto& est = out.estimate;
    std::optional<update_report> shadow_report;
    if constexpr (!pose) {
      if (shadow_) {
        // The shadow follows the filter's touch (known heading only); should it fail (a
        // model's error, not a contradiction), the filter's touch is taken back too.
        shadow_->save_state(shadow_saved_);
        try {
          shadow_report = detail::shadow_step(
              *shadow_,
              calls_ > 0 && moved
                  ? std::optional<odometry>(odometry{.dx_mm = moved->du_mm, .dy_mm = moved->dv_mm})
                  : std::nullopt,
              pre.accepted() ? &pre.pixels : nullptr, out.restarted);
        } catch (...) {
          shadow_->restore_state(shadow_saved_);
          filter.restore_state(saved_state_for<Filter>());
          touches_ = touches_before;
          restarts_ = restarts_before;
          throw;
        }
      }
    }
    detail::follow_touch(other_object_, out.restarted, out.report, shadow_report);
    r.probability_other_object = other_object_.probability_unknown();
    const confidence& conf = out.assessment;
    r.verdict = pre.accepted()
                    ? with_open_set(conf, r.probability_other_object, config_.confidence).verdict
                    : verdict::rejected_frame;
    r.position_mm = conf.centre_mm;
    r.probability_within = conf.probability_within;
    r.heading_probability = conf.heading_probability;
    r.most_probable_mm = est.map_mm.template head<2>();
    r.covariance_mm2 = est.covariance_mm2.template topLeftCorner<2, 2>();
    if constexpr (pose) r.heading_rad = est.map_mm(2);
    r.entropy_nats = est.entropy_nats;
    r.appearance_probability = est.hypothesis_probability;
    if (out.report) {
      r.log_prediction_support = out.report->log_prediction_support;
      r.log_marginal_likelihood = out.report->log_marginal_likelihood();
      r.path = out.report->path;
    }
    r.touches = touches_;
    return r;
  }

  static void check_finite(double a, double b, double c, const char* where) {
    if (!(std::isfinite(a) && std::isfinite(b) && std::isfinite(c)))
      detail::fail("localizer::", where, ": the motion or pose (", a, ", ", b, ", ", c,
                   ") is not finite; expected finite millimetres and radians — the position "
                   "source delivered an invalid sample");
  }

  // The photograph's scale, after checking the photograph and the scale.
  static double checked_photo(const image<float>& map, double mm_per_px) {
    if (map.size() == 0)
      detail::fail(
          "localizer: the map is empty; expected an image of the object (e.g. "
          "tacmap::load_image)");
    if (!map.allFinite())
      detail::fail("localizer: the map has non-finite pixels; expected finite intensities");
    if (!(std::isfinite(mm_per_px) && mm_per_px > 0.0))
      detail::fail("localizer: mm_per_px = ", mm_per_px,
                   "; expected the map's scale, a finite value > 0 millimetres per pixel");
    return mm_per_px;
  }

  double photo_mm_per_px_;
  detail::working_resolution resolution_;
  image<float> map_;
  double mm_per_px_;
  localizer_config config_;
  taxel_geometry sensor_;
  pixel_size window_;
  Measurement measurement_;
  std::optional<planar_filter_type> planar_;
  std::optional<pose_filter_type> pose_;
  typename planar_filter_type::saved_state planar_saved_;
  std::optional<planar_filter_type> shadow_;  // the open set's shadow (unknown_model::shadow)
  typename planar_filter_type::saved_state shadow_saved_;
  typename pose_filter_type::saved_state pose_saved_;
  std::size_t calls_ = 0;
  std::size_t touches_ = 0;
  std::size_t restarts_ = 0;
  std::optional<arm_pose> last_pose_;
  detail::sensor_correction correction_{config_.calibrate_sensor, sensor_};
  open_set other_object_{config_.open_set};  // P(not this object)
};

/// The front door with the shipped models, chosen at run time by `localizer_config::model`
/// (`configured_models`): what the tools and the Python module run.
class localizer : public basic_localizer<configured_models> {
 public:
  using basic_localizer::basic_localizer;
};

/// The front door for a descriptor of your own (`descriptor_measurement<D>`): every capability
/// of `localizer`, C++ only. Known heading unless asked (`heading_support`): the (x, y, theta)
/// filter is compiled in only with `heading_support::localized`.
///
///     tacmap::descriptor_localizer<my_descriptor> loc(map, 0.2);  // D{} by default
///     auto r = loc.touch(frame);
///     tacmap::descriptor_localizer<my_descriptor, tacmap::heading_support::localized> turned(
///         map, 0.2, {.headings = 36});
template <descriptor D, heading_support Headings = heading_support::known>
using descriptor_localizer = basic_localizer<descriptor_measurement<D>, Headings>;

}  // namespace tacmap

// Compiled once in tacmap::precompiled where it is linked (tacmap/precompiled.hpp): the
// localizer's planar and (x, y, theta) filters.
#include "tacmap/precompiled.hpp"
#ifdef TACMAP_EXTERN_TEMPLATE
namespace tacmap {
TACMAP_EXTERN_FILTER_CORE(latent_grid<planar_grid<float>>,
                          robust_motion<latent_motion<odometry_gaussian>>);
TACMAP_EXTERN_FILTER_CORE(latent_grid<pose_grid<float>>,
                          robust_motion<latent_motion<pose_odometry_gaussian>>);
TACMAP_EXTERN_FILTER(latent_grid<planar_grid<float>>,
                     robust_motion<latent_motion<odometry_gaussian>>,
                     appearance_likelihood<configured_measurement>);
TACMAP_EXTERN_FILTER(latent_grid<pose_grid<float>>,
                     robust_motion<latent_motion<pose_odometry_gaussian>>,
                     appearance_likelihood<configured_rotated_measurement>);
}  // namespace tacmap
#endif
