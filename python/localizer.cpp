// tacmap's Python module: the front door — `Localizer`, its configuration and what a touch
// returns (C++ include/tacmap/localizer.hpp).
#include "bindings.hpp"
// (bindings.hpp first: it defines TACMAP_ASSERT for the tacmap headers below.)
#include <array>
#include <cstdint>
#include <mutex>
#include <span>
#include <variant>
#include <vector>

#include "front_door.hpp"
#include "tacmap/localizer.hpp"
#include "tacmap/tactile/preprocess.hpp"

namespace tacmap::python {

namespace {

// ---- enums: the names of the C++ to_string functions (and of tacmap-evaluate's options) ----

const choices<measurement_kind> model_names = {{"sift_lite", measurement_kind::lite},
                                               {"classic_sift", measurement_kind::classic},
                                               {"ncc", measurement_kind::ncc}};
const choices<pairing> pairing_names = {{"all_pairs", pairing::all_pairs},
                                        {"aligned", pairing::aligned}};
const choices<likelihood_shape> shape_names = {{"inverse", likelihood_shape::inverse},
                                               {"exponential", likelihood_shape::exponential}};
const choices<window_features> feature_names = {{"per_window", window_features::per_window},
                                                {"shared_dense", window_features::shared_dense}};
const choices<appearance_handling> appearance_names_ = {
    {"fixed", appearance_handling::fixed},
    {"latent", appearance_handling::latent},
    {"unsigned", appearance_handling::unsigned_gradients},
    {"per_patch", appearance_handling::per_patch}};
const choices<burst_statistic> burst_statistic_names = {
    {"median", burst_statistic::median}, {"trimmed_mean", burst_statistic::trimmed_mean}};
const choices<resize_method> resize_names = {{"bilinear", resize_method::bilinear},
                                             {"nearest", resize_method::nearest}};

// ---- Localizer: the C++ object and the lock that makes it safe to share between threads ----

using py_localizer = locked_front_door<localizer>;

tactile_frame frame_of(const localizer& loc, const py::handle& obj, const std::string& what) {
  return python::frame_of(loc.sensor(), obj, what, "localizer");
}

py::tuple extent_of(const localizer& loc) {
  const planar_grid<float>& g = loc.positions();
  const auto first = g.state_mm(0);
  const double h = 0.5 * g.mm_per_px();
  const double left = first(0) - h, top = first(1) - h;
  const double right = left + static_cast<double>(g.cols()) * g.mm_per_px();
  const double bottom = top + static_cast<double>(g.rows()) * g.mm_per_px();
  return py::make_tuple(left, right, bottom, top);
}

constexpr const char* localizer_doc = R"doc(One object from map to estimate (C++ tacmap::localizer).

Build it from the map image (intensities, any range, row 0 at the top), the map's scale and the
sensor's geometry; call `touch` for every frame with the arm's motion since the previous call
(or `touch_at` with the arm's pose)::

    loc = tacmap.Localizer(map, 0.2)          # defaults: the best measured
    r = loc.touch(frame)                      # first touch
    r = loc.touch(frame, (4.0, 0.0))          # moved 4 mm to the right
    if r.verdict == "localized": use(r.position_mm)

Preparing the map (the measurement model's descriptors of every window) happens once, in the
constructor; `reset()` starts a new exploration on the same map. Each touch is one step of the
paper's Table 1: predict with the motion since the previous touch, update with the frame.
The measurement model is one of the shipped ones (LocalizerConfig.model); a descriptor of your
own runs through the same front door in C++ only (tacmap::descriptor_localizer<D>).

Frames are Frame objects or 2-D arrays of raw counts, shape (sensor.rows, sensor.cols), any
real dtype (copied to float32). Positions are millimetres in the map frame: x to the right
along columns, y down along rows, origin at the map's top-left corner.

The GIL is released while the map is prepared and during touches; one localizer may be shared
between threads (calls are serialised), but two localizers run in parallel.)doc";

}  // namespace

void bind_config(py::module_& m) {
  // ---- PreprocessParams ----
  py::class_<preprocess_params> pre(m, "PreprocessParams");
  pre.def_readwrite("min_peak", &preprocess_params::min_peak,
                    "Reject when the largest taxel is below this (raw counts).")
      .def_readwrite("min_total", &preprocess_params::min_total,
                     "Reject when the sum of all taxels is below this (decision value).")
      .def_readwrite("min_contrast", &preprocess_params::min_contrast,
                     "Reject when (max - min) / max, the range the normalised image spans, is "
                     "below this fraction (not counts): the frame is flat, at whatever level (a "
                     "saturated frame, every taxel at full scale, is flat). 0 turns the check "
                     "off.")
      .def_readwrite("mm_per_px", &preprocess_params::mm_per_px,
                     "The map's scale (a Localizer replaces it by its map's).");
  enum_property(pre, "resize", &preprocess_params::resize, resize_names,
                "How taxel values are spread over map pixels: 'bilinear' interpolates between "
                "taxel centres (smooth); 'nearest' fills each taxel's cell (blocky).");
  keyword_struct<preprocess_params>(
      pre, {"min_peak", "min_total", "min_contrast", "mm_per_px", "resize"},
      "Configuration of tactile preprocessing (paper, Sec. IV-A; C++ "
      "tacmap::preprocess_params): reject frames collected unintentionally (weak) or without "
      "a pattern (flat), normalise by the maximum, resize to the map's scale. Thresholds are "
      "raw counts (Weiss arrays: 12 bit, 0..4095).");

  // ---- ConfidenceParams ----
  py::class_<confidence_params> conf(m, "ConfidenceParams");
  conf.def_readwrite("radius_mm", &confidence_params::radius_mm,
                     "What 'right' means: the estimate within this distance of the truth (mm). "
                     "5 mm: the paper's success criterion.")
      .def_readwrite("threshold", &confidence_params::threshold,
                     "The belief's P(error <= radius_mm) at or above which the verdict is "
                     "'localized'.")
      .def_readwrite("heading_tolerance_rad", &confidence_params::heading_tolerance_rad,
                     "Pose grids: what a right heading means (radians; 15 degrees).")
      .def_readwrite("contradiction", &confidence_params::contradiction,
                     "The touch's log_prediction_support below which the verdict is "
                     "'contradicted' (nats; -2: the touch 7.4 times more probable elsewhere). "
                     "-inf turns it off.");
  keyword_struct<confidence_params>(
      conf, {"radius_mm", "threshold", "heading_tolerance_rad", "contradiction"},
      "When the filter says 'localized' (C++ tacmap::confidence_params): the belief's "
      "probability that the estimate lies within radius_mm of the truth, against a threshold; "
      "and when a touch contradicts the prediction.");

  // ---- BurstParams ----
  py::class_<burst_params> bp(m, "BurstParams");
  bp.def_readwrite("settle_tolerance", &burst_params::settle_tolerance,
                   "A frame belongs to the settled press once its total is within this fraction "
                   "of the settled level; the frames before the first such frame are the "
                   "settling head.")
      .def_readwrite("outlier_tolerance", &burst_params::outlier_tolerance,
                     "After the head, frames whose total differs from the settled level by more "
                     "than this fraction are outliers (at least settle_tolerance).")
      .def_readwrite("trim_fraction", &burst_params::trim_fraction,
                     "'trimmed_mean': the fraction of the values dropped at each end, [0, 0.5).")
      .def_readwrite("min_total", &burst_params::min_total,
                     "Totals below this (counts) count as no load.");
  enum_property(bp, "statistic", &burst_params::statistic, burst_statistic_names,
                "How the frames kept are combined per taxel: 'median' (robust to single "
                "spikes) or 'trimmed_mean'.");
  keyword_struct<burst_params>(
      bp, {"settle_tolerance", "outlier_tolerance", "statistic", "trim_fraction", "min_total"},
      "How a press read as a burst of frames is combined into one (C++ tacmap::burst_params, "
      "tactile/burst.hpp): Localizer.touch_burst and LibraryLocalizer.touch_burst with "
      "LocalizerConfig.burst, or combine_burst alone.");

  // ---- SelfCalibrationParams ----
  py::class_<self_calibration_params> sc(m, "SelfCalibrationParams");
  sc.def_readwrite("window", &self_calibration_params::window,
                   "Touches kept for the estimate (the most recent).")
      .def_readwrite("min_touches", &self_calibration_params::min_touches,
                     "Touches loading a taxel's neighbourhood needed to call it dead or stuck, "
                     "and quiet touches needed to estimate its offset.")
      .def_readwrite("min_gain_touches", &self_calibration_params::min_gain_touches,
                     "Even-enough touches a taxel needs before its gain is estimated.")
      .def_readwrite("load_fraction", &self_calibration_params::load_fraction,
                     "Neighbours' mean >= this x peak: a gain observation.")
      .def_readwrite("unloaded_fraction", &self_calibration_params::unloaded_fraction,
                     "Every neighbour below this x peak: an offset observation.")
      .def_readwrite("dead_fraction", &self_calibration_params::dead_fraction,
                     "Gain (or median reading ratio) below this: dead.")
      .def_readwrite("stuck_fraction", &self_calibration_params::stuck_fraction,
                     "Reading spread below this x the neighbours' spread: stuck.")
      .def_readwrite("gain_tolerance", &self_calibration_params::gain_tolerance,
                     "Gains within this of 1 are left at 1.")
      .def_readwrite("min_peak", &self_calibration_params::min_peak,
                     "Touches whose peak is below this (counts) are not used (no contact).")
      .def_readwrite("iterations", &self_calibration_params::iterations,
                     "Fixed-point iterations of the gains.")
      .def_readwrite("refresh_every", &self_calibration_params::refresh_every,
                     "The estimate is redone every this many usable touches.");
  keyword_struct<self_calibration_params>(
      sc,
      {"window", "min_touches", "min_gain_touches", "load_fraction", "unloaded_fraction",
       "dead_fraction", "stuck_fraction", "gain_tolerance", "min_peak", "iterations",
       "refresh_every"},
      "A sensor that calibrates itself from its own touches (C++ "
      "tacmap::self_calibration_params, tactile/self_calibration.hpp): per-taxel gain and "
      "offset, dead and stuck taxels (which never vote), with no calibration rig. "
      "LocalizerConfig.calibrate_sensor turns it on.");

  // ---- TrackingParams ----
  py::class_<tracking_params> tp(m, "TrackingParams");
  tp.def_readwrite("epsilon", &tracking_params::epsilon,
                   "Predicted mass left outside the evaluated states, [0, 0.5); 0 turns "
                   "tracking off. 1e-9 for real touches.")
      .def_readwrite("tolerance", &tracking_params::tolerance,
                     "The largest bound on the posterior's total-variation error accepted on "
                     "the tracked path, (0, 1).")
      .def_readwrite("max_support", &tracking_params::max_support,
                     "The whole grid is evaluated when the support holds more than this "
                     "fraction of the states, (0, 1].")
      .def_readwrite("recheck_every", &tracking_params::recheck_every,
                     "The whole grid every this many tracked updates in a row (0: never).")
      .def_readwrite("doubt", &tracking_params::doubt,
                     "The estimated log_prediction_support of a tracked update below which the "
                     "whole grid is evaluated instead (-inf: never).")
      .def_readwrite("sample_every", &tracking_params::sample_every,
                     "Each tracked update also evaluates every this many-th row of the grid "
                     "(shifting by one row each touch): the sample this touch's doubt is judged "
                     "against (0: the last whole-grid update's evidence).")
      .def_readwrite("sample_layers", &tracking_params::sample_layers,
                     "The sample holds at most this many layers' worth of rows (0: every "
                     "layer); a grid with more layers (headings) samples one layer in k a touch, "
                     "the next the next (C++ tracking_params::sample_layers).")
      .def_static("default", &default_tracking,
                  "The values chosen by measurement for the localizer's default filter (C++ "
                  "default_tracking()), what LocalizerConfig uses unless told otherwise.");
  keyword_struct<tracking_params>(
      tp,
      {"epsilon", "tolerance", "max_support", "recheck_every", "doubt", "sample_every",
       "sample_layers"},
      "Tracking (C++ tacmap::tracking_params, filter/bayes_filter.hpp): once the belief is "
      "concentrated, a touch evaluates the likelihood only where the belief is and checks the "
      "whole grid when the touch doubts the prediction and every recheck_every touches. The "
      "default-constructed value is off (epsilon 0); TrackingParams.default() is the measured "
      "choice.");

  // ---- SlipRecheckParams ----
  py::class_<slip_recheck_params> sr(m, "SlipRecheckParams");
  sr.def_readwrite("doubt", &slip_recheck_params::doubt,
                   "The touch's log_prediction_support below which it is looked at again as a "
                   "slip (a log Bayes factor <= 0).")
      .def_readwrite("broad_probability", &slip_recheck_params::broad_probability,
                     "The slip hypothesis's share of the prediction, (0, 1).")
      .def_readwrite("broad_sigma_mm", &slip_recheck_params::broad_sigma_mm,
                     "The slip's spread, mm per axis.");
  keyword_struct<slip_recheck_params>(
      sr, {"doubt", "broad_probability", "broad_sigma_mm"},
      "A second look at a touch that doubts its prediction (C++ tacmap::slip_recheck_params, "
      "motion/robust_motion.hpp): its update is done again from the belief before the move, "
      "predicted with a broad component — the hypothesis that the object slipped in the "
      "grasp. LocalizerConfig.slip_recheck turns it on (Localizer only: a library's "
      "per-object motion cannot take it).");

  // ---- LocalizerConfig ----
  py::class_<localizer_config> cfg(m, "LocalizerConfig");
  enum_property(cfg, "model", &localizer_config::model, model_names,
                "Which measurement model localizes: 'sift_lite' (the paper's 2 x 2 x 8 dense "
                "SIFT, eq. (1)-(2)), 'classic_sift' (4 x 4 x 8 dense SIFT; the default, best "
                "measured) or 'ncc' (normalised cross-correlation baseline). Every shipped "
                "model is here; a descriptor of your own runs in C++ only "
                "(tacmap::descriptor_localizer<D>).");
  enum_property(cfg, "pairs", &localizer_config::pairs, pairing_names,
                "Descriptor models: which tactile patch is compared with which window patch "
                "in eq. (1): 'all_pairs' (the paper) or 'aligned' (patch m against patch m).");
  enum_property(cfg, "shape", &localizer_config::shape, shape_names,
                "Descriptor models: how a distance becomes a likelihood: 'inverse' (the "
                "paper's eq. (2)) or 'exponential' (exp(-d / tau)).");
  enum_property(cfg, "features", &localizer_config::features, feature_names,
                "Descriptor models: where a window's descriptors come from: 'per_window' (the "
                "paper: each window described on its own, like a tactile image) or "
                "'shared_dense' (computed once over the whole map and shared by overlapping "
                "windows: far cheaper, slightly different borders).");
  cfg.def_readwrite("tau", &localizer_config::tau,
                    "Temperature: exponential shape (descriptor distance units) or NCC (log p "
                    "= ncc / tau). None: 0.12 for the planar classic_sift model with the "
                    "exponential shape (the default, fitted with patch_spacing 13), else the "
                    "model's own default (descriptor 0.15, NCC 0.1).")
      .def_readwrite("patch_spacing", &localizer_config::patch_spacing,
                     "Pixels between the tactile image's descriptor patches. None: 13 for the "
                     "planar classic_sift model (its patches cover the whole touch), else the "
                     "paper's 9.")
      .def_readwrite("tempering", &localizer_config::tempering, "Exponent on the likelihood.")
      .def_readwrite("motion_sigma_mm", &localizer_config::motion_sigma_mm,
                     "Odometry noise per axis (odometry_gaussian sigma, Sec. III-B), mm.")
      .def_readwrite("motion_k", &localizer_config::motion_k,
                     "Odometry noise neighbours (the paper: 8).")
      .def_readwrite("preprocessing", &localizer_config::preprocessing,
                     "Frame thresholds (PreprocessParams); mm_per_px is replaced by the map's.")
      .def_readwrite("confidence", &localizer_config::confidence,
                     "When the verdict is 'localized' or 'contradicted' (ConfidenceParams).")
      .def_readwrite("tracking_headings", &localizer_config::tracking_headings,
                     "Whether tracking applies with headings > 0 too (C++ "
                     "localizer_config::tracking_headings). True (the default): measured, a "
                     "tracked 36-heading touch costs about a sixth of the whole grid and keeps "
                     "the recovery from kidnaps and slips.")
      .def_readwrite("headings", &localizer_config::headings,
                     "Unknown orientation: 0 localizes over (x, y) with the heading known (the "
                     "paper); N >= 1 over (x, y, theta) with N headings (descriptor models only; "
                     "odometry then in the sensor's frame).")
      .def_readwrite("turn_sigma_rad", &localizer_config::turn_sigma_rad,
                     "Pose motion: turn noise (headings > 0), radians.")
      .def_property(
          "prior_unknown", [](const localizer_config& c) { return c.open_set.prior_unknown; },
          [](localizer_config& c, double p) { c.open_set.prior_unknown = p; },
          "The prior probability, in (0, 1), that the touched surface is not the map (C++ "
          "open_set_params::prior_unknown): weighed against the map by the touches "
          "(TouchResult.probability_other_object). 0.5: as likely unknown as known.")
      .def_property(
          "unknown_evidence_weight",
          [](const localizer_config& c) { return c.open_set.evidence_weight; },
          [](localizer_config& c, double a) { c.open_set.evidence_weight = a; },
          "a in (0, 1] of the unknown surface's model (C++ open_set_params::evidence_weight): "
          "each touch moves the log odds of 'not this object' by -a (S - d), S its "
          "log_prediction_support. Fitted: 0.551; 1 with unknown_support_margin 0 is the "
          "memoryless model.")
      .def_property(
          "unknown_support_margin",
          [](const localizer_config& c) { return c.open_set.support_margin; },
          [](localizer_config& c, double d) { c.open_set.support_margin = d; },
          "d in [0, 20] nats of the unknown surface's model (C++ "
          "open_set_params::support_margin): the support a touch needs before it counts for "
          "the map. Fitted: 0.927.")
      .def_property(
          "unknown_model",
          [](const localizer_config& c) {
            return std::string(c.open_set.model == unknown_model::shadow ? "shadow" : "support");
          },
          [](localizer_config& c, const std::string& name) {
            if (name == "support")
              c.open_set.model = unknown_model::support;
            else if (name == "shadow")
              c.open_set.model = unknown_model::shadow;
            else
              tacmap::detail::fail("LocalizerConfig.unknown_model = '", name,
                                   "'; expected 'support' (each touch's support, the default) or "
                                   "'shadow' (a second filter over the mirrored map(s))");
          },
          "How a touch on an unknown surface is modelled (C++ open_set_params::model): "
          "'support' (-a (S - d) a touch, the default) or 'shadow' (a second filter over the "
          "mirrored map(s) follows the same touches; each moves the log odds by -(b (L - L') + "
          "c S - m), L and L' the two filters' evidence; twice the cost).")
      .def_property(
          "unknown_shadow_weight",
          [](const localizer_config& c) { return c.open_set.shadow_weight; },
          [](localizer_config& c, double b) { c.open_set.shadow_weight = b; },
          "b in (0, 1] of the shadow model (C++ open_set_params::shadow_weight). Fitted: 0.538.")
      .def_property(
          "unknown_shadow_support_weight",
          [](const localizer_config& c) { return c.open_set.shadow_support_weight; },
          [](localizer_config& c, double w) { c.open_set.shadow_support_weight = w; },
          "c in [0, 1] of the shadow model (C++ open_set_params::shadow_support_weight). "
          "Fitted: 0.241.")
      .def_property(
          "unknown_shadow_margin",
          [](const localizer_config& c) { return c.open_set.shadow_margin; },
          [](localizer_config& c, double margin) { c.open_set.shadow_margin = margin; },
          "m in [-20, 20] nats of the shadow model (C++ open_set_params::shadow_margin). "
          "Fitted: 0.618.");
  enum_property(cfg, "appearance", &localizer_config::appearance, appearance_names_,
                "How the map's brightness relates to the object's height: 'fixed' (raised "
                "parts look bright, as the paper's gecko), 'latent' (both relations are "
                "hypotheses of the filter, weighed by the touches; the default), 'unsigned' "
                "(descriptors of unsigned gradient orientation) or 'per_patch' (each tactile "
                "patch matched with whichever sign fits better; aligned pairs only).");
  cfg.def_readwrite("appearance_switch", &localizer_config::appearance_switch,
                    "'latent' only: probability that the appearance hypothesis changes between "
                    "touches, in [0, 0.5]. None: LocalizerConfig.default_appearance_switch.")
      .def_readwrite("lost_probability", &localizer_config::lost_probability,
                     "The probability that a move lands the sensor anywhere: the floor that "
                     "lets the filter recover from odometry outliers, slips and kidnaps. None: "
                     "LocalizerConfig.default_lost_probability; 0: the paper's motion model.")
      .def_readwrite("wide_probability", &localizer_config::wide_probability,
                     "The probability that a move is off by more than motion_sigma_mm (a wider "
                     "Gaussian of wide_sigma_mm). None: the C++ default "
                     "(LocalizerConfig.default_wide_probability); 0: none.")
      .def_readwrite("wide_sigma_mm", &localizer_config::wide_sigma_mm,
                     "The wide motion component's spread, mm.")
      .def_readwrite("broad_probability", &localizer_config::broad_probability,
                     "The probability that a move is off by centimetres (the object slipped in "
                     "the grasp): a broad Gaussian of broad_sigma_mm. None: the C++ default "
                     "(LocalizerConfig.default_broad_probability, 0); 0: none.")
      .def_readwrite("broad_sigma_mm", &localizer_config::broad_sigma_mm,
                     "The broad motion component's spread, mm.")
      .def_readwrite("burst", &localizer_config::burst,
                     "How a press given as a burst of frames (touch_burst, touch_at_burst) is "
                     "combined into one (BurstParams).")
      .def_readwrite("working_mm_per_px", &localizer_config::working_mm_per_px,
                     "The working resolution, mm per px: the scale the map is matched at. A "
                     "finer photograph is resampled to it before the map is prepared, so a "
                     "touch's cost is set by the object's area and the sensor, not the camera's "
                     "pixels; positions stay in the photograph's millimetres. None: the sensor's "
                     "pitch / 3 (LocalizerConfig.default_px_per_taxel). A coarser photograph is "
                     "used as it is, with a warning (Localizer.warnings).")
      .def_readwrite("pad_spread_mm", &localizer_config::pad_spread_mm,
                     "The map as the sensor sees it: the standard deviation, mm, of a Gaussian "
                     "by which the map is blurred before it is described (a touch shows nothing "
                     "finer than a taxel's cell). None: half the sensor's pitch "
                     "(LocalizerConfig.default_pad_spread_pitches); 0: the map as photographed "
                     "(LocalizerConfig.paper()).")
      .def_readonly_static("default_pad_spread_pitches",
                           &localizer_config::default_pad_spread_pitches)
      .def_readonly_static("default_px_per_taxel", &localizer_config::default_px_per_taxel)
      .def_readonly_static("min_px_per_taxel", &localizer_config::min_px_per_taxel)
      .def_readonly_static("default_appearance_switch",
                           &localizer_config::default_appearance_switch)
      .def_readonly_static("default_lost_probability", &localizer_config::default_lost_probability)
      .def_readonly_static("default_wide_probability", &localizer_config::default_wide_probability)
      .def_readonly_static("default_broad_probability",
                           &localizer_config::default_broad_probability)
      .def_static("paper", &localizer_config::paper,
                  "The paper's configuration (Sec. III-C, IV): SIFT-lite, all pairs (eq. (1)), "
                  "the inverse likelihood (eq. (2)), per-window features, a fixed appearance "
                  "and the Gaussian motion model without a floor.")
      .def("name", &localizer_config::name,
           "A short name for tables: 'sift_lite/all_pairs/inverse/per_window', with "
           "'/tau=0.5' when tau is set, and so on.");
  optional_params_property<localizer_config>(
      cfg, "calibrate_sensor", &localizer_config::calibrate_sensor, self_calibration_params{},
      "A sensor that calibrates itself (SelfCalibrationParams): every frame is first seen by an "
      "online estimate of each taxel's gain and offset and of dead or stuck taxels, and "
      "localized corrected (dead and stuck taxels never vote). The estimate outlives reset(); "
      "reset_sensor_calibration() starts it again. None (the default): frames are used as read. "
      "Measured: more sequences localized with a worn sensor, nothing changed for a healthy "
      "one, about 0.15 ms a touch.");
  optional_params_property<localizer_config>(
      cfg, "tracking", &localizer_config::tracking, default_tracking(),
      "Tracking (TrackingParams): once the belief is concentrated, a touch evaluates the "
      "likelihood only where the belief is and a sample of the rest. TrackingParams.default() "
      "(the default, also True); None: every touch evaluates the whole grid. Localizer only (a "
      "library evaluates every object's grid).");
  optional_params_property<localizer_config>(
      cfg, "slip_recheck", &localizer_config::slip_recheck, slip_recheck_params{},
      "A touch that doubts its prediction is looked at again as a slip (SlipRecheckParams). "
      "None (the default): off. Turn it on where objects slip in the grasp. Localizer only.");
  keyword_struct<localizer_config>(
      cfg, localizer_config_fields(),
      "Everything that configures the filter a Localizer (or a simulated experiment) runs (C++ "
      "tacmap::localizer_config): the measurement model, the motion model, the latent "
      "appearance, preprocessing and the verdict. The defaults are the best measured (README, "
      "'Localization results', 'The photo is not the touch', 'Confidence', 'When exploration "
      "goes wrong'); the paper's own configuration is LocalizerConfig.paper().\n\n"
      "    LocalizerConfig(model='sift_lite', features='shared_dense')  # fast\n\n"
      "Enumerations are strings (the names tacmap-evaluate uses). The keyword constructor "
      "validates the whole configuration (ValueError naming the setting); attributes set later "
      "are validated when a Localizer is built.");

  // ---- preprocess ----
  py::class_<preprocessed_frame>(m, "PreprocessedFrame",
                                 "The outcome of preprocessing one frame (C++ "
                                 "tacmap::preprocessed_frame).")
      .def_property_readonly(
          "rejection",
          [](const preprocessed_frame& p) { return choice_name(p.rejection, rejection_names); },
          "Why the frame was not used: 'none' (accepted), 'weak_peak', 'weak_total' or "
          "'flat'.")
      .def_property_readonly("accepted", &preprocessed_frame::accepted)
      .def_readonly("peak", &preprocessed_frame::peak, "The frame's maximum (raw counts).")
      .def_readonly("total", &preprocessed_frame::total, "The frame's sum (raw counts).")
      .def_readonly("contrast", &preprocessed_frame::contrast,
                    "The frame's max - min (raw counts).")
      .def_property_readonly(
          "pixels",
          [](const preprocessed_frame& p) -> py::object {
            if (!p.accepted()) return py::none();
            return to_numpy(p.pixels);
          },
          "The map-scale tactile image in [0, 1] (rows x cols in map pixels), or None when "
          "rejected.")
      .def("reason", &preprocessed_frame::reason,
           "A sentence for logs: why the frame was rejected (empty when accepted).");
  m.def(
      "preprocess",
      [](const py::object& frame, const preprocess_params& params) {
        const tactile_frame f =
            py::isinstance<tactile_frame>(frame)
                ? frame.cast<tactile_frame>()
                : py::module_::import("tacmap").attr("Frame")(frame).cast<tactile_frame>();
        return preprocess(f, params);
      },
      py::arg("frame"), py::arg("params") = preprocess_params{},
      "Preprocesses one frame (paper, Sec. IV-A): rejects weak or flat frames, normalises by "
      "the maximum and resizes taxels to map pixels at params.mm_per_px. `frame`: a Frame or a "
      "2-D array of counts (then taxels at 3.4 mm). Raises ValueError for a malformed frame "
      "(NaN or negative counts) or bad parameters; a weak or flat frame is not an error but a "
      "rejection, reported in the result.");
}

void bind_localizer(py::module_& m) {
  // ---- SensorCalibration ----
  py::class_<self_calibration>(m, "SensorCalibration",
                               "What a sensor's self-calibration has learnt (C++ "
                               "tacmap::self_calibration; LocalizerConfig.calibrate_sensor): "
                               "each taxel's gain, offset and status. A copy, read-only.")
      .def_property_readonly("touches", &self_calibration::touches, "Touches observed so far.")
      .def_property_readonly(
          "gain", [](const self_calibration& c) { return to_numpy(c.gain()); },
          "Per-taxel gain, float32 (rows, cols); 1 where not estimated or healthy.")
      .def_property_readonly(
          "offset", [](const self_calibration& c) { return to_numpy(c.offset()); },
          "Per-taxel offset in counts, float32 (rows, cols); 0 where not estimated.")
      .def_property_readonly(
          "live", [](const self_calibration& c) { return to_numpy(c.live()); },
          "The taxels that vote (bool (rows, cols)): not dead, not stuck.")
      .def_property_readonly(
          "status",
          [](const self_calibration& c) {
            const taxel_geometry& g = c.geometry();
            std::vector<std::vector<std::string>> out(static_cast<std::size_t>(g.rows));
            for (Eigen::Index r = 0; r < g.rows; ++r)
              for (Eigen::Index col = 0; col < g.cols; ++col)
                out[static_cast<std::size_t>(r)].emplace_back(to_string(c.status(r, col)));
            return out;
          },
          "Each taxel's status, rows of str: 'unestimated' (too few usable touches yet: left "
          "as it is), 'healthy', 'calibrated', 'dead' or 'stuck' (dead and stuck never vote).")
      .def(
          "reason",
          [](const self_calibration& c, Eigen::Index row, Eigen::Index col) {
            const taxel_geometry& g = c.geometry();
            if (row < 0 || row >= g.rows || col < 0 || col >= g.cols)
              throw py::index_error("SensorCalibration.reason: (row, col) = (" +
                                    std::to_string(row) + ", " + std::to_string(col) +
                                    "); expected 0 <= row < " + std::to_string(g.rows) +
                                    " and 0 <= col < " + std::to_string(g.cols));
            return c.reason(row, col);
          },
          py::arg("row"), py::arg("col"),
          "A sentence: why taxel (row, col) has its status (e.g. how many usable touches it "
          "has seen and needs).")
      .def("__repr__", [](const self_calibration& c) {
        return "SensorCalibration(touches=" + std::to_string(c.touches()) + ")";
      });

  // ---- TouchResult ----
  py::class_<touch_result>(m, "TouchResult",
                           "What one touch gave (C++ tacmap::touch_result): the estimate, how "
                           "sure the filter is of it, and what to do. Read-only.")
      .def_property_readonly(
          "verdict", [](const touch_result& r) { return to_string(r.verdict); },
          "'localized': act on position_mm; 'uncertain': touch again; 'contradicted': this "
          "touch fits elsewhere much better than where the filter expected it (slip, outlier, "
          "kidnap?) — touch again near here or re-grasp; 'rejected_frame': the frame was no "
          "touch (the arm's motion was still applied).")
      .def_property_readonly(
          "position_mm",
          [](const touch_result& r) { return vec2(r.position_mm.x(), r.position_mm.y()); },
          "The estimate (map frame, mm, numpy (x, y)): the centre of the disc of "
          "confidence.radius_mm that holds the most belief.")
      .def_readonly("heading_rad", &touch_result::heading_rad,
                    "The sensor's heading on the map (most probable); 0 when it is known.")
      .def_readonly("probability_within", &touch_result::probability_within,
                    "The belief's P(|position - position_mm| <= radius).")
      .def_readonly("heading_probability", &touch_result::heading_probability,
                    "P(|heading - heading_rad| <= heading tolerance); 1 when the heading is "
                    "known.")
      .def_readonly("probability_other_object", &touch_result::probability_other_object,
                    "P(not this object): the touches come from a surface other than the map's "
                    "(LocalizerConfig.prior_unknown, weighed by the touches). probability_within "
                    "is given this object; 'localized' needs (1 - probability_other_object) x "
                    "probability_within at the threshold.")
      .def_property_readonly(
          "most_probable_mm",
          [](const touch_result& r) {
            return vec2(r.most_probable_mm.x(), r.most_probable_mm.y());
          },
          "The single most probable state's position (mm, numpy (x, y)).")
      .def_property_readonly(
          "covariance_mm2",
          [](const touch_result& r) -> Eigen::Matrix2d { return r.covariance_mm2; },
          "The belief's covariance of position, mm^2 (numpy (2, 2)).")
      .def_readonly("entropy_nats", &touch_result::entropy_nats,
                    "The belief's entropy over positions, nats.")
      .def_readonly("appearance_probability", &touch_result::appearance_probability,
                    "Posterior of each appearance hypothesis (as photographed, inverted), or "
                    "[1.0] for a fixed appearance.")
      .def_readonly("log_prediction_support", &touch_result::log_prediction_support,
                    "How much more probable the touch is under the prediction than under "
                    "'anywhere on the map' (nats); 0 for a rejected frame.")
      .def_readonly("log_marginal_likelihood", &touch_result::log_marginal_likelihood,
                    "The touch's evidence log p(z_t | z_1..t-1); 0 for a rejected frame.")
      .def_property_readonly(
          "path", [](const touch_result& r) { return std::string(to_string(r.path)); },
          "Which states the touch's update evaluated: 'tracked' once the belief is "
          "concentrated (LocalizerConfig.tracking), else the whole grid and why ('full', "
          "'full (contradicted)', ...).")
      .def_property_readonly(
          "rejection",
          [](const touch_result& r) { return choice_name(r.rejection, rejection_names); },
          "Why the frame was rejected: 'none' when it was used, else 'weak_peak', "
          "'weak_total' or 'flat'.")
      .def_readonly("restarted", &touch_result::restarted,
                    "The filter started again from a uniform belief at this touch.")
      .def_readonly("frames_combined", &touch_result::frames_combined,
                    "Frames combined into this touch: 1 for a single frame; for a burst "
                    "(touch_burst), the frames kept (settling and outlier frames dropped).")
      .def_readonly("touches", &touch_result::touches,
                    "Touches used since construction or reset(), this one included.")
      .def_property_readonly("accepted", &touch_result::accepted,
                             "True when the frame was used (rejection == 'none').")
      .def("__repr__", [](const touch_result& r) {
        return std::string("TouchResult(verdict='") + to_string(r.verdict) + "', position_mm=(" +
               number(r.position_mm.x()) + ", " + number(r.position_mm.y()) +
               "), probability_within=" + number(r.probability_within) +
               ", touches=" + std::to_string(r.touches) + ")";
      });

  // ---- NextTouchRanking ----
  py::class_<next_touch_ranking>(m, "NextTouchRanking",
                                 "Candidate moves ranked by what the touch after each is expected "
                                 "to decide (C++ tacmap::next_touch_ranking). Read-only.")
      .def_property_readonly(
          "order",
          [](const next_touch_ranking& r) {
            return py::array_t<std::int64_t>(
                static_cast<py::ssize_t>(r.order.size()),
                std::vector<std::int64_t>(r.order.begin(), r.order.end()).data());
          },
          "Candidate indices, best first (numpy int64); equal scores keep the input order.")
      .def_property_readonly(
          "score",
          [](const next_touch_ranking& r) {
            return py::array_t<double>(static_cast<py::ssize_t>(r.score.size()), r.score.data());
          },
          "Each candidate's score in input order (numpy float64): the expected entropy "
          "reduction in nats, or with objective 'verdict' the expected probability within the "
          "verdict's radius after the touch.")
      .def_property_readonly(
          "on_map",
          [](const next_touch_ranking& r) {
            return py::array_t<double>(static_cast<py::ssize_t>(r.on_map.size()), r.on_map.data());
          },
          "Each candidate's probability, under the belief, that the sensor lands on the map.")
      .def_property_readonly(
          "candidates", [](const next_touch_ranking& r) { return moves_to_numpy(r.candidates); },
          "The moves ranked, in input order (numpy float64 (N, 2), (dx_mm, dy_mm) each): "
          "candidates[order[0]] is the best.")
      .def_property_readonly(
          "best", [](const next_touch_ranking& r) { return r.best(); },
          "The index of the best candidate (order[0]).")
      .def_readonly("uninformative", &next_touch_ranking::uninformative,
                    "True when every score is within the tolerance of every other: no candidate "
                    "is expected to decide more than another (order is then the input order).")
      .def_readonly("entropy_nats", &next_touch_ranking::entropy_nats,
                    "The entropy of the hypotheses drawn from the belief, before the touch.")
      .def_readonly("hypotheses", &next_touch_ranking::hypotheses,
                    "Distinct hypotheses drawn from the belief.")
      .def("__repr__", [](const next_touch_ranking& r) {
        return "NextTouchRanking(best=" + std::to_string(r.best()) +
               ", candidates=" + std::to_string(r.score.size()) +
               ", uninformative=" + (r.uninformative ? "True" : "False") + ")";
      });

  m.def(
      "touch_region",
      [](double x_min_mm, double x_max_mm, double y_min_mm, double y_max_mm, double step_mm) {
        return moves_to_numpy(touch_region{.x_min_mm = x_min_mm,
                                           .x_max_mm = x_max_mm,
                                           .y_min_mm = y_min_mm,
                                           .y_max_mm = y_max_mm,
                                           .step_mm = step_mm}
                                  .candidates());
      },
      py::arg("x_min_mm"), py::arg("x_max_mm"), py::arg("y_min_mm"), py::arg("y_max_mm"),
      py::arg("step_mm") = 1.0,
      "The moves of a reachable rectangle (C++ tacmap::touch_region::candidates()): a lattice "
      "of step_mm from (x_min_mm, y_min_mm) to (x_max_mm, y_max_mm), relative to where the "
      "sensor is now, as an (N, 2) float64 array of (dx_mm, dy_mm), x fastest — the "
      "candidates of next_touch. Raises ValueError for a rectangle that is not finite or "
      "inverted, a step that is not a finite positive number, or more than a million points.");

  // ---- Localizer ----
  py::class_<py_localizer> localizer_class(m, "Localizer", localizer_doc);
  def_front_door_members<py_localizer>(
      localizer_class,
      "Restarts from a uniform belief since construction or reset() (TouchResult.restarted "
      "says when: the motion carried every state off the map, or a touch ruled them all out).");
  localizer_class
      .def(py::init([](const py::object& map, double mm_per_px,
                       std::optional<localizer_config> config,
                       std::optional<taxel_geometry> sensor) {
             image<float> img = to_image(map, "Localizer: map", "(rows, cols)");
             const py::gil_scoped_release release;  // preparing the map takes a while
             return std::make_unique<py_localizer>(std::move(img), mm_per_px,
                                                   config.value_or(localizer_config{}),
                                                   sensor.value_or(taxel_geometry{}));
           }),
           py::arg("map"), py::arg("mm_per_px"), py::arg("config") = py::none(),
           py::arg("sensor") = py::none(),
           "map: 2-D array of intensities (any range, any real dtype; row 0 at the top). "
           "mm_per_px: the map's scale. config: a LocalizerConfig (None: the defaults). "
           "sensor: a TaxelGeometry (None: 14 x 6 at 3.4 mm).\n\n"
           "Raises TypeError or ValueError for a map that is not a 2-D real array, an empty or "
           "non-finite map, a scale that is not a finite positive number, a map smaller than "
           "the sensor's footprint, or an invalid configuration (each named with what was "
           "expected).")
      .def(
          "touch",
          [](py_localizer& self, const py::object& frame, const py::object& moved) {
            tactile_frame f = frame_of(self.impl, frame, "Localizer.touch: frame");
            const motion mv = motion_of(moved, "Localizer.touch: moved");
            return locked(self, [&](localizer& loc) {
              if (const auto* o = std::get_if<odometry>(&mv)) return loc.touch(f, *o);
              if (const auto* s = std::get_if<sensor_odometry>(&mv)) return loc.touch(f, *s);
              return loc.touch(f);
            });
          },
          py::arg("frame"), py::arg("moved") = py::none(),
          "One touch: preprocessing, prediction with `moved`, update with the frame; returns "
          "a TouchResult.\n\n"
          "frame: a Frame or a 2-D array of raw counts of shape (sensor.rows, sensor.cols).\n"
          "moved: the motion since the previous call —\n"
          "  None: no motion (the first touch of an exploration);\n"
          "  (dx_mm, dy_mm): in the map's frame (known heading only: with headings > 0 the map "
          "frame's motion is unknown, give the sensor-frame triple or use touch_at);\n"
          "  (du_mm, dv_mm, dtheta_rad): in the sensor's own frame (u along its columns, v "
          "along its rows) and its turn; with a known heading the turn must be 0.\n"
          "The motion of the first call after construction or reset() is ignored: there is "
          "nothing to move yet. A rejected frame (verdict 'rejected_frame') still applies the "
          "motion.\n\n"
          "Raises TypeError/ValueError for a frame of the wrong shape or dtype, NaN or negative "
          "counts, or a motion that is not finite or does not fit the configuration.")
      .def(
          "touch_burst",
          [](py_localizer& self, const py::object& frames, const py::object& moved) {
            const std::vector<tactile_frame> burst =
                burst_of(self.impl.sensor(), frames, "Localizer.touch_burst", "localizer");
            const motion mv = motion_of(moved, "Localizer.touch_burst: moved");
            const std::span<const tactile_frame> view(burst);
            return locked(self, [&](localizer& loc) {
              if (const auto* o = std::get_if<odometry>(&mv)) return loc.touch(view, *o);
              if (const auto* s = std::get_if<sensor_odometry>(&mv)) return loc.touch(view, *s);
              return loc.touch(view);
            });
          },
          py::arg("frames"), py::arg("moved") = py::none(),
          "One touch from a burst of frames of the same press (the paper averaged 20 "
          "readings): combined robustly first (combine_burst with config.burst: the settling "
          "frames and outlier frames dropped, then each taxel's median), then as touch(). "
          "frames: a sequence of Frames or 2-D arrays, or a 3-D array (frames, rows, cols). "
          "Raises ValueError for an empty burst or frames of different geometry, before "
          "anything changes.")
      .def(
          "touch_at",
          [](py_localizer& self, const py::object& frame, double x_mm, double y_mm,
             double theta_rad) {
            tactile_frame f = frame_of(self.impl, frame, "Localizer.touch_at: frame");
            return locked(self, [&](localizer& loc) {
              return loc.touch_at(f, {.x_mm = x_mm, .y_mm = y_mm, .theta_rad = theta_rad});
            });
          },
          py::arg("frame"), py::arg("x_mm"), py::arg("y_mm"), py::arg("theta_rad") = 0.0,
          "A touch with the arm's pose (its own frame, mm and radians): the motion since the "
          "previous touch_at becomes the odometry. With a known heading (headings = 0) the "
          "arm's x and y axes must be parallel to the map's and the yaw may not change by "
          "more than 5 degrees between touches; with unknown heading any frame will do, "
          "because only motion relative to the sensor is used.")
      .def(
          "touch_at_burst",
          [](py_localizer& self, const py::object& frames, double x_mm, double y_mm,
             double theta_rad) {
            const std::vector<tactile_frame> burst =
                burst_of(self.impl.sensor(), frames, "Localizer.touch_at_burst", "localizer");
            const std::span<const tactile_frame> view(burst);
            return locked(self, [&](localizer& loc) {
              return loc.touch_at(view, {.x_mm = x_mm, .y_mm = y_mm, .theta_rad = theta_rad});
            });
          },
          py::arg("frames"), py::arg("x_mm"), py::arg("y_mm"), py::arg("theta_rad") = 0.0,
          "touch_at() with a press read as a burst of frames (as touch_burst). Raises "
          "ValueError for an empty burst or frames of different geometry, before anything "
          "changes.")
      .def(
          "next_touch",
          [](py_localizer& self, const py::object& candidates, int hypotheses,
             const std::string& objective) {
            const std::vector<odometry> moves = candidates_of(candidates, "Localizer.next_touch");
            const next_touch_params params =
                next_touch_params_of(hypotheses, objective, "Localizer.next_touch");
            return locked(self, [&](localizer& loc) {
              return loc.next_touch(std::span<const odometry>(moves), params);
            });
          },
          py::arg("candidates"), py::arg("hypotheses") = 64, py::arg("objective") = "verdict",
          "Ranks candidate moves (map frame, mm, from where the sensor is now) by what the "
          "touch after each is expected to decide; returns a NextTouchRanking. The belief is "
          "unchanged. candidates: an (N, 2) array or a sequence of (dx_mm, dy_mm). "
          "objective: 'verdict' (the expected probability within the verdict's radius, the "
          "default) or 'entropy' (the expected entropy reduction). Raises ValueError for no "
          "candidates, a non-finite one, or one off the map from anywhere on it (naming it and "
          "the map's extent).")
      .def(
          "reset", [](py_localizer& self) { locked(self, [](localizer& loc) { loc.reset(); }); },
          "Starts a new exploration on the same map: a uniform belief, no previous pose.")
      .def(
          "belief",
          [](py_localizer& self) {
            return to_numpy(locked(self, [](localizer& loc) { return loc.belief(); }));
          },
          "The belief over positions (summed over headings and appearances): a new float32 "
          "array of shape `shape` (rows, cols), one value per position of the sensor's centre, "
          "summing to 1. Element (r, c) is at position_mm(r, c); plot it with "
          "matplotlib's imshow(belief, extent=loc.extent_mm).")
      .def(
          "heading_belief",
          [](py_localizer& self) {
            const auto layers = locked(self, [](localizer& loc) { return loc.heading_belief(); });
            const auto [rows, cols] =
                std::pair(self.impl.positions().rows(), self.impl.positions().cols());
            return to_numpy(layers, rows, cols);
          },
          "The belief per heading (summed over appearances): a float32 array (headings, rows, "
          "cols), layer k at heading_rad(k). Known heading: shape (1, rows, cols), belief().")
      .def(
          "heading_rad",
          [](py_localizer& self, Eigen::Index k) {
            const int n = std::max(1, self.impl.config().headings);
            if (k < 0 || k >= n)
              throw py::index_error("Localizer.heading_rad: layer " + std::to_string(k) +
                                    "; expected 0 .. " + std::to_string(n - 1) +
                                    " (the layers of heading_belief())");
            return self.impl.heading_rad(k);
          },
          py::arg("k"), "The heading of layer k of heading_belief() (radians, map frame).")
      .def_property_readonly(
          "shape",
          [](py_localizer& self) {
            return py::make_tuple(self.impl.positions().rows(), self.impl.positions().cols());
          },
          "(rows, cols) of belief(): the sensor centre's candidate positions.")
      .def(
          "position_mm",
          [](py_localizer& self, Eigen::Index row, Eigen::Index col) {
            const planar_grid<float>& g = self.impl.positions();
            if (row < 0 || row >= g.rows() || col < 0 || col >= g.cols())
              throw py::index_error("Localizer.position_mm: (row, col) = (" + std::to_string(row) +
                                    ", " + std::to_string(col) + "); expected 0 <= row < " +
                                    std::to_string(g.rows()) + " and 0 <= col < " +
                                    std::to_string(g.cols()) + " (the shape of belief())");
            const auto p = g.state_mm(g.index({row, col}));
            return vec2(p(0), p(1));
          },
          py::arg("row"), py::arg("col"),
          "The map-frame position (mm, numpy (x, y)) of element (row, col) of belief(): the "
          "sensor centre at that candidate position.")
      .def_property_readonly(
          "extent_mm", [](py_localizer& self) { return extent_of(self.impl); },
          "(left, right, bottom, top) in mm: the edges of belief()'s pixels in the map frame, "
          "for matplotlib's imshow(loc.belief(), extent=loc.extent_mm) (origin 'upper', the "
          "default: y grows downwards, as on the map).")
      .def_property_readonly(
          "map_extent_mm",
          [](py_localizer& self) {
            const auto& map = self.impl.map();
            const double mm = self.impl.mm_per_px();
            return py::make_tuple(0.0, static_cast<double>(map.cols()) * mm,
                                  static_cast<double>(map.rows()) * mm, 0.0);
          },
          "(left, right, bottom, top) in mm of the map image, for imshow(loc.map, "
          "extent=loc.map_extent_mm).")
      .def_property_readonly(
          "window",
          [](py_localizer& self) {
            return py::make_tuple(self.impl.window().width, self.impl.window().height);
          },
          "The sensor's footprint on the map, px, as (width, height) (C++ pixel_size).")
      .def_property_readonly(
          "config", [](py_localizer& self) { return self.impl.config(); },
          "The configuration (a copy), with preprocessing.mm_per_px set to the map's scale.")
      .def_property_readonly(
          "map", [](py_localizer& self) { return to_numpy(self.impl.map()); },
          "The map (a float32 copy).")
      .def_property_readonly(
          "mm_per_px", [](py_localizer& self) { return self.impl.mm_per_px(); }, "The map's scale.")
      .def_property_readonly(
          "photo_mm_per_px", [](py_localizer& self) { return self.impl.photo_mm_per_px(); },
          "The photograph's own scale, as given to the constructor (mm_per_px is the working "
          "resolution the map is matched at; positions are millimetres either way).")
      .def_property_readonly(
          "sensor", [](py_localizer& self) { return self.impl.sensor(); },
          "The sensor's geometry (a TaxelGeometry copy).")
      .def_property_readonly(
          "headings", [](py_localizer& self) { return self.impl.config().headings; },
          "0 when the heading is known, else the number of headings of the pose grid.")
      .def("__repr__", [](py_localizer& self) {
        const auto& map = self.impl.map();
        return "Localizer(map " + std::to_string(map.rows()) + " x " + std::to_string(map.cols()) +
               " px at " + number(self.impl.mm_per_px()) + " mm/px, config '" +
               self.impl.config().name() + "', touches=" +
               std::to_string(locked(self, [](localizer& loc) { return loc.touches(); })) + ")";
      });
}

}  // namespace tacmap::python
