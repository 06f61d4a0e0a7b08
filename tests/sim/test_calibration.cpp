// Calibration (sim/calibration.hpp): the reliability diagram and the maximum-likelihood
// temperature, on data whose true temperature is known and on simulated gecko touches.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "gecko_protocol.hpp"
#include "measurement/raw_patch_descriptor.hpp"
#include "table_filter.hpp"
#include "tacmap/sim/calibration.hpp"
#include "tacmap/sim/experiment.hpp"
#include "tacmap/sim/protocol.hpp"
#include "test_support.hpp"

namespace test_calibration {

using tacmap_test::message_of;
using filter_t = tacmap_test::table_filter;

namespace {

// `count` one-touch sequences drawn from the model itself: random distances d(x) per touch, the
// truth drawn from p(x) ∝ exp(-d(x) / true_tau), log-likelihoods recorded at `reference_tau`.
void add_model_data(tacmap::likelihood_calibration<filter_t>& cal, const filter_t& f,
                    double true_tau, double reference_tau, int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const auto n = f.grid().size();
  for (int q = 0; q < count; ++q) {
    Eigen::ArrayXd d(n);
    for (Eigen::Index i = 0; i < n; ++i) d(i) = 2.0 * u(rng);
    Eigen::ArrayXd p = (-d / true_tau).exp();
    p /= p.sum();
    double r = u(rng);
    Eigen::Index truth = 0;
    while (truth + 1 < n && r > p(truth)) r -= p(truth++);
    tacmap::sequence_result run;
    run.sequence = static_cast<std::size_t>(q);
    tacmap::touch_record rec;
    const auto s = f.grid().state_mm(truth);
    rec.true_x_mm = s(0);
    rec.true_y_mm = s(1);
    run.touches.push_back(rec);
    run.log_likelihoods.push_back((-d / reference_tau).cast<float>());
    cal.add(f, tacmap::touch_sequence(1), run);
  }
}

using tacmap_test::gecko;

}  // namespace

TEST_CASE("reliability: bins, expected calibration error and Brier score by hand") {
  // Bin [0.2, 0.3): claims 0.2, 0.25, outcomes 0, 1 -> mean 0.225, frequency 0.5.
  // Bin [0.9, 1.0]: claims 0.9, 1.0, outcomes 1, 1 -> mean 0.95, frequency 1.
  const std::vector<double> p{0.2, 0.25, 0.9, 1.0};
  const std::vector<char> o{0, 1, 1, 1};
  const auto r = tacmap::reliability(p, o);
  REQUIRE(r.bins.size() == 10);
  CHECK(r.count == 4);
  CHECK(r.bins[2].count == 2);
  CHECK(r.bins[2].mean_probability == doctest::Approx(0.225));
  CHECK(r.bins[2].frequency == doctest::Approx(0.5));
  CHECK(r.bins[9].count == 2);  // 1.0 falls in the last, closed bin
  CHECK(r.bins[9].frequency == doctest::Approx(1.0));
  CHECK(std::isnan(r.bins[0].frequency));
  CHECK(r.expected_calibration_error == doctest::Approx(0.5 * 0.275 + 0.5 * 0.05));
  CHECK(r.brier_score == doctest::Approx((0.04 + 0.5625 + 0.01 + 0.0) / 4.0));
  CHECK(message_of([&] {
          (void)tacmap::reliability(p, std::vector<char>{1});
        }).find("4 probabilities but 1 outcomes") != std::string::npos);
  CHECK(message_of([&] {
          (void)tacmap::reliability(std::vector<double>{1.5}, std::vector<char>{1});
        }).find("probability 1.5 at claim 0; expected [0, 1]") != std::string::npos);
}

TEST_CASE("the fitted temperature is the one the data were drawn with") {
  const filter_t f = tacmap_test::lattice_filter();
  for (const double true_tau : {0.1, 0.3}) {
    tacmap::likelihood_calibration<filter_t> cal(0.25);
    add_model_data(cal, f, true_tau, 0.25, 600, 7U);
    tacmap::tau_fit_params params;
    params.truth_radius_mm = 0.0;
    const auto fit = cal.fit(params);
    CAPTURE(true_tau);
    CHECK(fit.sane);
    CHECK(fit.tau == doctest::Approx(true_tau).epsilon(0.15));
    CHECK(fit.mean_log_score >= fit.mean_log_score_at_reference - 1e-9);
    CHECK(fit.touches == 600);
    // The curve is the scan and the refinement, by tau, with its maximum at the fit.
    for (std::size_t k = 1; k < fit.curve.size(); ++k)
      CHECK(fit.curve[k - 1].first <= fit.curve[k].first);
    for (const auto& [tau, score] : fit.curve) CHECK(score <= fit.mean_log_score + 1e-9);
  }
}

TEST_CASE("calibration data that cannot pin a temperature down is refused, with reasons") {
  const filter_t f = tacmap_test::lattice_filter();
  tacmap::likelihood_calibration<filter_t> few(0.25);
  add_model_data(few, f, 0.2, 0.25, 5, 1U);
  CHECK(message_of([&] {
          (void)few.fit();
        }).find("5 accepted touches in 5 sequences; expected at least 30 touches") !=
        std::string::npos);

  // Every touch identical: the same frame at the same place.
  tacmap::likelihood_calibration<filter_t> same(0.25);
  tacmap::sequence_result run;
  tacmap::touch_record rec;
  rec.true_x_mm = f.grid().state_mm(5)(0);
  rec.true_y_mm = f.grid().state_mm(5)(1);
  run.touches.push_back(rec);
  Eigen::ArrayXf ll(f.grid().size());
  for (Eigen::Index i = 0; i < ll.size(); ++i) ll(i) = -0.1F * static_cast<float>(i % 5);
  run.log_likelihoods.push_back(ll);
  for (int q = 0; q < 40; ++q) same.add(f, tacmap::touch_sequence(1), run);
  CHECK(message_of([&] { (void)same.fit(); }).find("every touch has the same log-likelihood") !=
        std::string::npos);

  // Flat likelihoods: nothing to fit.
  tacmap::likelihood_calibration<filter_t> flat(0.25);
  run.log_likelihoods[0].setConstant(-1.0F);
  for (int q = 0; q < 40; ++q) {
    run.touches[0].true_x_mm = f.grid().state_mm(q)(0);
    flat.add(f, tacmap::touch_sequence(1), run);
  }
  CHECK(message_of([&] { (void)flat.fit(); }).find("flat over the states") != std::string::npos);

  // A truth off the map: the data's scale is not the map's.
  run.touches[0].true_x_mm = 250.0;
  CHECK(message_of([&] {
          flat.add(f, tacmap::touch_sequence(1), run);
        }).find("is the map's scale (mm per px) the one the data were recorded at?") !=
        std::string::npos);
  // A run without its log-likelihoods.
  run.log_likelihoods.clear();
  CHECK(message_of([&] {
          flat.add(f, tacmap::touch_sequence(1), run);
        }).find("run it with keep_log_likelihoods = true") != std::string::npos);
  CHECK(message_of([] {
          tacmap::likelihood_calibration<filter_t> bad(0.0);
        }).find("reference tau 0") != std::string::npos);
}

TEST_CASE("a temperature the data push to the end of the range is reported, not used") {
  const filter_t f = tacmap_test::lattice_filter();
  tacmap::likelihood_calibration<filter_t> cal(0.25);
  add_model_data(cal, f, 0.05, 0.25, 200, 3U);
  tacmap::tau_fit_params params;
  params.tau_min = 0.5;  // the truth (0.05) lies below the range
  params.truth_radius_mm = 0.0;
  const auto fit = cal.fit(params);
  CHECK_FALSE(fit.sane);
  CHECK(fit.message.find("highest at the end of the search range") != std::string::npos);
}

TEST_CASE("simulated gecko touches: the fit improves the log score and the claims' calibration") {
  tacmap::localization_config config;
  config.scenario = tacmap::scenario_params::realistic();
  config.simulator = tacmap::realistic_sensor(config.simulator);
  config.simulator_seed = 101;
  config.model = tacmap::measurement_kind::lite;  // with shared features: builds fastest
  config.features = tacmap::window_features::shared_dense;
  config.tau = 0.25;
  tacmap::localization_experiment experiment(gecko(), config);
  tacmap::likelihood_calibration<tacmap::localization_experiment::filter_type> cal(0.25);
  for (std::size_t q = 0; q < 12; ++q) {
    const auto run = experiment.run(q, false, true);
    REQUIRE(run.log_likelihoods.size() == run.touches.size());
    cal.add(experiment.filter(), gecko().sequences[q], run, Eigen::Index{0});
  }
  const auto fit = cal.fit();
  CHECK(fit.sane);
  CHECK(fit.tau > 0.02);
  CHECK(fit.tau < 2.0);
  CHECK(fit.mean_log_score >= fit.mean_log_score_at_reference);
  const auto at_fit = cal.confidence_claims(fit.tau);
  CHECK(at_fit.probability.size() == fit.touches);
  CHECK(at_fit.said_and_right <= at_fit.said);
}

TEST_CASE("fit_tau fits a user's descriptor on a photograph, whatever the reference tau") {
  // The gecko's map as "the user's photograph": 7 touch locations, 22 orders.
  const tacmap::touch_protocol photo =
      tacmap::photo_touch_protocol(gecko().map, gecko().mm_per_px, 5);
  CHECK(photo.locations.size() == 7);
  CHECK(photo.sequences.size() == 22);
  tacmap::localization_config config;
  config.features = tacmap::window_features::shared_dense;  // one field: fast to prepare
  const tacmap::descriptor_measurement<tacmap_test::raw_patch> mine{};
  const auto fit = tacmap::fit_tau({photo}, config, mine, {}, 6);
  CHECK(fit.sequences == 6);
  CHECK(fit.touches >= 30);
  CHECK(fit.sane);
  CHECK(fit.reference_tau == 0.15);  // the descriptor model's default: what it ran at
  CHECK(fit.mean_log_score >= fit.mean_log_score_at_reference);
  // Log-likelihoods are linear in 1 / tau: recorded at another temperature, the same fit. (A
  // reference that is not the temperature the model ran at would scale the fit.)
  config.tau = 0.6;
  const auto again = tacmap::fit_tau({photo}, config, mine, {}, 6);
  CHECK(again.reference_tau == 0.6);
  CHECK(again.tau == doctest::Approx(fit.tau).epsilon(0.02));
  // Another descriptor, another scale: raw pixels' distances are not SIFT's.
  config.tau.reset();
  config.model = tacmap::measurement_kind::lite;
  const auto sift = tacmap::fit_tau({photo}, config, tacmap::configured_models{}, {}, 6);
  CHECK(std::abs(std::log(sift.tau / fit.tau)) > 0.3);
  config.headings = 4;
  CHECK(message_of([&] { (void)tacmap::fit_tau({photo}, config, mine); }).find("headings = 4") !=
        std::string::npos);
}

}  // namespace test_calibration
