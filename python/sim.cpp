// tacmap's Python module: simulation — the tactile simulator, the scenarios that make it
// realistic, touch protocols and the evaluation's experiment (C++ include/tacmap/sim/).
#include "bindings.hpp"
// (bindings.hpp first: it defines TACMAP_ASSERT for the tacmap headers below.)

#include <mutex>

#include "tacmap/sim/experiment.hpp"
#include "tacmap/sim/faults.hpp"
#include "tacmap/sim/protocol.hpp"
#include "tacmap/sim/scenario.hpp"
#include "tacmap/sim/tactile_simulator.hpp"

namespace tacmap::python {

namespace {

const choices<relief_kind> relief_names = {{"binary", relief_kind::binary},
                                           {"continuous", relief_kind::continuous}};
const choices<fault_oracle> oracle_names = {{"none", fault_oracle::none},
                                            {"transition", fault_oracle::transition},
                                            {"told", fault_oracle::told}};
const choices<relief_polarity> polarity_names = {{"bright", relief_polarity::bright_raised},
                                                 {"dark", relief_polarity::dark_raised},
                                                 {"random", relief_polarity::random}};
const choices<frame_rejection> rejection_names = {{"none", frame_rejection::none},
                                                  {"weak_peak", frame_rejection::weak_peak},
                                                  {"weak_total", frame_rejection::weak_total},
                                                  {"flat", frame_rejection::flat}};

// An experiment and the lock that serialises its runs (the GIL is released while it runs).
struct py_experiment {
  py_experiment(const touch_protocol& p, localization_config config)
      : protocol(&p), impl(p, std::move(config)) {}
  const touch_protocol* protocol;  // kept alive by the Python object (keep_alive)
  localization_experiment impl;
  std::mutex mutex;
};

// A LocalizationConfig, or a LocalizerConfig with the simulated world's defaults around it.
localization_config experiment_config(const py::object& config) {
  if (config.is_none()) return {};
  if (py::isinstance<localization_config>(config)) return config.cast<localization_config>();
  if (py::isinstance<localizer_config>(config)) {
    localization_config c;
    static_cast<localizer_config&>(c) = config.cast<localizer_config>();
    return c;
  }
  throw py::type_error("Experiment: config is a " +
                       std::string(py::str(py::type::of(config).attr("__name__"))) +
                       "; expected None, a LocalizationConfig or a LocalizerConfig");
}

press_variation press_of(double depth_scale, double tilt_u_rad, double tilt_v_rad) {
  return {.depth_scale = depth_scale, .tilt_u_rad = tilt_u_rad, .tilt_v_rad = tilt_v_rad};
}

py::list images_of(const std::vector<image<float>>& images) {
  py::list out;
  for (const auto& img : images) {
    if (img.size() == 0)
      out.append(py::none());
    else
      out.append(to_numpy(img));
  }
  return out;
}

constexpr const char* experiment_doc = R"doc(One map and one configuration of the paper's evaluation
(C++ tacmap::localization_experiment): the filter, with its measurement model built once, and the
simulator's relief. `run(k)` replays sequence k of the protocol from a uniform belief: at every
step the simulator renders a noisy frame at the TRUE location, the filter predicts with the
MEASURED odometry (what the arm reported) and updates with the frame; the truth only scores the
estimate. A scenario (LocalizationConfig.scenario) makes the run realistic: the model matches
against a camera image of the object (visual_map) while the simulator presses the object's true
relief, off by the sequence's registration error and each press's jitter.

Metrics, as the paper counts them (Sec. IV-B): a sequence is localized when the error is below
5 mm by touch 6 and stays below for every later touch (SequenceResult.localized()).

    protocol = tacmap.load_protocol("data/gecko/protocol.txt")
    experiment = tacmap.Experiment(protocol, tacmap.LocalizationConfig(
        scenario=tacmap.ScenarioParams.realistic(), simulator=tacmap.realistic_sensor()))
    results = experiment.run_all()
    print(sum(r.localized() for r in results), "of", len(results), "localized")

The GIL is released while the map is prepared and during runs.)doc";

}  // namespace

void bind_simulation(py::module_& m) {
  // ---- ReliefParams, relief_from_image ----
  py::class_<relief_params> relief_cls(m, "ReliefParams");
  enum_property(relief_cls, "kind", &relief_params::kind, relief_names,
                "'binary': pixels brighter than threshold protrude by height_mm (the paper's "
                "gecko); 'continuous': height = height_mm x intensity.");
  relief_cls
      .def_readwrite("threshold", &relief_params::threshold,
                     "Binary: intensity above which the object protrudes.")
      .def_readwrite("height_mm", &relief_params::height_mm,
                     "Binary: protrusion; continuous: height of intensity 1 (mm).")
      .def_readwrite("edge_smoothing_px", &relief_params::edge_smoothing_px,
                     "Binary: Gaussian sigma (map px) rounding the edges; 0 = sharp.");
  keyword_struct<relief_params>(
      relief_cls, {"kind", "threshold", "height_mm", "edge_smoothing_px"},
      "How an image's intensity becomes a relief (C++ tacmap::relief_params). Defaults: the "
      "paper's gecko, a 2-D shape protruding 4 mm from its base, from an image in [0, 1].");
  m.def(
      "relief_from_image",
      [](const py::object& intensity, const relief_params& params) {
        const image<float> img =
            to_image(intensity, "relief_from_image: intensity", "(rows, cols)");
        return to_numpy(relief_from_image(img, params));
      },
      py::arg("intensity"), py::arg("params") = relief_params{},
      "Turns an intensity image (e.g. the map, in [0, 1]) into a relief in mm (a new float32 "
      "array). Binary: 1 above threshold, else 0, optionally smoothed, times height_mm. "
      "Continuous: height_mm x intensity. Raises ValueError for an empty image or a non-finite "
      "pixel (named by row and column).");

  // ---- SimulatorParams ----
  py::class_<simulator_params> sp(m, "SimulatorParams");
  sp.def_readwrite("geometry", &simulator_params::geometry,
                   "The array (TaxelGeometry; 14 x 6 at 3.4 mm, the paper's Weiss array).")
      .def_readwrite("press_depth_mm", &simulator_params::press_depth_mm,
                     "Indentation of the highest point under the sensor, mm.")
      .def_readwrite("supersample", &simulator_params::supersample,
                     "Sample points per cell side for the cell integral.")
      .def_readwrite("foam_sigma_mm", &simulator_params::foam_sigma_mm,
                     "Load spread by the foam cover, mm (half a 3.4 mm pitch).")
      .def_readwrite("gain_counts_per_mm", &simulator_params::gain_counts_per_mm,
                     "Counts per mm of indentation for a nominal taxel.")
      .def_readwrite("gain_variation", &simulator_params::gain_variation,
                     "Relative standard deviation of the per-taxel gain.")
      .def_readwrite("noise_counts", &simulator_params::noise_counts,
                     "Standard deviation of the read-out noise, counts.")
      .def_readwrite("dead_fraction", &simulator_params::dead_fraction,
                     "Fraction of taxels that always read 0.")
      .def_readwrite("full_scale_counts", &simulator_params::full_scale_counts,
                     "Saturation value (12-bit read-out: 4095).")
      .def_readwrite("saturation_counts", &simulator_params::saturation_counts,
                     "Soft saturation level: counts = S tanh(counts / S) before the noise; 0 = "
                     "linear up to full scale.")
      .def_readwrite("hysteresis", &simulator_params::hysteresis,
                     "Fraction of the previous frame's counts that persists into the next.")
      .def_readwrite("baseline_drift_counts", &simulator_params::baseline_drift_counts,
                     "Standard deviation of each frame's step of the taxels' baseline random "
                     "walk, counts (a burst's frames share one press's step).")
      .def_readwrite("frames_per_press", &simulator_params::frames_per_press,
                     "Frames read per press (render_press): 1 = one settled frame; the paper "
                     "read 20.")
      .def_readwrite("settle_start", &simulator_params::settle_start,
                     "Bursts: the first frame's fraction of the press depth (1 = no settling).")
      .def_readwrite("settle_frames", &simulator_params::settle_frames,
                     "Bursts: time constant of the settling, frames.")
      .def_readwrite("bump_probability", &simulator_params::bump_probability,
                     "Bursts: probability that a frame after the first is read during a bump "
                     "(an outlier frame); 0 = none.")
      .def_readwrite("bump_depth_spread", &simulator_params::bump_depth_spread,
                     "A bump's force: the depth times a factor uniform in [1 - s, 1 + s].")
      .def_readwrite("bump_shift_mm", &simulator_params::bump_shift_mm,
                     "A bump's slide of the array, mm, in a random direction.")
      .def_readwrite("seed", &simulator_params::seed,
                     "Fixes gains, dead taxels and the noise stream.")
      .def_property(
          "frame_interval_ns",
          [](const simulator_params& p) {
            return std::chrono::duration_cast<std::chrono::nanoseconds>(p.frame_interval).count();
          },
          [](simulator_params& p, std::int64_t ns) {
            p.frame_interval = std::chrono::nanoseconds(ns);
          },
          "Timestamp step between rendered frames, ns.");
  keyword_struct<simulator_params>(
      sp, {"geometry",           "press_depth_mm",    "supersample",   "foam_sigma_mm",
           "gain_counts_per_mm", "gain_variation",    "noise_counts",  "dead_fraction",
           "full_scale_counts",  "saturation_counts", "hysteresis",    "baseline_drift_counts",
           "frames_per_press",   "settle_start",      "settle_frames", "bump_probability",
           "bump_depth_spread",  "bump_shift_mm",     "seed",          "frame_interval_ns"},
      "Configuration of the tactile simulator (C++ tacmap::simulator_params). The defaults "
      "describe the paper's Weiss array on a 4 mm relief: a 1 mm press gives about 2000 of "
      "4095 counts on a fully loaded cell, with a few percent of noise and gain spread.");
  m.def(
      "realistic_sensor",
      [](std::optional<simulator_params> base) {
        return realistic_sensor(base.value_or(simulator_params{}));
      },
      py::arg("base") = py::none(),
      "The sensor of the realistic scenario: the paper's array after use, not a new one (40 "
      "counts of noise, 10 % gain spread, 2 of 84 taxels dead, a 2.5 mm foam spread). Starts "
      "from `base` (geometry, press depth, seed) and replaces the imperfections.");
  m.def(
      "harsh_sensor",
      [](std::optional<simulator_params> base) {
        return harsh_sensor(base.value_or(simulator_params{}));
      },
      py::arg("base") = py::none(),
      "The sensor of the harsh scenario (issue 34; docs/simulator.md): 5 % of full scale noise, "
      "+-30 % gains, 10 % dead taxels, a one-pitch pad spread, soft saturation at 3000 counts, "
      "8 % hysteresis and a drifting baseline.");

  // ---- Simulator ----
  py::class_<tactile_simulator>(
      m, "Simulator",
      "A simulated tactile array pressed onto one object (C++ tacmap::tactile_simulator): "
      "contact of a plane with the relief, cell integration, foam spread, per-taxel gain, "
      "read-out noise, rounding, saturation and dead taxels. Poses are in the map frame (x "
      "right along columns, y down along rows, mm); with theta = 0 the array's rows run along "
      "the map's y axis.\n\n"
      "    protocol = tacmap.load_protocol('data/gecko/protocol.txt')\n"
      "    sim = tacmap.Simulator(protocol.relief_mm(), protocol.mm_per_px)\n"
      "    frame = sim.render(40.0, 50.0)\n\n"
      "Deterministic: the same parameters and sequence of render calls give the same frames.")
      .def(py::init([](const py::object& relief_mm, double mm_per_px,
                       std::optional<simulator_params> params) {
             image<float> relief = to_image(relief_mm, "Simulator: relief_mm", "(rows, cols)");
             const pixel_size size{relief.cols(), relief.rows()};
             return tactile_simulator(std::move(relief), size, mm_per_px,
                                      params.value_or(simulator_params{}));
           }),
           py::arg("relief_mm"), py::arg("mm_per_px"), py::arg("params") = py::none(),
           "relief_mm: the object's height in mm at every map pixel (2-D array, e.g. "
           "relief_from_image(map) or TouchProtocol.relief_mm()); mm_per_px: the map's scale; "
           "params: SimulatorParams (None: the defaults). Raises ValueError for a non-finite "
           "height or a parameter out of range.")
      .def(
          "render",
          [](tactile_simulator& s, double x, double y, double theta, double depth_scale,
             double tilt_u, double tilt_v) {
            return s.render({x, y, theta}, press_of(depth_scale, tilt_u, tilt_v));
          },
          py::arg("x_mm"), py::arg("y_mm"), py::arg("theta_rad") = 0.0, py::kw_only(),
          py::arg("depth_scale") = 1.0, py::arg("tilt_u_rad") = 0.0, py::arg("tilt_v_rad") = 0.0,
          "One frame (a Frame) as the sensor reports it with its centre at (x_mm, y_mm) and "
          "turned by theta_rad: expected counts plus noise on loaded taxels, rounded, "
          "saturated, dead taxels at 0. depth_scale and the tilts vary this press. Advances "
          "the noise stream and the frame number. Raises ValueError when the footprint leaves "
          "the map (the message gives the map's extent).")
      .def(
          "render_press",
          [](tactile_simulator& s, double x, double y, double theta, double depth_scale,
             double tilt_u, double tilt_v) {
            return s.render_press({x, y, theta}, press_of(depth_scale, tilt_u, tilt_v));
          },
          py::arg("x_mm"), py::arg("y_mm"), py::arg("theta_rad") = 0.0, py::kw_only(),
          py::arg("depth_scale") = 1.0, py::arg("tilt_u_rad") = 0.0, py::arg("tilt_v_rad") = 0.0,
          "One press read as params.frames_per_press frames (a list of Frame): each with its "
          "own noise, the first ones still settling; combine_burst combines them as the localizer "
          "does. "
          "With one frame per press, [render(...)] exactly.")
      .def(
          "expected_counts",
          [](const tactile_simulator& s, double x, double y, double theta, double depth_scale,
             double tilt_u, double tilt_v) {
            return to_numpy(
                s.expected_counts({x, y, theta}, press_of(depth_scale, tilt_u, tilt_v)));
          },
          py::arg("x_mm"), py::arg("y_mm"), py::arg("theta_rad") = 0.0, py::kw_only(),
          py::arg("depth_scale") = 1.0, py::arg("tilt_u_rad") = 0.0, py::arg("tilt_v_rad") = 0.0,
          "The noiseless, unquantised, unsaturated counts (a float32 array).")
      .def(
          "fits",
          [](const tactile_simulator& s, double x, double y, double theta) {
            return s.fits({x, y, theta});
          },
          py::arg("x_mm"), py::arg("y_mm"), py::arg("theta_rad") = 0.0,
          "True when the pose is finite and the whole sensor footprint lies on the map.")
      .def_property_readonly("params", &tactile_simulator::params, "The SimulatorParams (a copy).",
                             py::return_value_policy::copy)
      .def_property_readonly(
          "relief", [](const tactile_simulator& s) { return to_numpy(s.relief()); },
          "The relief in mm (a float32 copy).")
      .def_property_readonly("mm_per_px", &tactile_simulator::mm_per_px)
      .def_property_readonly(
          "map_size",
          [](const tactile_simulator& s) {
            return py::make_tuple(s.map_size().width, s.map_size().height);
          },
          "(width, height) of the map, px.")
      .def_property_readonly(
          "taxel_gain", [](const tactile_simulator& s) { return to_numpy(s.taxel_gain()); },
          "Per-taxel gain factors (around 1), fixed for this simulator.")
      .def_property_readonly(
          "dead_taxels", [](const tactile_simulator& s) { return to_numpy(s.dead_taxels()); },
          "Taxels that always read 0 (a bool array), fixed for this simulator.");

  // ---- ScenarioParams ----
  py::class_<scenario_params> sc(m, "ScenarioParams");
  sc.def_readwrite("albedo_variation", &scenario_params::albedo_variation,
                   "Camera map: relative standard deviation of the print's surface texture.")
      .def_readwrite("albedo_scale_px", &scenario_params::albedo_scale_px,
                     "Correlation length of that texture, map px.")
      .def_readwrite("illumination_gradient", &scenario_params::illumination_gradient,
                     "Illumination falloff across the map: peak-to-peak relative change.")
      .def_readwrite("shading", &scenario_params::shading,
                     "Fraction of the light that is directional (0 = diffuse, no shading).")
      .def_readwrite("light_elevation_deg", &scenario_params::light_elevation_deg,
                     "Elevation of the directional light above the map plane, degrees.")
      .def_readwrite("camera_blur_px", &scenario_params::camera_blur_px,
                     "Gaussian blur of the camera's optics and resampling, map px.")
      .def_readwrite("camera_noise", &scenario_params::camera_noise,
                     "Camera sensor noise, standard deviation in linear intensity (of 1).")
      .def_readwrite("camera_gamma", &scenario_params::camera_gamma,
                     "Tone curve: the map stores intensity^(1 / gamma) (sRGB ~ 2.2).")
      .def_readwrite("ink_coverage", &scenario_params::ink_coverage,
                     "Fraction of the map's area covered by printed ink strokes (photo edges "
                     "with no touch edges).")
      .def_readwrite("ink_contrast", &scenario_params::ink_contrast,
                     "Opacity of that ink towards black or white (1 = opaque).")
      .def_readwrite("albedo_contrast", &scenario_params::albedo_contrast,
                     "How much of the image's brightness variation the object's albedo keeps.");
  enum_property(sc, "polarity", &scenario_params::polarity, polarity_names,
                "Whether raised parts look brighter ('bright', the gecko) or darker ('dark') "
                "than their surroundings, or either per sequence ('random').");
  sc.def_readwrite("mixed_polarity", &scenario_params::mixed_polarity,
                   "Fraction of the map's area where the height-brightness relation is the "
                   "opposite of the sequence's polarity (a two-tone part).")
      .def_readwrite("registration_shift_mm", &scenario_params::registration_shift_mm,
                     "Shift of the object against the map, mm (per sequence).")
      .def_readwrite("registration_rotation_deg", &scenario_params::registration_rotation_deg,
                     "Rotation of the object about the map's centre, degrees (per sequence).")
      .def_readwrite("orientation_jitter_deg", &scenario_params::orientation_jitter_deg,
                     "Standard deviation of the array's in-plane orientation per press, "
                     "degrees.")
      .def_readwrite("tilt_jitter_deg", &scenario_params::tilt_jitter_deg,
                     "Standard deviation of the array's tilt about each axis per press, "
                     "degrees.")
      .def_readwrite("press_depth_jitter", &scenario_params::press_depth_jitter,
                     "Relative standard deviation of the press depth.")
      .def_readwrite("shadow_depth", &scenario_params::shadow_depth,
                     "Fraction of the light a cast shadow over 20-40 % of the map takes.")
      .def_readwrite("shadow_edge_px", &scenario_params::shadow_edge_px,
                     "The shadow's penumbra, map px (Gaussian sigma).")
      .def_readwrite("defocus_px", &scenario_params::defocus_px,
                     "Radius of the defocus disc, map px.")
      .def_readwrite("map_scale_error", &scenario_params::map_scale_error,
                     "Relative error of the map's scale (sign drawn per sequence).")
      .def_readwrite("light_press_fraction", &scenario_params::light_press_fraction,
                     "Fraction of presses that are light.")
      .def_readwrite("light_press_scale", &scenario_params::light_press_scale,
                     "Depth of a light press relative to the nominal one.")
      .def_readwrite("partial_press_fraction", &scenario_params::partial_press_fraction,
                     "Fraction of presses that land tilted (partial contact).")
      .def_readwrite("partial_press_tilt_deg", &scenario_params::partial_press_tilt_deg,
                     "Tilt of a partial press, degrees.")
      .def_static("harsh", &scenario_params::harsh,
                  "A lab's conditions (issue 34; docs/simulator.md): unknown_object(), plus a "
                  "cast shadow, defocus, a stronger gradient, a 3 % map scale error, light and "
                  "partial presses. Use it with harsh_sensor().")
      .def_static("realistic", &scenario_params::realistic,
                  "The scenario of the paper's setup (a webcam image of a matte print under a "
                  "desk lamp, ~1 mm / 1 degree registration, 3 degrees orientation jitter, 20 % "
                  "press depth jitter); each value is argued in sim/scenario.hpp. Use it with "
                  "realistic_sensor().")
      .def_static("unknown_object", &scenario_params::unknown_object,
                  "A photograph of an object we know nothing about: the realistic scenario, "
                  "plus random polarity per sequence, 20 % mixed polarity and printed ink.")
      .def("changes_map", &scenario_params::changes_map,
           "True when some camera effect is on (the map differs from the protocol's image).")
      .def("changes_relief", &scenario_params::changes_relief,
           "True when the relief pressed may differ from the protocol's.")
      .def("moves_sensor", &scenario_params::moves_sensor,
           "True when the sensor's pose or press departs from the protocol's.");
  keyword_struct<scenario_params>(
      sc,
      {"albedo_variation",
       "albedo_scale_px",
       "illumination_gradient",
       "shading",
       "light_elevation_deg",
       "camera_blur_px",
       "camera_noise",
       "camera_gamma",
       "ink_coverage",
       "ink_contrast",
       "albedo_contrast",
       "polarity",
       "mixed_polarity",
       "registration_shift_mm",
       "registration_rotation_deg",
       "orientation_jitter_deg",
       "tilt_jitter_deg",
       "press_depth_jitter",
       "shadow_depth",
       "shadow_edge_px",
       "defocus_px",
       "map_scale_error",
       "light_press_fraction",
       "light_press_scale",
       "partial_press_fraction",
       "partial_press_tilt_deg"},
      "Simulation scenario (C++ tacmap::scenario_params): how the camera's map, the object's "
      "relief and registration, and each press depart from the ideal. Every effect is off "
      "(ideal) by default; ScenarioParams.realistic() is the paper's setup and "
      "ScenarioParams.unknown_object() an object we know nothing about. tacmap-evaluate's "
      "--scenario names: ideal = ScenarioParams() with SimulatorParams(); realistic = "
      "realistic() with realistic_sensor(); unknown = unknown_object() with "
      "realistic_sensor().");

  // ---- ExplorationFaults ----
  py::class_<exploration_faults> faults(m, "ExplorationFaults");
  faults
      .def_readwrite("outlier_probability", &exploration_faults::outlier_probability,
                     "Per move, the probability of an odometry outlier.")
      .def_readwrite("outlier_mm", &exploration_faults::outlier_mm, "An outlier's error, mm.")
      .def_readwrite("odometry_sigma_mm", &exploration_faults::odometry_sigma_mm,
                     "The true odometry noise per axis, mm (None: the protocol's own measured "
                     "odometry).")
      .def_readwrite("slip_touch", &exploration_faults::slip_touch,
                     "1-based touch from which the object has slipped (0: none).")
      .def_readwrite("slip_mm", &exploration_faults::slip_mm, "How far it slipped, mm.")
      .def_readwrite("kidnap_touch", &exploration_faults::kidnap_touch,
                     "1-based touch at which the sensor is put elsewhere (0: none).")
      .def("any", &exploration_faults::any);
  enum_property(faults, "oracle", &exploration_faults::oracle, oracle_names,
                "Evaluations' ceilings, not a method: what the filter is told about the faults. "
                "'none'; 'transition' (after every move the belief is mixed with its ring of "
                "outlier_mm, weight outlier_probability: the outliers' true motion model); "
                "'told' (after each outlier move, and at the slip's touch when it happened, the "
                "belief is replaced by its ring of the fault's size). On top of the filter's own "
                "floor and wide component.");
  keyword_struct<exploration_faults>(
      faults,
      {"outlier_probability", "outlier_mm", "odometry_sigma_mm", "slip_touch", "slip_mm",
       "kidnap_touch", "oracle"},
      "Faults during exploration (C++ tacmap::exploration_faults): odometry outliers and "
      "noise, a slip, a kidnap. None by default.");

  // ---- LocalizationConfig ----
  py::class_<localization_config, localizer_config> lc(m, "LocalizationConfig");
  lc.def_readwrite("simulator_seed", &localization_config::simulator_seed,
                   "Seeds the simulator; each sequence forks its own stream.")
      .def_readwrite("simulator", &localization_config::simulator,
                     "The simulator's physics (SimulatorParams; its seed is replaced per "
                     "sequence).")
      .def_readwrite("scenario", &localization_config::scenario,
                     "Camera map, registration and per-press effects (ScenarioParams; ideal by "
                     "default).")
      .def_readwrite("faults", &localization_config::faults,
                     "Faults during exploration (ExplorationFaults; none by default).")
      .def_readwrite("random_orientation", &localization_config::random_orientation,
                     "Each sequence's sensor heading drawn uniformly from [-pi, pi) instead of "
                     "0; the odometry is then reported in the sensor's frame (use with "
                     "headings > 0).");
  std::vector<std::string> experiment_fields = localizer_config_fields();
  for (const char* f : {"simulator_seed", "simulator", "scenario", "faults", "random_orientation"})
    experiment_fields.emplace_back(f);
  keyword_struct<localization_config>(
      lc, std::move(experiment_fields),
      "Everything that configures one simulated localization run (C++ "
      "tacmap::localization_config): the filter (the LocalizerConfig fields, same defaults) "
      "and the simulated world around it.");

  // ---- protocols ----
  py::class_<protocol_step>(m, "ProtocolStep",
                            "One step of a sequence: the location touched and the move that "
                            "brought the sensor there from the previous step's location (zero "
                            "for the first step).")
      .def_readonly("location", &protocol_step::location, "Index into TouchProtocol.locations.")
      .def_property_readonly(
          "true_motion",
          [](const protocol_step& s) { return vec2(s.true_motion.dx_mm, s.true_motion.dy_mm); },
          "The exact displacement (dx_mm, dy_mm), numpy (ground truth).")
      .def_property_readonly(
          "measured_motion",
          [](const protocol_step& s) {
            return vec2(s.measured_motion.dx_mm, s.measured_motion.dy_mm);
          },
          "What the arm reported (dx_mm, dy_mm), numpy: truth plus odometry noise. What "
          "Localizer.touch takes as `moved`.")
      .def("__repr__", [](const protocol_step& s) {
        return "ProtocolStep(location=" + std::to_string(s.location) + ", measured_motion=(" +
               std::string(py::repr(py::float_(s.measured_motion.dx_mm))) + ", " +
               std::string(py::repr(py::float_(s.measured_motion.dy_mm))) + "))";
      });
  py::class_<touch_protocol>(
      m, "TouchProtocol",
      "A whole touch protocol (C++ tacmap::touch_protocol): the map, its relief, the touch "
      "locations and the sequences that visit them. Read-only; load one with load_protocol.")
      .def_readonly("map_file", &touch_protocol::map_file,
                    "The map image, relative to the manifest's folder.")
      .def_property_readonly(
          "map", [](const touch_protocol& p) { return to_numpy(p.map); },
          "The visual map, intensities in [0, 1] (a float32 copy).")
      .def_readonly("mm_per_px", &touch_protocol::mm_per_px, "The map's scale.")
      .def_property_readonly(
          "relief", [](const touch_protocol& p) { return p.relief; },
          "How the map becomes a relief (ReliefParams copy).")
      .def_property_readonly(
          "locations",
          [](const touch_protocol& p) {
            py::array_t<double> out({static_cast<py::ssize_t>(p.locations.size()), py::ssize_t{2}});
            auto a = out.mutable_unchecked<2>();
            for (std::size_t i = 0; i < p.locations.size(); ++i) {
              a(static_cast<py::ssize_t>(i), 0) = p.locations[i].x_mm;
              a(static_cast<py::ssize_t>(i), 1) = p.locations[i].y_mm;
            }
            return out;
          },
          "The touch locations: sensor centres (x_mm, y_mm) in the map frame, a numpy array "
          "(n, 2).")
      .def_property_readonly(
          "sequences", [](const touch_protocol& p) { return p.sequences; },
          "The sequences: a list of lists of ProtocolStep, in order.")
      .def_readonly("readings_per_location", &touch_protocol::readings_per_location,
                    "Frames taken at each touch (the paper: 20).")
      .def_readonly("odometry_sigma_mm", &touch_protocol::odometry_sigma_mm,
                    "Per-axis noise of measured_motion (documentation).")
      .def_readonly("seed", &touch_protocol::seed,
                    "The seed the data was generated from (documentation).")
      .def_property_readonly(
          "map_size",
          [](const touch_protocol& p) {
            return py::make_tuple(p.map_size().width, p.map_size().height);
          },
          "(width, height) of the map, px.")
      .def(
          "relief_mm", [](const touch_protocol& p) { return to_numpy(p.relief_mm()); },
          "The relief in mm the simulator presses on (a new float32 array).")
      .def("__repr__", [](const touch_protocol& p) {
        return "TouchProtocol(map '" + p.map_file + "' " + std::to_string(p.map.cols()) + " x " +
               std::to_string(p.map.rows()) + " px, " + std::to_string(p.locations.size()) +
               " locations, " + std::to_string(p.sequences.size()) + " sequences)";
      });
  m.def(
      "load_protocol",
      [](const std::filesystem::path& manifest, std::optional<taxel_geometry> sensor) {
        return load_protocol(manifest, sensor.value_or(taxel_geometry{}));
      },
      py::arg("manifest"), py::arg("sensor") = py::none(),
      "Reads a protocol manifest (protocol.txt) and everything it names: the map image "
      "(binary PGM), the locations and the sequences (paths relative to the manifest's "
      "folder). Locations are checked against the map for a sensor of the given geometry "
      "(None: 14 x 6 at 3.4 mm). Raises ValueError naming the file, line and field of the "
      "first problem. The format: data/README.md.");

  // ---- experiment results ----
  py::class_<touch_record>(m, "TouchRecord",
                           "What happened at one touch of a simulated run (C++ "
                           "tacmap::touch_record). Read-only.")
      .def_readonly("step", &touch_record::step, "0-based position in the sequence.")
      .def_readonly("location", &touch_record::location, "Index of the touch location.")
      .def_readonly("true_x_mm", &touch_record::true_x_mm, "Ground truth sensor centre.")
      .def_readonly("true_y_mm", &touch_record::true_y_mm)
      .def_readonly("map_x_mm", &touch_record::map_x_mm,
                    "The belief's most probable state after this touch.")
      .def_readonly("map_y_mm", &touch_record::map_y_mm)
      .def_readonly("map_error_mm", &touch_record::map_error_mm,
                    "The most probable state's distance to the truth.")
      .def_readonly("estimate_x_mm", &touch_record::estimate_x_mm,
                    "The estimate: the centre of the 5 mm disc that holds the most belief.")
      .def_readonly("estimate_y_mm", &touch_record::estimate_y_mm)
      .def_readonly("error_mm", &touch_record::error_mm, "The estimate's distance to the truth.")
      .def_readonly("true_theta_rad", &touch_record::true_theta_rad,
                    "The sensor's heading on the map (0 unless random_orientation).")
      .def_readonly("map_theta_rad", &touch_record::map_theta_rad,
                    "The most probable heading (pose grids; else 0).")
      .def_readonly("entropy_nats", &touch_record::entropy_nats,
                    "The belief's entropy after this touch (positions).")
      .def_readonly("appearance_probability", &touch_record::appearance_probability,
                    "Posterior of each appearance hypothesis after this touch.")
      .def_readonly("odometry_outlier", &touch_record::odometry_outlier,
                    "The move before this touch was an injected outlier.")
      .def_readonly("moved_unseen", &touch_record::moved_unseen,
                    "The object slipped, or the sensor was kidnapped, just before this touch "
                    "(not set when no direction kept the later touches on the map and the "
                    "sequence ran without it).")
      .def_readonly("lost_track", &touch_record::lost_track,
                    "The motion before this touch carried the whole belief off the map and the "
                    "run restarted from a uniform belief.")
      .def_readonly("frames_read", &touch_record::frames_read,
                    "Frames the simulator read for this press (SimulatorParams.frames_per_press).")
      .def_readonly("frames_combined", &touch_record::frames_combined,
                    "Of those, the frames combine_burst kept (1 for a single frame).")
      .def_readonly("accepted", &touch_record::accepted,
                    "False: preprocessing rejected the frame, no update.")
      .def_property_readonly(
          "rejection",
          [](const touch_record& r) { return choice_name(r.rejection, rejection_names); },
          "'none', 'weak_peak', 'weak_total' or 'flat'.")
      .def_readonly("probability_within", &touch_record::probability_within,
                    "The belief's P(|position - estimate| <= 5 mm) after this touch.")
      .def_readonly("heading_probability", &touch_record::heading_probability,
                    "Pose grids: P(|heading - MAP heading| <= 15 degrees); 1 otherwise.")
      .def_property_readonly(
          "verdict", [](const touch_record& r) { return to_string(r.verdict); },
          "The belief's own verdict: 'localized' or 'uncertain' (see contradicted).")
      .def_readonly("log_marginal_likelihood", &touch_record::log_marginal_likelihood,
                    "This touch's evidence log p(z_t | z_1..t-1); 0 for a rejected frame.")
      .def_readonly("log_prediction_support", &touch_record::log_prediction_support,
                    "This touch's support for the prediction (nats); 0 for a rejected frame.")
      .def_readonly("contradicted", &touch_record::contradicted,
                    "The verdict a robot would get is 'contradicted'.")
      .def("__repr__", [](const touch_record& r) {
        return "TouchRecord(step=" + std::to_string(r.step) +
               ", error_mm=" + std::string(py::repr(py::float_(r.error_mm))) + ", verdict='" +
               to_string(r.verdict) + "')";
      });
  py::class_<sequence_result>(m, "SequenceResult",
                              "One sequence's run (C++ tacmap::sequence_result). Read-only.")
      .def_readonly("sequence", &sequence_result::sequence, "The sequence's index.")
      .def_readonly("raised_dark", &sequence_result::raised_dark,
                    "The object's raised parts look darker in the photograph this sequence.")
      .def_readonly("touches", &sequence_result::touches, "A list of TouchRecord, one per touch.")
      .def_property_readonly(
          "tactile_images", [](const sequence_result& r) { return images_of(r.tactile_images); },
          "keep_images: each touch's preprocessed tactile image at map scale (None when "
          "rejected); else empty.")
      .def_property_readonly(
          "beliefs", [](const sequence_result& r) { return images_of(r.beliefs); },
          "keep_images: the position belief after each touch (float32 (rows, cols), plot with "
          "Experiment.extent_mm); else empty.")
      .def_property_readonly(
          "log_likelihoods",
          [](const sequence_result& r) {
            py::list out;
            for (const auto& ll : r.log_likelihoods) {
              py::array_t<float> a(ll.size());
              if (ll.size() > 0)
                std::memcpy(a.mutable_data(), ll.data(),
                            static_cast<std::size_t>(ll.size()) * sizeof(float));
              out.append(a);
            }
            return out;
          },
          "keep_log_likelihoods: each touch's log-likelihood over the filter's states (empty "
          "for a rejected frame).")
      .def_property_readonly(
          "errors_mm",
          [](const sequence_result& r) {
            py::array_t<double> out(static_cast<py::ssize_t>(r.touches.size()));
            for (std::size_t i = 0; i < r.touches.size(); ++i)
              out.mutable_at(static_cast<py::ssize_t>(i)) = r.touches[i].error_mm;
            return out;
          },
          "The estimate's error after each touch, mm (numpy).")
      .def(
          "touches_to_localize",
          [](const sequence_result& r, double threshold_mm) {
            return touches_to_localize(r.touches, threshold_mm);
          },
          py::arg("threshold_mm") = 5.0,
          "First touch (1-based) from which every error is below threshold_mm; None when the "
          "last touch is not below it.")
      .def(
          "localized",
          [](const sequence_result& r, double threshold_mm, std::size_t within) {
            return localized(r.touches, threshold_mm, within);
          },
          py::arg("threshold_mm") = 5.0, py::arg("within") = 6,
          "The paper's success (Sec. IV-B): error below threshold_mm by touch `within` and "
          "below it for every later touch.")
      .def("__repr__", [](const sequence_result& r) {
        return "SequenceResult(sequence=" + std::to_string(r.sequence) + ", " +
               std::to_string(r.touches.size()) + " touches, final error_mm=" +
               (r.touches.empty() ? std::string("None")
                                  : std::string(py::repr(py::float_(r.touches.back().error_mm)))) +
               ")";
      });
  m.def(
      "median_error_per_touch",
      [](const std::vector<sequence_result>& results) { return median_error_per_touch(results); },
      py::arg("results"),
      "Median error at each touch across sequences (the paper's Fig. 6): element t is the "
      "median of the errors at touch t + 1 over the sequences that have one.");

  // ---- Experiment ----
  py::class_<py_experiment>(m, "Experiment", experiment_doc)
      .def(py::init([](const touch_protocol& protocol, const py::object& config) {
             localization_config c = experiment_config(config);
             const py::gil_scoped_release release;  // building the model takes a while
             return std::make_unique<py_experiment>(protocol, std::move(c));
           }),
           py::arg("protocol"), py::arg("config") = py::none(),
           py::keep_alive<1, 2>(),  // the experiment refers to the protocol
           "protocol: a TouchProtocol (load_protocol). config: a LocalizationConfig, a "
           "LocalizerConfig (then the simulated world's defaults) or None (all defaults). "
           "Raises ValueError for a map smaller than the sensor or an invalid configuration.")
      .def(
          "run",
          [](py_experiment& self, Eigen::Index sequence, bool keep_images,
             bool keep_log_likelihoods) {
            if (sequence < 0)
              throw py::value_error("Experiment.run: sequence = " + std::to_string(sequence) +
                                    "; expected a sequence index >= 0");
            const py::gil_scoped_release release;
            const std::lock_guard<std::mutex> lock(self.mutex);
            return self.impl.run(static_cast<std::size_t>(sequence), keep_images,
                                 keep_log_likelihoods);
          },
          py::arg("sequence"), py::arg("keep_images") = false,
          py::arg("keep_log_likelihoods") = false,
          "Replays sequence `sequence` of the protocol from a uniform belief; returns a "
          "SequenceResult. keep_images: also every preprocessed tactile image and belief. "
          "Raises ValueError for a sequence out of range.")
      .def(
          "run_all",
          [](py_experiment& self, bool keep_images) {
            const py::gil_scoped_release release;
            const std::lock_guard<std::mutex> lock(self.mutex);
            std::vector<sequence_result> out;
            for (std::size_t k = 0; k < self.protocol->sequences.size(); ++k)
              out.push_back(self.impl.run(k, keep_images));
            return out;
          },
          py::arg("keep_images") = false,
          "run(k) for every sequence k of the protocol: a list of SequenceResult.")
      .def_property_readonly(
          "config", [](py_experiment& self) { return self.impl.config(); },
          "The configuration (a LocalizationConfig copy).")
      .def(
          "visual_map", [](py_experiment& self) { return to_numpy(self.impl.visual_map()); },
          "The map the measurement model matches against: the protocol's image, or what the "
          "scenario's camera makes of it.")
      .def(
          "relief_mm", [](py_experiment& self) { return to_numpy(self.impl.relief_mm()); },
          "The relief the sensor presses, mm.")
      .def_property_readonly(
          "extent_mm",
          [](py_experiment& self) {
            const image<float>& map = self.impl.visual_map();
            const double mm = self.impl.config().preprocessing.mm_per_px;
            const pixel_size w = tactile_window(self.impl.config().simulator.geometry, mm);
            const planar_grid<float> g({map.cols(), map.rows()}, mm, w);
            const auto first = g.state_mm(0);
            const double left = first(0) - 0.5 * mm, top = first(1) - 0.5 * mm;
            return py::make_tuple(left, left + static_cast<double>(g.cols()) * mm,
                                  top + static_cast<double>(g.rows()) * mm, top);
          },
          "(left, right, bottom, top) in mm of the beliefs' pixels, for imshow(belief, "
          "extent=experiment.extent_mm).");
}

}  // namespace tacmap::python
