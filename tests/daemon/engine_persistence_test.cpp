// Accepted measurements and the procedure state survive a restart; nothing resumes moving.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "fake_engine_fixture.hpp"

namespace ajar::testing {
namespace {

using protocol::EventKind;
using protocol::ProcedureState;

TEST_F(EngineTest, RestartRestoresParametersAndMovesNothing) {
  start();
  walk_to(ProcedureState::kReadyToEngage);
  const auto before = engine->status();
  restart();
  const auto after = engine->status();
  EXPECT_TRUE(after.restored_from_disk);
  EXPECT_EQ(after.state, ProcedureState::kReadyToEngage);
  ASSERT_TRUE(after.has_width && after.has_handle && after.has_plane && after.has_contact);
  EXPECT_EQ(after.width.length_m, before.width.length_m);
  EXPECT_EQ(after.handle.length_m, before.handle.length_m);
  EXPECT_EQ(after.plane.left_counts, before.plane.left_counts);
  EXPECT_EQ(after.plane.yaw_deviation_rad, before.plane.yaw_deviation_rad);
  EXPECT_TRUE(after.contact.contact_base_m == before.contact.contact_base_m);
  for (int i = 0; i < 50; ++i)
    engine->poll();
  EXPECT_EQ(move_calls(), 0);
  EXPECT_TRUE(arm->with_lock([](FakeArmControl& a) { return a.tasks.empty(); }));
  // And the procedure continues from there.
  expect_ack(send(protocol::Engage{}), ProcedureState::kEngaging);
}

TEST_F(EngineTest, RestartDuringAlignmentComesBackReadyToAlignWithoutMoving) {
  start();
  walk_to(ProcedureState::kAligning);
  // A crash: the state file says "aligning". (shutdown() would record the interruption itself;
  // copy the file as it is now, before the engine goes away, to model a crash.)
  const std::string file = config.state.directory + "/ajard.state";
  const std::string saved = file + ".crash";
  std::filesystem::copy_file(file, saved);
  engine.reset();
  std::filesystem::rename(saved, file);
  card = std::make_shared<FakeCardControl>();
  arm = std::make_shared<FakeArmControl>();
  start();
  EXPECT_TRUE(engine->status().restored_from_disk);
  EXPECT_EQ(engine->status().state, ProcedureState::kReadyToAlign);
  for (int i = 0; i < 50; ++i)
    engine->poll();
  EXPECT_EQ(move_calls(), 0);
  expect_refused(send(protocol::AlignBase{}), ErrorCode::kMissingPlane);
}

TEST_F(EngineTest, RestartDuringEngagingComesBackReadyToEngage) {
  start();
  walk_to(ProcedureState::kEngaging);
  restart();
  EXPECT_EQ(engine->status().state, ProcedureState::kReadyToEngage);
  EXPECT_TRUE(arm->with_lock([](FakeArmControl& a) { return a.tasks.empty(); }));
}

TEST_F(EngineTest, LatchedFaultSurvivesARestart) {
  start();
  walk_to(ProcedureState::kAligned);
  expect_ack(send(protocol::EmergencyStop{}), ProcedureState::kFault);
  restart();
  EXPECT_EQ(engine->status().state, ProcedureState::kFault);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kEmergencyStopped);
  expect_ack(send(protocol::Reset{}), ProcedureState::kAligned);
}

TEST_F(EngineTest, ClearedParametersStayClearedAfterRestart) {
  start();
  walk_to(ProcedureState::kAligned);
  expect_ack(send(protocol::Reset{true}), ProcedureState::kAwaitingWidth);
  restart();
  EXPECT_EQ(engine->status().state, ProcedureState::kAwaitingWidth);
  EXPECT_FALSE(engine->status().has_width);
}

TEST_F(EngineTest, CorruptStateFileStartsCleanWithAWarning) {
  std::filesystem::create_directories(config.state.directory);
  std::ofstream(config.state.directory + "/ajard.state") << "ajar-state 1\nwidth ???\ncrc32 0\n";
  start();
  EXPECT_EQ(engine->status().state, ProcedureState::kAwaitingWidth);
  EXPECT_FALSE(engine->status().restored_from_disk);
  const auto warnings = engine->startup_warnings();
  ASSERT_FALSE(warnings.empty());
  EXPECT_NE(warnings[0].find("state file"), std::string::npos) << warnings[0];
  // The daemon keeps working and writes a good file again.
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  restart();
  EXPECT_TRUE(engine->status().has_width);
}

TEST_F(EngineTest, StateThatNoLongerValidatesStartsClean) {
  start();
  walk_to(ProcedureState::kAwaitingHandle);
  engine.reset();
  config.limits.max_door_width_m = 0.6;  // the stored 0.85 m door is now out of range
  start();
  EXPECT_EQ(engine->status().state, ProcedureState::kAwaitingWidth);
  EXPECT_FALSE(engine->startup_warnings().empty());
}

TEST_F(EngineTest, UnwritableStateIsAWarningNotAFailure) {
  start();
  std::filesystem::remove_all(config.state.directory);
  std::ofstream(config.state.directory) << "now a file";  // the directory is gone
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  const auto warnings = engine->take_warnings();
  ASSERT_EQ(warnings.size(), 1U);
  EXPECT_NE(warnings[0].find("not persisted"), std::string::npos) << warnings[0];
  expect_ack(send(good_handle()), ProcedureState::kAwaitingPlane);
  EXPECT_TRUE(engine->take_warnings().empty());  // the same problem is reported once
}

}  // namespace
}  // namespace ajar::testing
