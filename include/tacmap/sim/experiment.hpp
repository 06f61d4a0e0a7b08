// tacmap: experiments — one touch protocol run through the whole localization pipeline, and the
// paper's metrics (Sec. IV-B, Figs. 5-8).
//
// A run replays one sequence of a `touch_protocol` on its map: at every step the tactile
// simulator renders a (noisy) frame at the TRUE location, `preprocess` turns it into a map-scale
// tactile image, the filter predicts with the MEASURED odometry (what the arm reported, Sec.
// III-B) and updates with the image (Sec. III-C). The true location is only used to score the
// estimate. A frame that `preprocess` rejects is reported and skips the update (the prediction
// still happens: the arm did move).
//
// Metrics, as the paper counts them (Sec. IV-B): a sequence is *localized* when the MAP error is
// below 5 mm by touch 6 and stays below for every later touch; its *touches to localize* is the
// first touch (1-based) from which the error stays below the threshold; Fig. 6 plots the error
// per touch across the 22 sequences (we report the median).
//
// A scenario (`localization_config::scenario`, sim/scenario.hpp) makes the run realistic: the
// measurement model matches against a camera image of the object (`visual_map()`) while the
// simulator still presses the object's true relief, off by the sequence's registration error
// and each press's jitter. The ideal scenario (the default) changes nothing.
//
// `localization_experiment` builds the (expensive: per-window descriptors of every window)
// measurement model once per map and configuration and reuses it for every sequence by resetting
// the filter.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <span>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/descriptor/unsigned_orientation.hpp"
#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/filter/confidence.hpp"
#include "tacmap/grid/latent_grid.hpp"
#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/grid/pose_grid.hpp"
#include "tacmap/image.hpp"
#include "tacmap/localizer.hpp"
#include "tacmap/measurement/appearance_likelihood.hpp"
#include "tacmap/measurement/descriptor_likelihood.hpp"
#include "tacmap/measurement/ncc_likelihood.hpp"
#include "tacmap/measurement/rotated_descriptor_likelihood.hpp"
#include "tacmap/motion/latent_motion.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"
#include "tacmap/motion/pose_odometry_gaussian.hpp"
#include "tacmap/motion/robust_motion.hpp"
#include "tacmap/sim/faults.hpp"
#include "tacmap/sim/protocol.hpp"
#include "tacmap/sim/random.hpp"
#include "tacmap/sim/scenario.hpp"
#include "tacmap/sim/tactile_simulator.hpp"
#include "tacmap/tactile/burst.hpp"
#include "tacmap/tactile/preprocess.hpp"
#include "tacmap/tactile/self_calibration.hpp"

namespace tacmap {

/// Where a simulated sequence's touches go.
enum class touch_order {
  /// The protocol's sequence: its locations in its (random) order — the paper's way.
  protocol,
  /// The first touch where the protocol's is; each next one chosen by `next_touch` among
  /// `localization_config::active_candidates` random positions on the map (filter/next_touch.hpp).
  active,
};

[[nodiscard]] inline const char* to_string(touch_order o) {
  return o == touch_order::protocol ? "random" : "active";
}

/// Everything that configures one simulated localization run: the filter (`localizer_config`:
/// the localizer's own settings and defaults) and the simulated world around it.
struct localization_config : localizer_config {
  std::uint64_t simulator_seed = 1;  ///< seeds the simulator; each sequence forks its own stream
  simulator_params simulator{};  ///< the simulator's physics (its seed is replaced per sequence)
  /// Camera map, registration and per-press effects (sim/scenario.hpp); ideal by default.
  scenario_params scenario{};
  /// Faults during exploration: odometry outliers and noise, a slip, a kidnap (sim/faults.hpp);
  /// none by default.
  exploration_faults faults{};
  /// Each sequence's sensor heading drawn uniformly from [-pi, pi) (its own stream of the
  /// simulator seed) instead of 0; the odometry is then reported in the sensor's frame.
  bool random_orientation = false;
  /// Self-calibration of the sensor (tactile/self_calibration.hpp): every frame is observed by a
  /// `self_calibration` and corrected by it before preprocessing. Off by default.
  bool self_calibrate = false;
  self_calibration_params calibration{};
  /// Touches the sensor made before the sequence (at random poses on the object, observed by
  /// the calibration, not localized): a sensor in use has a history, a 7-touch sequence alone
  /// is too short to estimate 84 taxels. Used only with `self_calibrate`.
  std::size_t calibration_warmup = 0;
  /// Where the touches go (`touch_order`). Active: each sequence as long as the protocol's, the
  /// candidates drawn uniformly over the map's positions from the sequence's own stream of the
  /// simulator seed (reproducible whatever sequences run); each move's odometry error (the
  /// protocol's noise, and the faults' `faults`) is that of the protocol's move at the same step,
  /// so that both orders of a sequence meet the same errors (`carry_faults_to_move`,
  /// sim/faults.hpp).
  touch_order order = touch_order::protocol;
  std::size_t active_candidates = 32;  ///< candidates per touch (active order)
  /// Active order: candidates are drawn at least this far from the previous touch (mm; 0: any).
  double active_min_move_mm = 0.0;
  next_touch_params next_touch{};  ///< the ranking's settings (active order)

  /// Throws std::invalid_argument for settings that contradict each other, naming both.
  void validate() const {
    localizer_config::validate();
    faults.validate();
    if (tracking) tracking->validate();
    if (order == touch_order::active) {
      next_touch.validate();
      if (active_candidates == 0)
        detail::fail(
            "localization_config: active_candidates = 0; expected at least one "
            "candidate position per touch for the active order (e.g. 32)");
      if (headings > 0)
        detail::fail(
            "localization_config: order = active ranks moves with a known heading, but "
            "headings = ",
            headings, "; use headings = 0 or the protocol's order");
    }
  }
};
namespace detail {

// The oracles of sim/faults.hpp's `fault_oracle`: the filter's belief becomes
// (1 - share) b + share ring(b), where ring(b) moves every state's mass by `radius_mm` in every
// direction equally (720 directions, each split over its four nearest states; mass carried off
// the grid is dropped and the rest renormalised, as the motion models do). Each rows x cols
// plane (appearance hypothesis, heading layer) on its own. In double, about 100 taps per state
// for 8 mm on the paper's grid (220 for 20 mm): a few million operations per move on a planar
// latent grid, about a hundred million on 36 headings: for evaluations only.
template <class Filter>
void spread_over_ring(Filter& filter, double radius_mm, double share) {
  const auto& grid = filter.grid();
  const Eigen::Index rows = grid.rows(), cols = grid.cols(), plane = rows * cols;
  const auto [pitch_x, pitch_y] = detail::lattice_pitch_mm(grid);
  std::map<std::pair<Eigen::Index, Eigen::Index>, double> taps;  // (dy, dx) -> weight
  constexpr int directions = 720;
  for (int k = 0; k < directions; ++k) {
    const double angle = 2.0 * std::numbers::pi * (k + 0.5) / directions;
    const double fx = radius_mm * std::cos(angle) / pitch_x;
    const double fy = radius_mm * std::sin(angle) / pitch_y;
    const double x0 = std::floor(fx), y0 = std::floor(fy), ax = fx - x0, ay = fy - y0;
    const auto ix = static_cast<Eigen::Index>(x0), iy = static_cast<Eigen::Index>(y0);
    const double w = 1.0 / directions;
    taps[{iy, ix}] += w * (1 - ax) * (1 - ay);
    taps[{iy, ix + 1}] += w * ax * (1 - ay);
    taps[{iy + 1, ix}] += w * (1 - ax) * ay;
    taps[{iy + 1, ix + 1}] += w * ax * ay;
  }
  const auto& belief = filter.belief();
  Eigen::ArrayXd mixed(belief.size());
  image<double> in(rows, cols), ring(rows, cols);
  for (Eigen::Index at = 0; at < belief.size(); at += plane) {
    in = Eigen::Map<const image<typename Filter::scalar_type>>(belief.data() + at, rows, cols)
             .template cast<double>();
    ring.setZero();
    for (const auto& [offset, w] : taps) {
      const auto [dy, dx] = offset;
      const Eigen::Index h = rows - std::abs(dy), wd = cols - std::abs(dx);
      if (h <= 0 || wd <= 0) continue;
      ring.block(std::max<Eigen::Index>(dy, 0), std::max<Eigen::Index>(dx, 0), h, wd) +=
          w * in.block(std::max<Eigen::Index>(-dy, 0), std::max<Eigen::Index>(-dx, 0), h, wd);
    }
    Eigen::Map<image<double>>(mixed.data() + at, rows, cols) = (1.0 - share) * in + share * ring;
  }
  if (!(mixed.sum() > 0.0)) return;  // everything carried off: keep the filter's own belief
  filter.set_prior(mixed);
}

}  // namespace detail

/// What happened at one touch.
struct touch_record {
  std::size_t step = 0;  ///< 0-based position in the sequence (touch number - 1)
  /// Index of the touch location in the protocol; in the active order, after the first touch,
  /// the map state (planar_grid index) chosen — before any slip or kidnap moved it.
  std::size_t location = 0;
  double true_x_mm = 0.0;  ///< ground truth sensor centre
  double true_y_mm = 0.0;
  double map_x_mm = 0.0;  ///< the belief's most probable state after this touch
  double map_y_mm = 0.0;
  double map_error_mm = 0.0;  ///< its distance to the truth
  /// The estimate after this touch (`assess`): the centre of the 5 mm disc that holds the most
  /// belief, the estimate most probably within 5 mm of the truth (the MAP position where the
  /// grid is not a lattice).
  double estimate_x_mm = 0.0;
  double estimate_y_mm = 0.0;
  double error_mm = 0.0;        ///< the estimate's distance to the truth
  double true_theta_rad = 0.0;  ///< the sensor's heading on the map (0 unless random)
  double map_theta_rad = 0.0;   ///< the MAP state's heading (pose grids; else 0 = known)
  double entropy_nats = 0.0;    ///< the belief's entropy after this touch (positions)
  /// Posterior of each appearance hypothesis after this touch (`localization_config::
  /// appearances()` order; one value 1 for `fixed`).
  std::vector<double> appearance_probability;
  /// The odometry the filter was told before this touch (map frame, mm; 0 at the first touch):
  /// the planned move, with the injected faults.
  double reported_dx_mm = 0.0;
  double reported_dy_mm = 0.0;
  bool odometry_outlier = false;  ///< the move before this touch was an injected outlier
  /// The object slipped, or the sensor was kidnapped, just before this touch (injected; not
  /// set when the fault could not happen in this sequence, `faulted_sequence::slipped`).
  bool moved_unseen = false;
  /// The motion before this touch carried the whole belief off the map (the filter refused it)
  /// and the run restarted from a uniform belief.
  bool lost_track = false;
  /// Frames the simulator read for this press (`simulator_params::frames_per_press`) and how
  /// many of them `combine_burst` kept (the localizer's `touch_result::frames_combined`; 1 for
  /// a single frame).
  std::size_t frames_read = 1;
  std::size_t frames_combined = 1;
  bool accepted = true;  ///< false: preprocess rejected the frame, no update
  frame_rejection rejection = frame_rejection::none;
  /// The belief's P(|position - estimate| <= 5 mm) after this touch (`assess`; the estimate is
  /// `estimate_x_mm`, `estimate_y_mm`): its claim that `error_mm` is below the success radius.
  /// Calibrated when it matches how often it is.
  double probability_within = 0.0;
  /// Pose grids: the belief's P(|heading - MAP heading| <= 15 degrees); 1 for known headings.
  double heading_probability = 1.0;
  /// The verdict from those probabilities (`localizer_config::confidence`).
  tacmap::verdict verdict = tacmap::verdict::uncertain;
  /// This touch's evidence log p(z_t | z_1..t-1) in the model's units
  /// (`update_report::log_marginal_likelihood`); 0 for a rejected frame.
  double log_marginal_likelihood = 0.0;
  /// This touch's `update_report::log_prediction_support` (0 for a rejected frame): below
  /// `confidence_params::contradiction` the touch contradicts the prediction.
  double log_prediction_support = 0.0;
  /// log_prediction_support < config.confidence.contradiction: the verdict a robot would get
  /// is `contradicted` (`verdict` above keeps the belief's own, for its calibration).
  bool contradicted = false;
};

/// One sequence's run. The images are filled only when asked for (`keep_images`).
struct sequence_result {
  std::size_t sequence = 0;
  /// The object's relation this sequence (the scenario's polarity, drawn per sequence when
  /// random): true when its raised parts look darker in the photograph.
  bool raised_dark = false;
  std::vector<touch_record> touches;  ///< one per touch, always
  // The next three are filled only when `run` is asked to keep images (keep_images = true);
  // otherwise they are empty, not one entry per touch: check their size before indexing.
  std::vector<image<float>> tactile_images;  ///< preprocessed, map scale (empty when rejected)
  /// The raw frames the simulator rendered (a burst's combined frame: what the filter used)
  std::vector<tactile_frame> frames;
  std::vector<image<float>> beliefs;  ///< position belief after each touch (all hypotheses)
  /// The measurement model's log-likelihood over the filter's states for each touch (empty for
  /// a rejected frame), filled only when asked for (`keep_log_likelihoods`): what a calibration
  /// replays with other likelihood scales (sim/calibration.hpp).
  std::vector<Eigen::Array<float, Eigen::Dynamic, 1>> log_likelihoods;
};

/// What a caller of `basic_localization_experiment::run` can take over, so that another filter
/// on the same touches chooses where they go (`library_experiment`'s active order): `rank`
/// ranks the active order's candidate moves instead of the experiment's own filter, and
/// `touched` sees each touch as soon as it is made (its record and its frame, as
/// `sequence_result` keeps them), before the next one is chosen. Either may be empty.
struct touch_hooks {
  std::function<next_touch_ranking(std::span<const odometry>)> rank;
  std::function<void(const touch_record&, const tactile_frame&)> touched;
};

/// First touch (1-based) from which every error is below `threshold_mm`; empty when the last
/// touch is not below it (or there are no touches).
[[nodiscard]] inline std::optional<std::size_t> touches_to_localize(
    const std::vector<touch_record>& touches, double threshold_mm = 5.0) {
  std::optional<std::size_t> first;
  for (std::size_t i = 0; i < touches.size(); ++i) {
    if (touches[i].error_mm < threshold_mm) {
      if (!first) first = i + 1;
    } else {
      first.reset();
    }
  }
  return first;
}

/// The paper's success (Sec.\ IV-B): error below `threshold_mm` by touch `within` and below it for
/// every later touch.
[[nodiscard]] inline bool localized(const std::vector<touch_record>& touches,
                                    double threshold_mm = 5.0, std::size_t within = 6) {
  const auto t = touches_to_localize(touches, threshold_mm);
  return t.has_value() && *t <= within;
}

/// Median of `values` (mean of the middle two for an even count); NaN when empty.
[[nodiscard]] inline double median(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto mid = static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  const double upper = values[static_cast<std::size_t>(mid)];
  if (values.size() % 2 == 1) return upper;
  const double lower = *std::max_element(values.begin(), values.begin() + mid);
  return 0.5 * (lower + upper);
}

/// Median error at each touch across sequences (Fig.\ 6): element t is the median of the errors
/// at touch t + 1 over the sequences that have one.
[[nodiscard]] inline std::vector<double> median_error_per_touch(
    const std::vector<sequence_result>& results) {
  std::size_t longest = 0;
  for (const auto& r : results) longest = std::max(longest, r.touches.size());
  std::vector<double> out;
  for (std::size_t t = 0; t < longest; ++t) {
    std::vector<double> at;
    for (const auto& r : results)
      if (t < r.touches.size()) at.push_back(r.touches[t].error_mm);
    out.push_back(median(std::move(at)));
  }
  return out;
}

/// One map and one configuration: the grid, the filter (with its measurement model built once)
/// and the simulator's relief. `run` replays a sequence from a uniform belief.
///
/// The object's relief comes from the protocol's image with the scenario's polarity
/// (`object_relief`): raised parts bright (+1) or dark (-1), drawn per sequence when the
/// polarity is random. Each polarity has its own relief and camera map (the shading of its
/// walls), so the experiment keeps one filter per polarity it meets (at most two).
///
/// Generic over the localizer's measurement policy (localizer.hpp): `localization_experiment`
/// runs the shipped models (`configured_models`), `basic_localization_experiment<
/// descriptor_measurement<D>>` a user's descriptor (what `fit_tau`, sim/calibration.hpp, runs).
template <localizer_measurement Measurement>
class basic_localization_experiment {
 public:
  using filter_type = planar_filter_for<Measurement>;
  using pose_filter_type = pose_filter_for<Measurement>;

  /// Throws std::invalid_argument for a protocol whose map is empty or smaller than the sensor's
  /// window, or for out-of-range or contradictory configuration values (named by the component
  /// that checks them).
  basic_localization_experiment(const touch_protocol& protocol, localization_config config,
                                Measurement measurement = Measurement{})
      : protocol_(&protocol),
        config_(std::move(config)),
        measurement_(std::move(measurement)),
        window_(checked_tactile_window(config_.simulator.geometry, protocol.mm_per_px,
                                       protocol.map_size(), "localization_experiment")),
        margin_px_(config_.scenario.moves_sensor() || config_.random_orientation
                       ? margin_px(protocol, config_)
                       : 0) {
    config_.validate();
    config_.scenario.validate();
    config_.preprocessing.mm_per_px = protocol.mm_per_px;
    const relief_polarity polarity = config_.scenario.polarity;
    if (polarity != relief_polarity::dark_raised) build_variant(0);
    if (polarity != relief_polarity::bright_raised) build_variant(1);
  }

  [[nodiscard]] const localization_config& config() const { return config_; }
  /// The planar filter (config().headings == 0) of the scenario's first polarity (bright
  /// raised, unless the scenario's polarity is dark_raised).
  [[nodiscard]] const filter_type& filter() const {
    TACMAP_ASSERT(first().filter.has_value(),
                  "filter(): this experiment localizes over (x, y, theta)");
    return *first().filter;
  }
  /// The (x, y, theta) filter (config().headings > 0), as `filter()`.
  [[nodiscard]] const pose_filter_type& pose_filter() const {
    TACMAP_ASSERT(first().pose_filter.has_value(), "pose_filter(): this experiment is planar");
    return *first().pose_filter;
  }
  /// The map the measurement model matches against: the protocol's image, or what the
  /// scenario's camera makes of it (for the first polarity, as `filter()`).
  [[nodiscard]] const image<float>& visual_map() const { return first().visual_map; }
  /// The relief the sensor presses (first polarity), mm.
  [[nodiscard]] const image<float>& relief_mm() const { return first().relief; }

  /// Replays sequence `index` of the protocol. `keep_images`: also return every preprocessed
  /// tactile image and belief image; `keep_log_likelihoods`: every touch's log-likelihood over
  /// the states. Throws std::invalid_argument for an index out of range.
  /// `hooks` (optional): another filter choosing the active order's touches (`touch_hooks`).
  [[nodiscard]] sequence_result run(std::size_t index, bool keep_images = false,
                                    bool keep_log_likelihoods = false,
                                    const touch_hooks& hooks = {}) {
    if (index >= protocol_->sequences.size())
      detail::fail("localization_experiment::run: sequence ", index,
                   " does not exist; expected 0 .. ",
                   protocol_->sequences.size() == 0 ? 0 : protocol_->sequences.size() - 1,
                   " (the protocol has ", protocol_->sequences.size(), " sequences)");
    bool dark = config_.scenario.polarity == relief_polarity::dark_raised;
    if (config_.scenario.polarity == relief_polarity::random) {
      // Its own stream: the other draws do not change with the polarity's.
      sim_rng polarity_rng(scenario_seed(config_.simulator_seed ^ 0xA0761D6478BD642FULL, index));
      dark = polarity_rng.uniform() < 0.5;
    }
    polarity_setup& v = *variants_[dark ? 1 : 0];
    sequence_result result;
    if (v.filter)
      result = run_on(*v.filter, v, index, keep_images, keep_log_likelihoods, hooks);
    else if constexpr (localizes_headings<Measurement>)
      result = run_on(*v.pose_filter, v, index, keep_images, keep_log_likelihoods, hooks);
    result.raised_dark = dark;
    return result;
  }

 private:
  // Everything that depends on the object's polarity: its relief, the camera's map of it, and
  // the filter whose measurement model was built from that map.
  struct polarity_setup {
    image<float> relief;                // mm, the object's height
    image<float> visual_map;            // what the camera shows (the protocol's image when ideal)
    image<float> pressed_relief;        // relief padded by margin_px_ for moved or turned presses
    std::optional<filter_type> filter;  // headings == 0
    std::optional<pose_filter_type> pose_filter;  // headings > 0
  };

  [[nodiscard]] const polarity_setup& first() const {
    return variants_[0] ? *variants_[0] : *variants_[1];
  }

  void build_variant(std::size_t which) {
    polarity_setup v;
    const int sign = which == 0 ? 1 : -1;
    v.relief = object_relief(protocol_->map, protocol_->relief, config_.scenario, sign,
                             scenario_seed(config_.simulator_seed ^ 0x2545F4914F6CDD1DULL, 0));
    v.visual_map = camera_image(protocol_->map, v.relief, protocol_->mm_per_px, config_.scenario,
                                scenario_seed(config_.simulator_seed, 0));
    v.pressed_relief = margin_px_ > 0 ? padded(v.relief, margin_px_) : v.relief;
    // The filter a `localizer` with this configuration runs on this map.
    if (config_.headings == 0) {
      v.filter.emplace(make_planar_filter(measurement_, config_, v.visual_map, protocol_->mm_per_px,
                                          window_, config_.simulator.geometry));
      if (const auto t = config_.tracking_for_filter()) v.filter->set_tracking(*t);
    } else if constexpr (localizes_headings<Measurement>) {
      v.pose_filter.emplace(make_pose_filter(measurement_, config_, v.visual_map,
                                             protocol_->mm_per_px, window_,
                                             config_.simulator.geometry));
      if (const auto t = config_.tracking_for_filter()) v.pose_filter->set_tracking(*t);
    } else {
      detail::fail("localization_experiment: headings = ", config_.headings,
                   ", but the measurement policy has no (x, y, theta) model; use headings = 0");
    }
    variants_[which].emplace(std::move(v));
  }

  template <class Filter>
  sequence_result run_on(Filter& filter, const polarity_setup& v, std::size_t index,
                         bool keep_images, bool keep_log_likelihoods, const touch_hooks& hooks) {
    constexpr bool pose = Filter::grid_type::dimension == 3;
    const touch_sequence& sequence = protocol_->sequences[index];
    // Each sequence gets its own noise stream, fixed by (seed, index): runs are reproducible
    // whatever order or subset of sequences is run.
    simulator_params sp = config_.simulator;
    std::uint64_t s = config_.simulator_seed ^ (0x9E3779B97F4A7C15ULL * (index + 1));
    sp.seed = splitmix64(s);
    // The relief pressed on, padded (edge heights continued) when the scenario moves the
    // sensor, so that a shifted or turned footprint near the map's border still lies on it.
    const scenario_params& sc = config_.scenario;
    // The lab's conditions (issue 34) draw from their own stream, so that the other draws stay
    // as they were: the map's scale error this sequence, then light and partial presses.
    sim_rng condition_rng(scenario_seed(config_.simulator_seed ^ 0x632BE59BD9B4E019ULL, index));
    // The object is `scale` times the size the map says: the simulator presses it at its true
    // scale (same pixels, larger mm), at the physical position of the map's point.
    const double scale =
        sc.map_scale_error > 0.0
            ? 1.0 + (condition_rng.uniform() < 0.5 ? -1.0 : 1.0) * sc.map_scale_error
            : 1.0;
    const double offset_mm = static_cast<double>(margin_px_) * protocol_->mm_per_px * scale;
    tactile_simulator simulator(v.pressed_relief,
                                {protocol_->map_size().width + 2 * margin_px_,
                                 protocol_->map_size().height + 2 * margin_px_},
                                protocol_->mm_per_px * scale, sp);
    // Registration error of this sequence and the stream of per-press variations.
    sim_rng scenario_rng(scenario_seed(config_.simulator_seed, index + 1));
    const double pi = std::numbers::pi;
    const double shift_angle = 2.0 * pi * scenario_rng.uniform();
    const double rotation =
        (scenario_rng.uniform() < 0.5 ? -1.0 : 1.0) * sc.registration_rotation_deg * pi / 180.0;
    const double cx = 0.5 * static_cast<double>(protocol_->map_size().width) * protocol_->mm_per_px;
    const double cy =
        0.5 * static_cast<double>(protocol_->map_size().height) * protocol_->mm_per_px;

    // The sensor's heading on the object for this sequence (random_orientation), from its own
    // stream so that the other draws do not change with it.
    double heading = 0.0;
    if (config_.random_orientation) {
      sim_rng heading_rng(scenario_seed(config_.simulator_seed ^ 0x5851F42D4C957F2DULL, index));
      heading = pose_grid<float>::wrap_angle(-pi + 2.0 * pi * heading_rng.uniform());
    }

    // The exploration's faults (none by default): where each touch really is, what odometry
    // the filter is told. Their own stream, so they do not change the other draws.
    sim_rng fault_rng(scenario_seed(config_.simulator_seed ^ 0x94D049BB133111EBULL, index));
    const faulted_sequence faulted =
        apply_faults(*protocol_, sequence,
                     planar_grid<float>(protocol_->map_size(), protocol_->mm_per_px, window_),
                     config_.faults, fault_rng);

    std::optional<self_calibration> calibration;
    if (config_.self_calibrate) {
      calibration.emplace(sp.geometry, config_.calibration);
      // The sensor's history: presses at random poses on the object, their own stream.
      sim_rng warmup_rng(scenario_seed(config_.simulator_seed ^ 0x1D8E4E27C47D124FULL, index));
      const double w = static_cast<double>(protocol_->map_size().width) * protocol_->mm_per_px;
      const double h = static_cast<double>(protocol_->map_size().height) * protocol_->mm_per_px;
      const double hu = 0.5 * static_cast<double>(sp.geometry.cols) * sp.geometry.pitch_mm;
      const double hv = 0.5 * static_cast<double>(sp.geometry.rows) * sp.geometry.pitch_mm;
      for (std::size_t k = 0; k < config_.calibration_warmup; ++k) {
        map_pose at{hu + (w - 2.0 * hu) * warmup_rng.uniform(),
                    hv + (h - 2.0 * hv) * warmup_rng.uniform(), heading};
        at.x_mm = at.x_mm * scale + offset_mm;
        at.y_mm = at.y_mm * scale + offset_mm;
        if (simulator.fits(at)) calibration->observe(read_press(simulator, at, {}).frame);
      }
    }

    filter.reset();
    sequence_result result;
    result.sequence = index;
    // The active order's stream of candidates, its own per sequence.
    sim_rng active_rng(scenario_seed(config_.simulator_seed ^ 0x2545F4914F6CDD1DULL, index));
    // Its slip's direction when the protocol's does not fit (`carry_faults_to_move`).
    sim_rng active_fault_rng(scenario_seed(
        config_.simulator_seed ^ 0x94D049BB133111EBULL ^ 0x2545F4914F6CDD1DULL, index));
    // Which touches a fault came before: the protocol's sequence's, or the active order's.
    std::vector<char> outlier = faulted.outlier;
    std::vector<char> unseen(sequence.size(), 0);  // a slip or kidnap before the touch
    if (faulted.slipped) unseen[config_.faults.slip_touch - 1] = 1;
    if (faulted.kidnapped) unseen[config_.faults.kidnap_touch - 1] = 1;
    touch_location previous{};
    std::size_t updates = 0;  // accepted touches so far
    for (std::size_t step = 0; step < sequence.size(); ++step) {
      const protocol_step& st = sequence[step];
      touch_location truth = faulted.truth[step];
      odometry reported = faulted.reported[step];
      std::size_t location = st.location;
      if constexpr (!pose) {
        if (config_.order == touch_order::active && step > 0) {
          const auto [target, state] = choose_next_touch(filter, previous, active_rng, hooks);
          location = static_cast<std::size_t>(state);
          const faulted_move m =
              carry_faults_to_move(*protocol_, sequence, faulted, config_.faults, step, previous,
                                   target, filter.grid().base(), active_fault_rng);
          truth = m.truth;
          reported = m.reported;
          outlier[step] = m.outlier ? 1 : 0;
          unseen[step] = m.slipped || m.kidnapped ? 1 : 0;
        }
      }
      previous = truth;
      if (scale != 1.0) {  // the arm measures mm of the object; the map's mm are off by scale
        reported.dx_mm *= scale;
        reported.dy_mm *= scale;
      }
      bool lost_track = false;
      // The move: the filter's prediction, then what the oracle tells it (sim/faults.hpp).
      const auto move = [&] {
        if constexpr (pose) {
          // The arm reports its motion in the sensor's own frame: R(-heading) (dx, dy).
          const double c = std::cos(heading), sn = std::sin(heading);
          const double dx = reported.dx_mm, dy = reported.dy_mm;
          filter.predict(
              {.du_mm = c * dx + sn * dy, .dv_mm = -sn * dx + c * dy, .dtheta_rad = 0.0});
        } else {
          filter.predict(reported);
        }
        const exploration_faults& f = config_.faults;
        if (f.oracle == fault_oracle::transition)
          detail::spread_over_ring(filter, f.outlier_mm, f.outlier_probability);
        if (f.oracle == fault_oracle::told) {
          if (outlier[step] != 0) detail::spread_over_ring(filter, f.outlier_mm, 1.0);
          if (unseen[step] != 0 && step + 1 == f.slip_touch)
            detail::spread_over_ring(filter, f.slip_mm, 1.0);
        }
      };
      // The belief before the move, for the slip recheck (`localizer_config::slip_recheck`).
      std::optional<typename Filter::belief_type> before;
      if (step > 0 && updates > 0 && config_.slip_recheck) before = filter.belief();
      if (step > 0) {
        try {
          move();
        } catch (const std::domain_error&) {
          // The odometry carried every state the belief allowed off the map (a fault the
          // motion model trusts): start again from a uniform belief, as a user would.
          filter.reset();
          lost_track = true;
        }
      }
      // Where the sensor really presses on the object: the true map pose carried by the
      // registration error, turned by this press's orientation jitter; and how it presses.
      map_pose pressed = truth.pose();
      pressed.theta_rad = pose_grid<float>::wrap_angle(pressed.theta_rad + heading);
      press_variation press;
      if (sc.moves_sensor()) {
        const double dx = pressed.x_mm - cx, dy = pressed.y_mm - cy;
        pressed.x_mm = cx + dx * std::cos(rotation) - dy * std::sin(rotation) +
                       sc.registration_shift_mm * std::cos(shift_angle);
        pressed.y_mm = cy + dx * std::sin(rotation) + dy * std::cos(rotation) +
                       sc.registration_shift_mm * std::sin(shift_angle);
        // Draws are made whatever their size, so one knob does not reshuffle the others.
        const double jitter = scenario_rng.normal(), tilt_u = scenario_rng.normal(),
                     tilt_v = scenario_rng.normal(), depth = scenario_rng.normal();
        pressed.theta_rad += rotation + sc.orientation_jitter_deg * pi / 180.0 * jitter;
        press.tilt_u_rad = std::clamp(sc.tilt_jitter_deg * pi / 180.0 * tilt_u, -0.4, 0.4);
        press.tilt_v_rad = std::clamp(sc.tilt_jitter_deg * pi / 180.0 * tilt_v, -0.4, 0.4);
        press.depth_scale = std::max(0.2, 1.0 + sc.press_depth_jitter * depth);
        // Light and partial presses (drawn whatever their fractions, from their own stream).
        const double light = condition_rng.uniform(), partial = condition_rng.uniform(),
                     axis = 2.0 * pi * condition_rng.uniform();
        if (light < sc.light_press_fraction) press.depth_scale *= sc.light_press_scale;
        if (partial < sc.partial_press_fraction) {
          const double t = sc.partial_press_tilt_deg * pi / 180.0;
          press.tilt_u_rad = std::clamp(press.tilt_u_rad + t * std::cos(axis), -0.45, 0.45);
          press.tilt_v_rad = std::clamp(press.tilt_v_rad + t * std::sin(axis), -0.45, 0.45);
        }
        if (scale != 1.0) {
          pressed.x_mm *= scale;
          pressed.y_mm *= scale;
        }
      }
      pressed.x_mm += offset_mm;
      pressed.y_mm += offset_mm;
      const combined_burst read = read_press(simulator, pressed, press);
      tactile_frame frame = read.frame;
      if (calibration) {
        calibration->observe(frame);
        frame = calibration->correct(frame).frame;
      }
      const preprocessed_frame pre = preprocess(frame, config_.preprocessing);
      touch_record rec;
      rec.step = step;
      rec.location = location;
      rec.true_x_mm = truth.x_mm;
      rec.true_y_mm = truth.y_mm;
      if (step > 0) {
        rec.reported_dx_mm = reported.dx_mm;
        rec.reported_dy_mm = reported.dy_mm;
      }
      rec.odometry_outlier = outlier[step] != 0;
      rec.moved_unseen = unseen[step] != 0;
      rec.lost_track = lost_track;
      rec.accepted = pre.accepted();
      rec.rejection = pre.rejection;
      rec.frames_read = simulator.params().frames_per_press;
      rec.frames_combined = read.used;
      if (rec.accepted) {
        update_report report;
        if (keep_log_likelihoods) {
          // What update() does, with the log-likelihood kept.
          belief_array<typename Filter::grid_type> ll(filter.grid().size());
          filter.measurement_model().log_likelihood(filter.grid(), pre.pixels, ll);
          report = filter.update_log_likelihood(ll);
          if (before && !lost_track && report.log_prediction_support < config_.slip_recheck->doubt)
            detail::recheck_as_slip(
                filter, *before, move, [&] { (void)filter.update_log_likelihood(ll); },
                *config_.slip_recheck);
          result.log_likelihoods.push_back(std::move(ll));
        } else {
          report = filter.update(pre.pixels);
          // As the localizer does (`detail::predict_and_update`).
          if (before && !lost_track && report.log_prediction_support < config_.slip_recheck->doubt)
            detail::recheck_as_slip(
                filter, *before, move, [&] { (void)filter.update(pre.pixels); },
                *config_.slip_recheck);
        }
        ++updates;
        rec.log_marginal_likelihood = report.log_marginal_likelihood();
        rec.log_prediction_support = report.log_prediction_support;
        rec.contradicted = report.log_prediction_support < config_.confidence.contradiction;
      } else if (keep_log_likelihoods) {
        result.log_likelihoods.emplace_back();
      }
      const auto est = filter.estimate();
      const confidence conf = assess(filter, est, config_.confidence);
      rec.probability_within = conf.probability_within;
      rec.heading_probability = conf.heading_probability;
      rec.verdict = conf.verdict;
      rec.estimate_x_mm = conf.centre_mm(0);
      rec.estimate_y_mm = conf.centre_mm(1);
      rec.error_mm = std::hypot(rec.estimate_x_mm - truth.x_mm, rec.estimate_y_mm - truth.y_mm);
      rec.map_x_mm = est.map_mm(0);
      rec.map_y_mm = est.map_mm(1);
      rec.map_error_mm = std::hypot(rec.map_x_mm - truth.x_mm, rec.map_y_mm - truth.y_mm);
      rec.true_theta_rad = heading;
      if constexpr (pose) rec.map_theta_rad = est.map_mm(2);
      rec.entropy_nats = est.entropy_nats;
      rec.appearance_probability = est.hypothesis_probability;
      result.touches.push_back(rec);
      if (hooks.touched) hooks.touched(rec, frame);
      if (keep_images) {
        result.tactile_images.push_back(rec.accepted ? pre.pixels : image<float>{});
        result.beliefs.push_back(position_belief(filter));
        result.frames.push_back(std::move(frame));
      }
    }
    return result;
  }

  // One press as the localizer takes it: one frame (`render`), or a burst of
  // `frames_per_press` frames (`render_press`) combined as `basic_localizer::touch(span)` does
  // (`combine_burst` with the configuration's `burst`). The result's `used` counts the frames
  // combined (1 for a single frame).
  [[nodiscard]] combined_burst read_press(tactile_simulator& simulator, const map_pose& at,
                                          const press_variation& press) const {
    if (simulator.params().frames_per_press == 1) {
      combined_burst one;
      one.frame = simulator.render(at, press);
      one.status.assign(1, burst_frame_status::used);
      one.used = 1;
      return one;
    }
    const std::vector<tactile_frame> burst = simulator.render_press(at, press);
    return combine_burst(std::span<const tactile_frame>(burst), config_.burst);
  }

  // The active order's next location: `active_candidates` positions drawn over the map's
  // states, ranked by `next_touch` as moves from `from` (the true location of the previous
  // touch: the arm knows where it moves), the best taken; by `hooks.rank` when given.
  template <class Filter>
  std::pair<touch_location, Eigen::Index> choose_next_touch(const Filter& filter,
                                                            const touch_location& from,
                                                            sim_rng& rng,
                                                            const touch_hooks& hooks) const {
    const auto& grid = filter.grid().base();
    std::vector<touch_location> places;
    std::vector<Eigen::Index> states;
    std::vector<odometry> moves;
    for (std::size_t k = 0, tries = 0; k < config_.active_candidates; ++tries) {
      const auto q = static_cast<Eigen::Index>(rng.below(static_cast<std::uint64_t>(grid.size())));
      const auto s = grid.state_mm(q);
      // Far enough from the previous touch (after 100 draws per candidate: anywhere).
      if (std::hypot(s(0) - from.x_mm, s(1) - from.y_mm) < config_.active_min_move_mm &&
          tries < 100 * config_.active_candidates)
        continue;
      ++k;
      places.push_back({s(0), s(1)});
      states.push_back(q);
      moves.push_back({.dx_mm = s(0) - from.x_mm, .dy_mm = s(1) - from.y_mm});
    }
    const next_touch_ranking r =
        hooks.rank ? hooks.rank(std::span<const odometry>(moves))
                   : detail::rank_planar_touches(filter, std::span<const odometry>(moves),
                                                 config_.confidence.radius_mm, config_.next_touch,
                                                 "localization_experiment (active order)");
    return {places[r.best()], states[r.best()]};
  }

  // Seeds of the scenario's draws: stream 0 for the camera map, index + 1 for sequence index;
  // independent of the simulator's own streams.
  static std::uint64_t scenario_seed(std::uint64_t seed, std::size_t stream) {
    std::uint64_t s = seed ^ 0xD1B54A32D192ED03ULL ^ (0xBF58476D1CE4E5B9ULL * (stream + 1));
    return splitmix64(s);
  }

  // Margin (map px) that keeps the pressed footprint on the padded relief: the registration's
  // displacement anywhere on the map plus the footprint's growth at any orientation.
  static Eigen::Index margin_px(const touch_protocol& p, const localization_config& c) {
    c.scenario.validate();
    const double w = 0.5 * static_cast<double>(p.map.cols()) * p.mm_per_px;
    const double h = 0.5 * static_cast<double>(p.map.rows()) * p.mm_per_px;
    const taxel_geometry& g = c.simulator.geometry;
    const auto cols = static_cast<double>(g.cols), rows = static_cast<double>(g.rows);
    const double half_diagonal = 0.5 * g.pitch_mm * std::hypot(cols, rows);
    const double half_short = 0.5 * g.pitch_mm * std::min(cols, rows);
    const double mm =
        c.scenario.registration_shift_mm +
        std::hypot(w, h) * c.scenario.registration_rotation_deg * std::numbers::pi / 180.0 +
        (half_diagonal - half_short) + 2.0 * p.mm_per_px +
        // A map scale off by e: the footprint covers up to 1 / (1 - e) of its pixels.
        half_diagonal * c.scenario.map_scale_error / (1.0 - c.scenario.map_scale_error);
    return static_cast<Eigen::Index>(std::ceil(mm / p.mm_per_px));
  }

  // `relief` with `m` pixels added on every side, repeating the edge heights.
  static image<float> padded(const image<float>& relief, Eigen::Index m) {
    image<float> out(relief.rows() + 2 * m, relief.cols() + 2 * m);
    for (Eigen::Index r = 0; r < out.rows(); ++r)
      for (Eigen::Index c = 0; c < out.cols(); ++c)
        out(r, c) = relief(std::clamp<Eigen::Index>(r - m, 0, relief.rows() - 1),
                           std::clamp<Eigen::Index>(c - m, 0, relief.cols() - 1));
    return out;
  }

  const touch_protocol* protocol_;
  localization_config config_;
  Measurement measurement_;
  pixel_size window_;
  Eigen::Index margin_px_;
  std::array<std::optional<polarity_setup>, 2> variants_;  // [0]: raised bright, [1]: raised dark
};

/// The experiment with the shipped models (`configured_models`): what tacmap-evaluate runs.
class localization_experiment : public basic_localization_experiment<configured_models> {
 public:
  using basic_localization_experiment::basic_localization_experiment;
};

}  // namespace tacmap
