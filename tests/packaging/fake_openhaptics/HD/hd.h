/* A stand-in for the OpenHaptics SDK's <HD/hd.h>, for tacmap's packaging tests only: the few
 * HDAPI declarations include/tacmap/devices/phantom_omni_hdapi.hpp uses, with the documented
 * values that the header checks against its own restated codes. Written for tacmap, not taken
 * from the SDK; hd_stub.cpp implements the functions as a motionless, calibrated device. */
#ifndef TACMAP_FAKE_OPENHAPTICS_HD_H
#define TACMAP_FAKE_OPENHAPTICS_HD_H

#include <stddef.h>

typedef unsigned int HHD;
typedef unsigned int HDenum;
typedef unsigned int HDerror;
typedef unsigned int HDCallbackCode;
typedef unsigned short HDushort;
typedef double HDdouble;
typedef int HDint;
typedef const char* HDstring;

#define HDCALLBACK
typedef HDCallbackCode(HDCALLBACK* HDSchedulerCallback)(void* data);

typedef struct {
  HDerror errorCode;
  int internalErrorCode;
  HHD hHD;
} HDErrorInfo;

#define HD_DEFAULT_DEVICE NULL
#define HD_SUCCESS 0x0000
#define HD_CURRENT_BUTTONS 0x2000
#define HD_CURRENT_POSITION 0x2050
#define HD_CURRENT_TRANSFORM 0x2052
#define HD_CALIBRATION_OK 0x5000
#define HD_CALIBRATION_NEEDS_UPDATE 0x5001
#define HD_CALIBRATION_NEEDS_MANUAL_INPUT 0x5002
#define HD_CALIBRATION_INKWELL 4
#define HD_CALLBACK_DONE 0
#define HD_CALLBACK_CONTINUE 1
#define HD_DEFAULT_SCHEDULER_PRIORITY 500

#ifdef __cplusplus
extern "C" {
#endif

HHD hdInitDevice(HDstring name);
void hdDisableDevice(HHD h);
void hdMakeCurrentDevice(HHD h);
HDErrorInfo hdGetError(void);
HDstring hdGetErrorString(HDerror code);
void hdStartScheduler(void);
void hdStopScheduler(void);
void hdScheduleSynchronous(HDSchedulerCallback callback, void* data, HDushort priority);
void hdBeginFrame(HHD h);
void hdEndFrame(HHD h);
void hdGetDoublev(HDenum param, HDdouble* values);
void hdGetIntegerv(HDenum param, HDint* values);
HDenum hdCheckCalibration(void);
void hdUpdateCalibration(HDenum style);

#ifdef __cplusplus
}
#endif

#endif
