#include <dlfcn.h>

#include <filesystem>
#include <system_error>

#include "ajar/install_paths.hpp"
#include "ajar/drivers/factory.hpp"
#include "ajar/drivers/gts_sim_control.hpp"
#include "library_symbol.hpp"

namespace ajar::drivers {

namespace {

constexpr const char* kCardSimLibrary = "card simulator library";

}  // namespace

GtsSimControl::GtsSimControl(const std::string& library_path) {
  handle_ = dlopen(library_path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle_ == nullptr) {
    const char* why = dlerror();
    throw DriverStartupError("cannot load card simulator library " + library_path + ": " +
                             (why != nullptr ? why : "unknown error"));
  }
  try {
    reset =
        resolve_symbol<AjarSim_Reset_t>(handle_, "AjarSim_Reset", kCardSimLibrary, library_path);
    set_time_scale = resolve_symbol<AjarSim_SetTimeScale_t>(handle_, "AjarSim_SetTimeScale",
                                                            kCardSimLibrary, library_path);
    set_manual_clock = resolve_symbol<AjarSim_SetManualClock_t>(handle_, "AjarSim_SetManualClock",
                                                                kCardSimLibrary, library_path);
    advance_clock_ns = resolve_symbol<AjarSim_AdvanceClockNs_t>(handle_, "AjarSim_AdvanceClockNs",
                                                                kCardSimLibrary, library_path);
    inject_fault_raw = resolve_symbol<AjarSim_InjectFault_t>(handle_, "AjarSim_InjectFault",
                                                             kCardSimLibrary, library_path);
    fail_next_calls = resolve_symbol<AjarSim_FailNextCalls_t>(handle_, "AjarSim_FailNextCalls",
                                                              kCardSimLibrary, library_path);
    set_call_delay_us = resolve_symbol<AjarSim_SetCallDelayUs_t>(handle_, "AjarSim_SetCallDelayUs",
                                                                 kCardSimLibrary, library_path);
    block_next_call = resolve_symbol<AjarSim_BlockNextCall_t>(handle_, "AjarSim_BlockNextCall",
                                                              kCardSimLibrary, library_path);
    release_blocked_calls = resolve_symbol<AjarSim_ReleaseBlockedCalls_t>(
        handle_, "AjarSim_ReleaseBlockedCalls", kCardSimLibrary, library_path);
    blocked_calls = resolve_symbol<AjarSim_BlockedCalls_t>(handle_, "AjarSim_BlockedCalls",
                                                           kCardSimLibrary, library_path);
    set_encoder_lag_ms = resolve_symbol<AjarSim_SetEncoderLagMs_t>(
        handle_, "AjarSim_SetEncoderLagMs", kCardSimLibrary, library_path);
    call_count = resolve_symbol<AjarSim_CallCount_t>(handle_, "AjarSim_CallCount", kCardSimLibrary,
                                                     library_path);
    last_update_mask = resolve_symbol<AjarSim_LastUpdateMask_t>(handle_, "AjarSim_LastUpdateMask",
                                                                kCardSimLibrary, library_path);
    last_stop = resolve_symbol<AjarSim_LastStop_t>(handle_, "AjarSim_LastStop", kCardSimLibrary,
                                                   library_path);
    now_ms =
        resolve_symbol<AjarSim_NowMs_t>(handle_, "AjarSim_NowMs", kCardSimLibrary, library_path);
  } catch (...) {
    dlclose(handle_);
    throw;
  }
}

GtsSimControl::~GtsSimControl() {
  dlclose(handle_);
}

void GtsSimControl::inject_fault(int axis, SimFault fault) const {
  inject_fault_raw(static_cast<short>(axis), static_cast<int>(fault));
}

std::string default_card_simulator_path() {
  const auto installed =
      install::beside_executable(install::kSbinToPkgLib, install::kCardSimulatorFile);
  std::error_code ec;
  if (!installed.empty() && std::filesystem::exists(installed, ec)) return installed.string();
#ifdef AJAR_CARDSIM_BUILD_PATH
  if (std::filesystem::exists(AJAR_CARDSIM_BUILD_PATH, ec)) return AJAR_CARDSIM_BUILD_PATH;
#endif
  return installed.string();
}

}  // namespace ajar::drivers
