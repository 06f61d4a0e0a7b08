// tacmap: simulation scenarios — what differs between a camera's picture of an object and the
// touch of it.
//
// The `ideal` scenario renders tactile frames from the very image the filter uses as its map:
// a binary relief pressed by a perfect sensor looks like a copy of the map, which flatters
// pixel matching (NCC). The paper's setup (Sec. IV) differs in ways no sensor noise captures:
//
//  * The map is a webcam image of the 3D print (Fig. 1), not its height map: the print's
//    colour and surface texture, uneven illumination, the side walls' shading under a light
//    that is not overhead, lens blur, sensor noise and the camera's tone curve.
//  * The object is registered to the map by a calibration (Sec. III-C assumes the transform is
//    known): it is off by a small shift and rotation, the same for every touch of a sequence.
//  * The sensor is carried by an arm whose "rotation and translation noises" the paper blames
//    for its two failures (Sec. IV-B): the array's in-plane orientation varies from touch to
//    touch, it is never exactly parallel to the surface, and it never presses equally hard.
//  * The sensor itself: more read-out noise, gain spread and dead cells than a new array, and a
//    foam cover that spreads load further (those are `simulator_params`; `realistic_sensor`).
//
// `scenario_params` holds the first three groups; `scenario_params::realistic()` and
// `realistic_sensor()` give values chosen from the physics of the paper's setup, each justified
// next to it, BEFORE measuring any model with them (README, "Localization results").
// Every effect is zero in the default (ideal) scenario, which leaves frames and maps
// bit-identical to a run without a scenario.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

#include "tacmap/image.hpp"
#include "tacmap/sim/random.hpp"
#include "tacmap/sim/tactile_simulator.hpp"

namespace tacmap {

/// Simulation scenario: how the camera's map, the object's registration and each press depart
/// from the ideal (see the file comment). All zero (ideal) by default.
struct scenario_params {
  // --- The visual map is a camera image (applied once per map, fixed by the seed) ---
  /// Multiplicative surface texture of the print (layer lines, filament colour, dust): relative
  /// standard deviation of the albedo.
  double albedo_variation = 0.0;
  /// Correlation length of that texture, map pixels (Gaussian sigma of smoothed white noise).
  double albedo_scale_px = 1.5;
  /// Illumination falloff across the map (lamp distance, vignetting): peak-to-peak relative
  /// change along a direction drawn from the seed.
  double illumination_gradient = 0.0;
  /// Fraction of the light that is directional (the rest ambient): the relief's walls facing
  /// the light are brighter, the others darker. 0 = fully diffuse light, no shading.
  double shading = 0.0;
  /// Elevation of the directional light above the map plane, degrees (90 = overhead, which
  /// shades only walls by their steepness); its azimuth is drawn from the seed.
  double light_elevation_deg = 60.0;
  /// Gaussian blur of the camera's optics and resampling to the map's scale, map pixels.
  double camera_blur_px = 0.0;
  /// Camera sensor noise, standard deviation in linear intensity units (of 1).
  double camera_noise = 0.0;
  /// Tone curve: the map stores linear intensity^(1 / camera_gamma) (sRGB ~ 2.2; 1 = linear).
  double camera_gamma = 1.0;

  // --- Registration of the object to the map (drawn once per sequence) ---
  /// Shift of the object against the map, mm (its direction is drawn per sequence).
  double registration_shift_mm = 0.0;
  /// Rotation of the object about the map's centre, degrees (its sign is drawn per sequence).
  double registration_rotation_deg = 0.0;

  // --- Each press (drawn per touch) ---
  /// Standard deviation of the array's in-plane orientation, degrees.
  double orientation_jitter_deg = 0.0;
  /// Standard deviation of the array's tilt about each of its axes, degrees.
  double tilt_jitter_deg = 0.0;
  /// Relative standard deviation of the press depth (force varies from press to press).
  double press_depth_jitter = 0.0;

  /// The scenario of the paper's setup; each value is argued in its comment.
  [[nodiscard]] static scenario_params realistic() {
    scenario_params s;
    // A matte PLA print seen by a webcam: layer lines and colour unevenness of a few percent;
    // the texture's grain is about the 1-2 mm of a print's layer/extrusion pattern.
    s.albedo_variation = 0.05;
    s.albedo_scale_px = 1.5;
    // A desk lamp or window light over a ~14 cm object plus webcam vignetting: 20 % from one
    // side of the map to the other is mild (vignetting alone reaches 30 % in the corners).
    s.illumination_gradient = 0.2;
    // Room light: about half ambient, half from one lamp 60 degrees up — the 4 mm walls of the
    // print show a bright and a dark side, as in any photograph of a relief.
    s.shading = 0.5;
    s.light_elevation_deg = 60.0;
    // A webcam's lens and the downsampling to 1.13 mm per px: about 0.7 px of blur.
    s.camera_blur_px = 0.7;
    // Indoor webcam noise after the sensor's own processing: ~1 % of full scale.
    s.camera_noise = 0.01;
    // Webcams deliver sRGB-encoded pixels: gamma 2.2.
    s.camera_gamma = 2.2;
    // Camera-to-arm calibration (checkerboard, ~0.5 px reprojection error at ~0.5 mm per
    // camera px) plus placing the print: ~1 mm and ~1 degree.
    s.registration_shift_mm = 1.0;
    s.registration_rotation_deg = 1.0;
    // The array on the Phantom's stylus twists as the foam settles and the gimbal turns: the
    // paper names rotation noise as its failure cause; 3 degrees moves the array's ends by
    // ~1.2 mm, about one map pixel.
    s.orientation_jitter_deg = 3.0;
    // Held normal by eye: 0.5 degrees over the 47.6 mm array is 0.4 mm of height difference,
    // under half the 1 mm press.
    s.tilt_jitter_deg = 0.5;
    // Position-controlled press on a compliant foam: the depth reached varies by ~20 %.
    s.press_depth_jitter = 0.2;
    return s;
  }

  /// True when some camera effect is on (the map differs from the protocol's image).
  [[nodiscard]] bool changes_map() const {
    return albedo_variation > 0.0 || illumination_gradient > 0.0 || shading > 0.0 ||
           camera_blur_px > 0.0 || camera_noise > 0.0 || camera_gamma != 1.0;
  }
  /// True when the sensor's pose or press departs from the protocol's.
  [[nodiscard]] bool moves_sensor() const {
    return registration_shift_mm > 0.0 || registration_rotation_deg > 0.0 ||
           orientation_jitter_deg > 0.0 || tilt_jitter_deg > 0.0 || press_depth_jitter > 0.0;
  }

  void validate() const {
    const auto in = [](const char* name, double value, double lo, double hi, const char* hint) {
      if (!(std::isfinite(value) && value >= lo && value <= hi))
        detail::fail("scenario_params: ", name, " = ", value, "; expected ", lo, " .. ", hi, hint);
    };
    in("albedo_variation", albedo_variation, 0.0, 1.0, " (relative, e.g. 0.05 for 5 %)");
    in("albedo_scale_px", albedo_scale_px, 0.0, 100.0, " map pixels");
    in("illumination_gradient", illumination_gradient, 0.0, 1.9,
       " (peak-to-peak relative change, e.g. 0.2)");
    in("shading", shading, 0.0, 1.0, " (fraction of directional light; 0 = diffuse)");
    in("light_elevation_deg", light_elevation_deg, 1.0, 90.0, " degrees above the map plane");
    in("camera_blur_px", camera_blur_px, 0.0, 100.0, " map pixels (Gaussian sigma)");
    in("camera_noise", camera_noise, 0.0, 1.0, " (standard deviation, intensity of 1)");
    in("camera_gamma", camera_gamma, 0.1, 10.0, " (2.2 for sRGB, 1 for linear)");
    in("registration_shift_mm", registration_shift_mm, 0.0, 50.0, " millimetres");
    in("registration_rotation_deg", registration_rotation_deg, 0.0, 45.0, " degrees");
    in("orientation_jitter_deg", orientation_jitter_deg, 0.0, 45.0,
       " degrees (standard deviation)");
    in("tilt_jitter_deg", tilt_jitter_deg, 0.0, 5.0, " degrees (standard deviation)");
    in("press_depth_jitter", press_depth_jitter, 0.0, 1.0,
       " (relative standard deviation, e.g. 0.2)");
  }
};

/// The sensor of the realistic scenario: the paper's array after use, not a new one. Starts
/// from `base` (geometry, press depth, seed) and replaces the imperfections.
[[nodiscard]] inline simulator_params realistic_sensor(simulator_params base = {}) {
  // Resistive arrays read with ~1 % of full scale noise under load (40 of 4095 counts).
  base.noise_counts = 40.0;
  // Cell-to-cell sensitivity of resistive arrays varies by 10-20 % without calibration.
  base.gain_variation = 0.10;
  // A used 84-cell array typically has a cell or two that no longer respond: 2 of 84.
  base.dead_fraction = 0.025;
  // The foam cover is a few mm thick and spreads a point load over about its thickness:
  // 2.5 mm, three quarters of a pitch (the ideal sensor: half a pitch).
  base.foam_sigma_mm = 2.5;
  return base;
}

/// The named scenarios of tacmap-evaluate's --scenario.
enum class scenario_kind { ideal, realistic };

[[nodiscard]] inline const char* to_string(scenario_kind k) {
  return k == scenario_kind::ideal ? "ideal" : "realistic";
}

/// What the camera sees of an object whose printed colour is `map` (intensities in [0, 1]) and
/// whose height is `relief_mm` (same size, mm), at `mm_per_px`: albedo texture x illumination x
/// shading, then blur, noise and the tone curve, clamped to [0, 1]. Deterministic for `seed`.
/// Returns `map` unchanged when `!params.changes_map()`.
[[nodiscard]] inline image<float> camera_image(const image<float>& map,
                                               const image<float>& relief_mm, double mm_per_px,
                                               const scenario_params& params, std::uint64_t seed) {
  params.validate();
  if (relief_mm.rows() != map.rows() || relief_mm.cols() != map.cols())
    detail::fail("camera_image: the relief is ", relief_mm.cols(), " x ", relief_mm.rows(),
                 " px (width x height) but the map is ", map.cols(), " x ", map.rows(),
                 " px; expected one height per map pixel");
  if (!(std::isfinite(mm_per_px) && mm_per_px > 0.0))
    detail::fail("camera_image: mm_per_px = ", mm_per_px,
                 "; expected the map's scale, a finite value > 0 millimetres per pixel");
  if (!params.changes_map()) return map;
  std::uint64_t s = seed;
  sim_rng texture_rng(splitmix64(s));
  sim_rng light_rng(splitmix64(s));
  sim_rng noise_rng(splitmix64(s));
  const Eigen::Index rows = map.rows();
  const Eigen::Index cols = map.cols();

  // Albedo texture: smoothed white noise rescaled to unit standard deviation.
  image<float> texture(rows, cols);
  for (Eigen::Index i = 0; i < texture.size(); ++i)
    texture.data()[i] = static_cast<float>(texture_rng.normal());
  detail::simulation::gaussian_blur(texture, params.albedo_scale_px);
  const double mean = texture.cast<double>().mean();
  const double sd = std::sqrt((texture.cast<double>() - mean).square().mean());
  const double texture_gain = sd > 0.0 ? params.albedo_variation / sd : 0.0;

  const double pi = std::numbers::pi;
  const double gradient_angle = 2.0 * pi * light_rng.uniform();
  const double azimuth = 2.0 * pi * light_rng.uniform();
  const double elevation = params.light_elevation_deg * pi / 180.0;
  const double lx = std::cos(elevation) * std::cos(azimuth);
  const double ly = std::cos(elevation) * std::sin(azimuth);
  const double lz = std::sin(elevation);
  const auto height = [&](Eigen::Index r, Eigen::Index c) {
    return static_cast<double>(relief_mm(std::clamp<Eigen::Index>(r, 0, rows - 1),
                                         std::clamp<Eigen::Index>(c, 0, cols - 1)));
  };
  image<float> out(rows, cols);
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index c = 0; c < cols; ++c) {
      const double albedo = static_cast<double>(map(r, c)) *
                            std::max(0.0, 1.0 + texture_gain * (texture(r, c) - mean));
      // Position in [-0.5, 0.5] along the gradient's direction (a unit square's projection).
      const double x = (static_cast<double>(c) + 0.5) / static_cast<double>(cols) - 0.5;
      const double y = (static_cast<double>(r) + 0.5) / static_cast<double>(rows) - 0.5;
      const double along =
          (x * std::cos(gradient_angle) + y * std::sin(gradient_angle)) / std::sqrt(2.0);
      const double illumination = 1.0 + params.illumination_gradient * along;
      // Lambertian shading of the surface normal, relative to a flat surface (flat = 1).
      const double gx = (height(r, c + 1) - height(r, c - 1)) / (2.0 * mm_per_px);
      const double gy = (height(r + 1, c) - height(r - 1, c)) / (2.0 * mm_per_px);
      const double n_dot_l = (-gx * lx - gy * ly + lz) / std::sqrt(1.0 + gx * gx + gy * gy);
      const double shade = (1.0 - params.shading) + params.shading * std::max(0.0, n_dot_l) / lz;
      out(r, c) = static_cast<float>(albedo * illumination * shade);
    }
  detail::simulation::gaussian_blur(out, params.camera_blur_px);
  for (Eigen::Index i = 0; i < out.size(); ++i) {
    const double linear = std::clamp(
        static_cast<double>(out.data()[i]) + params.camera_noise * noise_rng.normal(), 0.0, 1.0);
    out.data()[i] = static_cast<float>(std::pow(linear, 1.0 / params.camera_gamma));
  }
  return out;
}

}  // namespace tacmap
