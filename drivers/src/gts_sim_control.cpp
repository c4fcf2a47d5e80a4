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
  handle_ = open_library(kCardSimLibrary, library_path);
  try {
    const LibrarySymbols library(handle_, kCardSimLibrary, library_path);
    reset = library.get<AjarSim_Reset_t>("AjarSim_Reset");
    set_time_scale = library.get<AjarSim_SetTimeScale_t>("AjarSim_SetTimeScale");
    set_manual_clock = library.get<AjarSim_SetManualClock_t>("AjarSim_SetManualClock");
    advance_clock_ns = library.get<AjarSim_AdvanceClockNs_t>("AjarSim_AdvanceClockNs");
    inject_fault_raw = library.get<AjarSim_InjectFault_t>("AjarSim_InjectFault");
    fail_next_calls = library.get<AjarSim_FailNextCalls_t>("AjarSim_FailNextCalls");
    set_call_delay_us = library.get<AjarSim_SetCallDelayUs_t>("AjarSim_SetCallDelayUs");
    block_next_call = library.get<AjarSim_BlockNextCall_t>("AjarSim_BlockNextCall");
    release_blocked_calls =
        library.get<AjarSim_ReleaseBlockedCalls_t>("AjarSim_ReleaseBlockedCalls");
    blocked_calls = library.get<AjarSim_BlockedCalls_t>("AjarSim_BlockedCalls");
    set_encoder_lag_ms = library.get<AjarSim_SetEncoderLagMs_t>("AjarSim_SetEncoderLagMs");
    call_count = library.get<AjarSim_CallCount_t>("AjarSim_CallCount");
    last_update_mask = library.get<AjarSim_LastUpdateMask_t>("AjarSim_LastUpdateMask");
    last_stop = library.get<AjarSim_LastStop_t>("AjarSim_LastStop");
    now_ms = library.get<AjarSim_NowMs_t>("AjarSim_NowMs");
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
