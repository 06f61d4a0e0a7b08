// tacmap-calibrate — fits the likelihood's temperature tau by maximum likelihood (README,
// "Confidence"; sim/calibration.hpp).
//
// Simulates touch sequences on the given maps (photographs and/or protocol folders) in a
// scenario, records every touch's log-likelihood once, and replays the filter at other tau to
// find the one whose beliefs give the truth the highest mean log probability. Prints the fitted
// tau, the log score curve and how well the fitted beliefs' "P(error <= 5 mm)" claims match
// what happened on the calibration data (ECE, precision of "localized"). Use maps and seeds
// unlike those you evaluate on: the shipped default was fitted on photographs that
// tacmap-evaluate's tables do not use, with --seed 101.
//
//   tacmap-calibrate --photo my_object.png --photo other.jpg
//   tacmap-calibrate --protocol data/gecko --model sift_lite --curve curve.csv
//
// Exit status: 0 fitted; 1 the fit is not usable (the maximum at the end of the range: the
// message says why; the value is printed but must not be shipped); 2 bad input.
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cli_checks.hpp"
#include "photo_maps.hpp"
#include "tacmap/filter/confidence.hpp"
#include "tacmap/sim/calibration.hpp"
#include "tacmap/sim/experiment.hpp"
#include "tacmap/sim/protocol.hpp"
#include "tacmap/sim/scenario.hpp"

namespace {

struct named_map {
  std::string name;
  tacmap::touch_protocol protocol;
};

}  // namespace

int main(int argc, char** argv) try {
  CLI::App app{
      "tacmap-calibrate: fit the likelihood's temperature (tau) by maximum likelihood on "
      "simulated touches (docs/tools.md)\n\n"
      "Examples:\n"
      "  tacmap-calibrate --protocol data/gecko\n"
      "      the bundled gecko, the default model, the realistic scenario\n"
      "  tacmap-calibrate --protocol data/gecko --photo object.jpg --curve tau.csv\n"
      "      the gecko and your photograph together; the score curve into tau.csv\n"
      "  tacmap-calibrate --protocol data/gecko --model sift_lite --scenario ideal\n"
      "      another model, another scenario\n"};
  std::vector<std::string> photos, protocols;
  std::string model_name = "classic_sift", scenario_name = "realistic", curve_path;
  std::uint64_t seed = 101;
  long long sequences = 0;
  tacmap_tools::map_sizing_options sizing_options;
  long long patch_spacing = 0;  // 0: the model's default
  double tau_min = 0.01, tau_max = 10.0;
  double truth_radius = tacmap::tau_fit_params{}.truth_radius_mm;
  app.add_option("--photo", photos, "photograph(s) to use as maps (PNG/JPEG/PGM)")
      ->check(CLI::ExistingFile);
  app.add_option("--protocol", protocols,
                 "folder(s) with a protocol.txt (map, scale, touch locations and sequences), "
                 "e.g. data/gecko")
      ->check(CLI::ExistingDirectory);
  app.add_option("--model", model_name, "sift_lite or classic_sift (the default model)");
  app.add_option("--scenario", scenario_name, "ideal, realistic (default) or unknown");
  app.add_option("--seed", seed, "seeds the simulator and the photographs' protocols (101)")
      ->check(CLI::NonNegativeNumber);  // an unsigned option: -1 would wrap
  app.add_option("--sequences", sequences, "use the first N sequences of each map (0 = all)");
  sizing_options.add_to(app);
  app.add_option("--spacing", patch_spacing,
                 "px between the tactile image's descriptor patches (default: classic_sift 13, "
                 "sift_lite 9)")
      ->check(CLI::PositiveNumber);
  app.add_option("--tau-min", tau_min, "lower end of the search range")->check(CLI::PositiveNumber);
  app.add_option("--tau-max", tau_max, "upper end of the search range")->check(CLI::PositiveNumber);
  app.add_option("--truth-radius", truth_radius,
                 "mm: the states within this distance of the true position count as the truth "
                 "in the log score (0 = the nearest state)")
      ->check(CLI::Range(0.0, 10.0));
  app.add_option("--curve", curve_path, "write the log score curve (tau, score) to this CSV");
  app.footer(tacmap_tools::exit_status_footer);
  if (const auto status = tacmap_tools::parse(app, argc, argv)) return *status;
  if (sequences < 0)
    throw CLI::ValidationError("--sequences", std::to_string(sequences) +
                                                  " is not a number of sequences; expected N >= 0 "
                                                  "(the first N of each map; 0 = all)");
  const tacmap_tools::map_sizing sizing = sizing_options.chosen();
  if (photos.empty() && protocols.empty())
    throw CLI::ValidationError("maps",
                               "no map given; expected --photo FILE or --protocol FOLDER (at "
                               "least one)");

  tacmap::localization_config config;
  if (model_name == "sift_lite")
    config.model = tacmap::measurement_kind::lite;
  else if (model_name == "classic_sift")
    config.model = tacmap::measurement_kind::classic;
  else
    throw CLI::ValidationError("--model", "'" + model_name +
                                              "' is not one of: sift_lite, classic_sift (NCC's "
                                              "scale is not a descriptor temperature)");
  if (scenario_name == "realistic") {
    config.simulator = tacmap::realistic_sensor(config.simulator);
    config.scenario = tacmap::scenario_params::realistic();
  } else if (scenario_name == "unknown") {
    config.simulator = tacmap::realistic_sensor(config.simulator);
    config.scenario = tacmap::scenario_params::unknown_object();
  } else if (scenario_name != "ideal") {
    throw CLI::ValidationError("--scenario",
                               "'" + scenario_name + "' is not one of: ideal, realistic, unknown");
  }
  config.simulator_seed = seed;
  if (patch_spacing > 0) config.patch_spacing = patch_spacing;
  // The log-likelihoods are recorded at the temperature the configuration runs with by default
  // ("now" in the report) and rescaled.
  const double reference_tau =
      config.planar_tau().value_or(tacmap::descriptor_likelihood_params{}.tau);
  config.tau = reference_tau;

  std::vector<named_map> maps;
  for (const auto& dir : protocols)
    maps.push_back({std::filesystem::path(dir).filename().string(),
                    tacmap::load_protocol(std::filesystem::path(dir) / "protocol.txt")});
  for (std::size_t i = 0; i < photos.size(); ++i) {
    std::uint64_t s = seed + 0x9E3779B97F4A7C15ULL * (i + 1);
    maps.push_back({std::filesystem::path(photos[i]).stem().string(),
                    tacmap_tools::photo_protocol(photos[i], tacmap::splitmix64(s), 7, sizing)});
  }

  using filter_type = tacmap::localization_experiment::filter_type;
  tacmap::likelihood_calibration<filter_type> calibration(reference_tau);
  std::vector<std::unique_ptr<tacmap::localization_experiment>> experiments;
  for (const auto& m : maps) {
    experiments.push_back(std::make_unique<tacmap::localization_experiment>(m.protocol, config));
    auto& experiment = *experiments.back();
    const std::size_t n =
        sequences == 0 ? m.protocol.sequences.size()
                       : std::min(m.protocol.sequences.size(), static_cast<std::size_t>(sequences));
    for (std::size_t q = 0; q < n; ++q) {
      const auto run = experiment.run(q, false, true);
      calibration.add(experiment.filter(), m.protocol.sequences[q], run,
                      static_cast<Eigen::Index>(run.raised_dark ? 1 : 0));
    }
    std::fprintf(stderr, "recorded %s: %zu sequences\n", m.name.c_str(), n);
  }

  tacmap::tau_fit_params params;
  params.tau_min = tau_min;
  params.tau_max = tau_max;
  params.truth_radius_mm = truth_radius;
  const tacmap::tau_fit fit = calibration.fit(params);
  std::printf(
      "calibration data: %zu maps, %zu sequences, %zu accepted touches (%s scenario, %s, "
      "seed %llu)\n",
      maps.size(), fit.sequences, fit.touches, scenario_name.c_str(), model_name.c_str(),
      static_cast<unsigned long long>(seed));
  std::printf(
      "mean log score of the truth (within %.1f mm): %.3f at tau = %.3g (now), %.3f at "
      "tau = %.3g (fitted)\n",
      truth_radius, fit.mean_log_score_at_reference, fit.reference_tau, fit.mean_log_score,
      fit.tau);
  for (const double tau : {fit.reference_tau, fit.tau}) {
    const auto claims = calibration.confidence_claims(tau);
    const auto r = tacmap::reliability(claims.probability, claims.outcome);
    std::printf(
        "tau = %.3g: ECE of P(error <= 5 mm) %.1f points, Brier %.3f, \"localized\" "
        "precision %.1f %% (%zu of %zu), %.1f %% of right estimates called localized\n",
        tau, 100.0 * r.expected_calibration_error, r.brier_score,
        claims.said == 0
            ? 0.0
            : 100.0 * static_cast<double>(claims.said_and_right) / static_cast<double>(claims.said),
        claims.said_and_right, claims.said,
        claims.right == 0 ? 0.0
                          : 100.0 * static_cast<double>(claims.said_and_right) /
                                static_cast<double>(claims.right));
  }
  if (!curve_path.empty()) {
    std::ofstream out(curve_path);
    if (!out)
      tacmap::detail::fail<std::runtime_error>("tacmap-calibrate: cannot open '", curve_path,
                                               "' for writing; check the folder exists");
    out << "tau,mean_log_score\n";
    for (const auto& [tau, score] : fit.curve) out << tau << ',' << score << '\n';
  }
  if (!fit.sane) {
    std::printf("NOT USABLE: %s\n", fit.message.c_str());
    return 1;
  }
  std::printf(
      "fitted tau = %.4g (set tacmap::localizer_config::tau = %.4g for this model, or "
      "tacmap-evaluate --tau; for a descriptor of your own, tacmap::fit_tau in "
      "tacmap/sim/calibration.hpp)\n",
      fit.tau, fit.tau);
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "\ntacmap-calibrate: %s\n", e.what());
  return 2;
}
