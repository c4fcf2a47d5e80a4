// Opening the arm's RS-232 device for SerialManipulator (serial_arm.cpp): libserial opens and
// configures it (baud, data bits, parity, stop bits from SerialArmSettings; no flow control), and
// the caller gets its own non-blocking descriptor, close-on-exec, to read with poll()/read() and to
// close() itself. Settings libserial cannot express are refused (kDriverError naming the key);
// a device that cannot be opened or configured is kArmDisconnected naming the device and why.
#pragma once

#include "ajar/core/result.hpp"
#include "ajar/drivers/settings.hpp"

namespace ajar::drivers {

Result<int> open_arm_port(const SerialArmSettings& s);

}  // namespace ajar::drivers
