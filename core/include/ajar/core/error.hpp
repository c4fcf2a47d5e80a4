// One table of error codes for the whole product: geometry and validation (core), the wire
// protocol, sessions and the procedure (daemon), and the drivers. The numeric values are part of
// the wire protocol and stable across versions: never renumber, only append.
//
// AJAR_ERROR_CODES is that table, one row per code: X(enumerator, code, NAME, meaning, what the
// client should do). The enum below, to_string / error_code_from_string and error_table() (the
// rows as data) are all expanded from it, and docs/protocol.md section 8 is tested against it
// (tests/protocol/protocol_doc_test.cpp): a code is added by one row here and its row there.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

// clang-format off
#define AJAR_ERROR_CODES(X)                                                                        \
  X(kOk, 0, OK,                                                                                    \
    "no error (Event.fault / Status.latched_fault when none)",                                     \
    "–")                                                                                           \
  /* 1xx: framing and decoding (protocol/): decoders answer these, both directions */              \
  X(kBadMagic, 100, BAD_MAGIC,                                                                     \
    "frame does not start with AJAR",                                                              \
    "framing lost: the connection is closed; fix the client's framing, reconnect")                 \
  X(kUnsupportedVersion, 101, UNSUPPORTED_VERSION,                                                 \
    "major version not spoken by this peer",                                                       \
    "the connection is closed; use protocol major 1")                                              \
  X(kPayloadTooLarge, 102, PAYLOAD_TOO_LARGE,                                                      \
    "payload_length above 1024",                                                                   \
    "framing lost: the connection is closed; fix the sender")                                      \
  X(kCrcMismatch, 103, CRC_MISMATCH,                                                               \
    "CRC-32C over header and payload does not match",                                              \
    "the request was not executed; re-send it (same request id)")                                  \
  X(kBadPayloadLength, 104, BAD_PAYLOAD_LENGTH,                                                    \
    "payload length wrong for the message type",                                                   \
    "not executed; client bug (layout) — fix the encoder")                                         \
  X(kUnknownMessageType, 105, UNKNOWN_MESSAGE_TYPE,                                                \
    "type not known to this version (or not a host → daemon type)",                                \
    "not executed; check Welcome.version_minor before using newer types")                          \
  X(kInvalidEnumValue, 106, INVALID_ENUM_VALUE,                                                    \
    "an enum or bool field holds a value outside its table",                                       \
    "not executed; fix the field named in field")                                                  \
  X(kNonFiniteNumber, 107, NON_FINITE_NUMBER,                                                      \
    "NaN or infinity in a numeric field",                                                          \
    "not executed; the operator's pick was invalid (e.g. no depth): pick again")                   \
  X(kUnknownFlags, 108, UNKNOWN_FLAGS,                                                             \
    "reserved flag bits set",                                                                      \
    "not executed; send only flags this daemon version knows")                                     \
  X(kBadString, 109, BAD_STRING,                                                                   \
    "string too long, non-zero padding, invalid UTF-8 or control characters",                      \
    "not executed; sanitize the string")                                                           \
  X(kBadCount, 110, BAD_COUNT,                                                                     \
    "element count outside the allowed range (plane points 3..16)",                                \
    "not executed; send 3..16 points")                                                             \
  /* 2xx: session rules (daemon/) */                                                               \
  X(kHelloRequired, 200, HELLO_REQUIRED,                                                           \
    "first message of a session must be Hello",                                                    \
    "send Hello, then repeat the request")                                                         \
  X(kAlreadyGreeted, 201, ALREADY_GREETED,                                                         \
    "second Hello on one session",                                                                 \
    "ignore; the first Hello's role stands (reconnect to change it, or take over)")                \
  X(kNotController, 202, NOT_CONTROLLER,                                                           \
    "command needs the controller role",                                                           \
    "observers may only watch; reconnect as controller (with take_over if needed)")                \
  X(kControllerBusy, 203, CONTROLLER_BUSY,                                                         \
    "another session holds control and take_over was not requested",                               \
    "ask the operator; send Hello with take_over = 1 to take control, or as observer")             \
  X(kTooManyClients, 204, TOO_MANY_CLIENTS,                                                        \
    "maximum number of clients reached; the connection will be closed",                            \
    "retry later; close idle clients")                                                             \
  X(kRateLimited, 205, RATE_LIMITED,                                                               \
    "telemetry rate negative (a rate above the loop rate is not refused: it is capped at "         \
    "Welcome.loop_rate_hz, 5.9)",                                                                  \
    "send a rate ≥ 0 (0 = off)")                                                                   \
  X(kShuttingDown, 206, SHUTTING_DOWN,                                                             \
    "the daemon is stopping: until it closes the session only Stop and EmergencyStop are "         \
    "executed (and acknowledged)",                                                                 \
    "reconnect after it has restarted")                                                            \
  X(kNotSupported, 207, NOT_SUPPORTED,                                                             \
    "1.1: this daemon (or its drivers) cannot do the request yet",                                 \
    "show the message; do not retry")                                                              \
  X(kNoSuchRecording, 208, NO_SUCH_RECORDING,                                                      \
    "1.2: FetchRecording names no recording of the daemon (field name: unknown, removed by "       \
    "rotation since it was listed, or a path)",                                                    \
    "list the recordings again (ListRecordings)")                                                  \
  X(kRequestOutOfRange, 209, REQUEST_OUT_OF_RANGE,                                                 \
    "1.2: a request parameter is outside its range; the field names it: FetchRecording offset "    \
    "beyond the file's size or max_length outside 1..960, SaveRecording last_s not above 0 "       \
    "or above 86400",                                                                              \
    "fix the field named")                                                                         \
  /* 3xx: geometry and validation (core/) */                                                       \
  X(kNonFinite, 300, NON_FINITE,                                                                   \
    "a value is NaN or infinite. **Never for a number on the wire**: a NaN or infinity "           \
    "there is refused by the decoder first (NON_FINITE_NUMBER, 107). ajard's validation "          \
    "returns 300 only for a value it *derives* that is not finite (an overflow from extreme "      \
    "but finite coordinates, e.g. a point taken to the base frame), naming that value's "          \
    "field (p1.x, width_m, normal, ...)",                                                          \
    "pick the point(s) again")                                                                     \
  X(kPointOutOfDepthRange, 301, POINT_OUT_OF_DEPTH_RANGE,                                          \
    "a camera-frame point is outside the sensor's depth range",                                    \
    "pick a point on the door with a valid depth")                                                 \
  X(kPointsTooClose, 302, POINTS_TOO_CLOSE,                                                        \
    "two points are closer than the minimum separation (duplicates)",                              \
    "pick points further apart")                                                                   \
  X(kAmbiguousDirection, 303, AMBIGUOUS_DIRECTION,                                                 \
    "P1 and P2 have the same lateral position: the direction cannot be told",                      \
    "pick P1 and P2 clearly left/right of each other")                                             \
  X(kPointsNotSideBySide, 304, POINTS_NOT_SIDE_BY_SIDE,                                            \
    "the two points are mostly apart in depth or height, not laterally",                           \
    "pick P1/P2 across the door / along the handle")                                               \
  X(kWidthOutOfRange, 305, WIDTH_OUT_OF_RANGE,                                                     \
    "door width outside the configured range (Welcome limits)",                                    \
    "re-measure; check the picked edges")                                                          \
  X(kHandleLengthOutOfRange, 306, HANDLE_LENGTH_OUT_OF_RANGE,                                      \
    "handle length outside the configured range",                                                  \
    "re-measure the handle")                                                                       \
  X(kPointsCollinear, 307, POINTS_COLLINEAR,                                                       \
    "plane points do not span a plane",                                                            \
    "pick points spread over the door leaf")                                                       \
  X(kPlaneNotVertical, 308, PLANE_NOT_VERTICAL,                                                    \
    "the fitted plane is too far from vertical to be a door",                                      \
    "pick points on the door leaf only")                                                           \
  X(kYawOutOfRange, 309, YAW_OUT_OF_RANGE,                                                         \
    "yaw correction larger than the configured maximum",                                           \
    "drive the base closer to square, then measure the plane again")                               \
  X(kOutOfReach, 310, OUT_OF_REACH,                                                                \
    "contact point outside the arm's reachable workspace",                                         \
    "pick another contact point or move the base")                                                 \
  X(kPlaneResidualTooLarge, 311, PLANE_RESIDUAL_TOO_LARGE,                                         \
    "plane fit RMS residual above the configured maximum",                                         \
    "pick points again, on the flat leaf (not the handle/frame)")                                  \
  X(kUnknownFrame, 312, UNKNOWN_FRAME,                                                             \
    "a point names a frame that is neither camera nor base. **Never sent by ajard**: a "           \
    "frame value other than 0/1 is refused by the decoder first (INVALID_ENUM_VALUE, 106, "        \
    "field e.g. p1.frame), and nothing else makes a point's frame. Kept in the table (codes "      \
    "are never renumbered) for implementations that validate points they did not decode",          \
    "send frame 0 or 1")                                                                           \
  X(kTransformNotRigid, 313, TRANSFORM_NOT_RIGID,                                                  \
    "the configured camera→base matrix is not rigid",                                              \
    "configuration error on the robot: tell the integrator")                                       \
  X(kStandoffOutOfRange, 314, STANDOFF_OUT_OF_RANGE,                                               \
    "1.1: Approach standoff below approach_min_standoff_m",                                        \
    "ask for a larger standoff")                                                                   \
  /* 4xx: the procedure (daemon/) */                                                               \
  X(kWrongState, 400, WRONG_STATE,                                                                 \
    "command not allowed in the current procedure state",                                          \
    "GetStatus; follow the procedure order")                                                       \
  X(kMissingDoorWidth, 401, MISSING_DOOR_WIDTH,                                                    \
    "measure the door width first",                                                                \
    "send MeasureDoorWidth")                                                                       \
  X(kMissingHandle, 402, MISSING_HANDLE,                                                           \
    "measure the handle first",                                                                    \
    "send MeasureHandle")                                                                          \
  X(kMissingPlane, 403, MISSING_PLANE,                                                             \
    "measure the door plane first",                                                                \
    "send MeasureDoorPlane")                                                                       \
  X(kNotAligned, 404, NOT_ALIGNED,                                                                 \
    "align the base first",                                                                        \
    "send AlignBase and wait for motion_finished")                                                 \
  X(kMissingContactPoint, 405, MISSING_CONTACT_POINT,                                              \
    "set the contact point first",                                                                 \
    "send SetContactPoint")                                                                        \
  X(kFaultLatched, 406, FAULT_LATCHED,                                                             \
    "a fault is latched",                                                                          \
    "show Status.latched_fault; send Reset after fixing the cause")                                \
  X(kMotionInProgress, 407, MOTION_IN_PROGRESS,                                                    \
    "a motion is running, or the wheels are still stopping after one (every command that "         \
    "measures or moves, Drive and Approach included)",                                             \
    "wait for motion_finished / motion_stopped, or send Stop")                                     \
  X(kQueueFull, 408, QUEUE_FULL,                                                                   \
    "control loop command queue full",                                                             \
    "retry the same request (same id) after a short delay")                                        \
  X(kMeasurementStale, 409, MEASUREMENT_STALE,                                                     \
    "1.1: the base moved since a stored measurement (field: plane or contact; plane when "         \
    "both are stale)",                                                                             \
    "measure it again")                                                                            \
  X(kNoDoorDistance, 410, NO_DOOR_DISTANCE,                                                        \
    "1.1: Approach without width points or a plane to give the distance (field empty)",            \
    "measure the width (or the plane) first")                                                      \
  X(kNotSquareToDoor, 411, NOT_SQUARE_TO_DOOR,                                                     \
    "1.1: Approach while the base is not square to the door within "                               \
    "approach_square_tolerance_rad",                                                               \
    "align first (or jog square)")                                                                 \
  X(kApproachTooFar, 412, APPROACH_TOO_FAR,                                                        \
    "1.1: the approach move is longer than approach_max_travel_m (field standoff_m)",              \
    "jog closer first")                                                                            \
  X(kDriveNotAllowed, 413, DRIVE_NOT_ALLOWED,                                                      \
    "1.1: the base may not move because of the arm: Drive/Approach while engaging or "             \
    "engaged (field empty); Drive/Approach/AlignBase while the arm has not reported idle "         \
    "since its last task (field arm)",                                                             \
    "wait for the arm's task to end, or Stop (a done arm withdraws on Stop)")                      \
  X(kAtMinimumStandoff, 414, AT_MINIMUM_STANDOFF,                                                  \
    "Drive straight forward while the base is at approach_min_standoff_m from the door (a "        \
    "fresh door distance; field linear_m_s)",                                                      \
    "back off, turn, or measure the door again")                                                   \
  /* 5xx: drivers */                                                                               \
  X(kDriverError, 500, DRIVER_ERROR,                                                               \
    "generic driver failure (see message)",                                                        \
    "show the message; Reset; call service if it repeats")                                         \
  X(kDriverNotActive, 501, DRIVER_NOT_ACTIVE,                                                      \
    "a driver is not in the active state",                                                         \
    "check Status.card / Status.arm; Reset")                                                       \
  X(kCardCommunication, 502, CARD_COMMUNICATION,                                                   \
    "the motion card did not answer",                                                              \
    "check the card/cabling; Reset")                                                               \
  X(kCardBusy, 503, CARD_BUSY,                                                                     \
    "the motion card is busy",                                                                     \
    "retry shortly")                                                                               \
  X(kCardBadParameter, 504, CARD_BAD_PARAMETER,                                                    \
    "the motion card refused a parameter",                                                         \
    "a bug or bad configuration: report it")                                                       \
  X(kAxisAlarm, 505, AXIS_ALARM,                                                                   \
    "drive alarm on an axis",                                                                      \
    "check the drive; clear its alarm; Reset")                                                     \
  X(kFollowingError, 506, FOLLOWING_ERROR,                                                         \
    "a wheel did not follow its command",                                                          \
    "check for obstacles / wheel slip; Reset")                                                     \
  X(kLimitHit, 507, LIMIT_HIT,                                                                     \
    "a limit switch was hit",                                                                      \
    "move clear manually; Reset")                                                                  \
  X(kMotionTimeout, 508, MOTION_TIMEOUT,                                                           \
    "motion did not finish before its deadline",                                                   \
    "check the base; Reset")                                                                       \
  X(kArmTimeout, 509, ARM_TIMEOUT,                                                                 \
    "the arm controller did not acknowledge after retries",                                        \
    "check the arm link; Reset")                                                                   \
  X(kArmDisconnected, 510, ARM_DISCONNECTED,                                                       \
    "the arm's serial device is gone",                                                             \
    "reconnect the arm; Reset")                                                                    \
  X(kArmRejected, 511, ARM_REJECTED,                                                               \
    "the arm controller refused the task",                                                         \
    "check the contact point / door model; measure again")                                         \
  X(kDeadman, 512, DEADMAN,                                                                        \
    "the controller went silent (or left) during motion",                                          \
    "keep sending frames (Ping) while moving; Reset")                                              \
  X(kEmergencyStopped, 513, EMERGENCY_STOPPED,                                                     \
    "an emergency stop was commanded",                                                             \
    "make the scene safe; Reset to continue")                                                      \
  X(kCardOpenFailed, 514, CARD_OPEN_FAILED,                                                        \
    "the motion card could not be opened (missing, in use, driver)",                               \
    "daemon start-up problem: tell the integrator")                                                \
  X(kArmFault, 515, ARM_FAULT,                                                                     \
    "the arm controller reported a fault (task aborted)",                                          \
    "check the arm; Reset")                                                                        \
  X(kArmNotClear, 516, ARM_NOT_CLEAR,                                                              \
    "the arm has not reported idle (clear of the door): a stop it did not confirm within "         \
    "safety.arm_stop_timeout_s (latched), or a Reset while it still does not report idle",         \
    "the arm may still be at the door: check the arm and its link; Reset again once "              \
    "Status.arm_state is idle")                                                                    \
  X(kLoopStalled, 517, LOOP_STALLED,                                                               \
    "the control loop stopped cycling (a motion-card call did not return); the base was "          \
    "emergency-stopped by another path where the card allows it",                                  \
    "check the card and its bus; Reset once Status shows the loop running again "                  \
    "(docs/control-loop.md, \"Stalled loop\")")                                                    \
  X(kStateRejected, 518, STATE_REJECTED,                                                           \
    "latched at start: the state file could not be read, decoded or validated with the "           \
    "config (moved aside as ajard.state.rejected-<time>; its own latched fault, if it could "      \
    "be read, is kept instead); the stored measurements are gone",                                 \
    "read the journal; measure again; Reset")                                                      \
  X(kUncleanShutdown, 519, UNCLEAN_SHUTDOWN,                                                       \
    "latched at start: the previous run did not end with a clean shutdown (crash, kill -9, "       \
    "watchdog abort, power loss) — a stop acknowledged just before may not have been "             \
    "recorded",                                                                                    \
    "check the robot and the scene; Reset")                                                        \
  X(kVelocityMismatch, 520, VELOCITY_MISMATCH,                                                     \
    "the wheels did not do what the motion card was told: a wheel's measured velocity "            \
    "stayed outside the commanded one, or the wheels moved with no motion running (a card "        \
    "that missed a command or reports stale status); the daemon emergency-stopped them",           \
    "check the card and the drives; Reset")                                                        \
  /* 9xx: bugs */                                                                                  \
  X(kInternal, 900, INTERNAL,                                                                      \
    "a bug",                                                                                       \
    "report it with the daemon log")

// clang-format on

namespace ajar {

enum class ErrorCode : std::uint16_t {
#define AJAR_ERROR_ENUMERATOR(enumerator, code, name, meaning, action) enumerator = code,
  AJAR_ERROR_CODES(AJAR_ERROR_ENUMERATOR)
#undef AJAR_ERROR_ENUMERATOR
};

// One row of the table: the code, its stable symbolic name ("POINTS_COLLINEAR"), what it means and
// what a client should do about it (the columns of docs/protocol.md section 8).
struct ErrorInfo {
  ErrorCode value;
  std::string_view word;
  std::string_view meaning;
  std::string_view action;
};

// Every row, in code order.
std::span<const ErrorInfo> error_table() noexcept;
// The row of `code`; nullptr for a value the table does not have (a code from a newer peer).
const ErrorInfo* error_info(ErrorCode code) noexcept;

// Stable symbolic name, e.g. "POINTS_COLLINEAR". Unknown values give "UNKNOWN".
std::string_view to_string(ErrorCode code) noexcept;
// The code named `name` ("CRC_MISMATCH"); nullopt for a name the table does not have.
std::optional<ErrorCode> error_code_from_string(std::string_view name) noexcept;

// What went wrong and where. `field` names the offending input in the request's terms,
// e.g. "p2.z", "points[3]", "width_m", "frame"; empty when the error is not about one field.
struct Error {
  ErrorCode code = ErrorCode::kInternal;
  std::string field;
  std::string message;
};

}  // namespace ajar
