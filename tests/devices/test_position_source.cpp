// The position_source concept (both ways), the map-frame calibration, odometry between poses,
// and the scripted source.
#include <doctest/doctest.h>

#include <chrono>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>

#include "tacmap/devices/position_source.hpp"
#include "tacmap/io/session_log.hpp"
#include "tacmap/tacmap.hpp"

namespace test_position_source {

namespace {

using namespace std::chrono_literals;
using tacmap::map_calibration;
using tacmap::sensor_pose;
constexpr double pi = std::numbers::pi;

// ---- position_source, both ways ------------------------------------------------------------
struct parked {  // the minimal conforming type from the concept's comment
  std::optional<sensor_pose> next_pose(std::chrono::milliseconds) {
    return sensor_pose{sensor_pose::clock::now()};
  }
};
struct returns_plain_pose {  // no way to say "exhausted"
  sensor_pose next_pose(std::chrono::milliseconds) { return {}; }
};
struct no_timeout {
  std::optional<sensor_pose> next_pose() { return std::nullopt; }
};
struct takes_int_timeout {  // a bare number of unknown unit is not a timeout
  std::optional<sensor_pose> next_pose(int) { return std::nullopt; }
};
struct returns_position_only {
  std::optional<Eigen::Vector3d> next_pose(std::chrono::milliseconds) { return std::nullopt; }
};
struct differently_named {
  std::optional<sensor_pose> read(std::chrono::milliseconds) { return std::nullopt; }
};

static_assert(tacmap::position_source<parked>);
static_assert(tacmap::position_source<tacmap::scripted_position_source>);
static_assert(tacmap::position_source<tacmap::session_reader>);
static_assert(!tacmap::position_source<returns_plain_pose>);
static_assert(!tacmap::position_source<no_timeout>);
static_assert(!tacmap::position_source<takes_int_timeout>);
static_assert(!tacmap::position_source<returns_position_only>);
static_assert(!tacmap::position_source<differently_named>);
static_assert(!tacmap::position_source<int>);

sensor_pose at(double x, double y, double z, double yaw = 0.0, long long ms = 0) {
  return {sensor_pose::clock::time_point(std::chrono::milliseconds(ms)), x, y, z, yaw};
}

template <class F>
std::string message_of(F&& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no exception)";
}

}  // namespace

TEST_CASE("position_source: a parked source yields poses") {
  parked p;
  const auto pose = p.next_pose(10ms);
  REQUIRE(pose);
  CHECK(pose->finite());
}

TEST_CASE("map_calibration: horizontal plane maps device x to map x and device z to map y") {
  const map_calibration c = map_calibration::horizontal();
  CHECK_NOTHROW(c.validate());
  const Eigen::Vector2d d = c.displacement_to_map_mm({10.0, 7.0, 5.0});  // y (up) is dropped
  CHECK(d.x() == doctest::Approx(10.0));
  CHECK(d.y() == doctest::Approx(5.0));
}

TEST_CASE("map_calibration: vertical plane maps device up to map up (negative map y)") {
  const map_calibration c = map_calibration::vertical();
  const Eigen::Vector2d d = c.displacement_to_map_mm({2.0, 5.0, 9.0});  // z (toward user) dropped
  CHECK(d.x() == doctest::Approx(2.0));
  CHECK(d.y() == doctest::Approx(-5.0));
}

TEST_CASE("map_calibration: rotation, scale and translation") {
  const map_calibration c = map_calibration::horizontal(pi / 2, {100.0, 50.0}, 2.0);
  // Device +x (1 mm) -> plane (1, 0) -> rotated by 90 degrees to (0, 1) -> scaled to (0, 2).
  const Eigen::Vector2d d = c.displacement_to_map_mm({1.0, 0.0, 0.0});
  CHECK(d.x() == doctest::Approx(0.0).epsilon(1e-12));
  CHECK(d.y() == doctest::Approx(2.0));
  // Device +z (3 mm) -> plane (0, 3) -> rotated to (-3, 0) -> scaled to (-6, 0).
  const Eigen::Vector2d e = c.displacement_to_map_mm({0.0, 0.0, 3.0});
  CHECK(e.x() == doctest::Approx(-6.0));
  CHECK(e.y() == doctest::Approx(0.0).epsilon(1e-12));
  const Eigen::Vector2d p = c.to_map_mm(at(1.0, 0.0, 3.0));
  CHECK(p.x() == doctest::Approx(94.0));
  CHECK(p.y() == doctest::Approx(52.0));
}

TEST_CASE("map_calibration: to_device_mm inverts to_map_mm, and height points off the surface") {
  const map_calibration h = map_calibration::horizontal(0.4, {20.0, -7.0}, 1.1);
  const Eigen::Vector3d d = h.to_device_mm({33.0, 44.0}, 8.0);
  CHECK(d.y() == doctest::Approx(8.0));  // up, above the table
  const Eigen::Vector2d back = h.to_map_mm(d);
  CHECK(back.x() == doctest::Approx(33.0));
  CHECK(back.y() == doctest::Approx(44.0));
  const map_calibration v = map_calibration::vertical();
  const Eigen::Vector3d w = v.to_device_mm({5.0, 6.0}, 3.0);
  CHECK(w.x() == doctest::Approx(5.0));
  CHECK(w.y() == doctest::Approx(-6.0));
  CHECK(w.z() == doctest::Approx(3.0));  // toward the user, who faces the upright object
}

TEST_CASE("map_calibration: invalid calibrations are refused with the offending value") {
  map_calibration c;
  c.plane_axes << 1, 0, 0, 1, 0, 0;  // u = v
  CHECK(message_of([&] { c.validate(); }).find("not orthonormal") != std::string::npos);
  c = map_calibration::horizontal();
  c.plane_axes(0, 0) = 2.0;
  CHECK_THROWS_AS(c.validate(), std::invalid_argument);
  c = map_calibration::horizontal();
  c.scale = 0.0;
  CHECK(message_of([&] { c.validate(); }).find("scale = 0") != std::string::npos);
  c = map_calibration::horizontal();
  c.rotation_rad = std::numeric_limits<double>::quiet_NaN();
  CHECK(message_of([&] { c.validate(); }).find("rotation_rad = nan") != std::string::npos);
  c = map_calibration::horizontal();
  c.translation_mm.y() = std::numeric_limits<double>::infinity();
  CHECK_THROWS_AS(c.validate(), std::invalid_argument);
}

TEST_CASE("map_calibration: two reference points recover rotation, translation and scale") {
  const map_calibration truth = map_calibration::horizontal(0.7, {30.0, -12.0}, 1.05);
  // Device positions whose map images are the two reference points (invert the calibration).
  const auto device_for = [&](Eigen::Vector2d map, double height) {
    const Eigen::Vector2d plane =
        truth.rotation().transpose() * ((map - truth.translation_mm) / truth.scale);
    return Eigen::Vector3d(plane.x(), height, plane.y());
  };
  const Eigen::Vector2d ma(10.0, 20.0), mb(110.0, 95.0);
  const Eigen::Vector3d da = device_for(ma, 3.0), db = device_for(mb, -4.0);
  const map_calibration fitted =
      map_calibration::from_two_points(truth.plane_axes, da, ma, db, mb, true);
  CHECK(fitted.rotation_rad == doctest::Approx(0.7));
  CHECK(fitted.scale == doctest::Approx(1.05));
  CHECK(fitted.translation_mm.x() == doctest::Approx(30.0));
  CHECK(fitted.translation_mm.y() == doctest::Approx(-12.0));
  const Eigen::Vector2d check = fitted.to_map_mm(device_for({60.0, 60.0}, 0.0));
  CHECK(check.x() == doctest::Approx(60.0));
  CHECK(check.y() == doctest::Approx(60.0));
  // Without fitting the scale it stays 1 and the first point is matched exactly.
  const map_calibration rigid =
      map_calibration::from_two_points(truth.plane_axes, da, ma, db, mb, false);
  CHECK(rigid.scale == 1.0);
  CHECK(rigid.rotation_rad == doctest::Approx(0.7));
  CHECK((rigid.to_map_mm(da) - ma).norm() == doctest::Approx(0.0).epsilon(1e-9));
  // Coincident points cannot define a rotation.
  CHECK(message_of([&] {
          (void)map_calibration::from_two_points(truth.plane_axes, da, ma, da, mb);
        }).find("apart") != std::string::npos);
}

TEST_CASE("map_calibration: the heading of a direction in the object's plane") {
  const map_calibration c = map_calibration::horizontal();
  CHECK(*c.plane_heading({1.0, 0.0, 0.0}) == doctest::Approx(0.0));
  CHECK(*c.plane_heading({0.0, 0.0, 2.0}) == doctest::Approx(pi / 2));
  CHECK(*c.plane_heading({-1.0, 0.3, 0.0}) == doctest::Approx(pi));
  CHECK_FALSE(c.plane_heading({0.0, 1.0, 0.0}));   // along the normal
  CHECK_FALSE(c.plane_heading({0.01, 1.0, 0.0}));  // within ~6 degrees of it
  CHECK_FALSE(c.plane_heading({0.0, 0.0, 0.0}));
}

TEST_CASE("odometry_between: displacement in the map frame, wrapped heading change, time") {
  const map_calibration c = map_calibration::horizontal(pi / 2);
  const sensor_pose a = at(0.0, 10.0, 0.0, 3.0, 100);
  const sensor_pose b = at(4.0, 12.0, 1.0, -3.0, 350);
  const tacmap::pose_change d = tacmap::odometry_between(a, b, c);
  // Plane displacement (4, 1), rotated by 90 degrees: (-1, 4).
  CHECK(d.dx_mm == doctest::Approx(-1.0));
  CHECK(d.dy_mm == doctest::Approx(4.0));
  CHECK(d.dyaw_rad == doctest::Approx(2 * pi - 6.0));  // -6 rad wrapped to (-pi, pi]
  CHECK(d.elapsed == std::chrono::milliseconds(250));
  CHECK(d.distance_mm() == doctest::Approx(std::sqrt(17.0)));
  const tacmap::odometry u = d.control();
  CHECK(u.dx_mm == d.dx_mm);
  CHECK(u.dy_mm == d.dy_mm);
  // Reverse motion is the exact opposite.
  const tacmap::pose_change back = tacmap::odometry_between(b, a, c);
  CHECK(back.dx_mm == doctest::Approx(1.0));
  CHECK(back.dyaw_rad == doctest::Approx(-(2 * pi - 6.0)));
}

TEST_CASE("odometry_between: timestamps too far apart for the clock's count are refused") {
  using clock = std::chrono::steady_clock;
  const map_calibration c = map_calibration::horizontal();
  sensor_pose early = at(0.0, 0.0, 0.0);
  sensor_pose late = at(1.0, 0.0, 0.0);
  early.timestamp = clock::time_point(clock::duration(std::numeric_limits<clock::rep>::min()));
  late.timestamp = clock::time_point(clock::duration(std::numeric_limits<clock::rep>::max()));
  // max - min and min - max overflow a signed 64-bit count (undefined behaviour; it used to wrap
  // to a small "elapsed" silently).
  for (const auto& [a, b] : {std::pair{early, late}, std::pair{late, early}}) {
    try {
      (void)tacmap::odometry_between(a, b, c);
      FAIL("no exception");
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      CHECK(what.find("odometry_between: the time from tick") != std::string::npos);
      CHECK(what.find(std::to_string(std::numeric_limits<clock::rep>::max())) != std::string::npos);
      CHECK(what.find("does not fit its 64-bit count") != std::string::npos);
    }
  }
  // The widest differences that fit are exact, in both directions.
  sensor_pose zero = at(0.0, 0.0, 0.0);
  zero.timestamp = clock::time_point(clock::duration(0));
  CHECK(tacmap::odometry_between(zero, late, c).elapsed.count() ==
        std::numeric_limits<clock::rep>::max());
  CHECK(tacmap::odometry_between(zero, early, c).elapsed.count() ==
        std::numeric_limits<clock::rep>::min());
  zero.timestamp = clock::time_point(clock::duration(-1));  // one tick more: max + 1
  CHECK_THROWS_AS((void)tacmap::odometry_between(zero, late, c), std::invalid_argument);
}

TEST_CASE("odometry_between: invalid poses and calibrations are refused") {
  const sensor_pose good = at(0, 0, 0);
  sensor_pose bad = at(1, 2, 3);
  bad.y_mm = std::numeric_limits<double>::quiet_NaN();
  const std::string m =
      message_of([&] { (void)tacmap::odometry_between(good, bad, map_calibration{}); });
  CHECK(m.find("pose b") != std::string::npos);
  CHECK(m.find("nan") != std::string::npos);
  map_calibration broken;
  broken.scale = -1.0;
  CHECK_THROWS_AS((void)tacmap::odometry_between(good, good, broken), std::invalid_argument);
}

TEST_CASE("odometry_between drives the paper's motion model in map millimetres") {
  using grid_t = tacmap::planar_grid<double>;
  const grid_t grid({.width = 40, .height = 40}, 1.0, {.width = 4, .height = 4});  // 37 x 37
  struct flat {
    using measurement_type = int;
    void log_likelihood(const grid_t&, const int&, Eigen::ArrayXd& out) const { out.setZero(); }
  };
  tacmap::bayes_filter filter(grid, tacmap::odometry_gaussian({.sigma_mm = 0.5, .k = 8}), flat{});
  Eigen::ArrayXd prior = Eigen::ArrayXd::Zero(grid.size());
  prior(grid.index({10, 10})) = 1.0;
  filter.set_prior(prior);
  // The device moved 6 mm along +x and 3 mm toward the user (+z): map (+6, +3) mm.
  const auto d = tacmap::odometry_between(at(0, 0, 0), at(6, 40, 3), map_calibration{});
  filter.predict(d.control());
  const auto e = filter.estimate();
  const auto start = grid.state_mm(grid.index({10, 10}));
  CHECK(e.mean_mm.x() - start.x() == doctest::Approx(6.0).epsilon(1e-6));
  CHECK(e.mean_mm.y() - start.y() == doctest::Approx(3.0).epsilon(1e-6));
}

TEST_CASE("scripted_position_source: poses in order, then nothing, for good") {
  tacmap::scripted_position_source s({at(1, 0, 0), at(2, 0, 0)});
  CHECK(s.size() == 2);
  CHECK(s.next_pose(1ms)->x_mm == 1.0);
  CHECK(s.remaining() == 1);
  CHECK(s.next_pose(1ms)->x_mm == 2.0);
  CHECK_FALSE(s.next_pose(1ms));
  CHECK_FALSE(s.next_pose(1ms));
  sensor_pose bad = at(0, 0, 0);
  bad.yaw_rad = std::numeric_limits<double>::infinity();
  const std::string m = message_of([&] { tacmap::scripted_position_source({at(0, 0, 0), bad}); });
  CHECK(m.find("pose 1") != std::string::npos);
}

TEST_CASE("wrap_angle keeps angles in the half-open interval from -pi to pi") {
  using tacmap::detail::wrap_angle;
  CHECK(wrap_angle(0.0) == 0.0);
  CHECK(wrap_angle(pi) == doctest::Approx(pi));
  CHECK(wrap_angle(-pi) == doctest::Approx(pi));
  CHECK(wrap_angle(3 * pi / 2) == doctest::Approx(-pi / 2));
  CHECK(wrap_angle(-7.0) == doctest::Approx(-7.0 + 2 * pi));
  CHECK(wrap_angle(40.0) > -pi);
  CHECK(wrap_angle(40.0) <= pi);
}

}  // namespace test_position_source
