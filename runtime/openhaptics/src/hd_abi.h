// The part of the OpenHaptics HD API's binary interface that organsim uses
// (hdDefines.h, hdDevice.h, hdScheduler.h): types and values as the library
// defines them. Shared by the backend and the tests' stand-in library.
#pragma once

namespace organsim::devices::hd {

using HHD = unsigned int;
using HDenum = unsigned int;
using HDCallbackCode = unsigned int;
using HDSchedulerHandle = unsigned long;
using HDSchedulerCallback = HDCallbackCode (*)(void*);
struct HDErrorInfo {
  unsigned int errorCode;
  int internalErrorCode;
  HHD hHD;
};

constexpr HHD kInvalidHandle = 0xFFFFFFFF;
constexpr HDenum kCurrentButtons = 0x2000;       // 1 int: a bit per stylus button
constexpr int kDeviceButton1 = 1 << 0;           // the stylus's first (front) button
constexpr HDenum kCurrentPosition = 0x2050;      // 3 doubles, mm
constexpr HDenum kCurrentTransform = 0x2052;     // 16 doubles, column-major 4×4, translation in mm
constexpr HDenum kCurrentForce = 0x2700;         // 3 doubles, N
constexpr HDenum kNominalMaxStiffness = 0x2602;  // N/mm
constexpr HDenum kNominalMaxForce = 0x2603;      // N
constexpr HDenum kForceOutput = 0x4000;
constexpr HDCallbackCode kCallbackDone = 0;
constexpr HDCallbackCode kCallbackContinue = 1;
constexpr unsigned short kMaxSchedulerPriority = 0xFFFF;

}  // namespace organsim::devices::hd
