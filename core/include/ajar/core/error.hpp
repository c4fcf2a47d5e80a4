// One table of error codes for the whole product: geometry and validation (core), the wire
// protocol, sessions and the procedure (daemon), and the drivers. The numeric values are part of
// the wire protocol and stable across versions: never renumber, only append.
// docs/protocol.md carries the same table with what a client should do for each code.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace ajar {

enum class ErrorCode : std::uint16_t {
  kOk = 0,

  // 1xx: framing and decoding (protocol/).
  kBadMagic = 100,  // frame does not start with the magic: framing lost, connection closed
  kUnsupportedVersion = 101,  // major version not spoken by this peer
  kPayloadTooLarge = 102,     // payload length above the hard maximum: framing lost
  kCrcMismatch = 103,         // CRC-32C over header and payload does not match
  kBadPayloadLength = 104,    // payload length wrong for the message type
  kUnknownMessageType = 105,  // message type not known to this version
  kInvalidEnumValue = 106,    // an enum field holds a value outside its table
  kNonFiniteNumber = 107,     // NaN or infinity in a numeric field
  kUnknownFlags = 108,  // reserved flag bits set: frame refused, not executed; session continues
  kBadString = 109,     // string field too long or not UTF-8 printable
  kBadCount = 110,      // element count outside the allowed range (e.g. plane points 3..16)

  // 2xx: session rules (daemon/).
  kHelloRequired = 200,      // first message of a session must be Hello
  kAlreadyGreeted = 201,     // second Hello on one session
  kNotController = 202,      // command needs the controller role
  kControllerBusy = 203,     // another session holds control and take-over was not requested
  kTooManyClients = 204,     // max clients reached; connection will be closed
  kRateLimited = 205,        // telemetry rate outside 0..loop rate (or similar)
  kShuttingDown = 206,       // daemon is stopping
  kNotSupported = 207,       // 1.1: this daemon or its drivers cannot do the request (yet)
  kNoSuchRecording = 208,    // 1.2: no recording of that name (field "name")
  kRequestOutOfRange = 209,  // 1.2: a request parameter outside its range (the field names it)

  // 3xx: geometry and validation (core/).
  kNonFinite = 300,             // a value is NaN or infinite
  kPointOutOfDepthRange = 301,  // a camera-frame point is outside the sensor's depth range
  kPointsTooClose = 302,        // two points are closer than the minimum separation (duplicates)
  kAmbiguousDirection = 303,    // y1 == y2 (within tolerance): Algorithm 1 cannot tell CW from CCW
  kPointsNotSideBySide = 304,   // the two points are not laterally apart (mostly depth / height)
  kWidthOutOfRange = 305,       // door width outside the configured range
  kHandleLengthOutOfRange = 306,
  kPointsCollinear = 307,        // plane points do not span a plane
  kPlaneNotVertical = 308,       // the fitted plane is too far from vertical to be a door
  kYawOutOfRange = 309,          // yaw correction larger than the configured maximum
  kOutOfReach = 310,             // contact point outside the arm's reachable workspace
  kPlaneResidualTooLarge = 311,  // plane fit RMS residual above the configured maximum
  kUnknownFrame = 312,           // a point names a frame that is neither camera nor base
  kTransformNotRigid = 313,   // camera->base matrix not rigid (rotation, determinant, bottom row)
  kStandoffOutOfRange = 314,  // 1.1: Approach standoff below the configured minimum

  // 4xx: the procedure (daemon/).
  kWrongState = 400,           // command not allowed in the current procedure state
  kMissingDoorWidth = 401,     // measure the door width first
  kMissingHandle = 402,        // measure the handle first
  kMissingPlane = 403,         // measure the door plane first
  kNotAligned = 404,           // align the base first
  kMissingContactPoint = 405,  // set the contact point first
  kFaultLatched = 406,         // a fault is latched: Reset first
  kMotionInProgress = 407,     // wait for the motion to finish or Stop it
  kQueueFull = 408,            // control loop command queue full: retry later
  // 1.1: driving the base.
  kMeasurementStale = 409,   // the base moved since a stored measurement: measure it again
  kNoDoorDistance = 410,     // Approach: no width points and no plane give the distance
  kNotSquareToDoor = 411,    // Approach: the base is not square to the door within tolerance
  kApproachTooFar = 412,     // Approach: the move is longer than the configured maximum
  kDriveNotAllowed = 413,    // the base may not move now (engaging, engaged, arm not idle, ...)
  kAtMinimumStandoff = 414,  // Drive straight forward at the minimum standoff from the door

  // 5xx: drivers.
  kDriverError = 500,        // generic driver failure (see message)
  kDriverNotActive = 501,    // driver lifecycle not in the active state
  kCardCommunication = 502,  // motion card did not answer (GTS codes -1..-5, -7)
  kCardBusy = 503,           // GTS -8
  kCardBadParameter = 504,   // GTS 7
  kAxisAlarm = 505,          // drive alarm on an axis
  kFollowingError = 506,
  kLimitHit = 507,
  kMotionTimeout = 508,     // motion did not finish before its deadline
  kArmTimeout = 509,        // arm controller did not acknowledge within timeout after retries
  kArmDisconnected = 510,   // serial device gone
  kArmRejected = 511,       // arm controller refused the task
  kDeadman = 512,           // controller went silent during motion
  kEmergencyStopped = 513,  // an emergency stop was commanded: Reset to continue
  kCardOpenFailed = 514,    // GTS -6: the card could not be opened (missing, in use, driver)
  kArmFault = 515,          // the arm controller reported a fault (task aborted): clear_fault
  kArmNotClear = 516,    // the arm has not reported idle (clear of the door): a stop not confirmed
                         // in time latches it; Reset is refused with it until the arm reports idle
  kLoopStalled = 517,    // the control loop stopped cycling (a card call hung): base stopped
  kStateRejected = 518,  // the state file could not be restored (latched at start): Reset
  kUncleanShutdown = 519,   // the previous run did not end cleanly (latched at start): Reset
  kVelocityMismatch = 520,  // the wheels did not do what the card was told (a card that does not
                            // apply a command, or reports stale status): emergency stop

  kInternal = 900,  // a bug: please report
};

// Stable symbolic name, e.g. "POINTS_COLLINEAR". Unknown values give "UNKNOWN".
std::string_view to_string(ErrorCode code) noexcept;

// What went wrong and where. `field` names the offending input in the request's terms,
// e.g. "p2.z", "points[3]", "width_m", "frame"; empty when the error is not about one field.
struct Error {
  ErrorCode code = ErrorCode::kInternal;
  std::string field;
  std::string message;
};

}  // namespace ajar
