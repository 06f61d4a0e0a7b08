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
// Beyond the paper's gecko (a light print raised over a dark base): a photograph does not say
// how an object's brightness relates to its height. A tactile image measures height, a photo
// albedo x illumination, and the relation between them is the object's own:
//
//  * Raised parts may be brighter (the gecko) or darker (black rubber letters on white card,
//    dark coins on a light tray) than their surroundings: `polarity`, and `object_relief`,
//    which builds the pressed relief from the photo under either sign.
//  * Both within one object (a two-tone moulded part, a label over part of a relief):
//    `mixed_polarity`.
//  * Ink printed on a flat face has edges in the photo and none under the finger:
//    `ink_coverage`, `ink_contrast` (camera map only, never the relief).
//  * A relief of one colour shows only through its shading: `albedo_contrast`.
//
// `scenario_params` holds these groups; `scenario_params::realistic()`,
// `scenario_params::unknown_object()` and `realistic_sensor()` give values chosen from the
// physics of the setup, each justified next to it, BEFORE measuring any model with them
// (README, "Localization results"). Every effect is zero in the default (ideal) scenario, which
// leaves frames and maps bit-identical to a run without a scenario.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <vector>

#include "tacmap/image.hpp"
#include "tacmap/sim/random.hpp"
#include "tacmap/sim/tactile_simulator.hpp"

namespace tacmap {

/// How the object's height shows in its photograph (see the file comment).
enum class relief_polarity {
  bright_raised,  ///< "bright": raised parts are brighter than their surroundings (the gecko)
  dark_raised,    ///< "dark": raised parts are darker (black letters on white card)
  random,         ///< "random": either, drawn per sequence by the experiment (an unknown object)
};

/// The names tacmap-evaluate's --polarity takes.
[[nodiscard]] inline const char* to_string(relief_polarity p) {
  switch (p) {
    case relief_polarity::bright_raised:
      return "bright";
    case relief_polarity::dark_raised:
      return "dark";
    case relief_polarity::random:
      return "random";
  }
  return "?";
}

/// Simulation scenario: how the camera's map, the object's relief and registration, and each
/// press depart from the ideal (see the file comment). Every effect off (ideal) by default.
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
  /// Printed ink unrelated to height (text, logos, markings): the fraction of the map's area
  /// covered by random strokes (5-30 px long, 1-3 px wide, random direction), fixed by the
  /// seed. Changes the camera map's albedo only: ink has photo edges and no touch edges.
  double ink_coverage = 0.0;
  /// Opacity of that ink: half the strokes pull the albedo towards black, half towards white,
  /// by this fraction (1 = opaque black or white ink).
  double ink_contrast = 0.5;
  /// How much of the protocol image's brightness variation the object's albedo keeps:
  /// albedo = mean + albedo_contrast x (image - mean). 0 = an object of one colour, whose
  /// relief shows in the photo only through shading.
  double albedo_contrast = 1.0;
  /// A cast shadow (the arm, the camera, a lamp's shade) over part of the map: the light
  /// falling there is reduced by this fraction. The shadow's straight edge crosses the map in
  /// a direction drawn from the seed and it covers 20-40 % of the map. 0 = no shadow.
  double shadow_depth = 0.0;
  /// Width of the shadow's penumbra, map pixels (Gaussian sigma of its edge).
  double shadow_edge_px = 3.0;
  /// Defocus: the camera focused off the object's face blurs with a disc (circle of confusion)
  /// of this radius, map pixels, on top of `camera_blur_px`'s Gaussian. 0 = in focus.
  double defocus_px = 0.0;

  // --- The map's scale (drawn once per sequence) ---
  /// Relative error of the map's scale: the object is (1 +- map_scale_error) times the size
  /// the map's mm_per_px says (sign drawn per sequence). The sensor then covers 1 / (1 +- e) of
  /// the map pixels it should, and the arm's odometry, exact in mm, is off by e of every move
  /// in the map's units. 0 = the scale is exact.
  double map_scale_error = 0.0;

  // --- How the relief relates to the photo's brightness (object_relief) ---
  /// Whether raised parts are brighter or darker than their surroundings, or either per
  /// sequence. bright_raised keeps the relief the protocol's (`relief_from_image` of the map).
  relief_polarity polarity = relief_polarity::bright_raised;
  /// Fraction of the map's area, in smooth random regions fixed per map by the seed, where the
  /// height-brightness relation is the opposite of the sequence's polarity (a two-tone part).
  double mixed_polarity = 0.0;

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
  /// Fraction of presses that are light: the array only brushes the relief, at
  /// `light_press_scale` of the press depth (a cautious controller, a soft object).
  double light_press_fraction = 0.0;
  /// Depth of a light press relative to the nominal one.
  double light_press_scale = 0.3;
  /// Fraction of presses that are partial: the array lands tilted by `partial_press_tilt_deg`
  /// about a random in-plane axis, so only part of it meets the relief (the edge of an object,
  /// a wrist that does not comply).
  double partial_press_fraction = 0.0;
  /// Tilt of a partial press, degrees (2 degrees over the 47.6 mm array is 1.7 mm: with the
  /// 1 mm press, about a third of the array stays off the surface).
  double partial_press_tilt_deg = 2.0;

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

  /// A photograph of an object we know nothing about: the realistic scenario, plus the ways the
  /// object's height may relate to its picture. Values argued before any measurement.
  [[nodiscard]] static scenario_params unknown_object() {
    scenario_params s = realistic();
    // A photo alone does not tell whether raised parts are lighter (a light print on a dark
    // base) or darker (dark rubber or embossed letters on a light card) — both are common, so
    // each sequence's object is either, with equal odds.
    s.polarity = relief_polarity::random;
    // Many objects are two-tone somewhere: a light moulded case with dark rubber keys or feet,
    // a contrasting inlay, a label stuck over part of a relief. A fifth of the area is a
    // noticeable minority, not so much that the "opposite" relation becomes the main one.
    s.mixed_polarity = 0.2;
    // Printed text, logos and markings typically cover a few percent of a product's face (a
    // logo and a line of text on a ~14 cm object: ~5 %). Mid-tone print on a coloured body is
    // more common than pure black on white: 40 % of the way to black or white.
    s.ink_coverage = 0.05;
    s.ink_contrast = 0.4;
    // The object's colours keep their full contrast: an object of one colour (relief seen only
    // through shading) is a different question — can a photo show the relief at all — which
    // --albedo-contrast asks separately; mixing it in would confound it with polarity.
    s.albedo_contrast = 1.0;
    return s;
  }

  /// The conditions a lab has (issue 34): everything of `unknown_object()`, a worse camera (a
  /// cast shadow, defocus, a stronger gradient), a map scale known to a few percent, light and
  /// partial presses. Use with `harsh_sensor()`. Every value is argued in docs/simulator.md.
  [[nodiscard]] static scenario_params harsh() {
    scenario_params s = unknown_object();
    // A bench lamp to one side plus vignetting: 40 % across the map (the realistic 20 % is a
    // well-lit desk).
    s.illumination_gradient = 0.4;
    // The arm or the camera itself shades part of the object: a shadow taking 40 % of the
    // light (an ambient-lit shadow in a room is 30-60 % darker).
    s.shadow_depth = 0.4;
    s.shadow_edge_px = 3.0;
    // A webcam at 30-50 cm with fixed focus, object a few cm off the focal plane: a circle of
    // confusion of about 1.5 map px (1.7 mm) radius.
    s.defocus_px = 1.5;
    // The map's scale from a ruler in the picture or the camera's calibration at an assumed
    // distance: 3 % (1.5 cm of a 50 cm working distance).
    s.map_scale_error = 0.03;
    // A position-controlled press on an unknown object: one press in five barely touches
    // (30 % of the depth), one in five lands tilted by 2 degrees.
    s.light_press_fraction = 0.2;
    s.light_press_scale = 0.3;
    s.partial_press_fraction = 0.2;
    s.partial_press_tilt_deg = 2.0;
    return s;
  }

  /// True when some camera effect is on (the map differs from the protocol's image).
  [[nodiscard]] bool changes_map() const {
    return albedo_variation > 0.0 || illumination_gradient > 0.0 || shading > 0.0 ||
           camera_blur_px > 0.0 || camera_noise > 0.0 || camera_gamma != 1.0 ||
           ink_coverage > 0.0 || albedo_contrast != 1.0 || shadow_depth > 0.0 || defocus_px > 0.0;
  }
  /// True when the relief pressed may differ from the protocol's (`relief_from_image` of the
  /// map): raised parts darker (always or per sequence), or mixed-polarity regions.
  [[nodiscard]] bool changes_relief() const {
    return polarity != relief_polarity::bright_raised || mixed_polarity > 0.0;
  }
  /// True when the sensor's pose or press departs from the protocol's.
  [[nodiscard]] bool moves_sensor() const {
    return registration_shift_mm > 0.0 || registration_rotation_deg > 0.0 ||
           orientation_jitter_deg > 0.0 || tilt_jitter_deg > 0.0 || press_depth_jitter > 0.0 ||
           map_scale_error > 0.0 || light_press_fraction > 0.0 || partial_press_fraction > 0.0;
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
    in("ink_coverage", ink_coverage, 0.0, 1.0,
       " (fraction of the map's area covered by ink strokes, e.g. 0.05)");
    in("ink_contrast", ink_contrast, 0.0, 1.0, " (ink opacity towards black or white; 1 = opaque)");
    in("albedo_contrast", albedo_contrast, 0.0, 1.0,
       " (fraction of the image's brightness variation the albedo keeps; 1 = all)");
    if (polarity != relief_polarity::bright_raised && polarity != relief_polarity::dark_raised &&
        polarity != relief_polarity::random)
      detail::fail("scenario_params: polarity = ", static_cast<int>(polarity),
                   "; expected relief_polarity::bright_raised, dark_raised or random");
    in("mixed_polarity", mixed_polarity, 0.0, 1.0,
       " (fraction of the map's area with the opposite polarity, e.g. 0.2)");
    in("registration_shift_mm", registration_shift_mm, 0.0, 50.0, " millimetres");
    in("registration_rotation_deg", registration_rotation_deg, 0.0, 45.0, " degrees");
    in("orientation_jitter_deg", orientation_jitter_deg, 0.0, 45.0,
       " degrees (standard deviation)");
    in("tilt_jitter_deg", tilt_jitter_deg, 0.0, 5.0, " degrees (standard deviation)");
    in("press_depth_jitter", press_depth_jitter, 0.0, 1.0,
       " (relative standard deviation, e.g. 0.2)");
    in("shadow_depth", shadow_depth, 0.0, 1.0,
       " (fraction of the light the shadow takes; 0 = no shadow)");
    in("shadow_edge_px", shadow_edge_px, 0.0, 100.0, " map pixels (Gaussian sigma of the edge)");
    in("defocus_px", defocus_px, 0.0, 50.0, " map pixels (radius of the defocus disc)");
    in("map_scale_error", map_scale_error, 0.0, 0.3,
       " (relative error of the map's scale, e.g. 0.03 for 3 %)");
    in("light_press_fraction", light_press_fraction, 0.0, 1.0, " (fraction of presses)");
    in("light_press_scale", light_press_scale, 0.0, 1.0,
       " (depth of a light press relative to the nominal one)");
    in("partial_press_fraction", partial_press_fraction, 0.0, 1.0, " (fraction of presses)");
    in("partial_press_tilt_deg", partial_press_tilt_deg, 0.0, 20.0,
       " degrees (tilt of a partial press)");
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

/// The sensor of the harsh scenario (issue 34): a worn array in a lab that is not climate
/// controlled. Starts from `base` and replaces the imperfections; each level is argued in
/// docs/simulator.md.
[[nodiscard]] inline simulator_params harsh_sensor(simulator_params base = {}) {
  base = realistic_sensor(base);
  // 5 % of full scale noise (200 of 4095): a worn cell under a compressed foam.
  base.noise_counts = 200.0;
  // Uncalibrated resistive cells after use: +-30 % (a standard deviation of 15 %).
  base.gain_variation = 0.15;
  // 10 % dead cells: 8 of 84, an array with a torn trace or a delaminated corner.
  base.dead_fraction = 0.1;
  // The foam cover spreads a point load over one pitch.
  base.foam_sigma_mm = 3.4;
  // The resistive response flattens well below the ADC's 4095: the DSA pads of the Schunk hand
  // top out near 3500 counts; the curve bends from about 3000.
  base.saturation_counts = 3000.0;
  // Piezoresistive foam keeps 5-10 % of a press after release (FSR hysteresis is 10-20 % of
  // full scale): 8 % of the previous frame persists.
  base.hysteresis = 0.08;
  // Baseline drift with temperature and creep: a standard deviation of 20 counts (0.5 % of
  // full scale) per frame, a random walk that reaches ~60 counts over ten touches.
  base.baseline_drift_counts = 20.0;
  return base;
}

/// The named scenarios of tacmap-evaluate's --scenario.
enum class scenario_kind {
  ideal,      ///< "ideal": scenario_params{}, the paper's sensor new
  realistic,  ///< "realistic": scenario_params::realistic(), realistic_sensor()
  unknown,    ///< "unknown": scenario_params::unknown_object(), realistic_sensor()
  harsh,      ///< "harsh": scenario_params::harsh(), harsh_sensor() (issue 34)
};

[[nodiscard]] inline const char* to_string(scenario_kind k) {
  switch (k) {
    case scenario_kind::ideal:
      return "ideal";
    case scenario_kind::realistic:
      return "realistic";
    case scenario_kind::unknown:
      return "unknown";
    case scenario_kind::harsh:
      return "harsh";
  }
  return "?";
}

namespace detail::simulation {

/// Smooth random weight in [0, 1] per pixel, about `fraction` of the area near 1 and the rest
/// near 0, deterministic for `seed`: the regions of opposite polarity.
inline image<float> mixed_polarity_weight(Eigen::Index rows, Eigen::Index cols, double fraction,
                                          std::uint64_t seed) {
  // Regions of about 15-30 px (17-34 mm at the paper's 1.13 mm per px): the size of a label, a
  // button or an inlay, comparable to the 48 x 20 mm array, so a touch may straddle one.
  constexpr double region_sigma_px = 6.0;
  // Transitions over ~4 px: a moulded or printed boundary is sharp, but a hard step in the
  // weight would be a relief edge where the object has none.
  constexpr double transition_sigma_px = 1.5;
  if (rows <= 0 || cols <= 0) return image<float>(rows, cols);
  // Noise on a padded field, cropped: the blur's renormalised border taps would otherwise give
  // border pixels a larger spread and so more of the extreme values the quantile picks.
  const auto pad = static_cast<Eigen::Index>(std::ceil(3.0 * region_sigma_px));
  std::uint64_t s = seed ^ 0x4D49584544504F4CULL;  // own stream, apart from camera_image's
  sim_rng rng(splitmix64(s));
  image<float> noise(rows + 2 * pad, cols + 2 * pad);
  for (Eigen::Index i = 0; i < noise.size(); ++i)
    noise.data()[i] = static_cast<float>(rng.normal());
  gaussian_blur(noise, region_sigma_px);
  const image<float> field = noise.block(pad, pad, rows, cols);
  // Threshold at the quantile that leaves `fraction` of the pixels above it.
  const auto n = static_cast<std::size_t>(field.size());
  const auto flipped = static_cast<std::size_t>(std::llround(fraction * static_cast<double>(n)));
  image<float> weight = image<float>::Zero(rows, cols);
  if (flipped >= n) {
    weight.setOnes();
  } else if (flipped > 0) {
    std::vector<float> values(field.data(), field.data() + field.size());
    const auto kth = values.begin() + static_cast<std::ptrdiff_t>(n - flipped);
    std::nth_element(values.begin(), kth, values.end());
    const float threshold = *kth;  // the smallest of the `flipped` largest values
    weight = (field >= threshold).cast<float>();
  }
  gaussian_blur(weight, transition_sigma_px);
  return weight;
}

/// Printed ink strokes covering `coverage` of a rows x cols map: per pixel -1 (no ink), 0 (dark
/// ink) or 1 (light ink). Strokes are drawn from `rng` until the coverage is reached.
inline image<float> ink_layer(Eigen::Index rows, Eigen::Index cols, double coverage, sim_rng& rng) {
  // Strokes of text, logos and markings at the paper's 1.13 mm per px: 6-34 mm long, 1-3 mm
  // wide.
  constexpr double min_length_px = 5.0, max_length_px = 30.0;
  constexpr double min_width_px = 1.0, max_width_px = 3.0;
  image<float> ink = image<float>::Constant(rows, cols, -1.0F);
  const double target = coverage * static_cast<double>(ink.size());
  if (!(target > 0.0)) return ink;
  // Centres also fall up to half a stroke beyond the map, so that the border is inked as often
  // as the middle.
  const double margin = max_length_px / 2.0;
  // Enough strokes to cover the map many times over: only reached for coverage ~ 1 on a tiny
  // map, where stopping a few pixels short is harmless, but a loop must end.
  const double max_strokes = 1000.0 * (static_cast<double>(ink.size()) + 4.0 * margin * margin);
  double covered = 0.0;
  for (double stroke = 0.0; covered < target && stroke < max_strokes; stroke += 1.0) {
    const double cx = -margin + (static_cast<double>(cols) + 2.0 * margin) * rng.uniform();
    const double cy = -margin + (static_cast<double>(rows) + 2.0 * margin) * rng.uniform();
    const double length = min_length_px + (max_length_px - min_length_px) * rng.uniform();
    const double half_width = 0.5 * (min_width_px + (max_width_px - min_width_px) * rng.uniform());
    const double angle = std::numbers::pi * rng.uniform();
    // Alternately dark and light: half the strokes each, whatever their number.
    const float colour = std::fmod(stroke, 2.0) == 0.0 ? 0.0F : 1.0F;
    const double dx = 0.5 * length * std::cos(angle), dy = 0.5 * length * std::sin(angle);
    // Pixels (centres at integer coordinates) within half the width of the segment.
    const double reach = 0.5 * length + half_width;
    const auto r0 = std::max<Eigen::Index>(0, static_cast<Eigen::Index>(std::floor(cy - reach)));
    const auto r1 =
        std::min<Eigen::Index>(rows - 1, static_cast<Eigen::Index>(std::ceil(cy + reach)));
    const auto c0 = std::max<Eigen::Index>(0, static_cast<Eigen::Index>(std::floor(cx - reach)));
    const auto c1 =
        std::min<Eigen::Index>(cols - 1, static_cast<Eigen::Index>(std::ceil(cx + reach)));
    for (Eigen::Index r = r0; r <= r1; ++r)
      for (Eigen::Index c = c0; c <= c1; ++c) {
        const double px = static_cast<double>(c) - cx, py = static_cast<double>(r) - cy;
        // Projection onto the segment from -1 (one end) to 1 (the other), clamped.
        const double t = std::clamp((px * dx + py * dy) / (dx * dx + dy * dy), -1.0, 1.0);
        if (std::hypot(px - t * dx, py - t * dy) > half_width) continue;
        if (ink(r, c) < 0.0F) covered += 1.0;
        ink(r, c) = colour;  // a later stroke prints over an earlier one
      }
  }
  return ink;
}

/// Where a cast shadow falls: per pixel in [0, 1] (1 = fully in the shadow). A straight edge
/// in a direction drawn from `rng`, placed so that 20-40 % of the map (also drawn) lies beyond
/// it, softened by a Gaussian penumbra of `edge_px`.
inline image<float> shadow_weight(Eigen::Index rows, Eigen::Index cols, double edge_px,
                                  sim_rng& rng) {
  const double angle = 2.0 * std::numbers::pi * rng.uniform();
  const double coverage = 0.2 + 0.2 * rng.uniform();
  image<double> along(rows, cols);
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index c = 0; c < cols; ++c)
      along(r, c) =
          static_cast<double>(c) * std::cos(angle) + static_cast<double>(r) * std::sin(angle);
  std::vector<double> sorted(along.data(), along.data() + along.size());
  if (sorted.empty()) return image<float>(rows, cols);
  const auto kth = static_cast<std::ptrdiff_t>(
      std::llround((1.0 - coverage) * static_cast<double>(sorted.size() - 1)));
  std::nth_element(sorted.begin(), sorted.begin() + kth, sorted.end());
  const double edge = sorted[static_cast<std::size_t>(kth)];
  image<float> w(rows, cols);
  for (Eigen::Index i = 0; i < w.size(); ++i) {
    const double d = along.data()[i] - edge;
    w.data()[i] = edge_px > 0.0
                      ? static_cast<float>(0.5 * std::erfc(-d / (edge_px * std::sqrt(2.0))))
                      : (d > 0.0 ? 1.0F : 0.0F);
  }
  return w;
}

/// Disc (pillbox) blur of radius `radius` pixels in place: a defocused lens's circle of
/// confusion. Taps falling outside the image are dropped and the rest renormalised, as
/// `gaussian_blur`. Radius 0 leaves the image as it is.
inline void disc_blur(image<float>& values, double radius) {
  if (!(radius > 0.0)) return;
  const auto reach = static_cast<Eigen::Index>(std::floor(radius));
  std::vector<std::pair<Eigen::Index, Eigen::Index>> taps;
  for (Eigen::Index dy = -reach; dy <= reach; ++dy)
    for (Eigen::Index dx = -reach; dx <= reach; ++dx)
      if (static_cast<double>(dx * dx + dy * dy) <= radius * radius) taps.emplace_back(dy, dx);
  const image<float> in = values;
  for (Eigen::Index r = 0; r < in.rows(); ++r)
    for (Eigen::Index c = 0; c < in.cols(); ++c) {
      double sum = 0.0;
      double n = 0.0;
      for (const auto& [dy, dx] : taps) {
        const Eigen::Index rr = r + dy, cc = c + dx;
        if (rr < 0 || rr >= in.rows() || cc < 0 || cc >= in.cols()) continue;
        sum += static_cast<double>(in(rr, cc));
        n += 1.0;
      }
      values(r, c) = static_cast<float>(sum / n);
    }
}

}  // namespace detail::simulation

/// The object's height (mm) for a photo `map` (intensities in [0, 1]) under `relief` (how
/// intensity becomes height: protocol's relief_params), with raised parts brighter (sign = +1)
/// or darker (sign = -1) than their surroundings, plus the scenario's mixed-polarity regions
/// (fixed by `seed`).
///
/// Sign -1 presses the inverted image (1 - map) through the same `relief_from_image`. In the
/// mixed regions the weight w in [0, 1] blends the two: relief = w R(opposite) + (1 - w)
/// R(this sign). Where w is near 0.5, on the regions' borders, the two average out (to half the
/// height for a binary or continuous relief, whose two signs sum to height_mm): the relief
/// flattens while the photo keeps its edges — albedo edges with no relief edge, as ink makes.
/// Sign +1 without mixed polarity is exactly `relief_from_image(map, relief)`.
/// Throws std::invalid_argument for a sign other than +1 or -1, out-of-range scenario values,
/// or what `relief_from_image` rejects.
[[nodiscard]] inline image<float> object_relief(const image<float>& map,
                                                const relief_params& relief,
                                                const scenario_params& s, int sign,
                                                std::uint64_t seed) {
  s.validate();
  if (sign != 1 && sign != -1)
    detail::fail("object_relief: sign = ", sign,
                 "; expected +1 (raised parts brighter than their surroundings) or -1 (darker)");
  const auto under = [&](int polarity_sign) {
    return polarity_sign > 0 ? relief_from_image(map, relief)
                             : relief_from_image(image<float>(1.0F - map), relief);
  };
  image<float> own = under(sign);
  if (!(s.mixed_polarity > 0.0)) return own;
  const image<float> opposite = under(-sign);
  const image<float> w =
      detail::simulation::mixed_polarity_weight(map.rows(), map.cols(), s.mixed_polarity, seed);
  return (w.cast<double>() * opposite.cast<double>() +
          (1.0 - w.cast<double>()) * own.cast<double>())
      .cast<float>();
}

/// What the camera sees of an object whose printed colour is `map` (intensities in [0, 1]) and
/// whose height is `relief_mm` (same size, mm), at `mm_per_px`: the albedo (the map's contrast
/// scaled by `albedo_contrast`, printed ink over it, times the surface texture) x illumination
/// x shading, then blur, noise and the tone curve, clamped to [0, 1]. Deterministic for
/// `seed`. Returns `map` unchanged when `!params.changes_map()`.
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
  sim_rng ink_rng(splitmix64(s));  // drawn after the others: their streams stay as they were
  sim_rng shadow_rng(splitmix64(s));
  const Eigen::Index rows = map.rows();
  const Eigen::Index cols = map.cols();

  // The object's own colour before texture: the map's contrast scaled about its mean, with ink
  // printed over it (ink of opacity ink_contrast, black or white, over whatever is beneath).
  // Without either effect it is the map itself, so the realistic scenario's maps stay
  // bit-identical.
  image<double> base = map.cast<double>();
  if (params.albedo_contrast != 1.0) {
    const double map_mean = base.mean();
    base = map_mean + params.albedo_contrast * (base - map_mean);
  }
  if (params.ink_coverage > 0.0) {
    const image<float> ink =
        detail::simulation::ink_layer(rows, cols, params.ink_coverage, ink_rng);
    for (Eigen::Index i = 0; i < base.size(); ++i)
      if (const float colour = ink.data()[i]; colour >= 0.0F)
        base.data()[i] = (1.0 - params.ink_contrast) * base.data()[i] +
                         params.ink_contrast * static_cast<double>(colour);
  }

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
      const double albedo = base(r, c) * std::max(0.0, 1.0 + texture_gain * (texture(r, c) - mean));
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
  if (params.shadow_depth > 0.0)
    out = (out.cast<double>() *
           (1.0 - params.shadow_depth * detail::simulation::shadow_weight(
                                            rows, cols, params.shadow_edge_px, shadow_rng)
                                            .cast<double>()))
              .cast<float>();
  detail::simulation::gaussian_blur(out, params.camera_blur_px);
  detail::simulation::disc_blur(out, params.defocus_px);
  for (Eigen::Index i = 0; i < out.size(); ++i) {
    const double linear = std::clamp(
        static_cast<double>(out.data()[i]) + params.camera_noise * noise_rng.normal(), 0.0, 1.0);
    out.data()[i] = static_cast<float>(std::pow(linear, 1.0 / params.camera_gamma));
  }
  return out;
}

}  // namespace tacmap
