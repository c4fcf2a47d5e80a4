// RequestLedger: the bounded memory behind exactly-once execution.
#include <gtest/gtest.h>

#include "ajar/daemon/request_ledger.hpp"

namespace ajar::daemon {
namespace {

using protocol::MessageType;

protocol::Message ack_of(MessageType t, protocol::ProcedureState state) {
  protocol::Ack ack;
  ack.acknowledged = t;
  ack.state = state;
  return ack;
}

protocol::ProcedureState state_in(const protocol::Message* m) {
  return std::get<protocol::Ack>(*m).state;
}

TEST(RequestLedger, FindsWhatWasRecordedForTheSameClientRequestAndType) {
  RequestLedger ledger;
  EXPECT_EQ(ledger.find(1, 10, MessageType::kAlignBase), nullptr);
  ledger.record(1, 10, MessageType::kAlignBase,
                ack_of(MessageType::kAlignBase, protocol::ProcedureState::kAligning));
  const auto* found = ledger.find(1, 10, MessageType::kAlignBase);
  ASSERT_NE(found, nullptr);
  EXPECT_EQ(state_in(found), protocol::ProcedureState::kAligning);
  EXPECT_EQ(ledger.find(2, 10, MessageType::kAlignBase), nullptr);  // other client instance
  EXPECT_EQ(ledger.find(1, 11, MessageType::kAlignBase), nullptr);  // other request id
  EXPECT_EQ(ledger.find(1, 10, MessageType::kEngage), nullptr);     // id reused for another type
}

TEST(RequestLedger, RecordingTheSameRequestIdAgainReplacesTheReply) {
  RequestLedger ledger;
  ledger.record(1, 10, MessageType::kEngage,
                ack_of(MessageType::kEngage, protocol::ProcedureState::kEngaging));
  ledger.record(1, 10, MessageType::kEngage,
                ack_of(MessageType::kEngage, protocol::ProcedureState::kEngaged));
  EXPECT_EQ(ledger.reply_count(1), 1U);
  EXPECT_EQ(state_in(ledger.find(1, 10, MessageType::kEngage)), protocol::ProcedureState::kEngaged);
}

TEST(RequestLedger, KeepsTheLastRepliesPerClient) {
  RequestLedger ledger(RequestLedger::Limits{4, 8});
  for (std::uint32_t id = 1; id <= 6; ++id) {
    ledger.record(7, id, MessageType::kReset,
                  ack_of(MessageType::kReset, protocol::ProcedureState::kAwaitingWidth));
  }
  EXPECT_EQ(ledger.reply_count(7), 4U);
  EXPECT_EQ(ledger.find(7, 1, MessageType::kReset), nullptr);
  EXPECT_EQ(ledger.find(7, 2, MessageType::kReset), nullptr);
  for (std::uint32_t id = 3; id <= 6; ++id)
    EXPECT_NE(ledger.find(7, id, MessageType::kReset), nullptr) << id;
}

TEST(RequestLedger, ForgetsTheLeastRecentlyUsedClientFirst) {
  RequestLedger ledger(RequestLedger::Limits{4, 2});
  ledger.record(1, 1, MessageType::kReset,
                ack_of(MessageType::kReset, protocol::ProcedureState::kAwaitingWidth));
  ledger.record(2, 1, MessageType::kReset,
                ack_of(MessageType::kReset, protocol::ProcedureState::kAwaitingWidth));
  ASSERT_NE(ledger.find(1, 1, MessageType::kReset), nullptr);  // client 1 used last
  ledger.record(3, 1, MessageType::kReset,
                ack_of(MessageType::kReset, protocol::ProcedureState::kAwaitingWidth));
  EXPECT_EQ(ledger.client_count(), 2U);
  EXPECT_NE(ledger.find(1, 1, MessageType::kReset), nullptr);
  EXPECT_EQ(ledger.find(2, 1, MessageType::kReset), nullptr);
  EXPECT_NE(ledger.find(3, 1, MessageType::kReset), nullptr);
}

TEST(RequestLedger, StoresErrorRepliesToo) {
  RequestLedger ledger;
  protocol::ErrorReply error;
  error.code = ErrorCode::kPointsCollinear;
  error.field = "points[2]";
  ledger.record(9, 3, MessageType::kMeasureDoorPlane, error);
  const auto* found = ledger.find(9, 3, MessageType::kMeasureDoorPlane);
  ASSERT_NE(found, nullptr);
  EXPECT_EQ(std::get<protocol::ErrorReply>(*found).code, ErrorCode::kPointsCollinear);
  EXPECT_EQ(std::get<protocol::ErrorReply>(*found).field.view(), "points[2]");
}

}  // namespace
}  // namespace ajar::daemon
