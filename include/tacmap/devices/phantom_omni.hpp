// tacmap: a SensAble / 3D Systems Phantom Omni (Geomagic Touch) as a `position_source`, through
// the OpenHaptics HDAPI — the paper's set-up: the tactile sensor rides on the Omni's stylus and
// the device's forward kinematics gives the sensor centre (Sec. IV).
//
// Everything here is SDK-free: `basic_phantom_omni<Api>` holds all the logic and calls the SDK
// only through `Api`, a small seam of HDAPI functions (`hd_api`). Tests drive it with a scripted
// fake; the real seam, which calls <HD/hd.h>, is `openhaptics_api` in
// devices/phantom_omni_hdapi.hpp and is compiled only when OpenHaptics is installed (CMake target
// `tacmap::phantom_omni`). With the SDK:
//
//   #include "tacmap/devices/phantom_omni_hdapi.hpp"
//   tacmap::phantom_omni omni({.tool_offset_mm = {0, 0, 35}});
//   std::optional<tacmap::sensor_pose> p = omni.next_pose(std::chrono::milliseconds(10));
//
// How a pose is read. HDAPI device state may only be read between hdBeginFrame and hdEndFrame on
// the servo thread (1 kHz). We hand it to the caller's thread with a *synchronous* callback
// (hdScheduleSynchronous blocks until the servo thread has run it), which copies
// HD_CURRENT_TRANSFORM and the buttons into a struct on the caller's stack — no shared state,
// no data race (unlike reading a struct an asynchronous callback keeps overwriting). The call
// returns within one servo tick, which is why `next_pose` never needs its timeout.
//
// Geometry. HD_CURRENT_TRANSFORM is the stylus frame in the device frame (mm; column-major
// 4 x 4; axes facing the device: +x right, +y up, +z toward the user). Its origin is the gimbal
// centre, not the sensor: the sensor centre is `tool_offset_mm`, a vector in the stylus frame,
// rotated by the stylus orientation and added. The heading is the stylus-frame direction
// `heading_axis` (the sensor's column direction) projected into the object's plane of
// `calibration` (devices/position_source.hpp).
//
// Errors. HDAPI reports errors on a stack read with hdGetError. After every call we drain it and
// turn what was there into a `device_error` naming the HD error (HD_COMM_ERROR, ...), its code,
// the SDK's own description and what to do. One object per process: the HDAPI scheduler is
// global.
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>  // determinant()
#include <array>
#include <chrono>
#include <concepts>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "tacmap/devices/position_source.hpp"
#include "tacmap/devices/serial_port.hpp"  // device_error
#include "tacmap/image.hpp"

namespace tacmap {

/// Codes of the OpenHaptics HDAPI that the adapter uses. These are documented numeric values,
/// restated so that the logic and its tests need no SDK; the real seam checks them against the
/// SDK's macros at compile time.
namespace hd {

inline constexpr unsigned success = 0x0000;  ///< HD_SUCCESS

// Parameters of hdGetDoublev / hdGetIntegerv.
inline constexpr unsigned current_buttons = 0x2000;    ///< HD_CURRENT_BUTTONS (int bit mask)
inline constexpr unsigned current_position = 0x2050;   ///< HD_CURRENT_POSITION (3 doubles, mm)
inline constexpr unsigned current_transform = 0x2052;  ///< HD_CURRENT_TRANSFORM (16, column-major)

// Calibration (hdCheckCalibration / hdUpdateCalibration).
inline constexpr unsigned calibration_ok = 0x5000;                  ///< HD_CALIBRATION_OK
inline constexpr unsigned calibration_needs_update = 0x5001;        ///< ..._NEEDS_UPDATE
inline constexpr unsigned calibration_needs_manual_input = 0x5002;  ///< ..._NEEDS_MANUAL_INPUT
inline constexpr unsigned calibration_inkwell = 4;                  ///< HD_CALIBRATION_INKWELL

// Scheduler callback results.
inline constexpr unsigned callback_done = 0;      ///< HD_CALLBACK_DONE: run once
inline constexpr unsigned callback_continue = 1;  ///< HD_CALLBACK_CONTINUE: every servo tick

/// The callback type of the seam. The real seam adapts it to the SDK's calling convention.
using callback = unsigned (*)(void*) noexcept;

/// One entry of HDAPI's error stack (HDErrorInfo without the device handle).
struct error_info {
  unsigned code = success;  ///< HDerror
  int internal_code = 0;    ///< the driver's own code, for 3D Systems support
  friend bool operator==(const error_info&, const error_info&) = default;
};

/// The HD_* name of an error code, or "unknown HD error".
[[nodiscard]] constexpr std::string_view error_name(unsigned code) noexcept {
  switch (code) {
    case 0x0000:
      return "HD_SUCCESS";
    case 0x0100:
      return "HD_INVALID_ENUM";
    case 0x0104:
      return "HD_BAD_HANDLE";
    case 0x0300:
      return "HD_DEVICE_FAULT";
    case 0x0301:
      return "HD_DEVICE_ALREADY_INITIATED";
    case 0x0302:
      return "HD_COMM_ERROR";
    case 0x0303:
      return "HD_COMM_CONFIG_ERROR";
    case 0x0304:
      return "HD_TIMER_ERROR";
    case 0x0400:
      return "HD_ILLEGAL_BEGIN";
    case 0x0401:
      return "HD_ILLEGAL_END";
    case 0x0402:
      return "HD_FRAME_ERROR";
    case 0x0501:
      return "HD_SCHEDULER_FULL";
    case 0x0600:
      return "HD_INVALID_LICENSE";
    default:
      return "unknown HD error";
  }
}

/// What to do about an error, for messages.
[[nodiscard]] constexpr std::string_view error_remedy(unsigned code) noexcept {
  switch (code) {
    case 0x0302:
    case 0x0303:
      return "check the device's cable (FireWire or USB) and power, and that the device is set up "
             "under this name in the OpenHaptics configuration tool (Phantom Configuration / "
             "Touch Setup)";
    case 0x0301:
      return "another program (or another phantom_omni object) already uses the device; close "
             "it first";
    case 0x0300:
      return "the device reported a fault: power-cycle it and run the manufacturer's diagnostic";
    case 0x0304:
      return "the servo-loop timer could not start: close other haptics programs; on Linux the "
             "driver may need real-time scheduling rights";
    case 0x0501:
      return "the servo loop has too many callbacks scheduled: another part of the program "
             "leaks scheduler callbacks";
    case 0x0600:
      return "OpenHaptics refuses its licence: check the installation";
    case 0x0400:
    case 0x0401:
    case 0x0402:
      return "a device frame was opened or closed wrongly — a bug in the program's use of "
             "hdBeginFrame/hdEndFrame, please report it";
    default:
      return "see the OpenHaptics documentation for this error";
  }
}

}  // namespace hd

/// The seam between the adapter's logic and the OpenHaptics HDAPI: the functions it calls.
///
/// A type `A` models `hd_api` when it is move-constructible and, for an `A a`, an
/// `A::handle_type h`, a device name `const char* name` (nullptr: the default device), a
/// `hd::callback cb`, a `void* data`, an `unsigned e`, and output pointers `double* d`, `int* i`:
///  1. `a.init_device(name)` returns `A::handle_type` (hdInitDevice).
///  2. `a.disable_device(h)`, `a.make_current_device(h)` (hdDisableDevice, hdMakeCurrentDevice).
///  3. `a.get_error()` is noexcept and returns `hd::error_info` — the newest error, popped, or
///     code `hd::success` when there is none (hdGetError).
///  4. `a.error_string(e)` returns something convertible to `std::string` (hdGetErrorString).
///  5. `a.start_scheduler()`, `a.stop_scheduler()` (hdStartScheduler, hdStopScheduler).
///  6. `a.schedule_synchronous(cb, data)` runs `cb(data)` on the servo thread and returns when
///     it has run (hdScheduleSynchronous at the default priority).
///  7. Inside a callback, all noexcept: `a.begin_frame(h)`, `a.end_frame(h)`,
///     `a.get_doublev(e, d)`, `a.get_integerv(e, i)`, `a.check_calibration()` returning
///     `unsigned`, `a.update_calibration(e)` (hdBeginFrame, hdEndFrame, hdGetDoublev,
///     hdGetIntegerv, hdCheckCalibration, hdUpdateCalibration). Being noexcept, nothing can throw
///     through the SDK's C frames.
///
/// Minimal conforming type (a device parked at the origin; the real seam is `openhaptics_api`,
/// a scripted fake is in tests/devices/test_phantom_omni.cpp):
/// ```
/// struct parked_omni {
///   using handle_type = unsigned;
///   unsigned init_device(const char*) { return 1; }
///   void disable_device(unsigned) {}
///   void make_current_device(unsigned) {}
///   hd::error_info get_error() noexcept { return {}; }
///   std::string error_string(unsigned) { return {}; }
///   void start_scheduler() {}
///   void stop_scheduler() {}
///   void schedule_synchronous(hd::callback cb, void* data) { cb(data); }
///   void begin_frame(unsigned) noexcept {}
///   void end_frame(unsigned) noexcept {}
///   void get_doublev(unsigned, double* v) noexcept {  // the identity transform
///     for (int i = 0; i < 16; ++i) v[i] = i % 5 == 0 ? 1.0 : 0.0;
///   }
///   void get_integerv(unsigned, int* v) noexcept { *v = 0; }
///   unsigned check_calibration() noexcept { return hd::calibration_ok; }
///   void update_calibration(unsigned) noexcept {}
/// };
/// ```
template <class A>
concept hd_api = std::move_constructible<A> &&
    requires(A& a, const char* name, typename A::handle_type h, hd::callback cb, void* data,
             unsigned e, double* d, int* i) {
  { a.init_device(name) } -> std::same_as<typename A::handle_type>;
  a.disable_device(h);
  a.make_current_device(h);
  { a.get_error() }
  noexcept->std::same_as<hd::error_info>;
  { a.error_string(e) } -> std::convertible_to<std::string>;
  a.start_scheduler();
  a.stop_scheduler();
  a.schedule_synchronous(cb, data);
  { a.begin_frame(h) }
  noexcept;
  { a.end_frame(h) }
  noexcept;
  { a.get_doublev(e, d) }
  noexcept;
  { a.get_integerv(e, i) }
  noexcept;
  { a.check_calibration() }
  noexcept->std::convertible_to<unsigned>;
  { a.update_calibration(e) }
  noexcept;
};

/// Configuration of `basic_phantom_omni`.
struct phantom_omni_options {
  std::string device_name;  ///< as configured in OpenHaptics; empty: the default device
  /// Gimbal centre -> sensor centre, in the stylus frame (mm). Measure it on the mount.
  Eigen::Vector3d tool_offset_mm = Eigen::Vector3d::Zero();
  /// The sensor's column direction (its x axis on the map) in the stylus frame.
  Eigen::Vector3d heading_axis = Eigen::Vector3d::UnitX();
  /// Device frame -> map frame; its plane defines the heading (`sensor_pose::yaw_rad`).
  map_calibration calibration = map_calibration::horizontal();
  /// When the device asks for calibration (HD_CALIBRATION_NEEDS_UPDATE), update it from the
  /// inkwell; otherwise opening fails and says so.
  bool auto_calibrate = true;

  /// Throws std::invalid_argument naming the field unless the options are usable.
  void validate() const {
    if (!detail::all_finite(tool_offset_mm))
      detail::fail("phantom_omni_options: tool_offset_mm = (", tool_offset_mm.x(), ", ",
                   tool_offset_mm.y(), ", ", tool_offset_mm.z(),
                   "); expected a finite vector in mm, in the stylus frame");
    if (!(detail::all_finite(heading_axis) && heading_axis.norm() > 1e-9))
      detail::fail("phantom_omni_options: heading_axis = (", heading_axis.x(), ", ",
                   heading_axis.y(), ", ", heading_axis.z(),
                   "); expected a finite, non-zero direction in the stylus frame");
    calibration.validate();
  }
};

/// One copy of the device state, taken inside a servo tick.
struct omni_state {
  std::chrono::steady_clock::time_point timestamp{};        ///< when the servo thread copied it
  Eigen::Matrix4d transform = Eigen::Matrix4d::Identity();  ///< stylus frame in device frame, mm
  int buttons = 0;                                          ///< bit 0: button 1, bit 1: button 2
};

/// Counters of one adapter.
struct phantom_omni_stats {
  std::uint64_t poses = 0;                ///< poses delivered
  std::uint64_t heading_undefined = 0;    ///< poses whose heading axis pointed along the normal
  std::uint64_t calibration_updates = 0;  ///< inkwell calibrations performed when opening
};

namespace detail {

/// Errors popped from the HD error stack, newest first as HDAPI gives them.
using hd_errors = std::vector<hd::error_info>;

/// Bound on errors drained at once: a broken driver that never returns HD_SUCCESS must not
/// hang us.
inline constexpr std::size_t max_hd_errors = 32;

inline std::string hex_code(unsigned code) {
  std::array<char, 16> buffer{};
  std::snprintf(buffer.data(), buffer.size(), "0x%03X", code);
  return buffer.data();
}

}  // namespace detail

/// The Phantom Omni as a `position_source`, all logic, HDAPI through `Api` (see the file comment).
/// Not copyable or movable (it owns the device and the global HDAPI scheduler); not thread-safe.
template <hd_api Api>
class basic_phantom_omni {
 public:
  using handle_type = typename Api::handle_type;

  /// Opens the device (hdInitDevice), starts the scheduler, checks the calibration (updating it
  /// from the inkwell when `auto_calibrate` and the device asks for it). Throws device_error
  /// naming the HD error and what to do; whatever was started is shut down again first.
  explicit basic_phantom_omni(phantom_omni_options options = {}, Api api = Api{})
      : options_(std::move(options)), api_(std::move(api)) {
    options_.validate();
    (void)drain_errors();  // errors left by someone else are not ours
    handle_ =
        api_.init_device(options_.device_name.empty() ? nullptr : options_.device_name.c_str());
    throw_on_errors("hdInitDevice", "open the device");
    initialized_ = true;
    try {
      api_.make_current_device(handle_);
      throw_on_errors("hdMakeCurrentDevice", "select the device");
      api_.start_scheduler();
      throw_on_errors("hdStartScheduler", "start the servo loop");
      scheduler_running_ = true;
      check_calibration();
    } catch (...) {
      shut_down();
      throw;
    }
  }

  basic_phantom_omni(const basic_phantom_omni&) = delete;
  basic_phantom_omni& operator=(const basic_phantom_omni&) = delete;
  basic_phantom_omni(basic_phantom_omni&&) = delete;
  basic_phantom_omni& operator=(basic_phantom_omni&&) = delete;

  /// Stops the scheduler and disables the device (the HDAPI shutdown order).
  ~basic_phantom_omni() { shut_down(); }

  /// The current sensor pose (device frame, see the file comment). Returns within one servo
  /// tick; `timeout` is accepted for the `position_source` concept and never reached. Throws
  /// device_error when the servo loop reports an error or does not run the copy.
  std::optional<sensor_pose> next_pose(std::chrono::milliseconds /*timeout*/ = {}) {
    return pose_from(read_state());
  }

  /// Copies the device state in one servo tick (synchronous callback, see the file comment).
  omni_state read_state() {
    struct copy {
      Api* api;
      handle_type handle;
      std::array<double, 16> transform{};
      int buttons = 0;
      std::chrono::steady_clock::time_point timestamp{};
    } c{&api_, handle_, {}, 0, {}};
    run_in_servo_loop(c, "copy the device state", [](copy& s) noexcept {
      s.api->begin_frame(s.handle);
      s.api->get_doublev(hd::current_transform, s.transform.data());
      s.api->get_integerv(hd::current_buttons, &s.buttons);
      s.api->end_frame(s.handle);
      s.timestamp = std::chrono::steady_clock::now();
    });
    omni_state state;
    state.timestamp = c.timestamp;
    state.transform = Eigen::Map<const Eigen::Matrix4d>(c.transform.data());  // column-major
    state.buttons = c.buttons;
    return state;
  }

  /// The sensor pose for a device state: gimbal centre + R tool_offset, heading from R
  /// heading_axis. Throws device_error when the transform is not finite or not rigid (a driver
  /// problem: the numbers cannot be a stylus pose).
  sensor_pose pose_from(const omni_state& state) {
    const Eigen::Matrix4d& t = state.transform;
    const Eigen::Matrix3d r = t.topLeftCorner<3, 3>();
    const bool rigid =
        detail::all_finite(t) && (r.transpose() * r).isApprox(Eigen::Matrix3d::Identity(), 1e-3) &&
        r.determinant() > 0.0 && t.row(3).isApprox(Eigen::RowVector4d(0.0, 0.0, 0.0, 1.0), 1e-9);
    if (!rigid)
      detail::fail<device_error>(
          device_label(), ": HD_CURRENT_TRANSFORM is not a rigid transform (rotation part ",
          r.row(0), " / ", r.row(1), " / ", r.row(2), ", last row ", t.row(3),
          "); expected a rotation and a translation in mm — the driver returned garbage, "
          "check the OpenHaptics installation");
    const Eigen::Vector3d centre = t.topRightCorner<3, 1>() + r * options_.tool_offset_mm;
    const std::optional<double> heading =
        options_.calibration.plane_heading(r * options_.heading_axis);
    if (heading)
      last_heading_ = *heading;
    else
      ++stats_.heading_undefined;  // the axis points through the plane: keep the last heading
    ++stats_.poses;
    return {state.timestamp, centre.x(), centre.y(), centre.z(), last_heading_};
  }

  [[nodiscard]] const phantom_omni_options& options() const { return options_; }
  [[nodiscard]] const phantom_omni_stats& stats() const { return stats_; }
  [[nodiscard]] handle_type handle() const { return handle_; }
  /// The seam (tests inspect their fake through it).
  [[nodiscard]] Api& api() { return api_; }

 private:
  std::string device_label() const {
    return "Phantom Omni '" +
           (options_.device_name.empty() ? std::string("default device") : options_.device_name) +
           "'";
  }

  detail::hd_errors drain_errors() noexcept {
    detail::hd_errors errors;
    try {
      for (std::size_t n = 0; n < detail::max_hd_errors; ++n) {
        const hd::error_info e = api_.get_error();
        if (e.code == hd::success) break;
        errors.push_back(e);
      }
    } catch (...) {  // only allocation can throw here; losing error details beats terminate()
    }
    return errors;
  }

  std::string describe(const hd::error_info& e) {
    std::string text = std::string(hd::error_name(e.code)) + " (" + detail::hex_code(e.code) +
                       ", internal " + std::to_string(e.internal_code);
    std::string sdk = api_.error_string(e.code);
    if (!sdk.empty()) text += ": " + sdk;
    return text + ")";
  }

  /// Throws device_error when the error stack holds anything after `call`. The oldest error
  /// (the cause; later ones are often consequences) decides the remedy.
  void throw_on_errors(std::string_view call, std::string_view what,
                       detail::hd_errors errors = {}) {
    for (const hd::error_info& e : drain_errors()) errors.push_back(e);
    if (errors.empty()) return;
    std::string list;
    for (auto it = errors.rbegin(); it != errors.rend(); ++it)
      list += (list.empty() ? "" : ", then ") + describe(*it);
    detail::fail<device_error>(device_label(), ": ", call, " failed (could not ", what, "): ", list,
                               " — ", hd::error_remedy(errors.back().code));
  }

  /// Runs `f(state)` once on the servo thread through a synchronous callback, drains the error
  /// stack there and here, and throws device_error for errors or when the callback never ran.
  template <class State, class F>
  void run_in_servo_loop(State& state, std::string_view what, F f) {
    struct context {
      State* state;
      F* f;
      Api* api;
      bool ran = false;
      std::array<hd::error_info, 8> errors{};
      std::size_t error_count = 0;
    } ctx{&state, &f, &api_};
    const hd::callback cb = [](void* data) noexcept -> unsigned {
      auto* c = static_cast<context*>(data);
      (*c->f)(*c->state);
      // Errors raised inside the frame are read on the servo thread, where they happened.
      for (std::size_t n = 0; n < c->errors.size(); ++n) {
        const hd::error_info e = c->api->get_error();
        if (e.code == hd::success) break;
        c->errors[c->error_count++] = e;
      }
      c->ran = true;
      return hd::callback_done;
    };
    api_.schedule_synchronous(cb, &ctx);
    const detail::hd_errors inside(
        ctx.errors.begin(), ctx.errors.begin() + static_cast<std::ptrdiff_t>(ctx.error_count));
    throw_on_errors("hdScheduleSynchronous", what, inside);
    if (!ctx.ran)
      detail::fail<device_error>(
          device_label(), ": the servo loop did not run the callback to ", what,
          " — the HDAPI scheduler is not running (another part of the program stopped it?); "
          "reopen the device");
  }

  void check_calibration() {
    const auto status = [&] {
      unsigned s = hd::calibration_ok;
      run_in_servo_loop(s, "check the calibration", [this](unsigned& out) noexcept {
        api_.begin_frame(handle_);
        out = static_cast<unsigned>(api_.check_calibration());
        api_.end_frame(handle_);
      });
      return s;
    };
    unsigned s = status();
    if (s == hd::calibration_needs_update && options_.auto_calibrate) {
      unsigned style = hd::calibration_inkwell;
      run_in_servo_loop(style, "update the calibration", [this](unsigned& st) noexcept {
        api_.begin_frame(handle_);
        api_.update_calibration(st);
        api_.end_frame(handle_);
      });
      ++stats_.calibration_updates;
      s = status();
    }
    if (s == hd::calibration_ok) return;
    if (s == hd::calibration_needs_manual_input || s == hd::calibration_needs_update)
      detail::fail<device_error>(
          device_label(), ": the device is not calibrated (",
          s == hd::calibration_needs_update ? "HD_CALIBRATION_NEEDS_UPDATE"
                                            : "HD_CALIBRATION_NEEDS_MANUAL_INPUT",
          "). Put the stylus into its inkwell (the Omni calibrates there) and open it again",
          s == hd::calibration_needs_update && !options_.auto_calibrate
              ? ", or set phantom_omni_options::auto_calibrate"
              : "");
    detail::fail<device_error>(device_label(), ": hdCheckCalibration returned ",
                               detail::hex_code(s),
                               ", which is not a calibration status (expected 0x5000..0x5002); "
                               "check the OpenHaptics installation");
  }

  void shut_down() noexcept {
    try {
      if (scheduler_running_) api_.stop_scheduler();
      if (initialized_) api_.disable_device(handle_);
    } catch (...) {  // a destructor must not throw; the device is going away either way
    }
    scheduler_running_ = false;
    initialized_ = false;
    (void)drain_errors();
  }

  phantom_omni_options options_;
  Api api_;
  handle_type handle_{};
  bool initialized_ = false;
  bool scheduler_running_ = false;
  double last_heading_ = 0.0;
  phantom_omni_stats stats_;
};

}  // namespace tacmap
