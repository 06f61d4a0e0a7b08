// tacmap-evaluate — the paper's evaluation (Sec. IV-B, Figs. 6-8) over maps x configurations.
//
// Runs every sequence of every map through the localization pipeline (sim/experiment.hpp) for
// every configuration in the cross product of --model x --pairing x --shape x --features (NCC
// ignores the last three), and writes one CSV row per (map, configuration, sequence, touch).
// Prints a summary per map and configuration: sequences localized (error < 5 mm by touch 6 and
// staying below), median touches to localize, median final error.
//
// Maps: the bundled gecko with its protocol (--gecko, on by default), and photographs (--photo,
// PNG, JPEG or binary PGM): each is turned grey, area-resized so that its longer side
// is 120 px, the aspect ratio kept (--max-side N; --map-px N for an N x N square; or kept at its
// own size, --native; each is reported on stderr) at the paper's 3.4/3 mm per px,
// pressed as a continuous relief (height = 4 mm x intensity) and given a
// generated protocol — 7 random touch locations, 22 random orders, odometry noise 0.5 mm per
// axis — all fixed by --seed. Everything (simulator noise included) is reproducible from --seed.
//
// Scenarios (sim/scenario.hpp): --scenario ideal (default) presses the map's own image with a
// new sensor; --scenario realistic makes the map a camera image (texture, illumination,
// shading, blur, noise, gamma), misregisters the object by ~1 mm / 1 degree per sequence,
// jitters every press (orientation, tilt, depth) and uses a worn sensor; --scenario unknown is
// a photo of an object we know nothing about: realistic, plus raised parts brighter or darker
// at random per sequence, regions of the opposite relation and printed ink. Every effect has
// its own option, applied on top of the scenario (e.g. --scenario realistic --camera-gamma 1,
// --polarity dark, --mixed-polarity 0.3, --ink-coverage 0.1, --albedo-contrast 0).
// --scenario harsh is a lab's conditions (issue 34; docs/simulator.md argues every level): unknown,
// plus a cast shadow, defocus, a stronger light gradient, a map scale 3 % off, light and partial
// presses, and a worn sensor that drifts, saturates, spreads and remembers the last press. Those
// conditions have their own options too (--shadow, --defocus, --map-scale-error, --light-presses,
// --partial-presses, --drift, --saturation, --hysteresis; --foam-sigma is the pad's spread), and
// the tables are preceded by a line naming every condition in effect.
//
// --touch-order random,active runs each configuration twice: in the protocol's random orders,
// and with every touch after the first chosen by localizer::next_touch among random positions
// on the map (sim/experiment.hpp, touch_order::active); a third table counts the sequences
// localized by touch 2, 3, 4 and 6.
//
//   tacmap-evaluate --photo camera.png --model sift_lite,ncc --output eval.csv
//   tacmap-evaluate --scenario realistic --model ncc --tau 0.05,0.1,0.2
#include <unistd.h>  // isatty

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "cli_checks.hpp"
#include "library_evaluation.hpp"
#include "photo_maps.hpp"
#include "tacmap/sim/calibration.hpp"
#include "tacmap/sim/experiment.hpp"
#include "tacmap/sim/protocol.hpp"
#include "tacmap/sim/random.hpp"
#include "tacmap/sim/scenario.hpp"

// The bundled data: TACMAP_INSTALLED_DATA_DIR is where an install puts it, relative to the
// installed executable's folder (bin/../share/tacmap/data) or absolute; TACMAP_DATA_DIR is the
// source tree this tool was built from. tools/CMakeLists.txt defines both.
#ifndef TACMAP_DATA_DIR
#define TACMAP_DATA_DIR "data"
#endif
#ifndef TACMAP_INSTALLED_DATA_DIR
#define TACMAP_INSTALLED_DATA_DIR "../share/tacmap/data"
#endif

namespace {

using tacmap::image;
using tacmap_tools::photo_protocol;

struct named_map {
  std::string name;
  tacmap::touch_protocol protocol;
};

template <class E>
E parse_choice(const std::string& what, const std::string& value,
               const std::vector<std::pair<std::string, E>>& choices) {
  std::string names;
  for (const auto& [name, e] : choices) {
    if (name == value) return e;
    names += (names.empty() ? "" : ", ") + name;
  }
  throw CLI::ValidationError(what, "'" + value + "' is not one of: " + names);
}

std::string csv_number(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.4f", v);
  return buf;
}

// The gecko protocol's folder when --gecko is not given: the installed copy beside this
// executable (so an installed tool works once its source tree is gone), else the source tree's.
// The first that holds protocol.txt; an error naming every folder tried when none does.
std::string default_gecko_dir(const char* argv0) {
  namespace fs = std::filesystem;
  std::vector<fs::path> tried;
  std::error_code ec;
  fs::path exe = fs::read_symlink("/proc/self/exe", ec);  // Linux; else argv[0] where it has a path
  if (ec && argv0 != nullptr && std::string(argv0).find('/') != std::string::npos)
    exe = fs::absolute(argv0, ec);
  if (!ec && !exe.empty())
    tried.push_back((exe.parent_path() / TACMAP_INSTALLED_DATA_DIR / "gecko").lexically_normal());
  tried.push_back(fs::path(TACMAP_DATA_DIR) / "gecko");
  std::string names;
  for (const auto& dir : tried) {
    if (fs::is_regular_file(dir / "protocol.txt", ec)) return dir.string();
    names += (names.empty() ? "" : ", ") + (dir / "protocol.txt").string();
  }
  throw CLI::ValidationError("--gecko", "no gecko protocol found (tried " + names +
                                            "); pass --gecko <folder holding protocol.txt>, "
                                            "e.g. <prefix>/share/tacmap/data/gecko, or --no-gecko "
                                            "with --photo");
}

void progress(std::size_t done, std::size_t total, const std::string& label) {
  constexpr std::size_t width = 30;
  const std::size_t filled = total == 0 ? width : done * width / total;
  std::fprintf(stderr, "\r[%s%s] %zu/%zu %-60.60s", std::string(filled, '#').c_str(),
               std::string(width - filled, ' ').c_str(), done, total, label.c_str());
  std::fflush(stderr);
}

// The belief's claims against what happened, over every touch of every sequence of one
// configuration (README, "Confidence").
struct confidence_tally {
  std::vector<double> within, heading, appearance;  // claimed probabilities
  std::vector<char> within_ok, heading_ok, appearance_ok;
  // Per touch number: touches with the estimate right (error < 5 mm), called localized, both.
  std::vector<std::size_t> right, said, said_and_right;
  // The "contradicted" signal: touches right after an injected fault (an odometry outlier, a
  // slip, a kidnap) and the other touches after the first, and how many of each it flagged.
  std::size_t faulted = 0, faulted_flagged = 0, clean = 0, clean_flagged = 0;

  void add(const tacmap::sequence_result& run, bool pose) {
    constexpr double radius_mm = 5.0;
    const double tolerance = tacmap::confidence_params{}.heading_tolerance_rad;
    for (const auto& r : run.touches) {
      const bool ok = r.error_mm <= radius_mm;
      within.push_back(r.probability_within);
      within_ok.push_back(ok ? 1 : 0);
      if (pose) {
        heading.push_back(r.heading_probability);
        heading_ok.push_back(
            std::abs(tacmap::wrap_angle(r.map_theta_rad - r.true_theta_rad)) <= tolerance ? 1 : 0);
      }
      if (r.appearance_probability.size() == 2) {
        const std::size_t said_h =
            r.appearance_probability[1] > r.appearance_probability[0] ? 1 : 0;
        appearance.push_back(r.appearance_probability[said_h]);
        appearance_ok.push_back(said_h == (run.raised_dark ? 1U : 0U) ? 1 : 0);
      }
      if (right.size() <= r.step) {
        right.resize(r.step + 1);
        said.resize(r.step + 1);
        said_and_right.resize(r.step + 1);
      }
      if (r.step > 0 && r.accepted) {
        const bool fault = r.odometry_outlier || r.moved_unseen;
        (fault ? faulted : clean) += 1;
        (fault ? faulted_flagged : clean_flagged) += r.contradicted ? 1U : 0U;
      }
      const bool localized = r.verdict == tacmap::verdict::localized;
      right[r.step] += ok ? 1U : 0U;
      said[r.step] += localized ? 1U : 0U;
      said_and_right[r.step] += ok && localized ? 1U : 0U;
    }
  }
};

std::string percent(std::size_t k, std::size_t n) {
  if (n == 0) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", 100.0 * static_cast<double>(k) / static_cast<double>(n));
  return buf;
}

std::string ece_text(const std::vector<double>& p, const std::vector<char>& ok) {
  if (p.empty()) return "-";
  const auto r = tacmap::reliability(p, ok);
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", 100.0 * r.expected_calibration_error);
  return buf;
}

// --burst-combine mean: every frame of a burst kept and averaged (no settling head or outlier
// frames dropped), the reference the default combination is measured against.
tacmap::burst_params plain_mean_burst() {
  tacmap::burst_params b;
  b.settle_tolerance = 1e9;
  b.outlier_tolerance = 1e9;
  b.statistic = tacmap::burst_statistic::trimmed_mean;
  b.trim_fraction = 0.0;
  return b;
}
bool is_plain_mean(const tacmap::burst_params& b) {
  return b.statistic == tacmap::burst_statistic::trimmed_mean && b.trim_fraction == 0.0 &&
         b.settle_tolerance >= 1e9;
}

// A configuration's name in the tables and the CSV: its filter's, and "/active" when its
// touches are chosen by next_touch (--touch-order active), the frames per press of a burst
// and "/mean" for bursts combined by their plain mean (--burst-combine mean).
std::string config_label(const tacmap::localization_config& c) {
  return c.name() + (c.order == tacmap::touch_order::active ? "/active" : "") +
         (c.simulator.frames_per_press == 1
              ? std::string()
              : "/frames " + std::to_string(c.simulator.frames_per_press) +
                    (is_plain_mean(c.burst)                                       ? "/mean"
                     : c.burst.statistic == tacmap::burst_statistic::trimmed_mean ? "/trimmed"
                                                                                  : ""));
}

// Second table: per configuration, over every map — the expected calibration error (points) of
// the belief's P(error <= 5 mm), of its heading and appearance claims, and the precision and
// recall of its "localized" verdict (confidence_params defaults) by touch number.
void print_confidence(const std::map<std::string, confidence_tally>& tallies,
                      const std::vector<tacmap::localization_config>& configs) {
  std::printf(
      "\n| configuration | touches | ECE P(error <= 5 mm), points | ECE heading | ECE "
      "appearance | \"localized\": precision %% | recall %% at touch 1, 2, ... | "
      "\"contradicted\" %%: at a fault / elsewhere |\n"
      "|---|---|---|---|---|---|---|---|\n");
  for (const auto& config : configs) {
    const auto it = tallies.find(config_label(config));
    if (it == tallies.end()) continue;
    const confidence_tally& t = it->second;
    std::size_t said = 0, said_right = 0;
    std::string recall;
    for (std::size_t k = 0; k < t.right.size(); ++k) {
      said += t.said[k];
      said_right += t.said_and_right[k];
      recall += (k == 0 ? "" : ", ") + percent(t.said_and_right[k], t.right[k]);
    }
    std::printf("| %s | %zu | %s | %s | %s | %s (%zu of %zu) | %s | %s / %s |\n",
                config_label(config).c_str(), t.within.size(),
                ece_text(t.within, t.within_ok).c_str(), ece_text(t.heading, t.heading_ok).c_str(),
                ece_text(t.appearance, t.appearance_ok).c_str(), percent(said_right, said).c_str(),
                said_right, said, recall.c_str(), percent(t.faulted_flagged, t.faulted).c_str(),
                percent(t.clean_flagged, t.clean).c_str());
  }
}

// Third table: per configuration, over every map — sequences localized (error below 5 mm from
// touch k on, as `tacmap::localized`) by touch 2, 3, 4 and 6: what choosing the touches
// (--touch-order active) is for.
struct early_tally {
  static constexpr std::size_t touches[] = {2, 3, 4, 6};
  std::size_t sequences = 0;
  std::size_t by[std::size(touches)] = {};
  void add(const std::vector<tacmap::touch_record>& run) {
    ++sequences;
    for (std::size_t k = 0; k < std::size(touches); ++k)
      by[k] += tacmap::localized(run, 5.0, touches[k]) ? 1U : 0U;
  }
};

void print_by_touch(const std::map<std::string, early_tally>& tallies,
                    const std::vector<tacmap::localization_config>& configs) {
  std::printf(
      "\n| configuration | touch order | sequences | localized by touch 2 | by touch 3 | by "
      "touch 4 | by touch 6 |\n|---|---|---|---|---|---|---|\n");
  for (const auto& config : configs) {
    const auto it = tallies.find(config_label(config));
    if (it == tallies.end()) continue;
    const early_tally& t = it->second;
    std::printf("| %s | %s | %zu |", config_label(config).c_str(), to_string(config.order),
                t.sequences);
    for (const std::size_t b : t.by) std::printf(" %s (%zu) |", percent(b, t.sequences).c_str(), b);
    std::printf("\n");
  }
}

// --oracle-ceiling: per configuration over every map, the filter's figures under the faults
// and the same sequences' with the filter told about them (the ceiling), side by side.
struct ceiling_tally {
  std::size_t sequences[2] = {0, 0}, localized[2] = {0, 0};
  tacmap::recovery_count within3[2], within5[2];
  void add(const tacmap::sequence_result& run, const tacmap::recovery_count& r3,
           const tacmap::recovery_count& r5, bool told) {
    const int i = told ? 1 : 0;
    ++sequences[i];
    localized[i] += tacmap::localized(run.touches) ? 1U : 0U;
    within3[i] += r3;
    within5[i] += r5;
  }
};

// "k of n (p %)" for the filter and the ceiling, and the filter's rate over the ceiling's.
std::string against_ceiling(std::size_t k, std::size_t n, std::size_t k_told, std::size_t n_told) {
  if (n == 0 || n_told == 0) return "- | - | -";
  const double a = static_cast<double>(k) / static_cast<double>(n);
  const double b = static_cast<double>(k_told) / static_cast<double>(n_told);
  char buf[160];
  std::snprintf(buf, sizeof buf, "%zu / %zu (%.1f %%) | %zu / %zu (%.1f %%) | %s", k, n, 100.0 * a,
                k_told, n_told, 100.0 * b,
                b > 0.0
                    ? (std::to_string(static_cast<int>(std::lround(100.0 * a / b))) + " %").c_str()
                    : "-");
  return buf;
}

void print_ceilings(const std::map<std::string, ceiling_tally>& tallies,
                    const std::vector<tacmap::localization_config>& configs) {
  std::printf(
      "\n| configuration | figure | the filter | told (the ceiling) | ratio |\n"
      "|---|---|---|---|---|\n");
  for (const auto& config : configs) {
    const auto it = tallies.find(config_label(config));
    if (it == tallies.end()) continue;
    const ceiling_tally& t = it->second;
    std::printf(
        "| %s | localized | %s |\n", config_label(config).c_str(),
        against_ceiling(t.localized[0], t.sequences[0], t.localized[1], t.sequences[1]).c_str());
    // Odometry noise alone has no discrete faults to recover from.
    if (t.within3[0].faults == 0 && t.within3[1].faults == 0) continue;
    std::printf("| %s | back within 3 touches of a fault | %s |\n", config_label(config).c_str(),
                against_ceiling(t.within3[0].recovered, t.within3[0].counted,
                                t.within3[1].recovered, t.within3[1].counted)
                    .c_str());
    std::printf("| %s | back within 5 touches of a fault | %s |\n", config_label(config).c_str(),
                against_ceiling(t.within5[0].recovered, t.within5[0].counted,
                                t.within5[1].recovered, t.within5[1].counted)
                    .c_str());
  }
}

// The conditions a run was made under, one line above its tables (issue 34: every condition in
// the tables): the scenario's name, then each effect that is on, grouped as photograph, sensor
// and contact.
std::string conditions_text(const char* scenario, const tacmap::simulator_params& sim,
                            const tacmap::scenario_params& e) {
  std::string photo, sensor, contact;
  const auto add = [](std::string& to, const char* name, double value, double off) {
    if (value == off) return;
    char buf[96];
    std::snprintf(buf, sizeof buf, "%s%s %.4g", to.empty() ? "" : ", ", name, value);
    to += buf;
  };
  add(photo, "texture", e.albedo_variation, 0.0);
  add(photo, "light gradient", e.illumination_gradient, 0.0);
  add(photo, "shading", e.shading, 0.0);
  add(photo, "shadow", e.shadow_depth, 0.0);
  add(photo, "blur px", e.camera_blur_px, 0.0);
  add(photo, "defocus px", e.defocus_px, 0.0);
  add(photo, "noise", e.camera_noise, 0.0);
  add(photo, "gamma", e.camera_gamma, 1.0);
  add(photo, "ink", e.ink_coverage, 0.0);
  add(photo, "albedo contrast", e.albedo_contrast, 1.0);
  add(photo, "mixed polarity", e.mixed_polarity, 0.0);
  add(photo, "scale error", e.map_scale_error, 0.0);
  add(photo, "registration mm", e.registration_shift_mm, 0.0);
  add(photo, "registration deg", e.registration_rotation_deg, 0.0);
  add(sensor, "noise counts", sim.noise_counts, 0.0);
  add(sensor, "gain spread", sim.gain_variation, 0.0);
  add(sensor, "dead", sim.dead_fraction, 0.0);
  add(sensor, "pad spread mm", sim.foam_sigma_mm, 0.0);
  add(sensor, "drift counts", sim.baseline_drift_counts, 0.0);
  add(sensor, "saturation counts", sim.saturation_counts, 0.0);
  add(sensor, "hysteresis", sim.hysteresis, 0.0);
  add(contact, "depth mm", sim.press_depth_mm, -1.0);
  // A burst's settling (--frames-per-press > 1), where it is not the default.
  add(contact, "burst settle start", sim.settle_start, tacmap::simulator_params{}.settle_start);
  add(contact, "burst settle frames", sim.settle_frames, tacmap::simulator_params{}.settle_frames);
  add(contact, "burst bumps", sim.bump_probability, 0.0);
  add(contact, "depth jitter", e.press_depth_jitter, 0.0);
  add(contact, "orientation jitter deg", e.orientation_jitter_deg, 0.0);
  add(contact, "tilt jitter deg", e.tilt_jitter_deg, 0.0);
  add(contact, "light presses", e.light_press_fraction, 0.0);
  if (e.light_press_fraction > 0.0) add(contact, "at depth x", e.light_press_scale, -1.0);
  add(contact, "partial presses", e.partial_press_fraction, 0.0);
  if (e.partial_press_fraction > 0.0) add(contact, "tilted deg", e.partial_press_tilt_deg, -1.0);
  return std::string("Conditions (scenario ") + scenario + ", polarity " +
         tacmap::to_string(e.polarity) + "): photograph: " + (photo.empty() ? "clean" : photo) +
         "; sensor: " + (sensor.empty() ? "ideal" : sensor) + "; contact: " + contact + ".";
}

}  // namespace

int main(int argc, char** argv) try {
  CLI::App app{
      "tacmap-evaluate: localization over maps x configurations (paper Sec. IV-B); a summary "
      "table per map and one CSV row per touch (docs/tools.md)\n\n"
      "Examples:\n"
      "  tacmap-evaluate --output gecko.csv\n"
      "      the bundled gecko, the default configuration, all 22 sequences\n"
      "  tacmap-evaluate --no-gecko --photo object.jpg --scenario realistic --output object.csv\n"
      "      your photograph as the map (longer side 120 px), a simulated camera and sensor\n"
      "  tacmap-evaluate --model sift_lite,ncc --sequences 6 --output compare.csv\n"
      "      two configurations compared (comma-separated lists: their cross product)\n"};
  std::string gecko_dir;  // empty: default_gecko_dir()
  bool no_gecko = false;
  std::vector<std::string> photos;
  std::vector<std::string> models{"classic_sift"}, pairings{"aligned"}, shapes{"exponential"},
      features{"per_window"}, appearances{"latent"};
  std::vector<double> appearance_switches;  // empty: the configuration's default
  // Signed, so that a negative count is refused rather than wrapped to "all".
  long long sequences = 0;
  std::size_t max_sequences = 0;
  std::uint64_t seed = 1;
  std::vector<double> taus;
  std::string scenario_name = "ideal";
  std::string polarity_name;  // empty: the scenario's
  double tempering = 1.0, motion_sigma = 1.0;
  int motion_k = 8;
  long long patch_spacing = 0;  // 0: the model's default
  std::vector<int> headings{0};
  bool random_orientation = false;
  double turn_sigma_deg = 5.0;
  std::string output = "evaluation.csv";
  double min_success = -1.0;
  bool quiet = false;
  bool library = false;
  long long library_sequences = -1;  // -1: as many as the maps' sequences together
  tacmap::library_likelihood_params library_params;
  std::string library_mode_name = "closed";
  double prior_unknown = tacmap::open_set_params{}.prior_unknown;
  tacmap::open_set_params unknown_model;  // its prior_unknown is --prior-unknown's
  std::string unknown_model_name = "support";
  // Overrides of the scenario's knobs: empty = the scenario's value.
  struct knob {
    const char* flag;
    const char* help;
    double lo, hi;
    std::optional<double> value;
  };
  std::vector<knob> sensor_knobs{
      {"--noise-counts", "sensor read-out noise, counts (of 4095)", 0.0, 4095.0, {}},
      {"--gain-variation", "relative per-taxel gain spread", 0.0, 10.0, {}},
      {"--dead-fraction", "fraction of dead taxels", 0.0, 1.0, {}},
      {"--press-depth", "indentation of the highest point, mm", 0.0, 100.0, {}},
      {"--foam-sigma", "load spread by the foam cover, mm", 0.0, 100.0, {}},
  };
  // The lab's conditions (issue 34): their own list, so the older knobs keep their order.
  std::vector<knob> lab_sensor_knobs{
      {"--drift",
       "sensor: per-frame std of the taxels' baseline random walk, counts",
       0.0,
       4095.0,
       {}},
      {"--saturation", "sensor: soft saturation level, counts (0 = linear)", 0.0, 1e6, {}},
      {"--hysteresis", "sensor: fraction of the previous frame that persists", 0.0, 0.99, {}},
      {"--settle-start",
       "--frames-per-press > 1: depth fraction of a burst's first frame (1 = no settling)",
       0.0,
       1.0,
       {}},
      {"--settle-frames",
       "--frames-per-press > 1: time constant of the settling, frames",
       0.0,
       1000.0,
       {}},
      {"--bumps",
       "--frames-per-press > 1: probability that a frame of a burst is read during a bump "
       "(its force off by up to 60 %, the array slid by half a pitch)",
       0.0,
       1.0,
       {}},
  };
  std::vector<knob> lab_scenario_knobs{
      {"--shadow",
       "camera map: fraction of the light a cast shadow takes (0 = none)",
       0.0,
       1.0,
       {}},
      {"--shadow-edge", "camera map: the shadow's penumbra, map px", 0.0, 100.0, {}},
      {"--defocus", "camera map: defocus disc radius, map px", 0.0, 50.0, {}},
      {"--map-scale-error",
       "the map's scale is off by this fraction (sign per sequence)",
       0.0,
       0.3,
       {}},
      {"--light-presses", "contact: fraction of presses that are light", 0.0, 1.0, {}},
      {"--light-press-scale",
       "contact: depth of a light press, fraction of the nominal",
       0.0,
       1.0,
       {}},
      {"--partial-presses",
       "contact: fraction of presses that land tilted (partial contact)",
       0.0,
       1.0,
       {}},
      {"--partial-press-tilt", "contact: tilt of a partial press, degrees", 0.0, 20.0, {}},
  };
  long long self_calibrate = -1;  // -1: off; N >= 0: on, after N warm-up touches
  std::vector<knob> scenario_knobs{
      {"--albedo-variation",
       "camera map: relative std of the print's surface texture",
       0.0,
       1.0,
       {}},
      {"--albedo-scale", "camera map: texture grain, map px", 0.0, 100.0, {}},
      {"--illumination-gradient", "camera map: peak-to-peak illumination change", 0.0, 1.9, {}},
      {"--shading", "camera map: fraction of directional light (0 = diffuse)", 0.0, 1.0, {}},
      {"--light-elevation", "camera map: light's elevation, degrees", 1.0, 90.0, {}},
      {"--camera-blur", "camera map: blur sigma, map px", 0.0, 100.0, {}},
      {"--camera-noise", "camera map: noise std (intensity of 1)", 0.0, 1.0, {}},
      {"--camera-gamma", "camera map: tone-curve gamma (1 = linear)", 0.1, 10.0, {}},
      {"--registration-shift", "object-to-map shift per sequence, mm", 0.0, 50.0, {}},
      {"--registration-rotation", "object-to-map rotation per sequence, degrees", 0.0, 45.0, {}},
      {"--orientation-jitter", "per-press orientation std, degrees", 0.0, 45.0, {}},
      {"--tilt-jitter", "per-press tilt std, degrees", 0.0, 5.0, {}},
      {"--press-depth-jitter", "per-press relative depth std", 0.0, 1.0, {}},
      {"--ink-coverage", "camera map: fraction of the area covered by printed ink", 0.0, 1.0, {}},
      {"--ink-contrast", "camera map: ink opacity towards black or white", 0.0, 1.0, {}},
      {"--albedo-contrast",
       "camera map: fraction of the image's contrast the object's colour keeps (0 = one colour)",
       0.0,
       1.0,
       {}},
      {"--mixed-polarity",
       "relief: fraction of the area where height and brightness relate the other way",
       0.0,
       1.0,
       {}},
  };
  app.add_option("--gecko", gecko_dir,
                 "folder of the gecko protocol (protocol.txt); default: the installed data, "
                 "<executable's folder>/" TACMAP_INSTALLED_DATA_DIR "/gecko, else " TACMAP_DATA_DIR
                 "/gecko");
  app.add_flag("--no-gecko", no_gecko, "do not evaluate on the gecko");
  app.add_option("--photo", photos, "photograph(s) to use as maps (PNG/JPEG/PGM)")
      ->check(CLI::ExistingFile);
  app.add_option("--model", models, "sift_lite, classic_sift, ncc (comma-separated)")
      ->delimiter(',');
  app.add_option("--pairing", pairings, "all_pairs, aligned")->delimiter(',');
  app.add_option("--shape", shapes, "inverse, exponential")->delimiter(',');
  app.add_option("--features", features, "per_window, shared_dense")->delimiter(',');
  app.add_option("--appearance", appearances,
                 "how the map's brightness relates to height: latent (default: both "
                 "relations as hypotheses of the filter), fixed (raised = bright, as before), "
                 "unsigned (unsigned-orientation descriptors), per_patch (each patch with "
                 "either sign); comma-separated to compare")
      ->delimiter(',');
  app.add_option("--appearance-switch", appearance_switches,
                 "latent appearance: probability that the hypothesis changes between touches "
                 "(comma-separated to compare; default 0.05)")
      ->delimiter(',')
      ->check(CLI::Range(0.0, 0.5));
  // Exploration faults (sim/faults.hpp).
  tacmap::exploration_faults faults;
  std::size_t photo_touches = 7;
  tacmap_tools::map_sizing_options sizing_options;
  double odometry_noise = -1.0;
  app.add_option("--outliers", faults.outlier_probability,
                 "fault: probability that a move's odometry is off by --outlier-size")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--outlier-size", faults.outlier_mm, "fault: an odometry outlier's error, mm (8)")
      ->check(CLI::Range(0.0, 100.0));
  app.add_option("--odometry-noise", odometry_noise,
                 "fault: the true odometry noise per axis, mm (default: the protocol's 0.5)")
      ->check(CLI::Range(0.0, 50.0));
  app.add_option("--slip-touch", faults.slip_touch,
                 "fault: the object slips by --slip mm before this touch (1-based; 0 = none)");
  app.add_option("--slip", faults.slip_mm, "fault: how far the object slips, mm (20)")
      ->check(CLI::Range(0.001, 100.0));
  std::string oracle_name = "none";
  app.add_option("--fault-oracle", oracle_name,
                 "a ceiling, not a method: what the filter is told about the faults: none, "
                 "transition (after every move the belief is mixed with its ring of "
                 "--outlier-size, weight --outliers: the outliers' true motion model), told "
                 "(after each outlier move the belief is replaced by its ring of --outlier-size, "
                 "at the slip's touch by its ring of --slip: when and how far, not which way); "
                 "on top of the filter's own floor and wide component (--wide-probability 0 "
                 "turns the latter off)");
  app.add_option("--kidnap-touch", faults.kidnap_touch,
                 "fault: the sensor is put down elsewhere at this touch, odometry as usual "
                 "(1-based; 0 = none)");
  std::vector<double> lost_probabilities;  // empty: the configuration's default
  std::vector<std::string> storages;       // empty: the configuration's default
  app.add_option("--storage", storages,
                 "per-window descriptors of the planar descriptor models: float32, int8 "
                 "(comma-separated to compare; default: the model's)")
      ->delimiter(',');
  app.add_option("--lost-probability", lost_probabilities,
                 "probability that a move lands the sensor anywhere (robust_motion; "
                 "comma-separated to compare; default: the configuration's)")
      ->delimiter(',')
      ->check(CLI::Range(0.0, 0.999));
  std::vector<double> wide_probabilities;
  double wide_sigma = tacmap::localizer_config{}.wide_sigma_mm;
  app.add_option("--wide-probability", wide_probabilities,
                 "probability that a move is off by more than --motion-sigma: a wide component "
                 "of --wide-sigma (robust_motion; comma-separated to compare; default 0.1)")
      ->delimiter(',')
      ->check(CLI::Range(0.0, 0.999));
  double pad_spread = -1.0;  // not given: the localizer's default, half the sensor's pitch
  app.add_option("--pad-spread", pad_spread,
                 "the map as the sensor sees it: blurred by this Gaussian sigma, mm, before it is "
                 "described (localizer_config::pad_spread_mm; default: half the sensor's pitch, "
                 "1.7; 0 = the map as photographed)")
      ->check(CLI::Range(0.0, tacmap::detail::max_pad_spread_mm));
  app.add_option("--wide-sigma", wide_sigma, "the wide component's spread, mm per axis (3)")
      ->check(CLI::Range(0.01, 100.0));
  std::vector<double> broad_probabilities;
  double broad_sigma = tacmap::localizer_config{}.broad_sigma_mm;
  app.add_option("--broad-probability", broad_probabilities,
                 "probability that a move is off by centimetres (a slip): a broad component of "
                 "--broad-sigma (robust_motion; comma-separated to compare; default 0)")
      ->delimiter(',')
      ->check(CLI::Range(0.0, 0.999));
  app.add_option("--broad-sigma", broad_sigma, "the broad component's spread, mm per axis (10)")
      ->check(CLI::Range(0.01, 1000.0));
  app.add_option("--touches", photo_touches,
                 "touches per sequence of the photographs' protocols (7; the gecko's are fixed)")
      ->check(CLI::Range(1, 200));
  sizing_options.add_to(app);
  app.add_option("--sequences", sequences, "run only the first N sequences of each map (0 = all)");
  app.add_option("--seed", seed, "seeds the simulator and the photographs' protocols")
      ->check(CLI::NonNegativeNumber);  // an unsigned option: -1 would wrap
  app.add_option("--tau", taus,
                 "temperature(s) (exponential shape / NCC), comma-separated; default: the model's")
      ->delimiter(',');
  app.add_option("--tempering", tempering, "exponent on the likelihood")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--motion-sigma", motion_sigma, "odometry noise sigma, mm")
      ->check(CLI::PositiveNumber);
  app.add_option("--spacing", patch_spacing,
                 "px between the tactile image's descriptor patches (default: classic_sift 13, "
                 "sift_lite and headings > 0 the paper's 9)")
      ->check(CLI::PositiveNumber);
  app.add_option("--motion-k", motion_k, "odometry noise neighbours (4, 8, 12, 20, 24, ...)");
  app.add_option("--headings", headings,
                 "0 = known orientation (the paper); N = localize x, y AND heading over N "
                 "headings (comma-separated list to compare, e.g. 0,36)")
      ->delimiter(',')
      ->check(CLI::Range(0, 3600));
  bool tracking = false;
  app.add_flag("--tracking", tracking,
               "the filter tracks once localized with tacmap::default_tracking() changed by the "
               "--tracking-* options (the default already tracks with default_tracking())");
  bool no_tracking = false;
  app.add_flag("--no-tracking", no_tracking,
               "every touch evaluates the whole grid (localizer_config::tracking empty; the "
               "default tracks once localized)");
  tacmap::tracking_params tracking_tuned = tacmap::default_tracking();
  app.add_option("--tracking-doubt", tracking_tuned.doubt,
                 "--tracking: the estimated prediction support (nats) below which a touch takes "
                 "the whole grid");
  app.add_option("--tracking-recheck", tracking_tuned.recheck_every,
                 "--tracking: the whole grid every this many tracked touches (0 = never)");
  app.add_option("--tracking-sample", tracking_tuned.sample_every,
                 "--tracking: each tracked touch also evaluates every this many-th row of the "
                 "grid, the sample its doubt is judged against (0 = none)");

  std::vector<std::string> touch_orders{"random"};
  app.add_option("--touch-order", touch_orders,
                 "where each touch after the first goes: random (the protocol's random orders) "
                 "or active (chosen by localizer::next_touch among --active-candidates random "
                 "positions on the map; known heading, no faults); a comma-separated list runs "
                 "each")
      ->delimiter(',');
  std::vector<std::size_t> frames_per_press{1};
  app.add_option("--frames-per-press", frames_per_press,
                 "frames the sensor reads per press (1 = one settled frame); more make a burst "
                 "with its own noise per frame and a settling head, combined by the localizer's "
                 "burst overload (combine_burst with localizer_config::burst); a comma-separated "
                 "list runs each (e.g. 1,5,20; the paper read 20)")
      ->delimiter(',')
      ->check(CLI::Range(1, 1000));
  std::vector<std::string> burst_combine{"robust"};
  app.add_option("--burst-combine", burst_combine,
                 "how a burst (--frames-per-press > 1) becomes one frame: robust (the "
                 "localizer's default: the settling head and outlier frames dropped, each "
                 "taxel's median), trimmed (the same frames, each taxel's 20 % trimmed mean) or "
                 "mean (every frame averaged: the reference); a comma-separated list runs each")
      ->delimiter(',')
      ->check(CLI::IsMember({"robust", "trimmed", "mean"}));
  std::size_t active_candidates = 32;
  app.add_option("--active-candidates", active_candidates,
                 "--touch-order active: candidate positions drawn per touch")
      ->check(CLI::Range(1, 10000));
  double active_min_move = 0.0;
  app.add_option("--active-min-move", active_min_move,
                 "--touch-order active: candidates at least this far from the previous touch, mm")
      ->check(CLI::Range(0.0, 1000.0));
  bool weigh_by_landing = false;
  app.add_flag("--next-touch-weigh-landing", weigh_by_landing,
               "--touch-order active: weigh each move's score by the belief's probability that "
               "it lands on the map (next_touch_params::weigh_by_landing)");
  double likelihood_scale = tacmap::next_touch_params{}.likelihood_scale;
  app.add_option("--next-touch-likelihood-scale", likelihood_scale,
                 "--touch-order active: factor on the predicted log-likelihoods, (0, 1] "
                 "(next_touch_params::likelihood_scale)")
      ->check(CLI::Range(1e-6, 1.0));
  int next_touch_hypotheses = tacmap::next_touch_params{}.hypotheses;
  app.add_option("--next-touch-hypotheses", next_touch_hypotheses,
                 "--touch-order active: hypotheses drawn from the belief per ranking "
                 "(next_touch_params::hypotheses; the cost grows as its square)")
      ->check(CLI::Range(1, 4096));
  std::string next_touch_objective = "verdict";
  app.add_option(
      "--next-touch-objective", next_touch_objective,
      "--touch-order active: what next_touch maximises, verdict (the expected probability "
      "within the verdict's radius; the default) or entropy (the expected entropy "
      "reduction)");
  bool oracle_ceiling = false;
  app.add_flag("--oracle-ceiling", oracle_ceiling,
               "run every sequence again with the filter told about the faults (--fault-oracle "
               "told for outliers and a slip, the true --odometry-noise as its motion noise) and "
               "print the filter's figures against that ceiling");
  bool slip_recheck = false;
  app.add_flag("--slip-recheck", slip_recheck,
               "the filter looks again, as a slip, at a touch that doubts its prediction "
               "(localizer_config::slip_recheck, off by default)");
  tacmap::slip_recheck_params recheck;
  app.add_option("--slip-recheck-doubt", recheck.doubt,
                 "--slip-recheck: the touch's log prediction support below which it runs (-1)")
      ->check(CLI::Range(-1000.0, 0.0));
  app.add_option("--slip-recheck-broad", recheck.broad_probability,
                 "--slip-recheck: the slip hypothesis's share of the prediction (0.3)")
      ->check(CLI::Range(0.001, 0.9));
  app.add_flag("--random-orientation", random_orientation,
               "configurations with headings > 0: each sequence's sensor heading is drawn "
               "uniformly (known-orientation ones keep heading 0)");
  app.add_option("--turn-sigma", turn_sigma_deg, "heading noise of the pose motion model, degrees")
      ->check(CLI::PositiveNumber);
  app.add_option("--output,-o", output, "CSV file to write");
  app.add_option(
         "--min-success-rate", min_success,
         "exit 1 when any map x configuration localizes fewer than this fraction of sequences")
      ->check(CLI::Range(0.0, 1.0));
  app.add_flag("--library", library,
               "which object, and where: every map is one object of one library; each sequence "
               "touches a random object, localized over the whole library (tables: recognition, "
               "localization, confusion)");
  app.add_option("--library-sequences", library_sequences,
                 "--library: sequences per configuration (default: the maps' sequences together)");
  app.add_option("--evidence-exponent", library_params.evidence_exponent,
                 "--library: exponent on each object's evidence (1 = Bayes)")
      ->check(CLI::Range(0.25, 8.0));
  app.add_option("--prune-below", library_params.prune_below,
                 "--library: posterior below which an object is no longer evaluated (1e-9)")
      ->check(CLI::Range(0.0, 0.01));
  app.add_option("--library-mode", library_mode_name,
                 "--library: closed (every sequence's object in the library), left-out (open set: "
                 "each sequence's own photograph left out of the library), wrong-object (each "
                 "object's touches on the next object's single map) or own-map (each object's "
                 "touches on its own single map)")
      ->capture_default_str();
  app.add_option("--prior-unknown", prior_unknown,
                 "prior probability that the touched surface is none of the maps, in (0, 1)")
      ->capture_default_str();
  app.add_option("--unknown-evidence-weight", unknown_model.evidence_weight,
                 "open set: the weight a on each touch's evidence, in (0, 1] (1: memoryless)")
      ->capture_default_str();
  app.add_option("--unknown-support-margin", unknown_model.support_margin,
                 "open set: the margin d, in nats, a touch's prediction support needs before it "
                 "counts for the maps, in [0, 20] (0: memoryless)")
      ->capture_default_str();
  app.add_option("--unknown-model", unknown_model_name,
                 "open set: support (each touch's prediction support, eq. 1 of "
                 "filter/open_set.hpp) or shadow (its evidence against a shadow filter over the "
                 "mirrored maps, eq. 2)")
      ->capture_default_str();
  app.add_option("--unknown-shadow-weight", unknown_model.shadow_weight,
                 "open set, shadow model: the weight b on each touch's evidence against the "
                 "shadow's, in (0, 1]")
      ->capture_default_str();
  app.add_option("--unknown-shadow-support-weight", unknown_model.shadow_support_weight,
                 "open set, shadow model: the weight c on each touch's support, in [0, 1]")
      ->capture_default_str();
  app.add_option("--unknown-shadow-margin", unknown_model.shadow_margin,
                 "open set, shadow model: the margin m in nats per touch, in [-20, 20]")
      ->capture_default_str();
  app.add_flag("--quiet,-q", quiet, "no progress bar (it is drawn only when stderr is a terminal)");
  app.add_option("--scenario", scenario_name,
                 "ideal (the map's own image, a new sensor), realistic (camera map, "
                 "misregistration, press jitter, worn sensor; sim/scenario.hpp), unknown "
                 "(realistic, plus random polarity, mixed polarity and printed ink) or harsh "
                 "(unknown, plus a lab's conditions: docs/simulator.md)");
  app.add_option("--polarity", polarity_name,
                 "relief: raised parts bright, dark, or random (drawn per sequence) "
                 "(default: the scenario's)");
  for (auto* knobs : {&sensor_knobs, &scenario_knobs, &lab_sensor_knobs, &lab_scenario_knobs})
    for (auto& k : *knobs)
      app.add_option(k.flag, k.value, std::string(k.help) + " (default: the scenario's)")
          ->check(CLI::Range(k.lo, k.hi));
  app.add_option("--self-calibrate", self_calibrate,
                 "correct every frame by a self_calibration of the sensor "
                 "(tactile/self_calibration.hpp) that has seen N touches at random poses before "
                 "each sequence (e.g. 56; 0 = only the sequence's own); default: off")
      ->check(CLI::Range(0LL, 100000LL));
  app.footer(tacmap_tools::exit_status_footer);
  if (const auto status = tacmap_tools::parse(app, argc, argv)) return *status;
  // The progress bar redraws one line with carriage returns: on a terminal only, never into
  // a log file.
  quiet = quiet || isatty(fileno(stderr)) == 0;

  if (sequences < 0)
    throw CLI::ValidationError("--sequences", std::to_string(sequences) +
                                                  " is not a number of sequences; expected N >= 0 "
                                                  "(the first N of each map; 0 = all)");
  max_sequences = static_cast<std::size_t>(sequences);
  const tacmap_tools::map_sizing sizing = sizing_options.chosen();
  if (odometry_noise >= 0.0) faults.odometry_sigma_mm = odometry_noise;
  faults.oracle =
      parse_choice<tacmap::fault_oracle>("--fault-oracle", oracle_name,
                                         {{"none", tacmap::fault_oracle::none},
                                          {"transition", tacmap::fault_oracle::transition},
                                          {"told", tacmap::fault_oracle::told}});
  try {
    faults.validate();
  } catch (const std::invalid_argument& e) {
    throw CLI::ValidationError("faults", e.what());
  }
  if (oracle_ceiling &&
      !(faults.outlier_probability > 0.0 || faults.slip_touch > 0 || faults.odometry_sigma_mm))
    throw CLI::ValidationError("--oracle-ceiling",
                               "there is no fault to tell the filter about; expected --outliers, "
                               "--slip-touch or --odometry-noise (kidnaps have no oracle)");
  if (oracle_ceiling && faults.oracle != tacmap::fault_oracle::none)
    throw CLI::ValidationError("--oracle-ceiling",
                               "with --fault-oracle " + oracle_name +
                                   "; expected --fault-oracle none: the ceiling is the oracle");
  const auto scenario =
      parse_choice<tacmap::scenario_kind>("--scenario", scenario_name,
                                          {{"ideal", tacmap::scenario_kind::ideal},
                                           {"realistic", tacmap::scenario_kind::realistic},
                                           {"unknown", tacmap::scenario_kind::unknown},
                                           {"harsh", tacmap::scenario_kind::harsh}});
  tacmap::simulator_params sim;  // the simulated sensor's physics (defaults: the paper's array)
  tacmap::scenario_params effects;
  if (scenario == tacmap::scenario_kind::realistic) {
    sim = tacmap::realistic_sensor(sim);
    effects = tacmap::scenario_params::realistic();
  } else if (scenario == tacmap::scenario_kind::unknown) {
    sim = tacmap::realistic_sensor(sim);
    effects = tacmap::scenario_params::unknown_object();
  } else if (scenario == tacmap::scenario_kind::harsh) {
    sim = tacmap::harsh_sensor(sim);
    effects = tacmap::scenario_params::harsh();
  }
  if (!polarity_name.empty())
    effects.polarity = parse_choice<tacmap::relief_polarity>(
        "--polarity", polarity_name,
        {{tacmap::to_string(tacmap::relief_polarity::bright_raised),
          tacmap::relief_polarity::bright_raised},
         {tacmap::to_string(tacmap::relief_polarity::dark_raised),
          tacmap::relief_polarity::dark_raised},
         {tacmap::to_string(tacmap::relief_polarity::random), tacmap::relief_polarity::random}});
  const auto set = [](const knob& k, auto& field) {
    if (k.value) field = *k.value;
  };
  set(sensor_knobs[0], sim.noise_counts);
  set(sensor_knobs[1], sim.gain_variation);
  set(sensor_knobs[2], sim.dead_fraction);
  set(sensor_knobs[3], sim.press_depth_mm);
  set(sensor_knobs[4], sim.foam_sigma_mm);
  double* const fields[] = {&effects.albedo_variation,       &effects.albedo_scale_px,
                            &effects.illumination_gradient,  &effects.shading,
                            &effects.light_elevation_deg,    &effects.camera_blur_px,
                            &effects.camera_noise,           &effects.camera_gamma,
                            &effects.registration_shift_mm,  &effects.registration_rotation_deg,
                            &effects.orientation_jitter_deg, &effects.tilt_jitter_deg,
                            &effects.press_depth_jitter,     &effects.ink_coverage,
                            &effects.ink_contrast,           &effects.albedo_contrast,
                            &effects.mixed_polarity};
  static_assert(std::size(fields) == 17);
  for (std::size_t i = 0; i < std::size(fields); ++i) set(scenario_knobs[i], *fields[i]);
  set(lab_sensor_knobs[0], sim.baseline_drift_counts);
  set(lab_sensor_knobs[1], sim.saturation_counts);
  set(lab_sensor_knobs[2], sim.hysteresis);
  set(lab_sensor_knobs[3], sim.settle_start);
  set(lab_sensor_knobs[4], sim.settle_frames);
  set(lab_sensor_knobs[5], sim.bump_probability);
  double* const lab_fields[] = {
      &effects.shadow_depth,           &effects.shadow_edge_px,        &effects.defocus_px,
      &effects.map_scale_error,        &effects.light_press_fraction,  &effects.light_press_scale,
      &effects.partial_press_fraction, &effects.partial_press_tilt_deg};
  static_assert(std::size(lab_fields) == 8);
  for (std::size_t i = 0; i < std::size(lab_fields); ++i)
    set(lab_scenario_knobs[i], *lab_fields[i]);
  sim.validate();
  effects.validate();
  const std::string calibration_text = self_calibrate < 0 ? std::string()
                                                          : " Self-calibration: on, after " +
                                                                std::to_string(self_calibrate) +
                                                                " warm-up touches per sequence.";
  if (!(std::isfinite(prior_unknown) && prior_unknown > 0.0 && prior_unknown < 1.0))
    throw CLI::ValidationError("--prior-unknown",
                               csv_number(prior_unknown) +
                                   " is not a probability in (0, 1); expected the prior that the "
                                   "touched surface is none of the maps (e.g. 0.5)");
  unknown_model.prior_unknown = prior_unknown;
  try {  // each field alone, so that the message names its option
    tacmap::open_set_params{.evidence_weight = unknown_model.evidence_weight}.validate();
  } catch (const std::invalid_argument& e) {
    throw CLI::ValidationError("--unknown-evidence-weight", e.what());
  }
  try {
    tacmap::open_set_params{.support_margin = unknown_model.support_margin}.validate();
  } catch (const std::invalid_argument& e) {
    throw CLI::ValidationError("--unknown-support-margin", e.what());
  }
  unknown_model.model = parse_choice<tacmap::unknown_model>(
      "--unknown-model", unknown_model_name,
      {{"support", tacmap::unknown_model::support}, {"shadow", tacmap::unknown_model::shadow}});
  try {
    tacmap::open_set_params{.shadow_weight = unknown_model.shadow_weight}.validate();
  } catch (const std::invalid_argument& e) {
    throw CLI::ValidationError("--unknown-shadow-weight", e.what());
  }
  try {
    tacmap::open_set_params{.shadow_support_weight = unknown_model.shadow_support_weight}
        .validate();
  } catch (const std::invalid_argument& e) {
    throw CLI::ValidationError("--unknown-shadow-support-weight", e.what());
  }
  try {
    tacmap::open_set_params{.shadow_margin = unknown_model.shadow_margin}.validate();
  } catch (const std::invalid_argument& e) {
    throw CLI::ValidationError("--unknown-shadow-margin", e.what());
  }
  const auto mode = parse_choice<tacmap_tools::library_mode>(
      "--library-mode", library_mode_name,
      {{"closed", tacmap_tools::library_mode::closed},
       {"left-out", tacmap_tools::library_mode::left_out},
       {"wrong-object", tacmap_tools::library_mode::wrong_object},
       {"own-map", tacmap_tools::library_mode::own_map}});
  if (mode != tacmap_tools::library_mode::closed && !library)
    throw CLI::ValidationError("--library-mode",
                               library_mode_name + " needs --library (the maps as one library)");
  std::vector<std::optional<double>> tau_values;
  for (const double t : taus) {
    if (!(std::isfinite(t) && t > 0.0))
      throw CLI::ValidationError("--tau", csv_number(t) +
                                              " is not a temperature; expected finite values > 0 "
                                              "(e.g. --tau 0.5,1,2)");
    tau_values.emplace_back(t);
  }
  if (tau_values.empty()) tau_values.emplace_back();  // the model's own default

  // Configurations: the cross product; NCC once (pairing, shape and features do not apply).
  std::vector<tacmap::localization_config> configs;
  for (const auto& m : models) {
    const auto kind =
        parse_choice<tacmap::measurement_kind>("--model", m,
                                               {{"sift_lite", tacmap::measurement_kind::lite},
                                                {"classic_sift", tacmap::measurement_kind::classic},
                                                {"ncc", tacmap::measurement_kind::ncc}});
    tacmap::localization_config base;
    base.model = kind;
    base.tempering = tempering;
    base.motion_sigma_mm = motion_sigma;
    base.motion_k = motion_k;
    if (patch_spacing > 0) base.patch_spacing = patch_spacing;
    base.simulator_seed = seed;
    base.open_set = unknown_model;
    base.simulator = sim;
    base.scenario = effects;
    base.faults = faults;
    base.self_calibrate = self_calibrate >= 0;
    base.calibration_warmup = self_calibrate > 0 ? static_cast<std::size_t>(self_calibrate) : 0;
    if (tracking) base.tracking = tracking_tuned;
    if (no_tracking) base.tracking.reset();
    if (slip_recheck) base.slip_recheck = recheck;
    if (kind == tacmap::measurement_kind::ncc) {
      for (const auto& t : tau_values) {
        auto c = base;
        c.tau = t;
        configs.push_back(c);
      }
      continue;
    }
    for (const auto& pr : pairings)
      for (const auto& sh : shapes)
        for (const auto& fe : features)
          for (const auto& t : tau_values) {
            auto c = base;
            c.tau = t;
            c.pairs = parse_choice<tacmap::pairing>(
                "--pairing", pr,
                {{"all_pairs", tacmap::pairing::all_pairs}, {"aligned", tacmap::pairing::aligned}});
            c.shape = parse_choice<tacmap::likelihood_shape>(
                "--shape", sh,
                {{"inverse", tacmap::likelihood_shape::inverse},
                 {"exponential", tacmap::likelihood_shape::exponential}});
            c.features = parse_choice<tacmap::window_features>(
                "--features", fe,
                {{"per_window", tacmap::window_features::per_window},
                 {"shared_dense", tacmap::window_features::shared_dense}});
            // tau only acts on the exponential shape: one inverse configuration, not one per tau.
            if (c.shape == tacmap::likelihood_shape::inverse) {
              c.tau.reset();
              const auto same = [&](const tacmap::localization_config& o) {
                return o.name() == c.name();
              };
              if (std::any_of(configs.begin(), configs.end(), same)) continue;
            }
            configs.push_back(c);
          }
  }

  // One copy of every configuration per --lost-probability and per --wide-probability value.
  const auto expand = [&](const std::vector<double>& values, auto assign) {
    if (values.empty()) return;
    std::vector<tacmap::localization_config> expanded;
    for (const double v : values)
      for (auto c : configs) {
        assign(c, v);
        expanded.push_back(c);
      }
    configs = std::move(expanded);
  };
  expand(lost_probabilities,
         [](tacmap::localization_config& c, double v) { c.lost_probability = v; });
  if (!storages.empty()) {
    std::vector<tacmap::localization_config> expanded;
    for (const auto& name : storages) {
      const auto storage = parse_choice<tacmap::descriptor_storage>(
          "--storage", name,
          {{"float32", tacmap::descriptor_storage::float32},
           {"int8", tacmap::descriptor_storage::int8}});
      for (auto c : configs) {
        c.storage = storage;
        expanded.push_back(c);
      }
    }
    configs = std::move(expanded);
  }
  for (auto& c : configs) c.wide_sigma_mm = wide_sigma;
  if (pad_spread >= 0.0)
    for (auto& c : configs) c.pad_spread_mm = pad_spread;
  expand(wide_probabilities,
         [](tacmap::localization_config& c, double v) { c.wide_probability = v; });
  for (auto& c : configs) c.broad_sigma_mm = broad_sigma;
  expand(broad_probabilities,
         [](tacmap::localization_config& c, double v) { c.broad_probability = v; });

  // One copy of every configuration per --headings value (NCC only with known orientation).
  {
    std::vector<tacmap::localization_config> expanded;
    for (const int h : headings)
      for (auto c : configs) {
        if (h > 0 && c.model == tacmap::measurement_kind::ncc) {
          std::fprintf(stderr,
                       "tacmap-evaluate: skipping ncc with --headings %d (no rotated NCC "
                       "model; descriptor models only)\n",
                       h);
          continue;
        }
        c.headings = h;
        c.random_orientation = h > 0 && random_orientation;
        c.turn_sigma_rad = turn_sigma_deg * std::numbers::pi / 180.0;
        expanded.push_back(c);
      }
    configs = std::move(expanded);
    if (configs.empty())
      throw CLI::ValidationError("--headings",
                                 "no configuration left to run (no rotated NCC model: use "
                                 "--model sift_lite or classic_sift with --headings > 0)");
  }

  // One copy of every configuration per --appearance (and, for latent, --appearance-switch).
  if (!appearance_switches.empty() &&
      std::find(appearances.begin(), appearances.end(), "latent") == appearances.end())
    throw CLI::ValidationError("--appearance-switch",
                               csv_number(appearance_switches.front()) +
                                   " switches between appearance hypotheses, but no --appearance "
                                   "given has them; add --appearance latent");
  {
    std::vector<tacmap::localization_config> expanded;
    for (const auto& a : appearances) {
      const auto handling = parse_choice<tacmap::appearance_handling>(
          "--appearance", a,
          {{"fixed", tacmap::appearance_handling::fixed},
           {"latent", tacmap::appearance_handling::latent},
           {"unsigned", tacmap::appearance_handling::unsigned_gradients},
           {"per_patch", tacmap::appearance_handling::per_patch}});
      // The switch list applies to latent appearances; the others take one unset switch.
      std::vector<std::optional<double>> switches;
      if (handling == tacmap::appearance_handling::latent)
        switches.assign(appearance_switches.begin(), appearance_switches.end());
      if (switches.empty()) switches.emplace_back();  // the configuration's default
      for (const auto& sw : switches) {
        for (auto c : configs) {
          c.appearance = handling;
          c.appearance_switch = sw;
          try {  // the configuration's own rules (e.g. no descriptors in NCC): skip, say why
            c.validate();
          } catch (const std::invalid_argument& e) {
            std::fprintf(stderr, "tacmap-evaluate: skipping %s: %s\n", c.name().c_str(), e.what());
            continue;
          }
          expanded.push_back(c);
        }
      }
    }
    if (expanded.empty())
      throw CLI::ValidationError("--appearance",
                                 "no configuration left to run (see the skipped ones above)");
    configs = std::move(expanded);
  }

  // One copy of every configuration per --touch-order.
  {
    const auto objective = parse_choice<tacmap::next_touch_objective>(
        "--next-touch-objective", next_touch_objective,
        {{"entropy", tacmap::next_touch_objective::entropy},
         {"verdict", tacmap::next_touch_objective::verdict}});
    std::vector<tacmap::localization_config> expanded;
    for (const auto& name : touch_orders) {
      const auto order = parse_choice<tacmap::touch_order>(
          "--touch-order", name,
          {{"random", tacmap::touch_order::protocol}, {"active", tacmap::touch_order::active}});
      if (order == tacmap::touch_order::active && library && library_mode_name != "closed")
        throw CLI::ValidationError("--touch-order",
                                   "active with --library-mode " + library_mode_name +
                                       "; expected --library-mode closed (the library filter "
                                       "chooses the touches on the object it holds)");
      for (auto c : configs) {
        c.order = order;
        c.active_candidates = active_candidates;
        c.next_touch.objective = objective;
        c.next_touch.weigh_by_landing = weigh_by_landing;
        c.next_touch.likelihood_scale = likelihood_scale;
        c.next_touch.hypotheses = next_touch_hypotheses;
        c.active_min_move_mm = active_min_move;
        if (order == tacmap::touch_order::active) {
          try {  // known heading, no faults: say which configurations cannot run it
            c.validate();
          } catch (const std::invalid_argument& e) {
            std::fprintf(stderr, "tacmap-evaluate: skipping %s: %s\n", config_label(c).c_str(),
                         e.what());
            continue;
          }
        }
        expanded.push_back(c);
      }
    }
    if (expanded.empty())
      throw CLI::ValidationError("--touch-order",
                                 "no configuration left to run (see the skipped ones above)");
    configs = std::move(expanded);
  }

  // One copy of every configuration per --frames-per-press and --burst-combine.
  {
    std::vector<tacmap::localization_config> expanded;
    for (const std::size_t n : frames_per_press)
      for (const std::string& combine : burst_combine) {
        if (n == 1 && combine != burst_combine.front()) continue;  // one frame: nothing to combine
        for (auto c : configs) {
          c.simulator.frames_per_press = n;
          if (combine == "mean") c.burst = plain_mean_burst();
          if (combine == "trimmed") c.burst.statistic = tacmap::burst_statistic::trimmed_mean;
          expanded.push_back(c);
        }
      }
    configs = std::move(expanded);
  }

  std::vector<named_map> maps;
  if (!no_gecko) {
    if (gecko_dir.empty()) gecko_dir = default_gecko_dir(argc > 0 ? argv[0] : nullptr);
    std::fprintf(stderr, "gecko: %s\n", gecko_dir.c_str());  // which data a log was made with
    maps.push_back(
        {"gecko", tacmap::load_protocol(std::filesystem::path(gecko_dir) / "protocol.txt")});
  }
  for (std::size_t i = 0; i < photos.size(); ++i) {
    std::uint64_t s = seed + 0x9E3779B97F4A7C15ULL * (i + 1);
    maps.push_back({std::filesystem::path(photos[i]).stem().string(),
                    photo_protocol(photos[i], tacmap::splitmix64(s), photo_touches, sizing)});
  }
  if (maps.empty()) throw CLI::ValidationError("maps", "no map: drop --no-gecko or give --photo");

  std::ofstream csv(output);
  if (!csv)
    tacmap::detail::fail<std::runtime_error>("tacmap-evaluate: cannot open '", output,
                                             "' for writing; check the folder exists");

  if (library) {
    if (oracle_ceiling)
      throw CLI::ValidationError("--oracle-ceiling",
                                 "with --library; expected single maps (the library's evaluation "
                                 "has no oracle)");
    if (maps.size() < 2)
      throw CLI::ValidationError("--library", "a library needs at least two maps (got " +
                                                  std::to_string(maps.size()) +
                                                  "); add --photo files");
    std::vector<tacmap::library_object> objects;
    std::size_t all_sequences = 0;
    for (const auto& m : maps) {
      objects.push_back({m.name, &m.protocol});
      const std::size_t n = m.protocol.sequences.size();
      all_sequences += max_sequences == 0 ? n : std::min(n, max_sequences);
    }
    if (library_sequences == 0 || library_sequences < -1)
      throw CLI::ValidationError(
          "--library-sequences",
          std::to_string(library_sequences) + " is not a number of sequences; expected N >= 1");
    std::fprintf(stderr, "scenario: %s, library of %zu objects\n", to_string(scenario),
                 objects.size());
    std::printf("%s%s\n\n", conditions_text(to_string(scenario), sim, effects).c_str(),
                calibration_text.c_str());
    const bool ok = tacmap_tools::run_library_evaluation(
        objects, configs,
        library_sequences > 0 ? static_cast<std::size_t>(library_sequences) : all_sequences,
        max_sequences, seed, min_success, quiet, csv, library_params, mode);
    csv.close();
    if (!csv)
      tacmap::detail::fail<std::runtime_error>("tacmap-evaluate: writing '", output, "' failed");
    std::fprintf(stderr, "wrote %s\n", std::filesystem::absolute(output).string().c_str());
    if (!ok) {
      std::fprintf(stderr, "tacmap-evaluate: a success rate is below --min-success-rate %.2f\n",
                   min_success);
      return 1;
    }
    return 0;
  }

  csv << "map,config,model,pairing,shape,features,sequence,touch,location,true_x_mm,true_y_mm,"
         "map_x_mm,map_y_mm,error_mm,entropy_nats,accepted,localized,touches_to_localize,scenario,"
         "tau,headings,true_theta_rad,map_theta_rad,raised_dark,p_inverted,p_within_5mm,"
         "p_heading,verdict,log_evidence,estimate_x_mm,estimate_y_mm,map_error_mm,"
         "log_prediction_support,contradicted,fault,frames_read,frames_combined\n";

  std::size_t total = 0;
  for (const auto& m : maps) {
    const std::size_t n = m.protocol.sequences.size();
    total += configs.size() * (max_sequences == 0 ? n : std::min(n, max_sequences));
  }
  std::size_t done = 0;
  bool below_floor = false;
  std::map<std::string, confidence_tally> confidence;  // per configuration, over every map
  std::map<std::string, early_tally> by_touch;         // likewise
  std::map<std::string, ceiling_tally> ceilings;       // --oracle-ceiling, per configuration
  // Per configuration: touches and frames combined into them (bursts, --frames-per-press).
  std::map<std::string, std::pair<std::size_t, std::size_t>> bursts;
  const auto within3_of = [](const tacmap::sequence_result& r) {
    return tacmap::fault_recoveries(r.touches, 3);
  };
  const auto within5_of = [](const tacmap::sequence_result& r) {
    return tacmap::fault_recoveries(r.touches, 5);
  };
  // The ceiling's configuration: the filter told when each outlier and the slip happened and
  // their size (fault_oracle::told), and the odometry's true noise as its own motion noise.
  const auto told_config = [&](tacmap::localization_config c) {
    if (c.faults.outlier_probability > 0.0 || c.faults.slip_touch > 0)
      c.faults.oracle = tacmap::fault_oracle::told;
    if (c.faults.odometry_sigma_mm) c.motion_sigma_mm = std::max(0.01, *c.faults.odometry_sigma_mm);
    return c;
  };
  std::fprintf(stderr, "scenario: %s\n", to_string(scenario));
  std::printf("%s%s\n\n", conditions_text(to_string(scenario), sim, effects).c_str(),
              calibration_text.c_str());
  std::printf(
      "| map | configuration | localized | median touches to localize | median final error mm | "
      "median final entropy nats | raised dark: localized | median final P(true appearance) | "
      "after each fault, back below 5 mm within 3 touches; within 5: back / counted |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  const std::size_t fault_touch = std::max(faults.slip_touch, faults.kidnap_touch);
  for (const auto& m : maps) {
    const std::size_t n = max_sequences == 0 ? m.protocol.sequences.size()
                                             : std::min(m.protocol.sequences.size(), max_sequences);
    for (const auto& config : configs) {
      if (!quiet)
        progress(done, total, m.name + " " + config_label(config) + " (building the model)");
      tacmap::localization_experiment experiment(m.protocol, config);  // once per map x config
      // The same sequences with the filter told about the faults (--oracle-ceiling).
      std::optional<tacmap::localization_experiment> ceiling_experiment;
      if (oracle_ceiling) ceiling_experiment.emplace(m.protocol, told_config(config));
      std::size_t successes = 0;
      std::vector<double> ttl, final_errors, final_entropies, right_appearance;
      early_tally& early = by_touch[config_label(config)];
      std::size_t dark_sequences = 0, dark_successes = 0, moved = 0;
      tacmap::recovery_count within3, within5;  // after each injected fault
      for (std::size_t q = 0; q < n; ++q) {
        const auto run = experiment.run(q);
        const bool ok = tacmap::localized(run.touches);
        const auto t = tacmap::touches_to_localize(run.touches);
        successes += ok ? 1U : 0U;
        if (ok) ttl.push_back(static_cast<double>(*t));
        early.add(run.touches);
        final_errors.push_back(run.touches.back().error_mm);
        final_entropies.push_back(run.touches.back().entropy_nats);
        // Only sequences the slip or kidnap moved: one that could not happen (no direction
        // kept the later touches on the map) would count as a recovery from nothing.
        const bool was_moved = std::any_of(run.touches.begin(), run.touches.end(),
                                           [](const auto& r) { return r.moved_unseen; });
        moved += was_moved ? 1U : 0U;
        within3 += tacmap::fault_recoveries(run.touches, 3);
        within5 += tacmap::fault_recoveries(run.touches, 5);
        if (ceiling_experiment) {
          auto& c = ceilings[config_label(config)];
          const auto ceiling_run = ceiling_experiment->run(q);
          c.add(run, within3_of(run), within5_of(run), false);
          c.add(ceiling_run, within3_of(ceiling_run), within5_of(ceiling_run), true);
        }
        if (run.raised_dark) {
          ++dark_sequences;
          dark_successes += ok ? 1U : 0U;
        }
        if (const auto& p = run.touches.back().appearance_probability; p.size() == 2)
          right_appearance.push_back(p[run.raised_dark ? 1 : 0]);
        for (const auto& r : run.touches)
          csv << m.name << ',' << config_label(config) << ',' << tacmap::to_string(config.model)
              << ','
              << (config.model == tacmap::measurement_kind::ncc ? ""
                                                                : tacmap::to_string(config.pairs))
              << ','
              << (config.model == tacmap::measurement_kind::ncc ? ""
                                                                : tacmap::to_string(config.shape))
              << ','
              << (config.model == tacmap::measurement_kind::ncc
                      ? ""
                      : tacmap::to_string(config.features))
              << ',' << q << ',' << r.step + 1 << ',' << r.location << ','
              << csv_number(r.true_x_mm) << ',' << csv_number(r.true_y_mm) << ','
              << csv_number(r.map_x_mm) << ',' << csv_number(r.map_y_mm) << ','
              << csv_number(r.error_mm) << ',' << csv_number(r.entropy_nats) << ','
              << (r.accepted ? 1 : 0) << ',' << (ok ? 1 : 0) << ','
              << (t ? std::to_string(*t) : std::string()) << ',' << to_string(scenario) << ','
              << (config.tau ? csv_number(*config.tau) : std::string()) << ',' << config.headings
              << ',' << csv_number(r.true_theta_rad) << ',' << csv_number(r.map_theta_rad) << ','
              << (run.raised_dark ? 1 : 0) << ','
              << (r.appearance_probability.size() == 2 ? csv_number(r.appearance_probability[1])
                                                       : std::string())
              << ',' << csv_number(r.probability_within) << ',' << csv_number(r.heading_probability)
              << ',' << tacmap::to_string(r.verdict) << ',' << csv_number(r.log_marginal_likelihood)
              << ',' << csv_number(r.estimate_x_mm) << ',' << csv_number(r.estimate_y_mm) << ','
              << csv_number(r.map_error_mm) << ',' << csv_number(r.log_prediction_support) << ','
              << (r.contradicted ? 1 : 0) << ',' << (r.odometry_outlier || r.moved_unseen ? 1 : 0)
              << ',' << r.frames_read << ',' << r.frames_combined << '\n';
        confidence[config_label(config)].add(run, config.headings > 0);
        for (const auto& r : run.touches) {
          auto& [touches, combined] = bursts[config_label(config)];
          ++touches;
          combined += r.frames_combined;
        }
        ++done;
        if (!quiet) progress(done, total, m.name + " " + config_label(config));
      }
      if (!quiet) std::fprintf(stderr, "\r%*s\r", 110, "");
      char ttl_text[32] = "-";
      if (!ttl.empty()) std::snprintf(ttl_text, sizeof ttl_text, "%.1f", tacmap::median(ttl));
      char appearance_text[32] = "-";
      if (!right_appearance.empty())
        std::snprintf(appearance_text, sizeof appearance_text, "%.3f",
                      tacmap::median(right_appearance));
      std::string recovery_text = "-";
      if (within3.faults > 0) {
        recovery_text = std::to_string(within3.recovered) + " / " +
                        std::to_string(within3.counted) + "; " + std::to_string(within5.recovered) +
                        " / " + std::to_string(within5.counted);
        if (within5.counted < within5.faults)
          recovery_text += " (" + std::to_string(within5.faults) + " faults)";
      }
      if (fault_touch > 0 && moved < n)
        recovery_text += " (" + std::to_string(n - moved) + " of " + std::to_string(n) +
                         " not moved: no room on the map)";
      std::printf("| %s | %s | %zu / %zu | %s | %.2f | %.2f | %zu / %zu | %s | %s |\n",
                  m.name.c_str(), config_label(config).c_str(), successes, n, ttl_text,
                  tacmap::median(final_errors), tacmap::median(final_entropies), dark_successes,
                  dark_sequences, appearance_text, recovery_text.c_str());
      std::fflush(stdout);
      if (n > 0 && static_cast<double>(successes) < min_success * static_cast<double>(n))
        below_floor = true;
    }
  }
  print_confidence(confidence, configs);
  print_by_touch(by_touch, configs);
  // What the bursts kept (`combine_burst` through the localizer's burst overload): the frames
  // read per press and how many of them were combined, on average over every touch.
  for (const auto& config : configs) {
    if (config.simulator.frames_per_press == 1) continue;
    const auto it = bursts.find(config_label(config));
    if (it == bursts.end() || it->second.first == 0) continue;
    std::printf("\n%s: %zu frames read per press, %.1f combined on average (%s)\n",
                config_label(config).c_str(), config.simulator.frames_per_press,
                static_cast<double>(it->second.second) / static_cast<double>(it->second.first),
                is_plain_mean(config.burst) ? "every frame averaged"
                                            : "the settling head and outlier frames dropped");
  }
  if (oracle_ceiling) print_ceilings(ceilings, configs);
  csv.close();
  if (!csv)
    tacmap::detail::fail<std::runtime_error>("tacmap-evaluate: writing '", output, "' failed");
  std::fprintf(stderr, "wrote %s\n", std::filesystem::absolute(output).string().c_str());
  if (below_floor) {
    std::fprintf(stderr, "tacmap-evaluate: a success rate is below --min-success-rate %.2f\n",
                 min_success);
    return 1;
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "\ntacmap-evaluate: %s\n", e.what());
  return 2;
}
