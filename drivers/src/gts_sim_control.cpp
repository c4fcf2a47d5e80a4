#include <dlfcn.h>

#include <filesystem>
#include <system_error>

#include "ajar/install_paths.hpp"
#include "ajar/drivers/factory.hpp"
#include "ajar/drivers/gts_sim_control.hpp"

namespace ajar::drivers {

namespace {

template <typename F>
F resolve(void* handle, const char* name, const std::string& path) {
  void* sym = dlsym(handle, name);
  if (sym == nullptr) {
    throw DriverStartupError("card simulator library " + path + " lacks the symbol " + name);
  }
  return reinterpret_cast<F>(sym);
}

}  // namespace

GtsSimControl::GtsSimControl(const std::string& library_path) {
  handle_ = dlopen(library_path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle_ == nullptr) {
    const char* why = dlerror();
    throw DriverStartupError("cannot load card simulator library " + library_path + ": " +
                             (why != nullptr ? why : "unknown error"));
  }
  try {
    reset = resolve<AjarSim_Reset_t>(handle_, "AjarSim_Reset", library_path);
    set_time_scale = resolve<AjarSim_SetTimeScale_t>(handle_, "AjarSim_SetTimeScale", library_path);
    set_manual_clock =
        resolve<AjarSim_SetManualClock_t>(handle_, "AjarSim_SetManualClock", library_path);
    advance_clock_ns =
        resolve<AjarSim_AdvanceClockNs_t>(handle_, "AjarSim_AdvanceClockNs", library_path);
    inject_fault_raw = resolve<AjarSim_InjectFault_t>(handle_, "AjarSim_InjectFault", library_path);
    fail_next_calls =
        resolve<AjarSim_FailNextCalls_t>(handle_, "AjarSim_FailNextCalls", library_path);
    set_call_delay_us =
        resolve<AjarSim_SetCallDelayUs_t>(handle_, "AjarSim_SetCallDelayUs", library_path);
    block_next_call =
        resolve<AjarSim_BlockNextCall_t>(handle_, "AjarSim_BlockNextCall", library_path);
    release_blocked_calls = resolve<AjarSim_ReleaseBlockedCalls_t>(
        handle_, "AjarSim_ReleaseBlockedCalls", library_path);
    blocked_calls = resolve<AjarSim_BlockedCalls_t>(handle_, "AjarSim_BlockedCalls", library_path);
    set_encoder_lag_ms =
        resolve<AjarSim_SetEncoderLagMs_t>(handle_, "AjarSim_SetEncoderLagMs", library_path);
    call_count = resolve<AjarSim_CallCount_t>(handle_, "AjarSim_CallCount", library_path);
    last_update_mask =
        resolve<AjarSim_LastUpdateMask_t>(handle_, "AjarSim_LastUpdateMask", library_path);
    last_stop = resolve<AjarSim_LastStop_t>(handle_, "AjarSim_LastStop", library_path);
    now_ms = resolve<AjarSim_NowMs_t>(handle_, "AjarSim_NowMs", library_path);
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
