// Driver selection and settings, filled by the daemon's config loader from the `drivers:` section
// of the YAML config. Selection is by config, never by #ifdef.
#pragma once

#include <cstdint>
#include <string>

namespace ajar::drivers {

enum class DriverKind : std::uint8_t { kSim, kMock, kReal };

struct GtsCardSettings {
  std::string library_path;      // real: the vendor's libgts.so; sim: the card simulator
  std::string card_config_path;  // passed to GT_LoadConfig; empty = skip
  int channel = 0;               // GT_Open channel
  int poll_timeout_ms = 2000;    // deadline for start-up waits (e.g. servo on)
  int axis_count = 4;            // axes on the card (GTS-400: 4, GTS-800: 8); valid 1..n
};

struct SerialArmSettings {
  std::string device = "/dev/ttyS0";
  int baud = 115200;
  int data_bits = 8;
  char parity = 'N';  // 'N', 'E' or 'O'
  int stop_bits = 1;
  int ack_timeout_ms = 200;    // per attempt
  int retries = 3;             // attempts after the first
  int reconnect_min_ms = 100;  // reconnect backoff, doubling up to max
  int reconnect_max_ms = 5000;
};

// The in-process mock's fault menu (tests and rehearsals).
enum class MockFault : std::uint8_t { kNone, kStuck, kSlow, kErrorCode, kIntermittent, kGarbage };

// The mock arm's: the same menu (MockManipulator, mock_arm.hpp), and the arm controller's own
// faults: it stops answering half way through a task or at the first stop of a task, resets half
// way through a task (idle, the task forgotten), or answers a stop but stays busy.
enum class MockArmFault : std::uint8_t {
  kNone,
  kStuck,
  kSlow,
  kErrorCode,
  kIntermittent,
  kGarbage,
  kSilentMidTask,
  kSilentMidStop,
  kResetMidTask,
  kStopIgnored,
};

struct MockSettings {
  MockFault card_fault = MockFault::kNone;
  MockArmFault arm_fault = MockArmFault::kNone;
  int slow_ms = 50;
};

struct DriverSettings {
  DriverKind kind = DriverKind::kSim;
  GtsCardSettings card;      // used by kReal and kSim (sim: simulator library path)
  SerialArmSettings arm;     // used by kReal
  MockSettings mock;         // used by kMock
  double sim_speedup = 1.0;  // sim: simulated time runs this much faster than real time
};

}  // namespace ajar::drivers
