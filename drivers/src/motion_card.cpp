#include "ajar/drivers/motion_card.hpp"

#include "ajar/drivers/gts_abi.hpp"

namespace ajar::drivers {

const char* gts_code_meaning(int code) noexcept {
  if (code == gts::kCmdExecuteError) return "execution error";
  if (code == gts::kCmdBadParameter) return "bad parameter";
  if (code >= -5 && code <= -1) return "communication failure";
  if (code == gts::kCmdOpenFailed) return "open failed";
  if (code == gts::kCmdNoResponse) return "no response";
  if (code == gts::kCmdBusy) return "resource busy";
  return "unknown vendor code";
}

std::string describe(const CardFailure& f) {
  if (f.code == ErrorCode::kOk) return "no failure";
  std::string s = (f.call != nullptr && *f.call != '\0') ? f.call : "card";
  if (f.vendor_code != 0) {
    if (f.axis > 0) s += "(axis " + std::to_string(f.axis) + ")";
    s += " failed: vendor code " + std::to_string(f.vendor_code) + " (" +
         gts_code_meaning(f.vendor_code) + ")";
    return s;
  }
  s += ": ";
  if (f.axis != 0) s += "axis " + std::to_string(f.axis) + ": ";
  s += (f.what != nullptr && *f.what != '\0') ? f.what : "failed";
  return s;
}

}  // namespace ajar::drivers
