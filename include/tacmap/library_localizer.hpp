// tacmap: `library_localizer` — which object, and where: the front door over a library of maps.
//
// A robot that has photographed several objects does not know which one its hand closed on.
// `library_localizer` takes the photographs (each at its own size and scale) and answers both
// questions from the same touches: the belief over (object, appearance, position) is one
// `bayes_filter` over a `library_grid` whose objects are the grids `localizer` would use for each
// photograph (`make_library_filter`), with the localizer's defaults — the latent appearance per
// object, the robust motion, the calibrated measurement model. Each touch reports every object's
// posterior, the most probable object and the position on its map, and a verdict whose
// probability is the joint one: the right object *and* within the radius. Beside the objects,
// "none of these" (filter/open_set.hpp): P(unknown), weighed by the same touches, which the
// objects' posteriors and the verdict's probability leave room for.
//
// Photographs may come at different sizes and scales. The objects are compared by the absolute
// log-likelihoods of their maps, and the shipped descriptors cover a fixed number of pixels: at
// different scales they would describe different physical areas, and their likelihoods would not
// be on one scale. So the library works at one scale (by default the coarsest of the maps; any
// other can be given): each map is resampled to it (`rescale`: area-averaged when shrinking,
// bilinear when enlarging), positions stay in each map's own millimetres. A scale at which the
// sensor's window is too small for the model's descriptors is refused with the map's name.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <numbers>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "tacmap/executor/concept.hpp"
#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/filter/confidence.hpp"
#include "tacmap/filter/open_set.hpp"
#include "tacmap/grid/latent_grid.hpp"
#include "tacmap/grid/library_grid.hpp"
#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/grid/pose_grid.hpp"
#include "tacmap/image.hpp"
#include "tacmap/localizer.hpp"
#include "tacmap/measurement/appearance_likelihood.hpp"
#include "tacmap/measurement/library_likelihood.hpp"
#include "tacmap/motion/latent_motion.hpp"
#include "tacmap/motion/library_motion.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"
#include "tacmap/motion/robust_motion.hpp"
#include "tacmap/tactile/preprocess.hpp"

namespace tacmap {

/// One object of a library: its name, its photograph (intensities, any range, row 0 at the
/// top) and the photograph's scale.
struct library_map {
  std::string name;
  image<float> map;
  double mm_per_px = 0.0;
};

/// The filter a `basic_library_localizer<M>` runs: objects x appearance hypotheses x positions
/// (known heading), each object's block the filter `make_planar_filter` builds for its map with
/// the measurement policy M (localizer.hpp).
template <class M>
using library_filter_for =
    bayes_filter<library_grid<latent_grid<planar_grid<float>>>,
                 library_motion<robust_motion<latent_motion<odometry_gaussian>>>,
                 library_likelihood<appearance_likelihood<typename M::planar_model>>>;
/// The filter a `library_localizer` runs (the shipped models, `configured_models`).
using library_localizer_filter = library_filter_for<configured_models>;

namespace detail {
// Checks a library's maps: at least one, each named, non-empty, finite, with a valid scale, and
// no map given twice (the same image at the same scale).
inline void check_library(const std::vector<library_map>& maps) {
  if (maps.empty())
    fail(
        "library: the library is empty; expected at least one map (a photograph of each object "
        "the robot may touch)");
  for (std::size_t k = 0; k < maps.size(); ++k) {
    const library_map& m = maps[k];
    if (m.map.size() == 0)
      fail("library: the map of '", m.name, "' (object ", k,
           ") is empty; expected an image of the object (e.g. tacmap::load_image)");
    if (!m.map.allFinite())
      fail("library: the map of '", m.name, "' (object ", k,
           ") has non-finite pixels; expected finite intensities");
    if (!(std::isfinite(m.mm_per_px) && m.mm_per_px > 0.0))
      fail("library: mm_per_px = ", m.mm_per_px, " for '", m.name, "' (object ", k,
           "); expected the map's scale, a finite value > 0 millimetres per pixel");
    for (std::size_t j = 0; j < k; ++j)
      if (maps[j].mm_per_px == m.mm_per_px && maps[j].map.rows() == m.map.rows() &&
          maps[j].map.cols() == m.map.cols() && (maps[j].map == m.map).all())
        fail("library: '", maps[j].name, "' (object ", j, ") and '", m.name, "' (object ", k,
             ") are the same image at the same scale; expected each object once — no touch "
             "could tell them apart (two different objects that look alike keep equal "
             "posteriors, reported by estimate().tied_objects)");
  }
}
}  // namespace detail

/// The scale a library of `maps` works at (see the file comment): `wanted` when given (finite,
/// > 0), else the coarsest of the maps' scales. Throws std::invalid_argument for an invalid
/// library or scale.
[[nodiscard]] inline double library_scale(const std::vector<library_map>& maps,
                                          std::optional<double> wanted = {}) {
  detail::check_library(maps);
  if (wanted) {
    if (!(std::isfinite(*wanted) && *wanted > 0.0))
      detail::fail("library: the library's scale is ", *wanted,
                   " mm per px; expected a finite value > 0 (or none: the coarsest map's)");
    return *wanted;
  }
  double coarsest = 0.0;
  for (const library_map& m : maps) coarsest = std::max(coarsest, m.mm_per_px);
  return coarsest;
}

/// The scale a library of `maps` works at for `config` and `sensor` when none is given: the
/// coarsest map's or the working resolution (`localizer_config::working_mm_per_px`), whichever
/// is coarser, so that photographs finer than the sensor resolves are matched at the working
/// resolution; `wanted` when given. Throws std::invalid_argument as `library_scale`, and for a
/// map so coarse that the sensor covers fewer than `localizer_config::min_px_per_taxel` px per
/// taxel (naming the map, its scale and the minimum).
[[nodiscard]] inline double library_scale(const std::vector<library_map>& maps,
                                          const localizer_config& config,
                                          const taxel_geometry& sensor,
                                          std::optional<double> wanted = {}) {
  const double coarsest = library_scale(maps, wanted);
  for (const library_map& m : maps)
    (void)detail::choose_working_resolution(config, sensor, m.mm_per_px,
                                            std::max(m.map.rows(), m.map.cols()),
                                            "library: '" + m.name + "'");
  if (wanted) return coarsest;
  return std::max(coarsest, config.working_scale(sensor));
}

namespace detail {
/// What `choose_working_resolution` warns of for each map of a library matched at `scale`.
inline std::vector<std::string> library_warnings(const std::vector<library_map>& maps,
                                                 const localizer_config& config,
                                                 const taxel_geometry& sensor) {
  std::vector<std::string> out;
  for (const library_map& m : maps) {
    const auto r =
        choose_working_resolution(config, sensor, m.mm_per_px, std::max(m.map.rows(), m.map.cols()),
                                  "library: '" + m.name + "'");
    out.insert(out.end(), r.warnings.begin(), r.warnings.end());
  }
  return out;
}
}  // namespace detail

/// The filter over a library that `library_localizer` runs: each map resampled to the library's
/// scale `library_scale(maps, mm_per_px)`, and for each the planar filter `make_planar_filter`
/// would build, as one block of a `library_grid`. `prior`: each object's prior probability
/// (empty: uniform). Known headings only (`config.headings` = 0). Throws std::invalid_argument
/// for an empty library, a map that is empty, non-finite, given twice or smaller than the sensor
/// at the library's scale, a scale at which the model cannot describe the sensor's window,
/// repeated names, a prior that does not sum to one, or an invalid configuration.
/// `measurement`: the policy whose planar model each map gets (localizer.hpp).
/// `executor`: where one is given, the maps are prepared in parallel on it, one map a chunk
/// (the same models as prepared one after the other: each map's preparation is unchanged).
template <localizer_measurement M>
[[nodiscard]] library_filter_for<M> make_library_filter(
    const M& measurement, const localizer_config& config, const std::vector<library_map>& maps,
    const taxel_geometry& sensor = {}, std::vector<double> prior = {},
    std::optional<double> mm_per_px = {}, executor_ref executor = {}) {
  config.validate();
  if (config.headings != 0)
    detail::fail("make_library_filter: headings = ", config.headings,
                 "; a library is localized with a known heading (headings = 0) for now — "
                 "build a library_grid of pose grids yourself for unknown headings");
  const double scale = library_scale(maps, config, sensor, mm_per_px);
  const auto appearances = config.appearances();
  std::vector<latent_grid<planar_grid<float>>> grids;
  std::vector<image<float>> resampled;
  std::vector<pixel_size> windows;
  std::vector<std::string> names;
  for (const library_map& m : maps) {
    const std::string who = "library: '" + m.name + "' at the library's scale";
    resampled.push_back(rescale(m.map, m.mm_per_px, scale));
    const image<float>& map = resampled.back();
    windows.push_back(checked_tactile_window(sensor, scale, {map.cols(), map.rows()}, who.c_str()));
    grids.emplace_back(
        planar_grid<float>({.width = map.cols(), .height = map.rows()}, scale, windows.back()),
        appearance_names(appearances));
    names.push_back(m.name);
  }
  // The expensive part, each map's measurement model, one map a chunk.
  using model_type = appearance_likelihood<typename M::planar_model>;
  std::vector<std::optional<model_type>> prepared(maps.size());
  executor.parallel_for(maps.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t k = begin; k < end; ++k) {
      try {
        prepared[k].emplace(
            measurement.planar(config,
                               detail::map_as_sensor_sees(config, resampled[k], scale, sensor),
                               windows[k]),
            appearances);
      } catch (const std::invalid_argument& e) {
        detail::fail("library: '", maps[k].name, "' at the library's scale (", scale,
                     " mm per px, the sensor's window ", windows[k].width, " x ", windows[k].height,
                     " px): ", e.what(),
                     " — give the library a finer scale (make_library_filter's mm_per_px)");
      }
    }
  });
  std::vector<model_type> models;
  models.reserve(maps.size());
  for (auto& m : prepared) models.push_back(std::move(*m));
  return library_filter_for<M>(
      library_grid<latent_grid<planar_grid<float>>>(std::move(grids), std::move(names),
                                                    std::move(prior)),
      library_motion(robust_motion(
          latent_motion<odometry_gaussian>(
              odometry_gaussian({.sigma_mm = config.motion_sigma_mm, .k = config.motion_k}),
              {.switch_probability = config.switch_probability()}),
          detail::robust_params(config))),
      library_likelihood<appearance_likelihood<typename M::planar_model>>(std::move(models)));
}

/// The surrogate maps of the open set's shadow filter (filter/open_set.hpp, eq. 2): each map
/// mirrored left to right, named "mirrored <name>". A mirrored photograph has the texture, the
/// contrast and the scale of its object, so its chance fits to a touch are those of a surface
/// like the library's, but it is no surface the touches come from (unless the object itself
/// is mirror-symmetric, whose touches then fit the shadow as well as the map).
[[nodiscard]] inline std::vector<library_map> mirrored_maps(const std::vector<library_map>& maps) {
  std::vector<library_map> out;
  out.reserve(maps.size());
  for (const library_map& m : maps)
    out.push_back({"mirrored " + m.name, m.map.rowwise().reverse().eval(), m.mm_per_px});
  return out;
}

/// The shipped models' library filter (`configured_models`): what `library_localizer` runs.
[[nodiscard]] inline library_localizer_filter make_library_filter(
    const localizer_config& config, const std::vector<library_map>& maps,
    const taxel_geometry& sensor = {}, std::vector<double> prior = {},
    std::optional<double> mm_per_px = {}, executor_ref executor = {}) {
  return make_library_filter(configured_models{}, config, maps, sensor, std::move(prior), mm_per_px,
                             executor);
}

/// What one touch on a library gave.
struct library_touch_result {
  /// localized: the most probable object and `position_mm` on its map are right with the
  /// belief's probability `probability_within` >= the threshold; see `touch_result`.
  tacmap::verdict verdict = tacmap::verdict::uncertain;
  /// The most probable object (index into the library) and its name.
  Eigen::Index object = 0;
  std::string object_name;
  /// Every object's posterior (the library's order); with `probability_unknown` they sum to 1.
  std::vector<double> object_probability;
  /// P(none of these): the touched object is not in the library (filter/open_set.hpp), from
  /// `localizer_config::open_set`'s prior and the touches' evidence.
  double probability_unknown = 0.0;
  /// Other objects as probable as `object` (identical maps): the position holds on each.
  std::vector<Eigen::Index> tied_objects;
  /// The estimate on `object`'s map (mm): the centre of the disc of `confidence.radius_mm` that
  /// holds the most belief.
  Eigen::Vector2d position_mm = Eigen::Vector2d::Zero();
  /// P(object is right and |position - position_mm| <= radius): the object is in the library,
  /// is `object`, and the position is within the radius.
  double probability_within = 0.0;
  /// `object`'s appearance hypotheses' posteriors (as photographed, inverted).
  std::vector<double> appearance_probability;
  double log_prediction_support = 0.0;  ///< see `touch_result`
  frame_rejection rejection = frame_rejection::none;
  bool restarted = false;           ///< see `touch_result`
  std::size_t touches = 0;          ///< touches used since construction or `reset()`
  std::size_t frames_combined = 1;  ///< see `touch_result`
  [[nodiscard]] bool accepted() const { return rejection == frame_rejection::none; }
};

/// Which object, and where, from map to estimate: `basic_localizer` over a library of
/// photographs, generic over the measurement policy `M` (localizer.hpp): `library_localizer`
/// runs the shipped models, `basic_library_localizer<descriptor_measurement<D>>` a descriptor
/// of your own (C++ only).
///
///     tacmap::library_localizer loc({{"mug", mug, 0.2}, {"box", box, 0.25}});
///     auto r = loc.touch(frame);
///     r = loc.touch(frame, tacmap::odometry{.dx_mm = 4.0});
///     if (r.verdict == tacmap::verdict::localized) use(r.object_name, r.position_mm);
///
/// Preparing the maps happens once, in the constructor. Not thread-safe.
template <localizer_measurement Measurement>
class basic_library_localizer {
 public:
  using filter_type = library_filter_for<Measurement>;

  /// `mm_per_px`: the scale the library works at (default: the coarsest map's or the working
  /// resolution, `localizer_config::working_mm_per_px`, whichever is coarser; see the file
  /// comment). `executor`: where one is given, the maps are prepared in parallel on it (it
  /// need only outlive the constructor). Throws std::invalid_argument as `make_library_filter`.
  explicit basic_library_localizer(const std::vector<library_map>& maps,
                                   localizer_config config = {}, taxel_geometry sensor = {},
                                   std::vector<double> prior = {},
                                   std::optional<double> mm_per_px = {},
                                   Measurement measurement = Measurement{},
                                   executor_ref executor = {})
      : config_(std::move(config)),
        sensor_(sensor),
        measurement_(std::move(measurement)),
        filter_(
            make_library_filter(measurement_, config_, maps, sensor_, prior, mm_per_px, executor)),
        warnings_(detail::library_warnings(maps, config_, sensor_)) {
    // The open set's shadow (filter/open_set.hpp, eq. 2): the mirrored maps, at the library's
    // scale and with its prior, weighed by the same motions and touches.
    if (config_.open_set.model == unknown_model::shadow)
      shadow_.emplace(make_library_filter(measurement_, config_, mirrored_maps(maps), sensor_,
                                          std::move(prior), mm_per_px, executor));
    config_.preprocessing.mm_per_px = library_scale(maps, config_, sensor_, mm_per_px);
  }

  /// The first touch of an exploration (or one without motion since the previous touch).
  library_touch_result touch(const tactile_frame& frame) { return step(frame, std::nullopt); }

  /// A touch after the sensor moved by `moved` (map frame, mm; the same for every object: the
  /// arm's motion) since the previous call.
  library_touch_result touch(const tactile_frame& frame, const odometry& moved) {
    if (!(std::isfinite(moved.dx_mm) && std::isfinite(moved.dy_mm)))
      detail::fail("library_localizer::touch: the motion (", moved.dx_mm, ", ", moved.dy_mm,
                   ") mm is not finite; expected finite millimetres — the position source "
                   "delivered an invalid sample");
    return step(frame, moved);
  }

  /// The same touches with a press given as a burst of frames, combined by `combine_burst` with
  /// `config().burst` first (see `basic_localizer::touch`).
  library_touch_result touch(std::span<const tactile_frame> burst) {
    return detail::touch_with_burst(burst, config_.burst,
                                    [&](const tactile_frame& f) { return touch(f); });
  }
  library_touch_result touch(std::span<const tactile_frame> burst, const odometry& moved) {
    return detail::touch_with_burst(burst, config_.burst,
                                    [&](const tactile_frame& f) { return touch(f, moved); });
  }

  /// A touch with the arm's pose (its own frame, axes parallel to the maps': see `arm_pose`):
  /// the motion since the previous `touch_at` becomes the odometry, as
  /// `basic_localizer::touch_at` with a known heading. The yaw may not change by more than 5
  /// degrees between touches (a library is localized with a known heading). The pose is kept
  /// only when the touch went through; `reset()` forgets it.
  library_touch_result touch_at(const tactile_frame& frame, const arm_pose& where) {
    if (!(std::isfinite(where.x_mm) && std::isfinite(where.y_mm) && std::isfinite(where.theta_rad)))
      detail::fail("library_localizer::touch_at: the arm's pose (", where.x_mm, ", ", where.y_mm,
                   ") mm, ", where.theta_rad,
                   " rad is not finite; expected finite millimetres and radians — the position "
                   "source delivered an invalid sample");
    std::optional<odometry> moved;
    if (last_pose_)
      moved = detail::known_heading_arm_motion(
          *last_pose_, where, "library_localizer::touch_at",
          "a library is localized with a known, fixed heading; keep the sensor's yaw within 5 "
          "degrees between touches");
    library_touch_result r = step(frame, moved);
    last_pose_ = where;
    return r;
  }
  library_touch_result touch_at(std::span<const tactile_frame> burst, const arm_pose& where) {
    return detail::touch_with_burst(burst, config_.burst,
                                    [&](const tactile_frame& f) { return touch_at(f, where); });
  }

  /// Starts a new exploration: each object's prior, a uniform belief on each map, no previous
  /// `touch_at` pose.
  void reset() {
    filter_.reset();
    if (shadow_) shadow_->reset();
    calls_ = 0;
    touches_ = 0;
    restarts_ = 0;
    unknown_.reset();
    last_pose_.reset();
  }

  /// The sensor's self-calibration (see `basic_localizer::sensor_calibration`), or nullptr.
  [[nodiscard]] const self_calibration* sensor_calibration() const {
    return correction_.estimate();
  }
  /// Forgets what the self-calibration learnt; `reset()` keeps it.
  void reset_sensor_calibration() { correction_.reset(); }

  /// Ranks candidate moves by what the touch after each is expected to decide about the object
  /// and the position together (hypotheses over both; see `basic_localizer::next_touch` and
  /// filter/next_touch.hpp). The belief is unchanged.
  [[nodiscard]] next_touch_ranking next_touch(std::span<const odometry> candidates,
                                              const next_touch_params& params = {}) const {
    return detail::rank_library_touches(filter_, candidates, config_.confidence.radius_mm, params,
                                        "library_localizer::next_touch");
  }
  /// The moves of a reachable rectangle (`touch_region::candidates()`), ranked.
  [[nodiscard]] next_touch_ranking next_touch(const touch_region& region,
                                              const next_touch_params& params = {}) const {
    const std::vector<odometry> c = region.candidates();
    return next_touch(std::span<const odometry>(c), params);
  }

  [[nodiscard]] const filter_type& filter() const { return filter_; }
  /// The open set's shadow filter over the mirrored maps (`unknown_model::shadow`; see
  /// filter/open_set.hpp, eq. 2), or nullptr with the support model.
  [[nodiscard]] const filter_type* shadow_filter() const { return shadow_ ? &*shadow_ : nullptr; }
  /// The configuration, with `preprocessing.mm_per_px` set to the library's scale.
  [[nodiscard]] const localizer_config& config() const { return config_; }
  [[nodiscard]] const Measurement& measurement() const { return measurement_; }
  /// The scale every map was resampled to, mm per px.
  [[nodiscard]] double mm_per_px() const { return config_.preprocessing.mm_per_px; }
  /// What the library could not do as well as it should, in words (see
  /// `basic_localizer::warnings()`): e.g. a photograph coarser than the working resolution.
  [[nodiscard]] const std::vector<std::string>& warnings() const { return warnings_; }
  [[nodiscard]] Eigen::Index objects() const { return filter_.grid().objects(); }
  /// Touches used and restarts from uniform since construction or `reset()`.
  [[nodiscard]] std::size_t touches() const { return touches_; }
  [[nodiscard]] std::size_t restarts() const { return restarts_; }
  /// P(none of these) after the last touch (`library_touch_result::probability_unknown`).
  [[nodiscard]] double probability_unknown() const { return unknown_.probability_unknown(); }
  /// Object k's position belief (summed over its appearance hypotheses), conditioned on k, as
  /// an image of its grid's positions; throws std::domain_error when k has posterior 0.
  [[nodiscard]] image<float> object_belief_image(Eigen::Index k) const {
    const auto& g = filter_.grid().object(k);
    const auto block = object_belief(filter_.grid(), filter_.belief(), k);
    const auto positions = marginal_belief(g, block);
    return Eigen::Map<const image<float>>(positions.data(), g.rows(), g.cols());
  }

 private:
  library_touch_result step(const tactile_frame& frame, const std::optional<odometry>& moved) {
    if (frame.geometry != sensor_)
      detail::fail("library_localizer::touch: the frame is ", frame.geometry.rows, " x ",
                   frame.geometry.cols, " taxels at ", frame.geometry.pitch_mm,
                   " mm, but this library was built for ", sensor_.rows, " x ", sensor_.cols,
                   " at ", sensor_.pitch_mm, " mm; build it with the frame's geometry");
    // Preprocess (and let the policy check the touch) first: a malformed frame throws before
    // anything changes.
    // All or nothing (the filter's half by localizer_step): a refused touch must not teach the
    // self-calibration either.
    std::optional<detail::sensor_correction> calibration_before;
    if (correction_.estimate()) calibration_before = correction_;
    std::optional<detail::step_outcome<filter_type>> stepped;
    std::optional<update_report> shadow_report;
    preprocessed_frame pre;
    const std::size_t touches_before = touches_, restarts_before = restarts_;
    try {
      pre = preprocess(correction_.apply(frame), config_.preprocessing);
      if constexpr (requires { measurement_.check_touch(config_, pre.pixels); })
        if (pre.accepted()) measurement_.check_touch(config_, pre.pixels);
      const std::vector<image<float>> view{pre.pixels};  // one scale: one view for every map
      stepped.emplace(detail::localizer_step(
          filter_,
          [&] {
            if (calls_ > 0 && moved) filter_.predict(*moved);
          },
          pre.accepted() ? &view : nullptr, config_.confidence, touches_, restarts_, saved_));
      if (shadow_) {
        // The shadow follows the filter's touch; should it fail (a model's error, not a
        // contradiction), the filter's touch is taken back too.
        shadow_->save_state(shadow_saved_);
        try {
          shadow_report = detail::shadow_step(*shadow_, calls_ > 0 ? moved : std::nullopt,
                                              pre.accepted() ? &view : nullptr, stepped->restarted);
        } catch (...) {
          shadow_->restore_state(shadow_saved_);
          filter_.restore_state(saved_);
          touches_ = touches_before;
          restarts_ = restarts_before;
          throw;
        }
      }
    } catch (...) {
      if (calibration_before) correction_ = std::move(*calibration_before);
      throw;
    }
    const auto& out = *stepped;
    ++calls_;
    library_touch_result r;
    r.restarted = out.restarted;
    r.rejection = pre.rejection;
    // The open set weighs the touch over the states evaluated (the objects not pruned).
    const auto& grid = filter_.grid();
    detail::follow_touch(unknown_, out.restarted, out.report, shadow_report);
    r.probability_unknown = unknown_.probability_unknown();
    const confidence conf =
        with_open_set(out.assessment, r.probability_unknown, config_.confidence);
    const auto& est = out.estimate;
    r.verdict = pre.accepted() ? conf.verdict : verdict::rejected_frame;
    r.object = est.map_object;
    r.object_name = grid.object_name(est.map_object);
    r.object_probability = est.object_probability;
    for (double& p : r.object_probability) p *= 1.0 - r.probability_unknown;
    r.tied_objects = est.tied_objects;
    r.position_mm = conf.centre_mm;
    r.probability_within = conf.probability_within;
    r.appearance_probability = est.hypothesis_probability;
    if (out.report) r.log_prediction_support = out.report->log_prediction_support;
    r.touches = touches_;
    return r;
  }

  localizer_config config_;
  taxel_geometry sensor_;
  Measurement measurement_;
  filter_type filter_;
  std::vector<std::string> warnings_;
  typename filter_type::saved_state saved_;  // localizer_step's (one belief's storage)
  std::optional<filter_type> shadow_;        // the open set's shadow (unknown_model::shadow)
  typename filter_type::saved_state shadow_saved_;
  std::size_t calls_ = 0;
  std::size_t touches_ = 0;
  std::size_t restarts_ = 0;
  detail::sensor_correction correction_{config_.calibrate_sensor, sensor_};
  open_set unknown_{config_.open_set};  // P(none of these)
  std::optional<arm_pose> last_pose_;   // touch_at's previous pose
};

/// The library front door with the shipped models (`configured_models`).
class library_localizer : public basic_library_localizer<configured_models> {
 public:
  using basic_library_localizer::basic_library_localizer;
};

}  // namespace tacmap
