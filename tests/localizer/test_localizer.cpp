// tacmap::localizer: one object from raw frames and odometry to an estimate and a verdict.
// Frames come from the tactile simulator pressing the bundled gecko's relief.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "sim/gecko_protocol.hpp"
#include "tacmap/localizer.hpp"
#include "tacmap/sim/tactile_simulator.hpp"
#include "test_support.hpp"

namespace test_localizer {

namespace {

using tacmap_test::gecko;

tacmap::tactile_simulator gecko_simulator(std::uint64_t seed) {
  const auto& p = gecko();
  return tacmap::tactile_simulator(p.relief_mm(), p.map_size(), p.mm_per_px, {.seed = seed});
}

// A fast configuration for the tests that are not about accuracy: SIFT-lite on the shared
// dense field (milliseconds to prepare, even unoptimised).
tacmap::localizer_config fast_config() {
  tacmap::localizer_config c;
  c.model = tacmap::measurement_kind::lite;
  c.features = tacmap::window_features::shared_dense;
  return c;
}

tacmap::tactile_frame empty_frame() {
  tacmap::tactile_frame f;
  f.counts.setZero();
  return f;
}

}  // namespace

TEST_CASE("a localizer with its defaults localizes the gecko from raw frames and says so") {
  const auto& p = gecko();
  tacmap::localizer loc(p.map, p.mm_per_px);
  CHECK(loc.positions().rows() * loc.positions().cols() > 1000);
  std::size_t localized_sequences = 0;
  for (std::size_t q = 0; q < 3; ++q) {
    CAPTURE(q);
    loc.reset();
    auto sim = gecko_simulator(100 + q);
    tacmap::touch_result r;
    double error_mm = 0.0;
    for (std::size_t t = 0; t < p.sequences[q].size(); ++t) {
      const auto& step = p.sequences[q][t];
      const auto& truth = p.locations[step.location];
      const auto frame = sim.render(truth.pose());
      r = t == 0 ? loc.touch(frame) : loc.touch(frame, step.measured_motion);
      CHECK(r.accepted());
      CHECK(r.touches == t + 1);
      error_mm = (r.position_mm - Eigen::Vector2d(truth.x_mm, truth.y_mm)).norm();
      // The belief is a distribution over the grid's positions.
      const auto b = loc.belief();
      CHECK(b.rows() == loc.positions().rows());
      CHECK(static_cast<double>(b.sum()) == doctest::Approx(1.0).epsilon(1e-4));
      CHECK(r.probability_within >= 0.0);
      CHECK(r.probability_within <= 1.0 + 1e-9);
      CHECK(r.appearance_probability.size() == 2);  // latent appearance by default
    }
    CHECK(error_mm < 5.0);
    if (r.verdict == tacmap::verdict::localized) ++localized_sequences;
    // The gecko's raised parts are bright in its map: "as photographed" wins.
    CHECK(r.appearance_probability[0] > 0.9);
  }
  CHECK(localized_sequences >= 2);
}

TEST_CASE("a rejected frame is reported, and the arm's motion before it still applies") {
  const auto& p = gecko();
  const auto config = fast_config();
  tacmap::localizer loc(p.map, p.mm_per_px, config);
  auto reference = tacmap::make_planar_filter(loc.config(), p.map, p.mm_per_px, loc.window());
  auto sim = gecko_simulator(7);
  const auto frame = sim.render(p.locations[0].pose());
  const auto first = loc.touch(frame);
  reference.update(tacmap::preprocess(frame, loc.config().preprocessing).pixels);
  const tacmap::odometry moved{.dx_mm = 3.0, .dy_mm = -2.0};
  const auto r = loc.touch(empty_frame(), moved);
  reference.predict(moved);
  CHECK(r.verdict == tacmap::verdict::rejected_frame);
  CHECK(r.rejection == tacmap::frame_rejection::weak_peak);
  CHECK_FALSE(r.accepted());
  CHECK(r.touches == 1);
  CHECK(loc.touches() == 1);
  CHECK(r.log_prediction_support == 0.0);
  REQUIRE(loc.planar_filter() != nullptr);
  CHECK((loc.planar_filter()->belief() - reference.belief()).abs().maxCoeff() == 0.0F);
  CHECK(first.touches == 1);
}

TEST_CASE("touch_at turns the arm's poses into the same odometry as touch") {
  const auto& p = gecko();
  tacmap::localizer by_motion(p.map, p.mm_per_px, fast_config());
  tacmap::localizer by_pose(p.map, p.mm_per_px, fast_config());
  auto sim = gecko_simulator(3);
  const auto& seq = p.sequences[1];
  tacmap::arm_pose arm{.x_mm = 500.0, .y_mm = -20.0, .theta_rad = 0.01};  // any origin
  for (std::size_t t = 0; t < seq.size(); ++t) {
    const auto frame = sim.render(p.locations[seq[t].location].pose());
    if (t > 0) {
      arm.x_mm += seq[t].measured_motion.dx_mm;
      arm.y_mm += seq[t].measured_motion.dy_mm;
    }
    const auto a = t == 0 ? by_motion.touch(frame) : by_motion.touch(frame, seq[t].measured_motion);
    const auto b = by_pose.touch_at(frame, arm);
    CHECK((a.position_mm - b.position_mm).norm() < 1e-9);
    CHECK(a.probability_within == doctest::Approx(b.probability_within).epsilon(1e-6));
  }
  CHECK((by_motion.belief() - by_pose.belief()).abs().maxCoeff() < 1e-6F);
  // A turned sensor breaks the known-heading model: refused, naming the turn.
  const auto frame = sim.render(p.locations[0].pose());
  arm.theta_rad += 0.5;
  CHECK_THROWS_WITH_AS(by_pose.touch_at(frame, arm), doctest::Contains("headings"),
                       std::invalid_argument);
}

TEST_CASE("with unknown heading only motion relative to the sensor counts: any arm frame") {
  const auto& p = gecko();
  auto config = fast_config();
  config.headings = 4;
  tacmap::localizer a(p.map, p.mm_per_px, config);
  tacmap::localizer b(p.map, p.mm_per_px, config);
  CHECK(a.planar_filter() == nullptr);
  REQUIRE(a.pose_filter() != nullptr);
  CHECK(a.heading_belief().size() == 4);
  CHECK(a.heading_rad(1) == doctest::Approx(std::numbers::pi / 2));
  auto sim = gecko_simulator(5);
  const auto& seq = p.sequences[2];
  // Frame A: the map's axes, sensor heading 0. Frame B: turned by 0.7 rad and shifted.
  const double phi = 0.7, c = std::cos(phi), s = std::sin(phi);
  double x = 0.0, y = 0.0;
  for (std::size_t t = 0; t < std::min<std::size_t>(seq.size(), 4); ++t) {
    const auto frame = sim.render(p.locations[seq[t].location].pose());
    if (t > 0) {
      x += seq[t].measured_motion.dx_mm;
      y += seq[t].measured_motion.dy_mm;
    }
    const auto ra = a.touch_at(frame, {.x_mm = x, .y_mm = y, .theta_rad = 0.0});
    const auto rb = b.touch_at(
        frame, {.x_mm = 40.0 + c * x - s * y, .y_mm = -7.0 + s * x + c * y, .theta_rad = phi});
    CHECK((ra.position_mm - rb.position_mm).norm() < 1e-6);
  }
  const auto ba = a.heading_belief(), bb = b.heading_belief();
  for (std::size_t k = 0; k < ba.size(); ++k) CHECK((ba[k] - bb[k]).abs().maxCoeff() < 1e-5F);
  // Map-frame odometry means nothing without the heading: refused.
  const auto frame = sim.render(p.locations[0].pose());
  CHECK_THROWS_WITH_AS(a.touch(frame, tacmap::odometry{.dx_mm = 1.0}),
                       doctest::Contains("sensor's frame"), std::invalid_argument);
}

TEST_CASE("the paper's configuration is the paper's motion model, in the plane and with headings") {
  for (const int headings : {0, 36}) {
    auto paper = tacmap::localizer_config::paper();
    paper.headings = headings;
    CHECK(paper.lost() == 0.0);
    CHECK(paper.wide() == 0.0);
    // The defaults protect both grids alike (the wide component per heading layer on poses).
    tacmap::localizer_config defaults;
    defaults.headings = headings;
    CHECK(defaults.lost() == tacmap::localizer_config::default_lost_probability);
    CHECK(defaults.wide() == tacmap::localizer_config::default_wide_probability);
  }
}

TEST_CASE("a move off the map restarts the paper's configuration instead of failing") {
  const auto& p = gecko();
  auto config = tacmap::localizer_config::paper();
  config.features = tacmap::window_features::shared_dense;  // fast to prepare
  tacmap::localizer loc(p.map, p.mm_per_px, config);
  auto sim = gecko_simulator(9);
  const auto frame = sim.render(p.locations[0].pose());
  CHECK_FALSE(loc.touch(frame).restarted);
  const auto r = loc.touch(frame, tacmap::odometry{.dx_mm = 1000.0, .dy_mm = 0.0});
  CHECK(r.restarted);
  CHECK(r.touches == 2);
  CHECK(loc.belief().allFinite());
  CHECK(static_cast<double>(loc.belief().sum()) == doctest::Approx(1.0).epsilon(1e-4));
}

// Localized on sequence 0, then kidnapped: the next touches are at the location farthest from
// the last one, and the arm reports no motion. Returns the verdicts and errors of those touches.
std::vector<std::pair<tacmap::verdict, double>> kidnapped(const tacmap::localizer_config& config,
                                                          double* support_first = nullptr) {
  const auto& p = gecko();
  tacmap::localizer loc(p.map, p.mm_per_px, config);
  auto sim = gecko_simulator(11);
  const auto& seq = p.sequences[0];
  tacmap::touch_result r;
  for (std::size_t t = 0; t < seq.size(); ++t) {
    const auto frame = sim.render(p.locations[seq[t].location].pose());
    r = t == 0 ? loc.touch(frame) : loc.touch(frame, seq[t].measured_motion);
  }
  REQUIRE(r.verdict == tacmap::verdict::localized);
  const auto& last = p.locations[seq.back().location];
  std::size_t far = 0;
  double farthest = 0.0;
  for (std::size_t i = 0; i < p.locations.size(); ++i) {
    const double d = std::hypot(p.locations[i].x_mm - last.x_mm, p.locations[i].y_mm - last.y_mm);
    if (d > farthest) farthest = d, far = i;
  }
  REQUIRE(farthest > 20.0);
  const Eigen::Vector2d truth(p.locations[far].x_mm, p.locations[far].y_mm);
  std::vector<std::pair<tacmap::verdict, double>> out;
  for (int t = 0; t < 3; ++t) {
    r = loc.touch(sim.render(p.locations[far].pose()), tacmap::odometry{});
    if (t == 0 && support_first) *support_first = r.log_prediction_support;
    out.emplace_back(r.verdict, (r.position_mm - truth).norm());
  }
  return out;
}

TEST_CASE("a kidnap: contradicted at once without the wide component, never confidently wrong") {
  auto config = fast_config();
  config.wide_probability = 0.0;  // the floor alone: the old place keeps its mass
  double support = 0.0;
  const auto narrow = kidnapped(config, &support);
  CHECK(narrow[0].first == tacmap::verdict::contradicted);
  CHECK(support < config.confidence.contradiction);
  // With the defaults' wide component as well: whatever the verdicts, "localized" is never
  // wrong, and the track is back within three touches.
  const auto wide = kidnapped(fast_config());
  for (const auto& [v, error_mm] : wide) {
    CAPTURE(error_mm);
    if (v == tacmap::verdict::localized) CHECK(error_mm < 5.0);
  }
  CHECK(wide.back().second < 5.0);
  for (const auto& [v, error_mm] : narrow)
    if (v == tacmap::verdict::localized) CHECK(error_mm < 5.0);
}

// The default localizer (tracking on) against the same one with tracking off, on sequence 0 and
// then kidnapped to its farthest location (the arm reporting no motion): every touch's result.
struct kidnap_run {
  std::vector<tacmap::touch_result> before, after;
  Eigen::Vector2d truth;
};
kidnap_run default_kidnap(const tacmap::localizer_config& config) {
  const auto& p = gecko();
  tacmap::localizer loc(p.map, p.mm_per_px, config);
  auto sim = gecko_simulator(11);
  const auto& seq = p.sequences[0];
  kidnap_run run;
  for (std::size_t t = 0; t < seq.size(); ++t) {
    const auto frame = sim.render(p.locations[seq[t].location].pose());
    run.before.push_back(t == 0 ? loc.touch(frame) : loc.touch(frame, seq[t].measured_motion));
  }
  const auto& last = p.locations[seq.back().location];
  std::size_t far = 0;
  double farthest = 0.0;
  for (std::size_t i = 0; i < p.locations.size(); ++i) {
    const double d = std::hypot(p.locations[i].x_mm - last.x_mm, p.locations[i].y_mm - last.y_mm);
    if (d > farthest) farthest = d, far = i;
  }
  run.truth = {p.locations[far].x_mm, p.locations[far].y_mm};
  for (int t = 0; t < 3; ++t)
    run.after.push_back(loc.touch(sim.render(p.locations[far].pose()), tacmap::odometry{}));
  return run;
}

TEST_CASE("the default localizer tracks once localized, and a kidnap is found as untracked") {
  const tacmap::localizer_config tracked_config;
  REQUIRE(tracked_config.tracking.has_value());
  CHECK(tracked_config.tracking->epsilon == tacmap::default_tracking().epsilon);
  tacmap::localizer_config full_config;
  full_config.tracking.reset();
  const kidnap_run tracked = default_kidnap(tracked_config);
  const kidnap_run full = default_kidnap(full_config);
  REQUIRE(tracked.before.back().verdict == tacmap::verdict::localized);
  REQUIRE(full.before.back().verdict == tacmap::verdict::localized);
  // Once localized the default takes the tracked path; with tracking off, never.
  std::size_t tracked_touches = 0, after_localized = 0;
  bool localized = false;
  for (std::size_t t = 0; t < tracked.before.size(); ++t) {
    CAPTURE(t);
    CHECK(full.before[t].path == tacmap::update_path::full);
    if (localized) {
      ++after_localized;
      tracked_touches += tracked.before[t].path == tacmap::update_path::tracked ? 1U : 0U;
    }
    localized = localized || tracked.before[t].verdict == tacmap::verdict::localized;
    CHECK((tracked.before[t].position_mm - full.before[t].position_mm).norm() < 1.5);
    CHECK(tracked.before[t].verdict == full.before[t].verdict);
  }
  REQUIRE(after_localized >= 2);
  CHECK(tracked_touches + 1 >= after_localized);
  // The kidnap: the first touch after it doubts the prediction, so the whole grid is evaluated
  // (a doubt signal that missed it would track on at the old place), and the sensor is found
  // again no later than with tracking off, as surely.
  CHECK(tracked.after[0].path == tacmap::update_path::full_contradicted);
  const auto found = [](const kidnap_run& run) {
    for (std::size_t t = 0; t < run.after.size(); ++t)
      if ((run.after[t].position_mm - run.truth).norm() < 5.0) return static_cast<int>(t);
    return 99;
  };
  REQUIRE(found(full) < 3);
  CHECK(found(tracked) <= found(full));
  for (std::size_t t = 0; t < 3; ++t) {
    CAPTURE(t);
    CHECK(tracked.after[t].probability_within ==
          doctest::Approx(full.after[t].probability_within).epsilon(0.05));
    if (tracked.after[t].verdict == tacmap::verdict::localized)
      CHECK((tracked.after[t].position_mm - tracked.truth).norm() < 5.0);
  }
}

TEST_CASE("a localizer refuses bad input with messages that say what to do") {
  const auto& p = gecko();
  CHECK_THROWS_WITH_AS(tacmap::localizer(tacmap::image<float>(), 1.0),
                       doctest::Contains("map is empty"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(tacmap::localizer(p.map, -1.0), doctest::Contains("mm_per_px = -1"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(tacmap::localizer(tacmap::image<float>::Zero(10, 10), p.mm_per_px),
                       doctest::Contains("at least the sensor's size"), std::invalid_argument);
  tacmap::image<float> nan_map = p.map;
  nan_map(3, 4) = std::numeric_limits<float>::quiet_NaN();
  CHECK_THROWS_WITH_AS(tacmap::localizer(nan_map, p.mm_per_px), doctest::Contains("non-finite"),
                       std::invalid_argument);
  auto bad = fast_config();
  bad.motion_sigma_mm = 0.0;
  CHECK_THROWS_WITH_AS(tacmap::localizer(p.map, p.mm_per_px, bad),
                       doctest::Contains("motion_sigma_mm = 0"), std::invalid_argument);

  tacmap::localizer loc(p.map, p.mm_per_px, fast_config());
  tacmap::tactile_frame other;
  other.geometry = {.rows = 4, .cols = 4, .pitch_mm = 3.4};
  other.counts = tacmap::image<float>::Constant(4, 4, 500.0F);
  CHECK_THROWS_WITH_AS(loc.touch(other), doctest::Contains("built for 14 x 6"),
                       std::invalid_argument);
  auto sim = gecko_simulator(1);
  const auto frame = sim.render(p.locations[0].pose());
  CHECK_THROWS_WITH_AS(
      loc.touch(frame, tacmap::odometry{.dx_mm = std::numeric_limits<double>::quiet_NaN()}),
      doctest::Contains("not finite"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(loc.touch(frame, tacmap::sensor_odometry{.dtheta_rad = 0.2}),
                       doctest::Contains("turned by 0.2"), std::invalid_argument);
  // Nothing above changed the belief: still uniform, no touch.
  CHECK(loc.touches() == 0);
  const auto b = loc.belief();
  CHECK(b.maxCoeff() == doctest::Approx(b.minCoeff()));
}

TEST_CASE("localizer_config::patch_spacing reaches the descriptor model and is checked") {
  const auto& p = gecko();
  auto config = fast_config();
  CHECK(config.name().find("spacing") == std::string::npos);
  config.patch_spacing = 12;  // sift_lite's 18 px patches at rows 0, 12, 24: the whole window
  CHECK(config.name().find("/spacing=12") != std::string::npos);
  tacmap::localizer paper_spacing(p.map, p.mm_per_px, fast_config());
  tacmap::localizer covering(p.map, p.mm_per_px, config);
  auto sim = gecko_simulator(5);
  const auto frame = sim.render(p.locations[2].pose());
  paper_spacing.touch(frame);
  covering.touch(frame);
  REQUIRE(covering.planar_filter() != nullptr);
  // Other patches, other likelihoods: the beliefs differ.
  CHECK((covering.planar_filter()->belief() - paper_spacing.planar_filter()->belief())
            .abs()
            .maxCoeff() > 1e-6F);
  config.patch_spacing = 0;
  CHECK(tacmap_test::message_of([&] {
          tacmap::localizer bad(p.map, p.mm_per_px, config);
        }).find("spacing = 0") != std::string::npos);
}

TEST_CASE("touch_at: finite poses whose difference overflows are refused as such, state kept") {
  const auto& p = gecko();
  tacmap::localizer loc(p.map, p.mm_per_px, fast_config());
  auto sim = gecko_simulator(5);
  const auto frame = sim.render(p.locations[0].pose());
  const double big = std::numeric_limits<double>::max();
  (void)loc.touch_at(frame, {.x_mm = big, .y_mm = 0.0});
  const tacmap::image<float> before = loc.belief();
  // -DBL_MAX - DBL_MAX is -infinity: not the position source's fault (both poses are finite).
  try {
    (void)loc.touch_at(frame, {.x_mm = -big, .y_mm = 0.0});
    FAIL("no exception");
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    CHECK(what.find("localizer::touch_at: the arm moved from (1.79769") != std::string::npos);
    CHECK(what.find("overflows a double") != std::string::npos);
    CHECK(what.find("position source") == std::string::npos);
  }
  CHECK((loc.belief() - before).abs().maxCoeff() == 0.0F);
  // The previous pose is kept: a pose near it is an ordinary touch.
  CHECK_NOTHROW((void)loc.touch_at(frame, {.x_mm = big, .y_mm = 1.0}));
}

TEST_CASE("a burst of frames is one touch: settling and outlier frames do not vote") {
  const auto& p = gecko();
  auto sim = gecko_simulator(7);
  const auto& seq = p.sequences[0];
  tacmap::localizer single(p.map, p.mm_per_px, fast_config());
  tacmap::localizer burst(p.map, p.mm_per_px, fast_config());
  for (std::size_t t = 0; t < 3; ++t) {
    CAPTURE(t);
    const auto& truth = p.locations[seq[t].location];
    const tacmap::tactile_frame frame = sim.render(truth.pose());
    // A press still settling (a third of the load), four settled readings, and one outlier
    // frame (the load doubled): the combined frame is the settled reading, taxel by taxel.
    std::vector<tacmap::tactile_frame> frames(6, frame);
    frames[0].counts = frame.counts / 3.0F;
    frames[5].counts = frame.counts * 2.0F;
    const auto a = t == 0 ? single.touch(frame) : single.touch(frame, seq[t].measured_motion);
    const auto b = t == 0 ? burst.touch(std::span<const tacmap::tactile_frame>(frames))
                          : burst.touch(std::span<const tacmap::tactile_frame>(frames),
                                        seq[t].measured_motion);
    CHECK(a.frames_combined == 1);
    CHECK(b.frames_combined == 4);
    CHECK(b.position_mm.isApprox(a.position_mm));
    CHECK(b.probability_within == doctest::Approx(a.probability_within));
    CHECK((burst.belief() - single.belief()).abs().maxCoeff() < 1e-6F);
  }
  // Bad bursts are refused before anything changes: empty, or frames of another geometry.
  const tacmap::image<float> before = burst.belief();
  CHECK_THROWS_WITH_AS((void)burst.touch(std::span<const tacmap::tactile_frame>()),
                       doctest::Contains("no frames"), std::invalid_argument);
  std::vector<tacmap::tactile_frame> mixed(2, sim.render(p.locations[0].pose()));
  mixed[1].geometry.cols = 5;
  mixed[1].counts.setConstant(14, 5, 100.0F);
  CHECK_THROWS_AS((void)burst.touch(std::span<const tacmap::tactile_frame>(mixed)),
                  std::invalid_argument);
  CHECK((burst.belief() - before).abs().maxCoeff() == 0.0F);
  CHECK(burst.touches() == 3);
}

TEST_CASE("a localizer with a self-calibrating sensor finds a dead taxel and keeps it past reset") {
  const auto& p = gecko();
  tacmap::localizer_config config = fast_config();
  config.calibrate_sensor = tacmap::self_calibration_params{};
  tacmap::localizer loc(p.map, p.mm_per_px, config);
  REQUIRE(loc.sensor_calibration() != nullptr);
  CHECK(tacmap::localizer(p.map, p.mm_per_px, fast_config()).sensor_calibration() == nullptr);
  auto sim = gecko_simulator(21);
  // Taxel (6, 2), in the middle of the array, reads nothing: a dead taxel.
  const auto dead = [](tacmap::tactile_frame f) {
    f.counts(6, 2) = 0.0F;
    return f;
  };
  std::size_t touches = 0;
  for (std::size_t q = 0; q < 4; ++q)
    for (const auto& step : p.sequences[q]) {
      (void)loc.touch(dead(sim.render(p.locations[step.location].pose())));
      ++touches;
      loc.reset();  // a new exploration: the sensor's estimate stays
    }
  CHECK(loc.sensor_calibration()->touches() == touches);
  CHECK(loc.sensor_calibration()->status(6, 2) == tacmap::taxel_status::dead);
  CHECK_FALSE(loc.sensor_calibration()->live()(6, 2));
  // The corrected frame localizes as well as the healthy one where the dead taxel is filled in.
  const auto& truth = p.locations[p.sequences[0][0].location];
  const auto r = loc.touch(dead(sim.render(truth.pose())));
  CHECK(r.accepted());
  loc.reset_sensor_calibration();
  CHECK(loc.sensor_calibration()->touches() == 0);
  CHECK(loc.sensor_calibration()->status(6, 2) == tacmap::taxel_status::unestimated);
  // Bad settings are refused up front.
  config.calibrate_sensor->window = 0;
  CHECK_THROWS_WITH_AS(tacmap::localizer(p.map, p.mm_per_px, config),
                       doctest::Contains("window = 0"), std::invalid_argument);
}

TEST_CASE("localizer_config::tracking turns tracking off and on, and the two agree") {
  const auto& p = gecko();
  tacmap::localizer_config tracked_config, full_config;
  tracked_config.tracking = tacmap::default_tracking();
  full_config.tracking.reset();
  tacmap::localizer full(p.map, p.mm_per_px, full_config);
  tacmap::localizer tracked(p.map, p.mm_per_px, tracked_config);
  REQUIRE(tracked.planar_filter() != nullptr);
  CHECK(tracked.planar_filter()->tracking().epsilon == tacmap::default_tracking().epsilon);
  CHECK(full.planar_filter()->tracking().epsilon == 0.0);
  auto sim = gecko_simulator(31);
  const auto& seq = p.sequences[1];
  for (std::size_t t = 0; t < seq.size(); ++t) {
    CAPTURE(t);
    const auto& truth = p.locations[seq[t].location];
    const auto frame = sim.render(truth.pose());
    const auto a = t == 0 ? full.touch(frame) : full.touch(frame, seq[t].measured_motion);
    const auto b = t == 0 ? tracked.touch(frame) : tracked.touch(frame, seq[t].measured_motion);
    CHECK((b.position_mm - a.position_mm).norm() < 1.5);
    CHECK(b.probability_within == doctest::Approx(a.probability_within).epsilon(0.02));
    CHECK(b.verdict == a.verdict);
  }
  // With unknown heading tracking applies by default too (tracking_headings), and can be turned
  // off there alone; on, the rotated model's hook is reached.
  tracked_config.headings = 8;
  CHECK(tacmap::localizer_config{}.tracking_headings);
  tracked_config.tracking_headings = false;
  CHECK(tacmap::localizer(p.map, p.mm_per_px, tracked_config).pose_filter()->tracking().epsilon ==
        0.0);
  tracked_config.tracking_headings = true;
  tacmap::localizer pose(p.map, p.mm_per_px, tracked_config);
  REQUIRE(pose.pose_filter() != nullptr);
  CHECK(pose.pose_filter()->tracking().epsilon > 0.0);
  const auto& truth = p.locations[seq[0].location];
  CHECK(pose.touch(sim.render(truth.pose())).accepted());
}

}  // namespace test_localizer
