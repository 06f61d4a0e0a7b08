// The fake OpenHaptics HD library (libHD.a) of the packaging tests: a Phantom Omni that is
// calibrated and holds its stylus still at (10, 20, 30) mm, axes aligned with the device frame.
#include <HD/hd.h>

extern "C" {

HHD hdInitDevice(HDstring) { return 1; }
void hdDisableDevice(HHD) {}
void hdMakeCurrentDevice(HHD) {}
HDErrorInfo hdGetError(void) { return HDErrorInfo{HD_SUCCESS, 0, 0}; }
HDstring hdGetErrorString(HDerror) { return "fake OpenHaptics"; }
void hdStartScheduler(void) {}
void hdStopScheduler(void) {}
void hdScheduleSynchronous(HDSchedulerCallback callback, void* data, HDushort) { callback(data); }
void hdBeginFrame(HHD) {}
void hdEndFrame(HHD) {}
void hdGetDoublev(HDenum param, HDdouble* values) {
  if (param == HD_CURRENT_POSITION) {
    values[0] = 10.0;
    values[1] = 20.0;
    values[2] = 30.0;
  } else if (param == HD_CURRENT_TRANSFORM) {
    for (int i = 0; i < 16; ++i) values[i] = (i % 5 == 0) ? 1.0 : 0.0;  // identity rotation
    values[12] = 10.0;
    values[13] = 20.0;
    values[14] = 30.0;
  }
}
void hdGetIntegerv(HDenum, HDint* values) { values[0] = 0; }
HDenum hdCheckCalibration(void) { return HD_CALIBRATION_OK; }
void hdUpdateCalibration(HDenum) {}

}  // extern "C"
