// The arm line protocol against literal byte strings (docs/manipulator-serial.md). CRCs were
// computed independently (CRC-16/CCITT-FALSE); a change of encoding breaks these tests.
#include <gtest/gtest.h>

#include <string>

#include "ajar/drivers/arm_protocol.hpp"

namespace ajar::drivers::arm {
namespace {

constexpr const char* kTaskLine =
    "$4711,TASK,7,0.6500,-0.1200,0.9500,0.9000,0.1200,CW,CCW*0BE3\r\n";

Message task_message() {
  Message m;
  m.seq = 4711;
  m.command = Command::kTask;
  m.task_id = 7;
  m.task.contact_base_m = core::Vec3(0.65, -0.12, 0.95);
  m.task.door_width_m = 0.9;
  m.task.handle_length_m = 0.12;
  m.task.door_direction = core::RotationDirection::kClockwise;
  m.task.handle_direction = core::RotationDirection::kCounterClockwise;
  return m;
}

std::string strip(std::string line) {  // what LineReader hands to decode()
  while (!line.empty() && (line.back() == '\n' || line.back() == '\r'))
    line.pop_back();
  return line;
}

TEST(ArmProtocol, CrcCheckValue) {
  EXPECT_EQ(crc16_ccitt("123456789"), 0x29B1);
  EXPECT_EQ(crc16_ccitt(""), 0xFFFF);
}

TEST(ArmProtocol, EncodesTaskFieldByField) {
  auto line = encode(task_message());
  ASSERT_TRUE(line.ok());
  EXPECT_EQ(line.value(), kTaskLine);
}

TEST(ArmProtocol, EncodesEveryMessageKind) {
  Message m;
  m.seq = 4712;
  m.command = Command::kStatus;
  EXPECT_EQ(encode(m).value(), "$4712,STAT*7F81\r\n");
  m = {};
  m.seq = 5;
  m.command = Command::kStop;
  EXPECT_EQ(encode(m).value(), "$5,STOP*CAEC\r\n");
  m = {};
  m.seq = 6;
  m.command = Command::kClear;
  EXPECT_EQ(encode(m).value(), "$6,CLR*DEF0\r\n");
  m = {};
  m.seq = 4711;
  m.command = Command::kAck;
  m.subject = Command::kTask;
  m.phase = ControllerPhase::kBusy;
  m.task_id = 7;
  EXPECT_EQ(encode(m).value(), "$4711,ACK,TASK,BUSY,7*BD13\r\n");
  m = {};
  m.seq = 9;
  m.command = Command::kNak;
  m.subject = Command::kTask;
  m.reason = RejectReason::kRefused;
  m.phase = ControllerPhase::kIdle;
  m.task_id = 3;
  EXPECT_EQ(encode(m).value(), "$9,NAK,TASK,REFUSED,IDLE,3*52CC\r\n");
  m = {};
  m.seq = 4712;
  m.command = Command::kReport;
  m.phase = ControllerPhase::kDone;
  m.task_id = 7;
  EXPECT_EQ(encode(m).value(), "$4712,STA,DONE,7*3856\r\n");
  m = {};
  m.seq = kUnsolicitedSeq;
  m.command = Command::kDone;
  m.task_id = 7;
  EXPECT_EQ(encode(m).value(), "$0,DONE,7*6CFB\r\n");
}

TEST(ArmProtocol, RefusesToEncodeNonFiniteLengths) {
  Message m = task_message();
  m.task.door_width_m = std::numeric_limits<double>::infinity();
  auto line = encode(m);
  ASSERT_FALSE(line.ok());
  EXPECT_EQ(line.error().code, ErrorCode::kNonFiniteNumber);
  EXPECT_EQ(line.error().field, "door_width_m");
}

TEST(ArmProtocol, DecodesTask) {
  auto m = decode(strip(kTaskLine));
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_EQ(m->seq, 4711);
  EXPECT_EQ(m->command, Command::kTask);
  EXPECT_EQ(m->task_id, 7U);
  EXPECT_DOUBLE_EQ(m->task.contact_base_m.x(), 0.65);
  EXPECT_DOUBLE_EQ(m->task.contact_base_m.y(), -0.12);
  EXPECT_DOUBLE_EQ(m->task.contact_base_m.z(), 0.95);
  EXPECT_DOUBLE_EQ(m->task.door_width_m, 0.9);
  EXPECT_DOUBLE_EQ(m->task.handle_length_m, 0.12);
  EXPECT_EQ(m->task.door_direction, core::RotationDirection::kClockwise);
  EXPECT_EQ(m->task.handle_direction, core::RotationDirection::kCounterClockwise);
}

TEST(ArmProtocol, DecodesReplies) {
  auto ack = decode("$4711,ACK,TASK,BUSY,7*BD13");
  ASSERT_TRUE(ack.ok());
  EXPECT_EQ(ack->command, Command::kAck);
  EXPECT_EQ(ack->subject, Command::kTask);
  EXPECT_EQ(ack->phase, ControllerPhase::kBusy);
  EXPECT_EQ(ack->task_id, 7U);

  auto nak = decode("$9,NAK,TASK,REFUSED,IDLE,3*52CC");
  ASSERT_TRUE(nak.ok());
  EXPECT_EQ(nak->command, Command::kNak);
  EXPECT_EQ(nak->reason, RejectReason::kRefused);
  EXPECT_EQ(nak->phase, ControllerPhase::kIdle);
  EXPECT_EQ(nak->task_id, 3U);

  auto done = decode("$0,DONE,7*6CFB");
  ASSERT_TRUE(done.ok());
  EXPECT_EQ(done->seq, kUnsolicitedSeq);
  EXPECT_EQ(done->command, Command::kDone);
  EXPECT_EQ(done->task_id, 7U);
}

TEST(ArmProtocol, RoundTripsEveryCommand) {
  for (Command c : {Command::kTask, Command::kStatus, Command::kStop, Command::kClear,
                    Command::kAck, Command::kNak, Command::kReport, Command::kDone}) {
    Message m = task_message();
    m.command = c;
    m.subject = Command::kStop;
    m.phase = ControllerPhase::kFault;
    m.reason = RejectReason::kBadRequest;
    auto line = encode(m);
    ASSERT_TRUE(line.ok());
    auto back = decode(strip(line.value()));
    ASSERT_TRUE(back.ok()) << line.value() << ": " << back.error().message;
    EXPECT_EQ(back->command, c);
    EXPECT_EQ(back->seq, m.seq);
    EXPECT_EQ(encode(back.value()).value(), line.value())
        << "re-encoding differs for " << line.value();
  }
}

TEST(ArmProtocol, RejectsBadCrc) {
  auto m = decode("$4711,ACK,TASK,BUSY,7*BD14");
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.error().code, ErrorCode::kCrcMismatch);
  // One flipped payload byte with the old CRC.
  m = decode("$4711,ACK,TASK,BUSY,8*BD13");
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.error().code, ErrorCode::kCrcMismatch);
  // Lower-case hex is not the format.
  m = decode("$4711,ACK,TASK,BUSY,7*bd13");
  ASSERT_FALSE(m.ok());
}

TEST(ArmProtocol, RejectsMalformedLinesWithValidCrc) {
  struct Case {
    const char* line;
    ErrorCode code;
    const char* field;
  };
  const Case cases[] = {
      {"$12,STA,SLEEPY,1*5A72", ErrorCode::kInvalidEnumValue, "phase"},
      {"$12,FOO*5FF9", ErrorCode::kUnknownMessageType, "command"},
      {"$12,STA,IDLE*1AD5", ErrorCode::kBadPayloadLength, "STA"},
      {"$12,TASK,1,nan,0.0000,0.0000,0.9000,0.1000,CW,CW*7FDE", ErrorCode::kNonFiniteNumber,
       "contact_base_m.x"},
      {"$12,TASK,1,0.1000,0.0000,0.0000,0.9000,0.1000,CW,UP*84CB", ErrorCode::kInvalidEnumValue,
       "handle_direction"},
  };
  for (const auto& c : cases) {
    auto m = decode(c.line);
    ASSERT_FALSE(m.ok()) << c.line;
    EXPECT_EQ(m.error().code, c.code) << c.line;
    EXPECT_EQ(m.error().field, c.field) << c.line;
  }
  EXPECT_FALSE(decode("").ok());
  EXPECT_FALSE(decode("$*0000").ok());
  EXPECT_FALSE(decode("4712,STAT*7F81").ok());
}

TEST(ArmProtocol, LineReaderSplitsAndStripsTerminators) {
  LineReader r;
  r.feed("$4712,STAT*7F81\r\n$0,DONE,7*6CFB\n");
  EXPECT_EQ(r.next_line(), "$4712,STAT*7F81");
  EXPECT_EQ(r.next_line(), "$0,DONE,7*6CFB");
  EXPECT_EQ(r.next_line(), std::nullopt);
  EXPECT_EQ(r.dropped_bytes(), 0U);
}

TEST(ArmProtocol, LineReaderReassemblesAcrossFeeds) {
  LineReader r;
  r.feed("$4711,ACK,TA");
  EXPECT_EQ(r.next_line(), std::nullopt);
  r.feed("SK,BUSY,7*BD");
  EXPECT_EQ(r.next_line(), std::nullopt);
  r.feed("13\r");
  EXPECT_EQ(r.next_line(), std::nullopt);
  r.feed("\n");
  EXPECT_EQ(r.next_line(), "$4711,ACK,TASK,BUSY,7*BD13");
}

TEST(ArmProtocol, LineReaderResynchronisesAfterGarbage) {
  LineReader r;
  // Noise, a '$' fragment cut off by a new '$', then a good line; then a line with a bad CRC and
  // a good one.
  static constexpr char kNoise[] = "\x01\xFFnoise$17,AC\x7F";
  r.feed(std::string(kNoise, sizeof kNoise - 1));
  r.feed("$4711,ACK,TASK,BUSY,7*BD13\r\n$9,STA,IDLE,0*0000\r\n$0,DONE,7*6CFB\r\n");
  std::vector<std::string> good;
  int bad = 0;
  while (auto line = r.next_line()) {
    if (decode(*line).ok()) {
      good.push_back(*line);
    } else {
      ++bad;
    }
  }
  ASSERT_EQ(good.size(), 2U);
  EXPECT_EQ(good[0], "$4711,ACK,TASK,BUSY,7*BD13");
  EXPECT_EQ(good[1], "$0,DONE,7*6CFB");
  EXPECT_EQ(bad, 1);                      // the bad-CRC line
  EXPECT_EQ(r.dropped_bytes(), 7U + 7U);  // "\x01\xFFnoise" and "$17,AC\x7F"
}

TEST(ArmProtocol, LineReaderDropsOverlongLines) {
  LineReader r;
  r.feed("$" + std::string(kMaxLineBytes + 10, 'A') + "\r\n$5,STOP*CAEC\r\n");
  EXPECT_EQ(r.next_line(), "$5,STOP*CAEC");
  EXPECT_EQ(r.next_line(), std::nullopt);
  EXPECT_GT(r.dropped_bytes(), kMaxLineBytes);
}

}  // namespace
}  // namespace ajar::drivers::arm
