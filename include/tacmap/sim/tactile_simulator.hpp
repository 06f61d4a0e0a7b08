// tacmap: `tactile_simulator` — tactile frames of a sensor pressed onto an object's relief.
//
// What it stands in for (paper, Sec. IV): a Weiss resistive array (14 x 6 cells, 3.4 mm pitch)
// under an elastic foam cover, held normal to a 3D-printed object whose 2-D shape protrudes
// 4 mm from its base, and pressed onto it by a Phantom Omni. The simulator turns a height map
// of the object (the *relief*, mm, one value per map pixel) and a sensor pose into the raw
// counts such an array reports, so that tests, demos and evaluations have tactile images that
// look like the map — and fail like a real sensor (noise, gain spread, saturation, dead cells).
//
// The physics, in the order applied (every constant lives in `simulator_params`):
//  1. Contact. The sensor plane is lowered onto the relief until the highest point under the
//     sensor is indented by `press_depth_mm`; every point under the sensor is indented by
//     max(0, height - plane height). A rigid plane on a rigid object: what is lower than the
//     plane is not touched. A `press_variation` scales the depth and tilts the plane for one
//     touch (sim/scenario.hpp draws them).
//  2. Cell integration. Each taxel reports the mean indentation over its square cell, sampled
//     at `supersample` x `supersample` points with bilinear interpolation of the relief.
//  3. Foam. The elastic cover spreads load to neighbouring cells: a Gaussian over taxels with
//     `foam_sigma_mm`. At the array's border the weights are renormalised over the taxels that
//     exist, so a uniform load reads uniform.
//  4. Transduction. counts = gain_counts_per_mm x taxel gain x indentation, where each taxel's
//     gain is 1 + gain_variation x N(0, 1), drawn once per simulator from the seed.
//  5. Read-out. Loaded taxels get additive Gaussian noise (`noise_counts`); taxels with no load
//     read exactly 0 (a resistive cell does not conduct without pressure). Values are rounded to
//     integers and saturate at `full_scale_counts` (4095 for the 12-bit Weiss read-out). Dead
//     taxels (`dead_fraction` of them, chosen once from the seed) always read 0.
//  6. What a lab's sensor adds (issue 34; all off by default, docs/simulator.md argues the
//     levels): `hysteresis` — a fraction of the previous frame's counts persists into this one
//     (the foam and the resistive layer recover slowly after a press); `saturation_counts` —
//     the resistive response compresses towards a ceiling, counts = S tanh(counts / S), before
//     the noise; `baseline_drift_counts` — every taxel's zero wanders as a random walk from
//     frame to frame (half of each step common to the array, as temperature moves it, half the
//     taxel's own), and is added to every live taxel, loaded or not.
//  7. A press read as a burst (`frames_per_press` > 1, `render_press`): the paper "stays at each
//     location for a certain time and 20 readings are thus collected" (Sec. IV-B). Every frame
//     has its own read-out noise. The burst is read from the moment of contact, while the foam
//     still creeps and the arm's position controller closes in: the press depth of frame k is
//     1 - (1 - settle_start) exp(-k / settle_frames) of the press's own, a first-order rise
//     (the settling head). The slow effects are the press's, not the frame's: the hysteresis
//     ghost is the previous PRESS's (the foam recovers over seconds, a burst lasts tenths), and
//     the baseline walks as far over a press's frames as over one frame (its step per frame is
//     baseline_drift_counts / sqrt(N): drift follows time between presses, not read-outs). A
//     single frame (N = 1) is read once the press has settled: exactly `render`.
//  8. Bumps within a burst (`bump_probability` > 0, bursts only): each frame after the first is,
//     with that probability, read while the arm is knocked or the hand twitches: the contact
//     force jumps (the frame's depth is scaled by a factor drawn uniformly from
//     [1 - bump_depth_spread, 1 + bump_depth_spread]) and the array slides by `bump_shift_mm`
//     in a random direction of the map (not off it), for that frame only. These are the outlier
//     frames a burst's combination must drop (`combine_burst`); their draws come from a stream of
//     their own, so every other frame reads as without them.
//
// Frames: a frame is `geometry.rows` x `geometry.cols` counts; taxel (r, c) sits at offset
// ((c - (cols - 1) / 2) pitch, (r - (rows - 1) / 2) pitch) from the sensor centre in the sensor's
// own axes. Map frame as in planar_grid: x right along columns, y down along rows, origin at the
// map's top-left corner, mm. With theta = 0 the array's rows run along the map's y axis (14 rows
// x 3.4 mm = 47.6 mm along y) and its columns along x; at the paper's scale taxel (r, c) lies
// over the map pixels that planar_grid's window at the same centre shows at (3r..3r+2,
// 3c..3c+2). A positive
// theta turns the array's column axis from the map's +x towards +y (clockwise on screen, since y
// points down); theta = pi shows the same patch with both frame axes reversed.
//
// Determinism: the simulator owns a `sim_rng` seeded from `seed`; gains, dead taxels and the
// noise stream come from independent sub-seeds. The same parameters and the same sequence of
// `render` calls give the same frames on every platform (see sim/random.hpp).
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <utility>
#include <vector>

#include "tacmap/image.hpp"
#include "tacmap/sim/random.hpp"
#include "tacmap/tactile/frame.hpp"

namespace tacmap {

/// Where the sensor is on the map: its centre in the map frame (mm) and its in-plane rotation
/// (radians). Not `sensor_pose` (devices/position_source.hpp), which is a device-frame reading;
/// `map_calibration` turns those into map-frame motion.
struct map_pose {
  double x_mm = 0.0;
  double y_mm = 0.0;
  double theta_rad = 0.0;  ///< 0: the array's rows run along the map's y axis (see file comment)
};

/// How one press departs from the nominal one (the realistic scenario's per-touch effects,
/// sim/scenario.hpp): an arm or a hand never presses twice with the same force, nor holds the
/// array exactly parallel to the surface. The default is the nominal press.
struct press_variation {
  double depth_scale = 1.0;  ///< multiplies `simulator_params::press_depth_mm`, >= 0
  double tilt_u_rad = 0.0;   ///< slope of the array's plane along its column (u) axis
  double tilt_v_rad = 0.0;   ///< slope of the array's plane along its row (v) axis

  void validate() const {
    if (!(std::isfinite(depth_scale) && depth_scale >= 0.0))
      detail::fail("press_variation: depth_scale = ", depth_scale,
                   "; expected a finite factor >= 0 on the press depth (1 = nominal)");
    const auto tilt = [](const char* name, double value) {
      if (!(std::isfinite(value) && std::abs(value) < 0.5))
        detail::fail("press_variation: ", name, " = ", value,
                     " rad; expected a finite tilt of magnitude < 0.5 rad (a few degrees is "
                     "realistic; beyond that the array would not lie on the surface)");
    };
    tilt("tilt_u_rad", tilt_u_rad);
    tilt("tilt_v_rad", tilt_v_rad);
  }
};

/// How an image's intensity becomes a relief.
enum class relief_kind {
  binary,      ///< pixels brighter than `threshold` protrude by `height_mm` (the paper's gecko)
  continuous,  ///< height = height_mm x intensity (a height field stored as an image)
};

/// Configuration of `relief_from_image`. Defaults: the paper's gecko, a 2-D shape protruding
/// 4 mm from its base (Sec. IV), from an image with intensities in [0, 1].
struct relief_params {
  relief_kind kind = relief_kind::binary;
  float threshold = 0.5F;  ///< binary: intensity above which the object protrudes
  double height_mm = 4.0;  ///< binary: protrusion; continuous: height of intensity 1
  double edge_smoothing_px =
      0.0;  ///< binary: Gaussian sigma (map px) rounding the edges; 0 = sharp

  void validate() const {
    if (!std::isfinite(threshold))
      detail::fail("relief_params: threshold = ", threshold,
                   "; expected a finite intensity (0.5 for an image scaled to [0, 1])");
    if (!std::isfinite(height_mm))
      detail::fail("relief_params: height_mm = ", height_mm,
                   "; expected a finite height in millimetres (the paper's gecko: 4)");
    if (!(std::isfinite(edge_smoothing_px) && edge_smoothing_px >= 0.0))
      detail::fail("relief_params: edge_smoothing_px = ", edge_smoothing_px,
                   "; expected a finite Gaussian sigma >= 0 in map pixels (0 = sharp edges)");
  }
};

namespace detail::simulation {

/// Position of the first non-finite element, or (-1, -1).
inline std::pair<Eigen::Index, Eigen::Index> first_non_finite(const image<float>& values) {
  for (Eigen::Index r = 0; r < values.rows(); ++r)
    for (Eigen::Index c = 0; c < values.cols(); ++c)
      if (!std::isfinite(values(r, c))) return {r, c};
  return {-1, -1};
}

// The separable Gaussian blur (tacmap/image.hpp) the simulator's relief, load and scenes use.
using tacmap::detail::gaussian_blur;
using tacmap::detail::gaussian_taps;

}  // namespace detail::simulation

/// Turns an intensity image (e.g.\ the visual map, scaled to [0, 1]) into a relief in mm.
/// Binary: 1 above `threshold`, else 0, optionally smoothed, times `height_mm`. Continuous:
/// `height_mm` x intensity. Throws std::invalid_argument for an empty image, a non-finite pixel
/// (named by row and column) or bad parameters.
[[nodiscard]] inline image<float> relief_from_image(const image<float>& intensity,
                                                    const relief_params& params = {}) {
  params.validate();
  if (intensity.size() == 0)
    detail::fail("relief_from_image: the image is ", intensity.rows(), " x ", intensity.cols(),
                 " px (rows x cols); expected a non-empty image");
  if (const auto [r, c] = detail::simulation::first_non_finite(intensity); r >= 0)
    detail::fail("relief_from_image: pixel (row ", r, ", col ", c, ") of the ", intensity.rows(),
                 " x ", intensity.cols(), " image is ", intensity(r, c),
                 "; expected finite intensities — check how the image was loaded or scaled");
  if (params.kind == relief_kind::continuous)
    return (intensity.cast<double>() * params.height_mm).cast<float>();
  image<float> mask = (intensity > params.threshold).cast<float>();
  detail::simulation::gaussian_blur(mask, params.edge_smoothing_px);
  return (mask.cast<double>() * params.height_mm).cast<float>();
}

/// Configuration of `tactile_simulator` (see the file comment for the model). The defaults
/// describe the paper's Weiss array on a 4 mm relief: a 1 mm press gives about 2000 of 4095
/// counts on a fully loaded cell, with a few percent of noise and gain spread.
struct simulator_params {
  taxel_geometry geometry{};           ///< 14 x 6 at 3.4 mm (the paper's Weiss array)
  double press_depth_mm = 1.0;         ///< indentation of the highest point under the sensor
  int supersample = 4;                 ///< sample points per cell side for the cell integral
  double foam_sigma_mm = 1.7;          ///< load spread by the foam cover (half a 3.4 mm pitch)
  double gain_counts_per_mm = 2000.0;  ///< counts per mm of indentation for a nominal taxel
  double gain_variation = 0.05;        ///< relative standard deviation of the per-taxel gain
  double noise_counts = 10.0;          ///< standard deviation of the read-out noise, counts
  double dead_fraction = 0.0;          ///< fraction of taxels that always read 0
  float full_scale_counts = 4095.0F;   ///< saturation value (12-bit read-out)
  /// Soft saturation: counts = S tanh(counts / S) before the noise (a resistive cell's response
  /// flattens under load); 0 = linear up to the hard full scale.
  double saturation_counts = 0.0;
  /// Fraction of the previous frame's noiseless counts that persists into the next frame
  /// (hysteresis of the foam and the resistive layer: a ghost of the last press); 0 = none.
  double hysteresis = 0.0;
  /// Standard deviation of each frame's step of the taxels' baseline random walk, counts (half
  /// the variance common to the array, half per taxel); 0 = a fixed zero. A burst's frames
  /// share one press's step (`render_press`).
  double baseline_drift_counts = 0.0;
  /// Frames read per press (`render_press`): 1 = one settled frame (`render`); the paper read 20.
  std::size_t frames_per_press = 1;
  /// A burst's first frame is pressed to this fraction of the press depth (the settling head;
  /// bursts only). 1 = no settling.
  double settle_start = 0.5;
  /// Time constant of the settling, frames: frame k of a burst is pressed to
  /// 1 - (1 - settle_start) exp(-k / settle_frames) of the depth. 0 = settled from frame 1 on.
  double settle_frames = 2.0;
  /// Probability that a frame of a burst (after its first) is read during a bump (file comment,
  /// step 8); 0 = none. Bursts only: a single frame is read once the press has settled.
  double bump_probability = 0.0;
  /// A bump's force: the frame's depth times a factor uniform in [1 - s, 1 + s], s in [0, 1].
  double bump_depth_spread = 0.6;
  /// A bump's slide of the array over the surface, mm, in a random direction (half the
  /// paper's pitch by default).
  double bump_shift_mm = 1.7;
  std::uint64_t seed = 1;  ///< fixes gains, dead taxels and the noise stream
  std::chrono::nanoseconds frame_interval = std::chrono::milliseconds(10);  ///< timestamp step

  void validate() const {
    geometry.validate();
    const auto non_negative = [](const char* name, double value, const char* hint) {
      if (!(std::isfinite(value) && value >= 0.0))
        detail::fail("simulator_params: ", name, " = ", value, "; expected a finite value >= 0",
                     hint);
    };
    non_negative("press_depth_mm", press_depth_mm, " millimetres (0 = just touching)");
    non_negative("foam_sigma_mm", foam_sigma_mm, " millimetres (0 = no spreading)");
    non_negative("gain_counts_per_mm", gain_counts_per_mm, " counts per millimetre");
    non_negative("gain_variation", gain_variation, " (relative, e.g. 0.05 for 5 %)");
    non_negative("noise_counts", noise_counts, " counts");
    non_negative("saturation_counts", saturation_counts,
                 " counts (0 = linear; a few thousand for a resistive cell)");
    non_negative("baseline_drift_counts", baseline_drift_counts,
                 " counts per frame (standard deviation of the baseline's step)");
    if (frames_per_press < 1 || frames_per_press > 1000)
      detail::fail("simulator_params: frames_per_press = ", frames_per_press,
                   "; expected 1 .. 1000 frames read per press (1 = one settled frame; the "
                   "paper read 20)");
    if (!(settle_start >= 0.0 && settle_start <= 1.0))
      detail::fail("simulator_params: settle_start = ", settle_start,
                   "; expected a fraction in [0, 1] of the press depth reached by a burst's "
                   "first frame (1 = no settling)");
    non_negative("settle_frames", settle_frames,
                 " frames (time constant of a burst's settling; 0 = settled after one frame)");
    if (!(bump_probability >= 0.0 && bump_probability <= 1.0))
      detail::fail("simulator_params: bump_probability = ", bump_probability,
                   "; expected a probability in [0, 1] that a burst's frame is read during a "
                   "bump (0 = none)");
    if (!(bump_depth_spread >= 0.0 && bump_depth_spread <= 1.0))
      detail::fail("simulator_params: bump_depth_spread = ", bump_depth_spread,
                   "; expected a fraction in [0, 1]: a bump scales the depth by a factor in "
                   "[1 - spread, 1 + spread]");
    if (!(std::isfinite(bump_shift_mm) && bump_shift_mm >= 0.0 && bump_shift_mm <= 1000.0))
      detail::fail("simulator_params: bump_shift_mm = ", bump_shift_mm,
                   "; expected a slide of 0 .. 1000 mm (half a pitch, 1.7, by default)");
    if (!(hysteresis >= 0.0 && hysteresis < 1.0))
      detail::fail("simulator_params: hysteresis = ", hysteresis,
                   "; expected a fraction in [0, 1) of the previous frame that persists "
                   "(0 = none, 0.05 is a worn foam)");
    if (supersample < 1 || supersample > 64)
      detail::fail("simulator_params: supersample = ", supersample,
                   "; expected 1 .. 64 sample points per cell side (4 is plenty)");
    if (!(dead_fraction >= 0.0 && dead_fraction <= 1.0))
      detail::fail("simulator_params: dead_fraction = ", dead_fraction,
                   "; expected a fraction of taxels in [0, 1]");
    if (!(std::isfinite(full_scale_counts) && full_scale_counts >= 1.0F &&
          full_scale_counts == std::round(full_scale_counts)))
      detail::fail("simulator_params: full_scale_counts = ", full_scale_counts,
                   "; expected a whole number of counts >= 1 (4095 for a 12-bit read-out)");
    if (frame_interval.count() < 0)
      detail::fail("simulator_params: frame_interval = ", frame_interval.count(),
                   " ns; expected a non-negative time step between frames");
  }
};

/// Simulated tactile array pressed onto one object (see the file comment for the model).
/// A value type; `render` advances the noise stream, everything else is const.
class tactile_simulator {
 public:
  /// `relief_mm`: the object's height in mm at every map pixel; `map` and `mm_per_px`: the map
  /// it belongs to (as given to planar_grid). Throws std::invalid_argument when the relief's size
  /// disagrees with the map, a height is not finite, or a parameter is out of range.
  tactile_simulator(image<float> relief_mm, pixel_size map, double mm_per_px,
                    simulator_params params = {})
      : relief_(std::move(relief_mm)), map_(map), mm_per_px_(mm_per_px), params_(params) {
    params_.validate();
    if (!(std::isfinite(mm_per_px) && mm_per_px > 0.0))
      detail::fail("tactile_simulator: mm_per_px = ", mm_per_px,
                   "; expected the map's scale, a finite value > 0 millimetres per pixel");
    if (map.width <= 0 || map.height <= 0)
      detail::fail("tactile_simulator: map = ", map.width, " x ", map.height,
                   " px (width x height); expected both > 0");
    if (relief_.cols() != map.width || relief_.rows() != map.height)
      detail::fail("tactile_simulator: the relief is ", relief_.cols(), " x ", relief_.rows(),
                   " px (width x height) but the map is ", map.width, " x ", map.height,
                   " px; expected one height per map pixel — build the relief from the map "
                   "image itself (relief_from_image)");
    if (const auto [r, c] = detail::simulation::first_non_finite(relief_); r >= 0)
      detail::fail("tactile_simulator: relief pixel (row ", r, ", col ", c, ") of the ",
                   relief_.cols(), " x ", relief_.rows(), " px relief is ", relief_(r, c),
                   "; expected finite heights in millimetres");

    const Eigen::Index rows = params_.geometry.rows;
    const Eigen::Index cols = params_.geometry.cols;
    std::uint64_t seeder = params_.seed;
    sim_rng gain_rng(splitmix64(seeder));
    sim_rng dead_rng(splitmix64(seeder));
    noise_rng_ = sim_rng(splitmix64(seeder));
    drift_rng_ = sim_rng(splitmix64(seeder));  // drawn after the others: they stay as they were
    bump_rng_ = sim_rng(splitmix64(seeder));   // likewise
    baseline_ = image<float>::Zero(params_.geometry.rows, params_.geometry.cols);
    previous_ = image<float>::Zero(params_.geometry.rows, params_.geometry.cols);

    gain_.resize(rows, cols);
    for (Eigen::Index r = 0; r < rows; ++r)
      for (Eigen::Index c = 0; c < cols; ++c)
        gain_(r, c) =
            static_cast<float>(std::max(0.0, 1.0 + params_.gain_variation * gain_rng.normal()));

    // Exactly round(fraction x n) dead taxels, chosen by a partial Fisher-Yates shuffle.
    dead_ = image<bool>::Constant(rows, cols, false);
    const auto n = static_cast<std::uint64_t>(rows * cols);
    const auto n_dead =
        static_cast<std::uint64_t>(std::llround(params_.dead_fraction * static_cast<double>(n)));
    std::vector<std::uint64_t> order(n);
    for (std::uint64_t i = 0; i < n; ++i) order[i] = i;
    for (std::uint64_t i = 0; i < n_dead; ++i) {
      std::swap(order[i], order[i + dead_rng.below(n - i)]);
      dead_.data()[order[i]] = true;
    }
  }

  [[nodiscard]] const simulator_params& params() const { return params_; }
  [[nodiscard]] const image<float>& relief() const { return relief_; }
  [[nodiscard]] pixel_size map_size() const { return map_; }
  [[nodiscard]] double mm_per_px() const { return mm_per_px_; }
  /// Per-taxel gain factors (around 1), fixed for this simulator.
  [[nodiscard]] const image<float>& taxel_gain() const { return gain_; }
  /// Taxels that always read 0, fixed for this simulator.
  [[nodiscard]] const image<bool>& dead_taxels() const { return dead_; }

  /// True when the pose is finite and the whole sensor footprint lies on the map.
  [[nodiscard]] bool fits(const map_pose& pose) const {
    if (!(std::isfinite(pose.x_mm) && std::isfinite(pose.y_mm) && std::isfinite(pose.theta_rad)))
      return false;
    const footprint f = footprint_of(pose);
    constexpr double tolerance_mm = 1e-6;  // poses computed from pixel indices land on the edge
    return f.x_min >= -tolerance_mm && f.y_min >= -tolerance_mm &&
           f.x_max <= width_mm() + tolerance_mm && f.y_max <= height_mm() + tolerance_mm;
  }

  /// Throws std::invalid_argument unless `fits(pose)`; the message names the pose, where the
  /// footprint would be and the map's extent in mm.
  void check_pose(const map_pose& pose) const {
    if (fits(pose)) return;
    const double w = static_cast<double>(params_.geometry.cols) * params_.geometry.pitch_mm;
    const double h = static_cast<double>(params_.geometry.rows) * params_.geometry.pitch_mm;
    if (!(std::isfinite(pose.x_mm) && std::isfinite(pose.y_mm) && std::isfinite(pose.theta_rad)))
      detail::fail("tactile_simulator: pose (x = ", pose.x_mm, " mm, y = ", pose.y_mm,
                   " mm, theta = ", pose.theta_rad,
                   " rad) is not finite; expected a finite "
                   "sensor centre in mm on the map and an angle in radians");
    const footprint f = footprint_of(pose);
    detail::fail("tactile_simulator: pose (x = ", pose.x_mm, " mm, y = ", pose.y_mm,
                 " mm, theta = ", pose.theta_rad, " rad) puts the ", w, " x ", h,
                 " mm sensor footprint at x in [", f.x_min, ", ", f.x_max, "] mm, y in [", f.y_min,
                 ", ", f.y_max, "] mm, outside the map's extent x in [0, ", width_mm(),
                 "] mm, y in [0, ", height_mm(), "] mm (", map_.width, " x ", map_.height,
                 " px at ", mm_per_px_,
                 " mm per px); expected a pose whose whole footprint lies "
                 "on the map — keep the centre at least half the footprint from every edge");
  }

  /// Steps 1-2: mean indentation (mm) of every taxel's cell, before the foam spreads it.
  /// `press`: this touch's depth and tilt (a tilted array is a tilted plane: the highest point
  /// of height minus plane is indented by the press depth).
  [[nodiscard]] image<float> indentation_mm(const map_pose& pose,
                                            const press_variation& press = {}) const {
    check_pose(pose);
    press.validate();
    const double slope_u = std::tan(press.tilt_u_rad);
    const double slope_v = std::tan(press.tilt_v_rad);
    const taxel_geometry& g = params_.geometry;
    const int n = params_.supersample;
    const double pitch = g.pitch_mm;
    const double c0 = 0.5 * static_cast<double>(g.cols - 1);
    const double r0 = 0.5 * static_cast<double>(g.rows - 1);
    const double cs = std::cos(pose.theta_rad);
    const double sn = std::sin(pose.theta_rad);

    // Heights under every sample point, taxel by taxel (row-major), n x n points per taxel.
    const auto per_taxel = static_cast<Eigen::Index>(n) * n;
    Eigen::ArrayXf heights(g.rows * g.cols * per_taxel);
    Eigen::Index k = 0;
    for (Eigen::Index r = 0; r < g.rows; ++r)
      for (Eigen::Index c = 0; c < g.cols; ++c)
        for (int a = 0; a < n; ++a)
          for (int b = 0; b < n; ++b) {
            const double u =
                (static_cast<double>(c) - c0 + (static_cast<double>(b) + 0.5) / n - 0.5) * pitch;
            const double v =
                (static_cast<double>(r) - r0 + (static_cast<double>(a) + 0.5) / n - 0.5) * pitch;
            // Height above the (possibly tilted) sensor plane through the centre.
            heights(k++) = static_cast<float>(
                sample(pose.x_mm + u * cs - v * sn, pose.y_mm + u * sn + v * cs) -
                (u * slope_u + v * slope_v));
          }
    const float plane =
        heights.maxCoeff() - static_cast<float>(params_.press_depth_mm * press.depth_scale);
    image<float> out(g.rows, g.cols);
    for (Eigen::Index t = 0; t < g.rows * g.cols; ++t)
      out.data()[t] = (heights.segment(t * per_taxel, per_taxel) - plane).max(0.0F).mean();
    return out;
  }

  /// Steps 1-4 and dead taxels: the noiseless, unquantised, unsaturated counts.
  [[nodiscard]] image<float> expected_counts(const map_pose& pose,
                                             const press_variation& press = {}) const {
    image<float> load = indentation_mm(pose, press);
    detail::simulation::gaussian_blur(load, params_.foam_sigma_mm / params_.geometry.pitch_mm);
    image<float> counts = (load.cast<double>() * params_.gain_counts_per_mm).cast<float>() * gain_;
    return dead_.select(0.0F, counts);
  }

  /// The taxels' current baseline offsets (counts; zero unless `baseline_drift_counts`).
  [[nodiscard]] const image<float>& baseline() const { return baseline_; }

  /// One frame as the sensor reports it: expected counts (plus the previous frame's ghost,
  /// compressed by the soft saturation) plus noise on loaded taxels, plus the drifting baseline,
  /// rounded, saturated, dead taxels at 0. Advances the noise stream and the frame number.
  [[nodiscard]] tactile_frame render(const map_pose& pose, const press_variation& press = {}) {
    return read_out(with_ghost(expected_counts(pose, press), previous_),
                    params_.baseline_drift_counts);
  }

  /// Depth fraction of frame `k` (0-based) of a burst of `frames` (file comment, step 7): 1
  /// for a single frame, 1 - (1 - settle_start) exp(-k / settle_frames) in a burst.
  [[nodiscard]] double settling(std::size_t k, std::size_t frames) const {
    if (frames <= 1) return 1.0;
    if (!(params_.settle_frames > 0.0)) return k == 0 ? params_.settle_start : 1.0;
    return 1.0 -
           (1.0 - params_.settle_start) * std::exp(-static_cast<double>(k) / params_.settle_frames);
  }

  /// One press read as `params().frames_per_press` frames (file comment, step 7): each with its
  /// own noise, the first ones still settling, some bumped (step 8, `bump_probability`); the
  /// hysteresis ghost is the previous press's and the baseline walks as far over the burst as over
  /// one frame. With one frame per press, exactly `{render(pose, press)}`. Advances the noise
  /// stream and the frame number.
  [[nodiscard]] std::vector<tactile_frame> render_press(const map_pose& pose,
                                                        const press_variation& press = {}) {
    const std::size_t n = params_.frames_per_press;
    if (n == 1) return {render(pose, press)};
    press.validate();
    const image<float> ghost = previous_;
    const double drift_step = params_.baseline_drift_counts / std::sqrt(static_cast<double>(n));
    std::vector<tactile_frame> frames;
    frames.reserve(n);
    for (std::size_t k = 0; k < n; ++k) {
      press_variation settling_press = press;
      settling_press.depth_scale = press.depth_scale * settling(k, n);
      map_pose at = pose;
      // Step 8: three draws per frame after the first whether it is bumped or not, so that
      // which frames are bumped does not change what a bump does.
      if (k > 0 && params_.bump_probability > 0.0) {
        const double hit = bump_rng_.uniform();
        const double force = 1.0 + params_.bump_depth_spread * (2.0 * bump_rng_.uniform() - 1.0);
        const double direction = 2.0 * std::numbers::pi * bump_rng_.uniform();
        if (hit < params_.bump_probability) {
          settling_press.depth_scale *= force;
          map_pose slid = pose;
          slid.x_mm += params_.bump_shift_mm * std::cos(direction);
          slid.y_mm += params_.bump_shift_mm * std::sin(direction);
          if (fits(slid)) at = slid;  // at the map's edge the array cannot slide off it
        }
      }
      // Every frame haunted by the previous press; the last frame's is the next press's ghost.
      frames.push_back(
          read_out(with_ghost(expected_counts(at, settling_press), ghost), drift_step));
    }
    return frames;
  }

 private:
  // Step 5, the hysteresis: `expected` plus `hysteresis` x the ghost of an earlier press;
  // `expected` itself becomes the ghost the next frame sees (previous_). `ghost` may be
  // previous_: it is read before previous_ is replaced.
  [[nodiscard]] image<float> with_ghost(image<float> expected, const image<float>& ghost) {
    if (!(params_.hysteresis > 0.0)) return expected;
    image<float> haunted =
        (expected.cast<double>() + params_.hysteresis * ghost.cast<double>()).cast<float>();
    previous_ = std::move(expected);
    return haunted;
  }

  // Steps 5-6 after the hysteresis: soft saturation, the baseline's walk by `drift_step`, noise,
  // rounding, the full scale and dead taxels; numbers the frame.
  [[nodiscard]] tactile_frame read_out(image<float> expected, double drift_step) {
    if (params_.saturation_counts > 0.0) {
      const double s = params_.saturation_counts;
      expected = expected.unaryExpr(
          [s](float v) { return static_cast<float>(s * std::tanh(static_cast<double>(v) / s)); });
    }
    if (params_.baseline_drift_counts > 0.0) {
      // A random walk: the baseline a touch meets is where the previous frames left it.
      const double step = drift_step * std::sqrt(0.5);
      const double common = step * drift_rng_.normal();
      for (Eigen::Index t = 0; t < baseline_.size(); ++t)
        baseline_.data()[t] += static_cast<float>(common + step * drift_rng_.normal());
    }
    tactile_frame frame;
    frame.geometry = params_.geometry;
    frame.counts.resize(expected.rows(), expected.cols());
    for (Eigen::Index t = 0; t < expected.size(); ++t) {
      // One draw per taxel whatever the load, so the noise a taxel gets does not depend on
      // where the others are touched.
      const double noise = params_.noise_counts * noise_rng_.normal();
      const double e = expected.data()[t];
      double value = (e > 0.0 && !dead_.data()[t]) ? std::round(e + noise) : 0.0;
      if (params_.baseline_drift_counts > 0.0 && !dead_.data()[t])
        value += std::round(static_cast<double>(baseline_.data()[t]));
      frame.counts.data()[t] = static_cast<float>(
          std::clamp(value, 0.0, static_cast<double>(params_.full_scale_counts)));
    }
    frame.sequence = frames_;
    frame.timestamp = tactile_frame::clock::time_point{} +
                      std::chrono::duration_cast<tactile_frame::clock::duration>(
                          params_.frame_interval * static_cast<std::int64_t>(frames_));
    ++frames_;
    return frame;
  }

  struct footprint {
    double x_min, x_max, y_min, y_max;
  };

  [[nodiscard]] double width_mm() const { return static_cast<double>(map_.width) * mm_per_px_; }
  [[nodiscard]] double height_mm() const { return static_cast<double>(map_.height) * mm_per_px_; }

  [[nodiscard]] footprint footprint_of(const map_pose& pose) const {
    const double hu = 0.5 * static_cast<double>(params_.geometry.cols) * params_.geometry.pitch_mm;
    const double hv = 0.5 * static_cast<double>(params_.geometry.rows) * params_.geometry.pitch_mm;
    const double cs = std::cos(pose.theta_rad);
    const double sn = std::sin(pose.theta_rad);
    // Half extents of the rotated rectangle's bounding box.
    const double ex = std::abs(hu * cs) + std::abs(hv * sn);
    const double ey = std::abs(hu * sn) + std::abs(hv * cs);
    return {pose.x_mm - ex, pose.x_mm + ex, pose.y_mm - ey, pose.y_mm + ey};
  }

  // Bilinear interpolation between pixel centres; pixel (r, c) is centred at
  // ((c + 0.5) s, (r + 0.5) s). Points within half a pixel of the border use the edge pixels.
  [[nodiscard]] float sample(double x_mm, double y_mm) const {
    const double u = std::clamp(x_mm / mm_per_px_ - 0.5, 0.0, static_cast<double>(map_.width - 1));
    const double v = std::clamp(y_mm / mm_per_px_ - 0.5, 0.0, static_cast<double>(map_.height - 1));
    const auto c0 = static_cast<Eigen::Index>(std::floor(u));
    const auto r0 = static_cast<Eigen::Index>(std::floor(v));
    const Eigen::Index c1 = std::min(c0 + 1, map_.width - 1);
    const Eigen::Index r1 = std::min(r0 + 1, map_.height - 1);
    const double fx = u - static_cast<double>(c0);
    const double fy = v - static_cast<double>(r0);
    const double top = (1.0 - fx) * relief_(r0, c0) + fx * relief_(r0, c1);
    const double bottom = (1.0 - fx) * relief_(r1, c0) + fx * relief_(r1, c1);
    return static_cast<float>((1.0 - fy) * top + fy * bottom);
  }

  image<float> relief_;
  pixel_size map_;
  double mm_per_px_;
  simulator_params params_;
  image<float> gain_;
  image<bool> dead_;
  sim_rng noise_rng_;
  sim_rng drift_rng_;
  sim_rng bump_rng_;
  image<float> baseline_;  // counts, the drifting zero of every taxel
  image<float> previous_;  // the previous frame's noiseless counts (hysteresis)
  std::uint32_t frames_ = 0;
};

}  // namespace tacmap
