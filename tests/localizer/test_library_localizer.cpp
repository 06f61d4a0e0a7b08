// Tests of the library front door (library_localizer, make_library_filter) and of its simulated
// evaluation (library_experiment): which object, and where (issue 15).
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "sim/gecko_protocol.hpp"
#include "tacmap/library_localizer.hpp"
#include "tacmap/sim/library_experiment.hpp"
#include "tacmap/sim/tactile_simulator.hpp"
#include "test_support.hpp"

namespace test_library_localizer {

namespace {

// SIFT-lite on the shared dense field: milliseconds to prepare a map, even unoptimised.
tacmap::localizer_config fast_library_config() {
  tacmap::localizer_config c;
  c.model = tacmap::measurement_kind::lite;
  c.features = tacmap::window_features::shared_dense;
  return c;
}

// Two other objects: the gecko's map turned upside down and mirrored (the same texture
// statistics, another layout) and its transpose photographed at a finer scale (resampled to the
// library's, the coarsest).
std::vector<tacmap::library_map> gecko_library() {
  const auto& p = tacmap_test::gecko();
  const tacmap::image<float> turned = p.map.reverse();
  const tacmap::image<float> transposed = p.map.transpose();
  return {{"turned", turned, p.mm_per_px},
          {"gecko", p.map, p.mm_per_px},
          {"transposed", tacmap::rescale(transposed, p.mm_per_px, 0.8 * p.mm_per_px),
           0.8 * p.mm_per_px}};
}

}  // namespace

TEST_CASE("library_localizer: touches on the gecko recognise it among other maps") {
  const auto& p = tacmap_test::gecko();
  tacmap::library_localizer loc(gecko_library(), fast_library_config());
  CHECK(loc.objects() == 3);
  CHECK(loc.mm_per_px() == p.mm_per_px);
  // The finer map was resampled to the library's scale: the (square) gecko's size again.
  CHECK(p.map.rows() == p.map.cols());
  CHECK(loc.filter().grid().object(2).base().size() == loc.filter().grid().object(1).base().size());
  tacmap::tactile_simulator sim(p.relief_mm(), p.map_size(), p.mm_per_px, {.seed = 5});
  tacmap::library_touch_result r;
  const auto& sequence = p.sequences[0];
  for (std::size_t t = 0; t < sequence.size(); ++t) {
    const auto& truth = p.locations[sequence[t].location];
    const auto frame = sim.render(truth.pose());
    r = t == 0 ? loc.touch(frame) : loc.touch(frame, sequence[t].measured_motion);
    CHECK(r.accepted());
    REQUIRE(r.object_probability.size() == 3);
    double sum = r.probability_unknown;  // the objects and "none of these"
    for (const double q : r.object_probability) sum += q;
    CHECK(sum == doctest::Approx(1.0).epsilon(1e-5));
  }
  const auto& truth = p.locations[sequence.back().location];
  CHECK(r.object == 1);
  CHECK(r.object_name == "gecko");
  CHECK(r.object_probability[1] > 0.9);
  CHECK(r.tied_objects.empty());
  CHECK((r.position_mm - Eigen::Vector2d(truth.x_mm, truth.y_mm)).norm() < 5.0);
  // The joint probability: never above the object's own posterior.
  CHECK(r.probability_within <= r.object_probability[1] + 1e-9);
  // The leading object's belief, as an image of its positions, sums to one.
  const auto b = loc.object_belief_image(1);
  CHECK(b.rows() == loc.filter().grid().object(1).base().rows());
  CHECK(static_cast<double>(b.sum()) == doctest::Approx(1.0).epsilon(1e-4));
  loc.reset();
  CHECK(loc.filter().estimate().object_probability[0] == doctest::Approx(1.0 / 3.0));
}

TEST_CASE("library_localizer: touch_at turns the arm's poses into the same odometry") {
  // The same gecko sequence given as motions and as the arm's poses (offset by an arbitrary
  // origin): the same beliefs touch for touch. A refused pose changes nothing and is not kept.
  const auto& p = tacmap_test::gecko();
  tacmap::library_localizer by_motion(gecko_library(), fast_library_config());
  tacmap::library_localizer by_pose(gecko_library(), fast_library_config());
  tacmap::tactile_simulator sim(p.relief_mm(), p.map_size(), p.mm_per_px, {.seed = 7});
  const auto& sequence = p.sequences[1];
  tacmap::arm_pose arm{.x_mm = 250.0, .y_mm = -40.0, .theta_rad = 0.3};
  tacmap::tactile_frame frame;
  for (std::size_t t = 0; t < sequence.size(); ++t) {
    frame = sim.render(p.locations[sequence[t].location].pose());
    if (t > 0) {
      arm.x_mm += sequence[t].measured_motion.dx_mm;
      arm.y_mm += sequence[t].measured_motion.dy_mm;
    }
    const auto a =
        t == 0 ? by_motion.touch(frame) : by_motion.touch(frame, sequence[t].measured_motion);
    // A small yaw jitter (under the 5 degrees a known heading allows) changes nothing.
    const auto b =
        by_pose.touch_at(frame, {.x_mm = arm.x_mm,
                                 .y_mm = arm.y_mm,
                                 .theta_rad = arm.theta_rad + (t % 2 == 0 ? 0.0 : 0.01)});
    CHECK(b.object == a.object);
    CHECK((b.position_mm - a.position_mm).norm() < 1e-9);
    REQUIRE(b.object_probability.size() == a.object_probability.size());
    for (std::size_t k = 0; k < a.object_probability.size(); ++k)
      CHECK(b.object_probability[k] == doctest::Approx(a.object_probability[k]).epsilon(1e-12));
  }
  // A turned arm and a NaN are refused, naming the value; the pose is not kept, so the next touch's
  // motion is counted from the last accepted pose.
  const std::size_t touches = by_pose.touches();
  CHECK_THROWS_WITH_AS(
      by_pose.touch_at(frame, {.x_mm = arm.x_mm, .y_mm = arm.y_mm, .theta_rad = 0.9}),
      doctest::Contains("yaw changed by"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(by_pose.touch_at(frame, {.x_mm = std::nan(""), .y_mm = 0.0}),
                       doctest::Contains("not finite"), std::invalid_argument);
  CHECK(by_pose.touches() == touches);
  const auto a = by_motion.touch(frame, tacmap::odometry{.dx_mm = 1.0, .dy_mm = 0.0});
  const auto b =
      by_pose.touch_at(frame, {.x_mm = arm.x_mm + 1.0, .y_mm = arm.y_mm, .theta_rad = 0.3});
  CHECK((b.position_mm - a.position_mm).norm() < 1e-9);
  // reset() forgets the pose: the next touch_at has no motion, as a first touch.
  by_pose.reset();
  by_motion.reset();
  CHECK((by_pose.touch_at(frame, {.x_mm = 0.0, .y_mm = 0.0}).position_mm -
         by_motion.touch(frame).position_mm)
            .norm() < 1e-9);
}

TEST_CASE("library_localizer: a move off every map restarts the paper's configuration") {
  // No motion floor: a 1 m move carries every state off every map, which the filter reports as
  // a std::domain_error; the localizer starts again from each object's prior instead.
  const auto& p = tacmap_test::gecko();
  auto config = tacmap::localizer_config::paper();
  config.features = tacmap::window_features::shared_dense;
  tacmap::library_localizer loc(gecko_library(), config);
  tacmap::tactile_simulator sim(p.relief_mm(), p.map_size(), p.mm_per_px, {.seed = 9});
  const auto frame = sim.render(p.locations[0].pose());
  CHECK_FALSE(loc.touch(frame).restarted);
  const auto r = loc.touch(frame, tacmap::odometry{.dx_mm = 1000.0, .dy_mm = 0.0});
  CHECK(r.restarted);
  CHECK(r.touches == 2);
  // Restarted before the update: the touch is weighed against the prior, which supports it.
  CHECK(r.log_prediction_support <= 1e-6);  // 0 up to the sums' rounding
  CHECK(r.log_prediction_support > -1.0);
  double sum = r.probability_unknown;
  for (const double q : r.object_probability) {
    CHECK(std::isfinite(q));
    sum += q;
  }
  CHECK(sum == doctest::Approx(1.0).epsilon(1e-5));
  CHECK(static_cast<double>(loc.object_belief_image(r.object).sum()) ==
        doctest::Approx(1.0).epsilon(1e-4));
}

TEST_CASE("library_localizer: bad libraries and touches are refused with the reason") {
  using tacmap_test::message_of;
  const auto& p = tacmap_test::gecko();
  const auto config = fast_library_config();
  auto maps = gecko_library();
  const auto refused = [&](std::vector<tacmap::library_map> m) {
    return message_of([&] { tacmap::library_localizer loc(std::move(m), config); });
  };
  CHECK(refused({}).find("library is empty") != std::string::npos);
  auto bad = maps;
  bad[2].mm_per_px = 0.0;
  CHECK(refused(bad).find("mm_per_px = 0 for 'transposed'") != std::string::npos);
  bad = maps;
  bad[0].map(3, 4) = std::numeric_limits<float>::quiet_NaN();
  CHECK(refused(bad).find("'turned' (object 0) has non-finite pixels") != std::string::npos);
  CHECK(message_of([&] {
          tacmap::library_localizer loc(maps, config, {}, {}, 1.5 * p.mm_per_px);
        }).find("give the library a finer scale") != std::string::npos);
  bad = maps;
  bad[1].map = tacmap::image<float>::Ones(20, 20);
  CHECK(refused(bad).find("at least the sensor's size") != std::string::npos);
  bad = maps;
  bad.push_back({"gecko again", p.map, p.mm_per_px});
  CHECK(refused(bad).find("same image at the same scale") != std::string::npos);
  bad = maps;
  bad[2].name = "gecko";
  CHECK(refused(bad).find("both named 'gecko'") != std::string::npos);
  CHECK(message_of([&] {
          tacmap::library_localizer loc(maps, config, {}, {0.5, 0.5, 0.5});
        }).find("sums to 1.5") != std::string::npos);
  auto pose = config;
  pose.headings = 36;
  CHECK(message_of([&] { tacmap::library_localizer loc(maps, pose); }).find("headings = 36") !=
        std::string::npos);
  tacmap::library_localizer loc(maps, config);
  tacmap::tactile_frame frame;
  frame.counts.setConstant(1000.0F);
  CHECK(message_of([&] {
          loc.touch(frame, tacmap::odometry{.dx_mm = std::numeric_limits<double>::infinity()});
        }).find("not finite") != std::string::npos);
}

TEST_CASE("library_experiment: the library filter and the object's own filter on one sequence") {
  const auto& p = tacmap_test::gecko();
  tacmap::touch_protocol turned = p;
  turned.map = p.map.reverse();
  tacmap::localization_config c;
  static_cast<tacmap::localizer_config&>(c) = fast_library_config();
  tacmap::library_experiment e({{"gecko", &p}, {"turned", &turned}}, c);
  CHECK(e.objects() == 2);
  const auto r = e.run(0, 1);
  CHECK(r.object == 0);
  REQUIRE(r.touches.size() == p.sequences[1].size());
  REQUIRE(r.known_object.size() == r.touches.size());
  // The same touches: the truth and the odometry agree with the object's own run.
  for (std::size_t t = 0; t < r.touches.size(); ++t) {
    CHECK(r.touches[t].true_x_mm == r.known_object[t].true_x_mm);
    CHECK(r.touches[t].reported_dx_mm == r.known_object[t].reported_dx_mm);
  }
  CHECK(r.recognized_at(r.touches.size()));
  CHECK(r.touches_to_recognize().has_value());
  CHECK(tacmap::localized(r.touches));
  // A position on the wrong object is no position.
  for (std::size_t t = 0; t < r.touches.size(); ++t)
    if (r.decided[t] != r.object) CHECK(std::isinf(r.touches[t].error_mm));
  CHECK(tacmap_test::message_of([&] { (void)e.run(2, 0); }).find("object 2") != std::string::npos);
  auto pose = c;
  pose.headings = 36;
  CHECK(tacmap_test::message_of([&] {
          tacmap::library_experiment bad({{"gecko", &p}}, pose);
        }).find("known heading") != std::string::npos);
}

}  // namespace test_library_localizer
