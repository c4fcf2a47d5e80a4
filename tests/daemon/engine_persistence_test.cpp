// Accepted measurements and the procedure state survive a restart; nothing resumes moving.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "fake_engine_fixture.hpp"
#include "state_file_checksum.hpp"

namespace ajar::testing {
namespace {

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

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
  EXPECT_TRUE(arm->tasks().empty());
  // And the procedure continues from there.
  expect_ack(send(protocol::Engage{}), ProcedureState::kEngaging);
}

TEST_F(EngineTest, RestartDuringAlignmentComesBackReadyToAlignWithoutMoving) {
  start();
  walk_to(ProcedureState::kAligning);
  // A crash: the state file says "aligning". (shutdown() would record the interruption itself;
  // copy the file as it is now, before the engine goes away, to model a crash.)
  ASSERT_TRUE(
      wait_for([&] { return engine->settled_generation() >= engine->accepted_generation(); }));
  const std::string file = config.state.directory + "/ajard.state";
  const std::string saved = file + ".crash";
  std::filesystem::copy_file(file, saved);
  engine.reset();
  std::filesystem::rename(saved, file);
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
  EXPECT_TRUE(arm->tasks().empty());
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
  ASSERT_EQ(warnings.size(), 2U);
  EXPECT_NE(warnings[0].find("state file"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[1].find(".rejected-"), std::string::npos) << warnings[1];
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
  const auto warnings = engine->startup_warnings();
  ASSERT_EQ(warnings.size(), 2U);
  EXPECT_NE(warnings[0].find("no longer validates"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[1].find(".rejected-"), std::string::npos) << warnings[1];
}

TEST_F(EngineTest, UnwritableStateIsAWarningNotAFailure) {
  start();
  std::filesystem::remove_all(config.state.directory);
  std::ofstream(config.state.directory) << "now a file";  // the directory is gone
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  // Saves run on the writer thread: the failure shows once that save has settled.
  const auto settled = [&] {
    return engine->settled_generation() >= engine->accepted_generation();
  };
  ASSERT_TRUE(wait_for(settled));
  const auto warnings = engine->take_warnings();
  ASSERT_EQ(warnings.size(), 1U);
  EXPECT_NE(warnings[0].find("not persisted"), std::string::npos) << warnings[0];
  expect_ack(send(good_handle()), ProcedureState::kAwaitingPlane);
  ASSERT_TRUE(wait_for(settled));
  EXPECT_TRUE(engine->take_warnings().empty());  // the same problem is reported once
}

// A checksum-valid file with impossible content (a fault code the daemon never latches) is not
// restored: it is kept beside the new file for inspection, and the startup warnings say where.
TEST_F(EngineTest, ImpossibleStateIsRejectedAndKept) {
  start();
  walk_to(ProcedureState::kAwaitingPlane);
  engine.reset();
  const std::string file = config.state.directory + "/ajard.state";
  std::string text = read_file(file);
  const auto at = text.find("fault 0");
  ASSERT_NE(at, std::string::npos) << text;
  text.replace(at, 7, "fault 65535");
  text = with_checksum(text.substr(0, text.rfind("crc32 ")));
  std::ofstream(file, std::ios::trunc) << text;
  start();
  EXPECT_EQ(engine->status().state, ProcedureState::kAwaitingWidth);
  EXPECT_FALSE(engine->status().restored_from_disk);
  const auto warnings = engine->startup_warnings();
  ASSERT_EQ(warnings.size(), 2U);
  EXPECT_NE(warnings[0].find("fault code '65535'"), std::string::npos) << warnings[0];
  const auto kept_at = warnings[1].find(file + ".rejected-");
  ASSERT_NE(kept_at, std::string::npos) << warnings[1];
  EXPECT_EQ(read_file(warnings[1].substr(kept_at)), text);  // kept as it was
  // The daemon keeps working and writes a good file again.
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  restart();
  EXPECT_TRUE(engine->status().restored_from_disk);
  EXPECT_TRUE(engine->status().has_width);
}

// Saves run on the state store's writer thread: a command returns while its save is still
// being written (a 300 ms disk), and it settles afterwards.
TEST_F(EngineTest, ACommandDoesNotWaitForTheDisk) {
  config.state.debug_write_delay_ms = 300;
  start();
  const auto before = engine->accepted_generation();
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  const auto generation = engine->accepted_generation();
  EXPECT_GT(generation, before);
  EXPECT_LT(engine->settled_generation(), generation);  // not yet on disk when the Ack is made
  ASSERT_TRUE(wait_for([&] { return engine->settled_generation() >= generation; }));
  restart();
  EXPECT_TRUE(engine->status().has_width);
}

}  // namespace
}  // namespace ajar::testing
