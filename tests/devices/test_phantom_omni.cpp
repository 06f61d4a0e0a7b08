// The Phantom Omni adapter's logic, driven through a scripted fake of the HDAPI seam: no SDK.
// The fake defines its own minimal types; it checks the HDAPI rules the adapter must follow
// (device state read only inside a frame, on the servo thread) and scripts errors.
#include <doctest/doctest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "tacmap/devices/phantom_omni.hpp"

namespace test_phantom_omni {

namespace {

namespace hd = tacmap::hd;
using Eigen::Vector3d;
constexpr double pi = std::numbers::pi;

struct fake_state {
  std::vector<std::string> calls;
  std::vector<hd::error_info> stack;                           // back() is the newest error
  std::map<std::string, std::vector<hd::error_info>> fail_on;  // pushed when the call happens
  std::map<std::string, std::string> descriptions;             // "hdGetErrorString"
  std::vector<std::array<double, 16>> transforms;  // one per state copy; the last repeats
  std::size_t transform_reads = 0;
  int buttons = 0;
  std::vector<unsigned> calibration;  // statuses in order; the last repeats
  std::size_t calibration_checks = 0;
  std::vector<unsigned> calibration_updates;
  bool servo_loop_runs = true;  // false: scheduled callbacks are dropped
  bool in_callback = false;
  bool in_frame = false;
  int rule_violations = 0;  // state read outside a frame or off the servo thread
  unsigned handle = 7;

  void call(const std::string& name) {
    calls.push_back(name);
    const auto it = fail_on.find(name);
    if (it != fail_on.end()) stack.insert(stack.end(), it->second.begin(), it->second.end());
  }
  bool called(const std::string& name) const {
    return std::find(calls.begin(), calls.end(), name) != calls.end();
  }
  std::ptrdiff_t position(const std::string& name) const {
    return std::find(calls.begin(), calls.end(), name) - calls.begin();
  }
};

/// A scripted HDAPI. Copies share the script (the adapter keeps its own copy).
struct fake_hd {
  using handle_type = unsigned;
  std::shared_ptr<fake_state> s = std::make_shared<fake_state>();

  handle_type init_device(const char* name) {
    s->call(std::string("hdInitDevice ") + (name == nullptr ? "<default>" : name));
    s->call("hdInitDevice");
    return s->handle;
  }
  void disable_device(handle_type h) { s->call("hdDisableDevice " + std::to_string(h)); }
  void make_current_device(handle_type h) { s->call("hdMakeCurrentDevice " + std::to_string(h)); }
  hd::error_info get_error() noexcept {
    if (s->stack.empty()) return {};
    const hd::error_info e = s->stack.back();
    s->stack.pop_back();
    return e;
  }
  std::string error_string(unsigned code) {
    const auto it = s->descriptions.find(std::string(hd::error_name(code)));
    return it == s->descriptions.end() ? std::string() : it->second;
  }
  void start_scheduler() { s->call("hdStartScheduler"); }
  void stop_scheduler() { s->call("hdStopScheduler"); }
  void schedule_synchronous(hd::callback cb, void* data) {
    s->call("hdScheduleSynchronous");
    if (!s->servo_loop_runs) return;
    s->in_callback = true;
    const unsigned result = cb(data);
    s->in_callback = false;
    if (result != hd::callback_done) ++s->rule_violations;  // a synchronous copy runs once
  }
  void begin_frame(handle_type) noexcept {
    s->call("hdBeginFrame");
    if (s->in_frame || !s->in_callback) ++s->rule_violations;
    s->in_frame = true;
  }
  void end_frame(handle_type) noexcept {
    s->call("hdEndFrame");
    if (!s->in_frame) ++s->rule_violations;
    s->in_frame = false;
  }
  void get_doublev(unsigned param, double* values) noexcept {
    s->call("hdGetDoublev");
    if (!s->in_frame || !s->in_callback || param != hd::current_transform) ++s->rule_violations;
    std::array<double, 16> t{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    if (!s->transforms.empty())
      t = s->transforms[std::min(s->transform_reads, s->transforms.size() - 1)];
    ++s->transform_reads;
    std::copy(t.begin(), t.end(), values);
  }
  void get_integerv(unsigned param, int* values) noexcept {
    s->call("hdGetIntegerv");
    if (!s->in_frame || !s->in_callback || param != hd::current_buttons) ++s->rule_violations;
    *values = s->buttons;
  }
  unsigned check_calibration() noexcept {
    s->call("hdCheckCalibration");
    if (!s->in_frame) ++s->rule_violations;
    if (s->calibration.empty()) return hd::calibration_ok;
    return s->calibration[std::min(s->calibration_checks++, s->calibration.size() - 1)];
  }
  void update_calibration(unsigned style) noexcept {
    s->call("hdUpdateCalibration");
    if (!s->in_frame) ++s->rule_violations;
    s->calibration_updates.push_back(style);
  }
};

// The minimal conforming type from the concept's comment.
struct parked_omni {
  using handle_type = unsigned;
  unsigned init_device(const char*) { return 1; }
  void disable_device(unsigned) {}
  void make_current_device(unsigned) {}
  hd::error_info get_error() noexcept { return {}; }
  std::string error_string(unsigned) { return {}; }
  void start_scheduler() {}
  void stop_scheduler() {}
  void schedule_synchronous(hd::callback cb, void* data) { cb(data); }
  void begin_frame(unsigned) noexcept {}
  void end_frame(unsigned) noexcept {}
  void get_doublev(unsigned, double* v) noexcept {  // the identity transform
    for (int i = 0; i < 16; ++i) v[i] = i % 5 == 0 ? 1.0 : 0.0;
  }
  void get_integerv(unsigned, int* v) noexcept { *v = 0; }
  unsigned check_calibration() noexcept { return hd::calibration_ok; }
  void update_calibration(unsigned) noexcept {}
};
static_assert(tacmap::hd_api<parked_omni>);

// Near misses of the seam: each lacks one requirement.
struct seam_throwing_get_error : fake_hd {
  hd::error_info get_error() { return {}; }  // not noexcept: could throw through the SDK
};
struct seam_without_handle_type {
  unsigned init_device(const char*) { return 0; }
};
struct seam_frame_may_throw : fake_hd {
  void begin_frame(handle_type) {}
};

static_assert(tacmap::hd_api<fake_hd>);
static_assert(!tacmap::hd_api<seam_throwing_get_error>);
static_assert(!tacmap::hd_api<seam_without_handle_type>);
static_assert(!tacmap::hd_api<seam_frame_may_throw>);
static_assert(tacmap::position_source<tacmap::basic_phantom_omni<fake_hd>>);

using omni_t = tacmap::basic_phantom_omni<fake_hd>;

/// Options with one field changed (designated initializers that skip fields trip g++ 12's
/// -Wmissing-field-initializers).
template <class F>
tacmap::phantom_omni_options options(F&& change) {
  tacmap::phantom_omni_options o;
  change(o);
  return o;
}

/// Column-major 4 x 4 (as HD_CURRENT_TRANSFORM) from a rotation and a translation.
std::array<double, 16> transform(const Eigen::Matrix3d& r, const Vector3d& t) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = r;
  m.topRightCorner<3, 1>() = t;
  std::array<double, 16> out{};
  Eigen::Map<Eigen::Matrix4d>(out.data()) = m;  // Eigen's default storage is column-major
  return out;
}

Eigen::Matrix3d about_y(double a) {
  return Eigen::AngleAxisd(a, Vector3d::UnitY()).toRotationMatrix();
}

template <class F>
std::string message_of(F&& f) {
  try {
    f();
  } catch (const tacmap::device_error& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("(not a device_error) ") + e.what();
  }
  return "(no exception)";
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

}  // namespace

TEST_CASE(
    "phantom_omni: opens, starts the servo loop, checks calibration, and shuts down in order") {
  fake_hd api;
  {
    omni_t omni({.device_name = "Left Omni"}, api);
    CHECK(api.s->called("hdInitDevice Left Omni"));
    CHECK(api.s->called("hdMakeCurrentDevice 7"));
    CHECK(api.s->position("hdStartScheduler") > api.s->position("hdInitDevice"));
    CHECK(api.s->called("hdCheckCalibration"));
    CHECK(omni.handle() == 7);
    CHECK_FALSE(api.s->called("hdStopScheduler"));
  }
  CHECK(api.s->called("hdStopScheduler"));
  CHECK(api.s->called("hdDisableDevice 7"));
  CHECK(api.s->position("hdStopScheduler") < api.s->position("hdDisableDevice 7"));
  CHECK(api.s->rule_violations == 0);
}

TEST_CASE("phantom_omni: the minimal seam of the concept's comment gives the origin") {
  tacmap::basic_phantom_omni<parked_omni> omni;
  const auto p = omni.next_pose();
  REQUIRE(p);
  CHECK(p->position_mm() == Vector3d::Zero());
  CHECK(p->yaw_rad == 0.0);
}

TEST_CASE("phantom_omni: the default device is opened with a null name") {
  fake_hd api;
  omni_t omni({}, api);
  CHECK(api.s->called("hdInitDevice <default>"));
}

TEST_CASE("phantom_omni: an init failure names the HD error, its code and the remedy") {
  fake_hd api;
  api.s->fail_on["hdInitDevice"] = {{0x302, 12}};
  api.s->descriptions["HD_COMM_ERROR"] = "Communication error";
  const std::string m = message_of([&] { omni_t omni({.device_name = "Left Omni"}, api); });
  CHECK(contains(m, "Phantom Omni 'Left Omni'"));
  CHECK(contains(m, "hdInitDevice failed"));
  CHECK(contains(m, "HD_COMM_ERROR (0x302, internal 12: Communication error)"));
  CHECK(contains(m, "cable"));
  // Nothing was started, so nothing is stopped or disabled.
  CHECK_FALSE(api.s->called("hdStartScheduler"));
  CHECK_FALSE(api.s->called("hdStopScheduler"));
  CHECK_FALSE(api.s->called("hdDisableDevice 7"));
}

TEST_CASE("phantom_omni: errors left by someone else are not blamed on opening") {
  fake_hd api;
  api.s->stack = {{0x100, 0}};  // a stale HD_INVALID_ENUM
  CHECK_NOTHROW(omni_t({}, api));
}

TEST_CASE("phantom_omni: several errors are listed oldest first, the oldest decides the remedy") {
  fake_hd api;
  api.s->fail_on["hdInitDevice"] = {{0x301, 0}, {0x104, 3}};  // already initiated, then bad handle
  const std::string m = message_of([&] { omni_t omni({}, api); });
  CHECK(contains(m, "HD_DEVICE_ALREADY_INITIATED (0x301, internal 0), then HD_BAD_HANDLE (0x104"));
  CHECK(contains(m, "another program"));
  fake_hd unknown;
  unknown.s->fail_on["hdInitDevice"] = {{0x999, 1}};
  CHECK(contains(message_of([&] { omni_t omni({}, unknown); }), "unknown HD error (0x999"));
}

TEST_CASE("phantom_omni: a scheduler that cannot start is reported, the device disabled") {
  fake_hd api;
  api.s->fail_on["hdStartScheduler"] = {{0x304, 5}};
  const std::string m = message_of([&] { omni_t omni({}, api); });
  CHECK(contains(m, "hdStartScheduler failed (could not start the servo loop)"));
  CHECK(contains(m, "HD_TIMER_ERROR (0x304, internal 5)"));
  CHECK(api.s->called("hdDisableDevice 7"));
  CHECK_FALSE(api.s->called("hdStopScheduler"));  // it never ran
}

TEST_CASE("phantom_omni: a servo loop that does not run the copy is an error, not a hang") {
  fake_hd api;
  omni_t omni({}, api);
  api.s->servo_loop_runs = false;
  const std::string m = message_of([&] { (void)omni.next_pose(); });
  CHECK(contains(m, "did not run the callback to copy the device state"));
  CHECK(contains(m, "scheduler is not running"));
}

TEST_CASE("phantom_omni: an error inside the servo frame is reported with its HD name") {
  fake_hd api;
  omni_t omni({}, api);
  api.s->fail_on["hdGetDoublev"] = {{0x300, 2}};
  const std::string m = message_of([&] { (void)omni.next_pose(); });
  CHECK(contains(m, "HD_DEVICE_FAULT (0x300, internal 2)"));
  CHECK(contains(m, "copy the device state"));
  CHECK(contains(m, "power-cycle"));
  api.s->fail_on.clear();
  CHECK_NOTHROW((void)omni.next_pose());  // the error was consumed; the device works again
  api.s->fail_on["hdScheduleSynchronous"] = {{0x501, 0}};
  CHECK(contains(message_of([&] { (void)omni.next_pose(); }), "HD_SCHEDULER_FULL"));
}

TEST_CASE("phantom_omni: calibration is updated from the inkwell when the device asks") {
  fake_hd api;
  api.s->calibration = {hd::calibration_needs_update, hd::calibration_ok};
  omni_t omni({}, api);
  REQUIRE(api.s->calibration_updates.size() == 1);
  CHECK(api.s->calibration_updates[0] == hd::calibration_inkwell);
  CHECK(omni.stats().calibration_updates == 1);
  CHECK(api.s->rule_violations == 0);
}

TEST_CASE("phantom_omni: a device that still needs calibration is refused, and shut down") {
  fake_hd manual;
  manual.s->calibration = {hd::calibration_needs_manual_input};
  const std::string m = message_of([&] { omni_t omni({}, manual); });
  CHECK(contains(m, "HD_CALIBRATION_NEEDS_MANUAL_INPUT"));
  CHECK(contains(m, "inkwell"));
  CHECK(manual.s->called("hdStopScheduler"));
  CHECK(manual.s->called("hdDisableDevice 7"));

  fake_hd no_auto;
  no_auto.s->calibration = {hd::calibration_needs_update};
  const std::string n =
      message_of([&] { omni_t omni(options([](auto& o) { o.auto_calibrate = false; }), no_auto); });
  CHECK(contains(n, "HD_CALIBRATION_NEEDS_UPDATE"));
  CHECK(contains(n, "auto_calibrate"));
  CHECK(no_auto.s->calibration_updates.empty());

  fake_hd bogus;
  bogus.s->calibration = {0x1234};
  CHECK(contains(message_of([&] { omni_t omni({}, bogus); }), "0x1234"));
}

TEST_CASE("phantom_omni: pose = gimbal centre + R tool offset, heading from R heading_axis") {
  fake_hd api;
  api.s->transforms = {transform(about_y(pi / 2), {10.0, 20.0, 30.0})};
  api.s->buttons = 2;
  omni_t omni(options([](auto& o) { o.tool_offset_mm = {0.0, 0.0, 35.0}; }), api);
  const tacmap::omni_state state = omni.read_state();
  CHECK(state.buttons == 2);
  CHECK(state.transform(0, 3) == 10.0);  // elements 12..14 of the column-major array
  CHECK(state.transform(2, 3) == 30.0);
  const auto before = std::chrono::steady_clock::now();
  const auto pose = omni.next_pose(std::chrono::milliseconds(10));
  REQUIRE(pose);
  // R about +y by 90 degrees takes the stylus z axis to device +x: (0, 0, 35) -> (35, 0, 0).
  CHECK(pose->x_mm == doctest::Approx(45.0));
  CHECK(pose->y_mm == doctest::Approx(20.0));
  CHECK(pose->z_mm == doctest::Approx(30.0).epsilon(1e-12));
  // The stylus x axis now points along device -z: heading -90 degrees in the table plane.
  CHECK(pose->yaw_rad == doctest::Approx(-pi / 2));
  CHECK(pose->timestamp <= std::chrono::steady_clock::now());
  CHECK(pose->timestamp + std::chrono::seconds(1) > before);
  CHECK(api.s->rule_violations == 0);
  CHECK(omni.stats().poses == 1);
}

TEST_CASE("phantom_omni: odometry from consecutive poses, through the map calibration") {
  fake_hd api;
  api.s->transforms = {transform(Eigen::Matrix3d::Identity(), {0.0, 0.0, 0.0}),
                       transform(about_y(0.3), {10.0, -2.0, 5.0})};
  const tacmap::map_calibration turned = tacmap::map_calibration::horizontal(pi / 2);
  omni_t omni(options([&](auto& o) { o.calibration = turned; }), api);
  const auto a = omni.next_pose();
  const auto b = omni.next_pose();
  REQUIRE(a);
  REQUIRE(b);
  CHECK(b->timestamp >= a->timestamp);
  const tacmap::pose_change straight =
      tacmap::odometry_between(*a, *b, tacmap::map_calibration::horizontal());
  CHECK(straight.dx_mm == doctest::Approx(10.0));
  CHECK(straight.dy_mm == doctest::Approx(5.0));
  CHECK(straight.dyaw_rad == doctest::Approx(-0.3));  // about +y turns x toward -z
  const tacmap::pose_change d = tacmap::odometry_between(*a, *b, turned);
  CHECK(d.dx_mm == doctest::Approx(-5.0));
  CHECK(d.dy_mm == doctest::Approx(10.0));
  CHECK(d.dyaw_rad == doctest::Approx(-0.3));  // an in-plane rotation does not change turns
}

TEST_CASE("phantom_omni: the tool offset moves the sensor when the stylus only rotates") {
  fake_hd api;
  api.s->transforms = {transform(Eigen::Matrix3d::Identity(), {0.0, 0.0, 0.0}),
                       transform(about_y(pi / 2), {0.0, 0.0, 0.0})};
  omni_t omni(options([](auto& o) { o.tool_offset_mm = {0.0, 0.0, 20.0}; }), api);
  const auto a = omni.next_pose();
  const auto b = omni.next_pose();
  const auto d = tacmap::odometry_between(*a, *b, tacmap::map_calibration{});
  // The sensor swings from (0, 0, 20) to (20, 0, 0) around the gimbal centre.
  CHECK(d.dx_mm == doctest::Approx(20.0));
  CHECK(d.dy_mm == doctest::Approx(-20.0));
}

TEST_CASE("phantom_omni: a heading axis along the plane normal keeps the last heading") {
  fake_hd api;
  const Eigen::Matrix3d tilt = Eigen::AngleAxisd(pi / 2, Vector3d::UnitZ()).toRotationMatrix();
  api.s->transforms = {transform(about_y(0.4), {0, 0, 0}), transform(tilt, {1, 0, 0})};
  omni_t omni({}, api);
  const auto a = omni.next_pose();
  const auto b = omni.next_pose();  // stylus x now points straight up: no heading in the plane
  CHECK(a->yaw_rad == doctest::Approx(-0.4));
  CHECK(b->yaw_rad == a->yaw_rad);
  CHECK(std::isfinite(b->yaw_rad));
  CHECK(omni.stats().heading_undefined == 1);
}

TEST_CASE("phantom_omni: a transform that is not rigid is a device error, not a pose") {
  fake_hd api;
  std::array<double, 16> scaled = transform(2.0 * Eigen::Matrix3d::Identity(), {0, 0, 0});
  std::array<double, 16> nan = transform(Eigen::Matrix3d::Identity(), {0, 0, 0});
  nan[13] = std::numeric_limits<double>::quiet_NaN();
  std::array<double, 16> mirrored = transform(-Eigen::Matrix3d::Identity(), {0, 0, 0});
  api.s->transforms = {scaled, nan, mirrored};
  omni_t omni({}, api);
  for (int i = 0; i < 3; ++i)
    CHECK(contains(message_of([&] { (void)omni.next_pose(); }), "not a rigid transform"));
  CHECK(omni.stats().poses == 0);
}

TEST_CASE("phantom_omni: options are validated before the device is touched") {
  fake_hd api;
  tacmap::phantom_omni_options o;
  o.tool_offset_mm.x() = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_AS(omni_t(o, api), std::invalid_argument);
  o = {};
  o.heading_axis.setZero();
  CHECK_THROWS_AS(omni_t(o, api), std::invalid_argument);
  o = {};
  o.calibration.scale = 0.0;
  CHECK_THROWS_AS(omni_t(o, api), std::invalid_argument);
  CHECK(api.s->calls.empty());
}

TEST_CASE("hd::error_name covers the documented codes") {
  CHECK(hd::error_name(0x0000) == "HD_SUCCESS");
  CHECK(hd::error_name(0x0100) == "HD_INVALID_ENUM");
  CHECK(hd::error_name(0x0303) == "HD_COMM_CONFIG_ERROR");
  CHECK(hd::error_name(0x0400) == "HD_ILLEGAL_BEGIN");
  CHECK(hd::error_name(0x0401) == "HD_ILLEGAL_END");
  CHECK(hd::error_name(0x0402) == "HD_FRAME_ERROR");
  CHECK(hd::error_name(0x0600) == "HD_INVALID_LICENSE");
  CHECK(hd::error_name(0x0777) == "unknown HD error");
}

}  // namespace test_phantom_omni
