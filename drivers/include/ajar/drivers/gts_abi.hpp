// The slice of the GoogolTech GTS C API (gts.h) that Ajar uses, declared once for the driver (which
// resolves these names with dlsym) and the card simulator (which exports them). The types are the
// vendor's exactly: C linkage, `short` return codes, `long` masks and positions (64-bit on Linux
// x86_64, as the vendor's Linux library is built), `double` profile values.
//
// Vendor conventions: every call returns 0 on success; 1 execution error, 7 bad parameter,
// -1..-5 communication failure, -6 open failed, -7 no response, -8 resource busy. Axes (and
// profiles, encoders) count from 1; axis n is bit 1 << (n - 1) in a mask. Positions in pulses,
// velocity in pulses/ms, acceleration in pulses/ms^2. Not thread-safe: one thread per card.
#pragma once

namespace ajar::drivers::gts {

extern "C" {

// GT_SetTrapPrm's parameter block (gts.h TTrapPrm): acc/dec in pulses/ms^2, velStart in pulses/ms,
// smoothTime in ms (0..50).
struct TTrapPrm {
  double acc;
  double dec;
  double velStart;
  short smoothTime;
};

// GT_SetJogPrm's parameter block (gts.h TJogPrm): acc/dec in pulses/ms^2 (speeding up / slowing
// down), smooth the jog smoothing coefficient (0 <= smooth < 1; 0 = none).
struct TJogPrm {
  double acc;
  double dec;
  double smooth;
};

// Function types, one per vendor call (the defaults of gts.h are passed explicitly by the driver).
using GT_Open_t = short (*)(short channel, short param);
using GT_Close_t = short (*)();
using GT_Reset_t = short (*)();
using GT_LoadConfig_t = short (*)(char* pFile);
using GT_ClrSts_t = short (*)(short axis, short count);
using GT_AxisOn_t = short (*)(short axis);
using GT_AxisOff_t = short (*)(short axis);
using GT_PrfTrap_t = short (*)(short profile);
using GT_SetTrapPrm_t = short (*)(short profile, TTrapPrm* pPrm);
// Velocity (jog) mode: GT_PrfJog selects it; GT_SetVel's velocity is then signed (the sign is the
// direction); GT_Update(mask) starts the new velocities of the axes in the mask together.
using GT_PrfJog_t = short (*)(short profile);
using GT_SetJogPrm_t = short (*)(short profile, TJogPrm* pPrm);
using GT_SetPos_t = short (*)(short profile, long pos);
// Trap mode: the cruise velocity (> 0); jog mode: the target velocity (signed).
using GT_SetVel_t = short (*)(short profile, double vel);
using GT_Update_t = short (*)(long mask);
using GT_GetSts_t = short (*)(short axis, long* pSts, short count, unsigned long* pClock);
using GT_GetPrfPos_t = short (*)(short profile, double* pValue, short count, unsigned long* pClock);
using GT_GetEncPos_t = short (*)(short encoder, double* pValue, short count, unsigned long* pClock);
// option: bit n-1 set = emergency (abrupt) stop of axis n, clear = smooth stop.
using GT_Stop_t = short (*)(long mask, long option);

}  // extern "C"

// Return codes.
inline constexpr short kCmdSuccess = 0;
inline constexpr short kCmdExecuteError = 1;
inline constexpr short kCmdBadParameter = 7;
inline constexpr short kCmdOpenFailed = -6;
inline constexpr short kCmdNoResponse = -7;
inline constexpr short kCmdBusy = -8;

// GT_GetSts status bits.
inline constexpr long kStsDriveAlarm = 0x2;
inline constexpr long kStsFollowingError = 0x10;
inline constexpr long kStsPositiveLimit = 0x20;
inline constexpr long kStsNegativeLimit = 0x40;
inline constexpr long kStsSmoothStop = 0x80;
inline constexpr long kStsEmergencyStop = 0x100;
inline constexpr long kStsServoOn = 0x200;
inline constexpr long kStsProfileMoving = 0x400;
inline constexpr long kStsInPosition = 0x800;

// The largest axis number Ajar addresses on one card (GTS-800 has 8 axes, GTS-400 4).
inline constexpr int kMaxAxes = 8;

inline constexpr long axis_mask(int axis) {
  return 1L << (axis - 1);
}

}  // namespace ajar::drivers::gts
