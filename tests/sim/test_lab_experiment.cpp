// The lab's conditions (issue 34) through localization_experiment on the bundled gecko: the map's
// scale error, light and partial presses, the harsh preset, and the self-calibrating sensor
// (tactile/self_calibration.hpp) against the worn and the healthy sensor.
#include <doctest/doctest.h>

#include <cstddef>
#include <vector>

#include "gecko_protocol.hpp"
#include "tacmap/sim/experiment.hpp"
#include "tacmap/sim/scenario.hpp"

namespace test_lab_experiment {

namespace {

using tacmap_test::gecko;

struct tally {
  std::size_t localized = 0;
  double mean_final_error = 0.0;
};

tally run_all(const tacmap::localization_config& config, std::size_t sequences) {
  tacmap::localization_experiment experiment(gecko(), config);
  tally t;
  for (std::size_t q = 0; q < sequences; ++q) {
    const auto run = experiment.run(q);
    t.localized += tacmap::localized(run.touches) ? 1U : 0U;
    t.mean_final_error += run.touches.back().error_mm / static_cast<double>(sequences);
  }
  return t;
}

}  // namespace

TEST_CASE("lab conditions: a map scale error shrinks what the sensor covers and biases odometry") {
  tacmap::localization_config config;
  config.model = tacmap::measurement_kind::ncc;
  config.appearance = tacmap::appearance_handling::fixed;
  config.simulator.noise_counts = 0.0;
  config.simulator.gain_variation = 0.0;
  const auto exact = tacmap::localization_experiment(gecko(), config).run(0, true);
  config.scenario.map_scale_error = 0.1;
  tacmap::localization_experiment scaled(gecko(), config);
  const auto off = scaled.run(0, true);
  const auto again = scaled.run(0, true);
  REQUIRE(off.touches.size() == exact.touches.size());
  bool frames_differ = false, odometry_differs = false;
  for (std::size_t t = 0; t < off.touches.size(); ++t) {
    CHECK(off.touches[t].error_mm == again.touches[t].error_mm);  // reproducible
    frames_differ |= !(off.frames[t].counts == exact.frames[t].counts).all();
    if (t > 0) {
      // The arm's odometry is exact in mm of the object: 10 % more or less than in the map's.
      const double ratio =
          std::hypot(off.touches[t].reported_dx_mm, off.touches[t].reported_dy_mm) /
          std::hypot(exact.touches[t].reported_dx_mm, exact.touches[t].reported_dy_mm);
      CHECK((ratio == doctest::Approx(1.1).epsilon(1e-9) ||
             ratio == doctest::Approx(0.9).epsilon(1e-9)));
      odometry_differs = true;
    }
  }
  CHECK(frames_differ);
  CHECK(odometry_differs);
}

TEST_CASE("lab conditions: light presses read less, partial presses leave part of the array off") {
  tacmap::localization_config config;
  config.model = tacmap::measurement_kind::ncc;
  config.appearance = tacmap::appearance_handling::fixed;
  config.simulator.noise_counts = 0.0;
  config.simulator.gain_variation = 0.0;
  const auto nominal = tacmap::localization_experiment(gecko(), config).run(1, true);
  config.scenario.light_press_fraction = 1.0;
  config.scenario.light_press_scale = 0.3;
  const auto light = tacmap::localization_experiment(gecko(), config).run(1, true);
  config.scenario.light_press_fraction = 0.0;
  config.scenario.partial_press_fraction = 1.0;
  config.scenario.partial_press_tilt_deg = 3.0;
  const auto partial = tacmap::localization_experiment(gecko(), config).run(1, true);
  for (std::size_t t = 0; t < nominal.frames.size(); ++t) {
    const auto& n = nominal.frames[t].counts;
    // A light press is 30 % of the depth: its peak is about 30 % of the nominal one.
    CHECK(light.frames[t].counts.maxCoeff() < 0.45F * n.maxCoeff());
    // A tilted press leaves more taxels unloaded than the nominal one.
    CHECK((partial.frames[t].counts == 0.0F).count() >= (n == 0.0F).count());
  }
}

TEST_CASE("lab conditions: the harsh scenario runs end to end and is reproducible") {
  tacmap::localization_config config;
  config.model = tacmap::measurement_kind::ncc;
  config.scenario = tacmap::scenario_params::harsh();
  config.simulator = tacmap::harsh_sensor(config.simulator);
  tacmap::localization_experiment experiment(gecko(), config);
  const auto a = experiment.run(2);
  const auto b = experiment.run(2);
  REQUIRE(a.touches.size() == b.touches.size());
  for (std::size_t t = 0; t < a.touches.size(); ++t)
    CHECK(a.touches[t].error_mm == b.touches[t].error_mm);
}

TEST_CASE("frames per press: each press a burst, combined as the localizer's burst overload") {
  tacmap::localization_config config;
  config.model = tacmap::measurement_kind::ncc;
  config.scenario = tacmap::scenario_params::harsh();
  config.simulator = tacmap::harsh_sensor(config.simulator);
  const auto one = tacmap::localization_experiment(gecko(), config).run(1, true);
  config.simulator.frames_per_press = 20;
  const auto burst = tacmap::localization_experiment(gecko(), config).run(1, true);
  REQUIRE(one.touches.size() == burst.touches.size());
  for (std::size_t t = 0; t < burst.touches.size(); ++t) {
    CHECK(one.touches[t].frames_read == 1);
    CHECK(one.touches[t].frames_combined == 1);
    CHECK(burst.touches[t].frames_read == 20);
    // combine_burst (config.burst's defaults) drops the settling head: the first frame is
    // pressed to half the depth, far beyond the 5 % settle tolerance.
    CHECK(burst.touches[t].frames_combined < 20);
    CHECK(burst.touches[t].frames_combined >= 1);
    // The frame kept is the combined one, of this press's frames (20 numbers per press).
    CHECK(burst.frames[t].sequence / 20 == t);
  }
  // The configuration's burst settings are the ones used: a tolerance that takes every frame
  // as settled keeps all 20.
  config.burst.settle_tolerance = 10.0;
  config.burst.outlier_tolerance = 10.0;
  const auto all = tacmap::localization_experiment(gecko(), config).run(1);
  for (const auto& r : all.touches) CHECK(r.frames_combined == 20);
}

TEST_CASE("self-calibration: never worse on a healthy sensor; measured on the worn one") {
  // The localizer's default model; the gecko's first 11 sequences.
  constexpr std::size_t n = 11;
  tacmap::localization_config healthy;
  const tally plain = run_all(healthy, n);
  healthy.self_calibrate = true;
  healthy.calibration_warmup = 56;
  const tally calibrated = run_all(healthy, n);
  MESSAGE("healthy sensor: localized ", plain.localized, " / ", n, " (mean final error ",
          plain.mean_final_error, " mm) without, ", calibrated.localized, " / ", n, " (",
          calibrated.mean_final_error, " mm) with self-calibration");
  CHECK(calibrated.localized >= plain.localized);

  tacmap::localization_config worn;
  worn.simulator.noise_counts = 200.0;   // the worn sensor: 5 % of full scale noise,
  worn.simulator.gain_variation = 0.15;  // gains +-30 %,
  worn.simulator.dead_fraction = 0.1;    // 10 % dead taxels
  worn.simulator.foam_sigma_mm = 2.5;
  const tally worn_plain = run_all(worn, n);
  worn.self_calibrate = true;
  worn.calibration_warmup = 56;
  const tally worn_calibrated = run_all(worn, n);
  MESSAGE("worn sensor: localized ", worn_plain.localized, " / ", n, " (mean final error ",
          worn_plain.mean_final_error, " mm) without, ", worn_calibrated.localized, " / ", n, " (",
          worn_calibrated.mean_final_error, " mm) with self-calibration");
  CHECK(worn_calibrated.localized + 1 >= worn_plain.localized);
}

}  // namespace test_lab_experiment
