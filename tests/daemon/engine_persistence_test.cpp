// Accepted measurements and the procedure state survive a restart; nothing resumes moving. A
// latched fault survives everything: a restart, a rejected state file, an unclean end (crash)
// right after it; a start after an unclean end latches UNCLEAN_SHUTDOWN; the shutdown's steps
// still execute stops.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include "fake_engine_fixture.hpp"
#include "ajar/daemon/state_store.hpp"
#include "ajar/protocol/codec.hpp"
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

// The state file as the daemon reads it.
daemon::StateRecord decoded(const std::string& bytes) {
  auto r = daemon::decode_state(bytes);
  EXPECT_TRUE(r.ok()) << r.error().message;
  return r.ok() ? *r : daemon::StateRecord{};
}

class EnginePersistence : public EngineTest {
 protected:
  std::string state_file() const { return config.state.directory + "/ajard.state"; }
  // A crash: the engine goes away without its shutdown's last save — the state file stays as it
  // is now (or as `on_disk`) — and a new engine starts on it.
  void crash_and_start(std::optional<std::string> on_disk = std::nullopt) {
    if (!on_disk) {
      ASSERT_TRUE(
          wait_for([&] { return engine->settled_generation() >= engine->accepted_generation(); }));
    }
    const std::string text = on_disk ? *on_disk : read_file(state_file());
    engine.reset();  // its shutdown writes the clean-shutdown mark: undone below
    std::ofstream(state_file(), std::ios::trunc) << text;
    events.clear();
    start();
  }
};

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

// A crash (the state file as it is while running, copied before the engine goes away) during an
// alignment: the restart latches UNCLEAN_SHUTDOWN; after the Reset the base is READY_TO_ALIGN with
// the plane consumed (it turned by an unknown amount), and nothing moved.
TEST_F(EnginePersistence, ACrashDuringAlignmentComesBackLatchedThenReadyToAlignWithoutMoving) {
  start();
  walk_to(ProcedureState::kAligning);
  crash_and_start();
  EXPECT_TRUE(engine->status().restored_from_disk);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kUncleanShutdown);
  for (int i = 0; i < 50; ++i)
    engine->poll();
  EXPECT_EQ(move_calls(), 0);
  expect_ack(send(protocol::Reset{}), ProcedureState::kReadyToAlign);
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

TEST_F(EnginePersistence, CorruptStateFileLatchesStateRejectedWithAWarning) {
  std::filesystem::create_directories(config.state.directory);
  std::ofstream(config.state.directory + "/ajard.state") << "ajar-state 2\nwidth ???\ncrc32 0\n";
  start();
  EXPECT_EQ(engine->status().state, ProcedureState::kFault);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kStateRejected);
  EXPECT_FALSE(engine->status().restored_from_disk);
  const auto warnings = engine->startup_warnings();
  ASSERT_EQ(warnings.size(), 3U);
  EXPECT_NE(warnings[0].find("state file"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[1].find(".rejected-"), std::string::npos) << warnings[1];
  EXPECT_NE(warnings[2].find("STATE_REJECTED"), std::string::npos) << warnings[2];
  // The fault is on disk before anything is served: a crash now keeps it.
  crash_and_start();
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kStateRejected);
  expect_refused(send(protocol::Drive{0.1, 0}), ErrorCode::kFaultLatched);
  // After a Reset the daemon works and writes a good file again.
  expect_ack(send(protocol::Reset{}), ProcedureState::kAwaitingWidth);
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  restart();
  EXPECT_TRUE(engine->status().has_width);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kOk);
}

TEST_F(EnginePersistence, StateThatNoLongerValidatesLatchesStateRejected) {
  start();
  walk_to(ProcedureState::kAwaitingHandle);
  engine.reset();
  config.limits.max_door_width_m = 0.6;  // the stored 0.85 m door is now out of range
  start();
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kStateRejected);
  EXPECT_FALSE(engine->status().has_width);
  const auto warnings = engine->startup_warnings();
  ASSERT_EQ(warnings.size(), 3U);
  EXPECT_NE(warnings[0].find("no longer validates"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[1].find(".rejected-"), std::string::npos) << warnings[1];
  EXPECT_NE(warnings[2].find("STATE_REJECTED"), std::string::npos) << warnings[2];
  expect_ack(send(protocol::Reset{}), ProcedureState::kAwaitingWidth);
}

// Issue 22 item 5: the file no longer validates, but the fault it holds is read and stays latched
// (the measurements are dropped, the file is kept aside).
TEST_F(EnginePersistence, AFaultInAStateFileThatNoLongerValidatesStaysLatched) {
  start();
  walk_to(ProcedureState::kAwaitingPlane);
  expect_ack(send(protocol::EmergencyStop{}), ProcedureState::kFault);
  engine.reset();
  config.limits.min_door_width_m = 0.9;  // the stored 0.85 m door is now out of range
  start();
  EXPECT_EQ(engine->status().state, ProcedureState::kFault);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kEmergencyStopped);
  EXPECT_FALSE(engine->status().has_width);
  const auto warnings = engine->startup_warnings();
  ASSERT_EQ(warnings.size(), 4U);
  EXPECT_NE(warnings[2].find("EMERGENCY_STOPPED"), std::string::npos) << warnings[2];
  EXPECT_NE(warnings[3].find("STATE_REJECTED"), std::string::npos) << warnings[3];
  EXPECT_NE(warnings[3].find("stays latched"), std::string::npos) << warnings[3];
  expect_refused(send(protocol::Drive{0.1, 0}), ErrorCode::kFaultLatched);
  for (int i = 0; i < 20; ++i)
    engine->poll();
  EXPECT_EQ(card->calls(drivers::CardCall::kJog), 0U);
  expect_ack(send(protocol::Reset{}), ProcedureState::kAwaitingWidth);
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
// restored: it is kept beside the new file for inspection, the startup warnings say where, and
// STATE_REJECTED latches (what the file held is unknown, a fault included).
TEST_F(EnginePersistence, ImpossibleStateIsRejectedKeptAndLatched) {
  start();
  walk_to(ProcedureState::kAwaitingPlane);
  engine.reset();
  const std::string file = config.state.directory + "/ajard.state";
  std::string text = read_file(file);
  ASSERT_EQ(decoded(text).procedure.fault, ErrorCode::kOk);
  text[14] = text[15] = '\xff';  // the latched fault: 65535
  text = with_header_crc(text);
  std::ofstream(file, std::ios::trunc) << text;
  start();
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kStateRejected);
  EXPECT_FALSE(engine->status().restored_from_disk);
  EXPECT_FALSE(engine->status().has_width);
  const auto warnings = engine->startup_warnings();
  ASSERT_EQ(warnings.size(), 3U);
  EXPECT_NE(warnings[0].find("fault code '65535'"), std::string::npos) << warnings[0];
  const auto kept_at = warnings[1].find(file + ".rejected-");
  ASSERT_NE(kept_at, std::string::npos) << warnings[1];
  EXPECT_EQ(read_file(warnings[1].substr(kept_at)), text);  // kept as it was
  // After a Reset the daemon works and writes a good file again.
  expect_ack(send(protocol::Reset{}), ProcedureState::kAwaitingWidth);
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  restart();
  EXPECT_TRUE(engine->status().restored_from_disk);
  EXPECT_TRUE(engine->status().has_width);
}

// Issue 22 item 6, made deterministic: the EmergencyStop's Ack does not wait for the disk (here a
// 300 ms save); a crash before that save lands leaves the record without the fault — and without
// the clean-shutdown mark, so the restart latches UNCLEAN_SHUTDOWN: nothing moves before a Reset.
TEST_F(EnginePersistence, ACrashRightAfterAnEmergencyStopAckComesBackLatched) {
  config.state.debug_write_delay_ms = 300;
  start();
  walk_to(ProcedureState::kAwaitingPlane);
  ASSERT_TRUE(
      wait_for([&] { return engine->settled_generation() >= engine->accepted_generation(); }));
  expect_ack(send(protocol::EmergencyStop{}), ProcedureState::kFault);
  const std::string on_disk = read_file(config.state.directory + "/ajard.state");
  EXPECT_EQ(decoded(on_disk).procedure.fault, ErrorCode::kOk) << "the save landed already";
  crash_and_start(on_disk);
  EXPECT_EQ(engine->status().state, ProcedureState::kFault);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kUncleanShutdown);
  EXPECT_TRUE(engine->status().has_width && engine->status().has_handle);
  expect_refused(send(protocol::Drive{0.1, 0}), ErrorCode::kFaultLatched);
  expect_refused(send(plane_at_yaw(0.1)), ErrorCode::kFaultLatched);
  for (int i = 0; i < 20; ++i)
    engine->poll();
  EXPECT_EQ(card->calls(drivers::CardCall::kJog), 0U);
  EXPECT_EQ(move_calls(), 0);
  expect_ack(send(protocol::Reset{}), ProcedureState::kAwaitingPlane);
}

// A clean shutdown leaves the mark: no fault after the restart. A first start (no file) is clean.
TEST_F(EnginePersistence, OnlyACleanShutdownOrAFirstStartComesBackWithoutAFault) {
  start();
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kOk);      // first start
  EXPECT_FALSE(decoded(read_file(state_file())).clean_shutdown);  // running, before serving
  walk_to(ProcedureState::kAwaitingPlane);
  engine.reset();  // shutdown()
  EXPECT_TRUE(decoded(read_file(state_file())).clean_shutdown);
  start();
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kOk);
  EXPECT_EQ(engine->status().state, ProcedureState::kAwaitingPlane);
}

// An upgrade: a state file of format 1 (an older ajard, which recorded no clean shutdown) is read
// — its measurements restored, its fault kept — and UNCLEAN_SHUTDOWN latches when it held none:
// whether that run ended cleanly is unknown. One Reset after the upgrade.
TEST_F(EnginePersistence, AVersionOneStateFileIsRestoredAndNeedsAReset) {
  start();
  walk_to(ProcedureState::kAwaitingPlane);
  engine.reset();
  const std::string file = config.state.directory + "/ajard.state";
  auto as_version_one = [&](ErrorCode fault) {
    daemon::StateRecord record = decoded(read_file(file));
    record.procedure.fault = fault;
    std::ofstream(file, std::ios::trunc) << legacy_text(record, 1);
  };
  as_version_one(ErrorCode::kOk);
  start();
  EXPECT_TRUE(engine->status().restored_from_disk);
  EXPECT_TRUE(engine->status().has_width && engine->status().has_handle);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kUncleanShutdown);
  ASSERT_EQ(engine->startup_warnings().size(), 1U);
  EXPECT_NE(engine->startup_warnings()[0].find("older ajard"), std::string::npos);
  expect_ack(send(protocol::Reset{}), ProcedureState::kAwaitingPlane);
  engine.reset();
  as_version_one(ErrorCode::kEmergencyStopped);
  start();
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kEmergencyStopped);  // never un-latched
  EXPECT_TRUE(engine->status().has_width);
}

// An upgrade from format 2 (a committed file, as the ajard before format 3 wrote it after a clean
// shutdown with the door's width and handle measured): read once — its measurements restored, no
// fault — and rewritten in format 3 by the start's first save, with the same requests.
TEST_F(EnginePersistence, AFormatTwoStateFileIsReadOnceAndRewrittenInFormatThree) {
  std::filesystem::create_directories(config.state.directory);
  const std::string committed = read_file(AJAR_SOURCE_DIR "/tests/daemon/data/ajard.state.format2");
  ASSERT_EQ(committed.rfind("ajar-state 2\n", 0), 0U) << committed;
  std::ofstream(state_file()) << committed;
  start();
  EXPECT_TRUE(engine->status().restored_from_disk);
  EXPECT_EQ(engine->status().state, ProcedureState::kAwaitingPlane);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kOk);
  EXPECT_TRUE(engine->startup_warnings().empty());
  const std::string rewritten = read_file(state_file());
  ASSERT_EQ(rewritten.rfind(daemon::kStateMagic, 0), 0U);
  const daemon::StateRecord now = decoded(rewritten);
  const daemon::StateRecord before = decoded(committed);
  EXPECT_EQ(now.format_version, 3);
  EXPECT_FALSE(now.clean_shutdown);  // running
  ASSERT_TRUE(now.procedure.width && now.procedure.handle);
  EXPECT_TRUE(protocol::wire_equal(*now.procedure.width, *before.procedure.width));
  EXPECT_TRUE(protocol::wire_equal(*now.procedure.handle, *before.procedure.handle));
  EXPECT_TRUE(protocol::wire_equal(*now.procedure.width, good_width()));
  restart();  // and format 3 comes back as format 2 did
  EXPECT_EQ(engine->status().state, ProcedureState::kAwaitingPlane);
  EXPECT_NEAR(engine->status().width.length_m, 0.85, 1e-12);
}

// The daemon does not serve when it cannot record that it runs: a crash would go unnoticed.
TEST_F(EnginePersistence, AStartThatCannotRecordItselfFails) {
  std::filesystem::create_directories(config.state.directory + "/ajard.state.tmp/occupied");
  EXPECT_THROW(start(), daemon::StartupError);
  EXPECT_EQ(card->calls(drivers::CardCall::kClose), 1U);  // the card was brought down again
}

// The shutdown's steps (the daemon's SIGTERM path): after begin_shutdown() everything but the
// stops is refused with SHUTTING_DOWN; an EmergencyStop is executed on the card, latched and —
// after seal_state() — on disk with the clean-shutdown mark.
TEST_F(EnginePersistence, DuringTheShutdownOnlyStopsAreExecutedAndAnEmergencyStopIsKept) {
  start();
  walk_to(ProcedureState::kAwaitingPlane);
  engine->begin_shutdown();
  expect_refused(send(plane_at_yaw(0.1)), ErrorCode::kShuttingDown);
  expect_refused(send(protocol::Reset{}), ErrorCode::kShuttingDown);
  expect_refused(send(protocol::Drive{0.1, 0}), ErrorCode::kShuttingDown);
  expect_ack(send(protocol::Stop{}), ProcedureState::kAwaitingPlane);
  const auto estops = card->calls(drivers::CardCall::kEmergencyStop);
  expect_ack(send(protocol::EmergencyStop{}), ProcedureState::kFault);
  ASSERT_TRUE(wait_for([&] { return card->calls(drivers::CardCall::kEmergencyStop) > estops; }));
  ASSERT_TRUE(engine->wheels_at_rest());
  engine->seal_state();
  ASSERT_TRUE(
      wait_for([&] { return engine->settled_generation() >= engine->accepted_generation(); }));
  const daemon::StateRecord on_disk = decoded(read_file(state_file()));
  EXPECT_TRUE(on_disk.clean_shutdown);
  EXPECT_EQ(on_disk.procedure.fault, ErrorCode::kEmergencyStopped);
  restart();
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kEmergencyStopped);
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
