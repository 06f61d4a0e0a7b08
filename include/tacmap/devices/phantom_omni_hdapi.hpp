// tacmap: the real OpenHaptics seam for `basic_phantom_omni` — compiled only where the
// proprietary OpenHaptics SDK is installed (CMake: link `tacmap::phantom_omni`, created when
// cmake/FindOpenHaptics.cmake finds <HD/hd.h> and the HD library).
//
// Each member forwards to one HDAPI function; all logic lives in devices/phantom_omni.hpp, where
// it is tested without the SDK. The numeric codes the logic restates are checked here against the
// SDK's own macros, so a differing SDK fails to compile instead of misbehaving.
#pragma once

#include <HD/hd.h>

#include <string>

#include "tacmap/devices/phantom_omni.hpp"

namespace tacmap {

/// `hd_api` over the installed OpenHaptics HDAPI.
struct openhaptics_api {
  using handle_type = HHD;

  static_assert(HD_SUCCESS == hd::success);
  static_assert(HD_CURRENT_BUTTONS == hd::current_buttons);
  static_assert(HD_CURRENT_POSITION == hd::current_position);
  static_assert(HD_CURRENT_TRANSFORM == hd::current_transform);
  static_assert(HD_CALIBRATION_OK == hd::calibration_ok);
  static_assert(HD_CALIBRATION_NEEDS_UPDATE == hd::calibration_needs_update);
  static_assert(HD_CALIBRATION_NEEDS_MANUAL_INPUT == hd::calibration_needs_manual_input);
  static_assert(HD_CALIBRATION_INKWELL == hd::calibration_inkwell);
  static_assert(HD_CALLBACK_DONE == hd::callback_done);
  static_assert(HD_CALLBACK_CONTINUE == hd::callback_continue);

  HHD init_device(const char* name) {
    return hdInitDevice(name == nullptr ? HD_DEFAULT_DEVICE : name);
  }
  void disable_device(HHD h) { hdDisableDevice(h); }
  void make_current_device(HHD h) { hdMakeCurrentDevice(h); }

  hd::error_info get_error() noexcept {
    const HDErrorInfo e = hdGetError();
    return {static_cast<unsigned>(e.errorCode), static_cast<int>(e.internalErrorCode)};
  }
  std::string error_string(unsigned code) {
    const char* s = hdGetErrorString(static_cast<HDerror>(code));
    return s == nullptr ? std::string() : std::string(s);
  }

  void start_scheduler() { hdStartScheduler(); }
  void stop_scheduler() { hdStopScheduler(); }

  void schedule_synchronous(hd::callback cb, void* data) {
    call c{cb, data};
    hdScheduleSynchronous(&trampoline, &c, HD_DEFAULT_SCHEDULER_PRIORITY);
  }

  void begin_frame(HHD h) noexcept { hdBeginFrame(h); }
  void end_frame(HHD h) noexcept { hdEndFrame(h); }
  void get_doublev(unsigned param, double* values) noexcept {
    hdGetDoublev(static_cast<HDenum>(param), values);
  }
  void get_integerv(unsigned param, int* values) noexcept {
    hdGetIntegerv(static_cast<HDenum>(param), values);
  }
  unsigned check_calibration() noexcept { return static_cast<unsigned>(hdCheckCalibration()); }
  void update_calibration(unsigned style) noexcept {
    hdUpdateCalibration(static_cast<HDenum>(style));
  }

 private:
  struct call {
    hd::callback cb;
    void* data;
  };
  // The SDK's calling convention (HDCALLBACK) around our plain noexcept callback.
  static HDCallbackCode HDCALLBACK trampoline(void* p) {
    const call* c = static_cast<const call*>(p);
    return static_cast<HDCallbackCode>(c->cb(c->data));
  }
};

static_assert(hd_api<openhaptics_api>);

/// The Phantom Omni through the installed OpenHaptics.
using phantom_omni = basic_phantom_omni<openhaptics_api>;

}  // namespace tacmap
