// The daemon's state machine: every change goes through one transition table, fail() included;
// a transition the table does not hold is a bug in the conductor, reported (InternalError
// naming both states) without changing the state.

#include "daemon/parallaxd/daemon_state.h"

#include <gtest/gtest.h>

#include "common/check.h"

namespace parallax::daemon {
namespace {

using S = DaemonState;

TEST(DaemonState, TheStagesOfAStartAndARecalibrationAreLegal) {
  StateMachine m;
  for (S s :
       {S::kCalibrating, S::kRegenerating, S::kStarting, S::kLoading, S::kPlaying, S::kPaused,
        S::kCalibrating, S::kRegenerating, S::kPaused, S::kLoading, S::kPlaying, S::kStopping}) {
    ASSERT_NO_THROW(m.enter(s)) << daemonStateName(s);
    EXPECT_EQ(m.state(), s);
  }
}

TEST(DaemonState, AnIllegalTransitionIsABugReportAndChangesNothing) {
  StateMachine m;  // starting: nothing plays before a scene has loaded
  try {
    m.enter(S::kPlaying);
    FAIL() << "starting -> playing accepted";
  } catch (const InternalError& e) {
    EXPECT_NE(std::string(e.what()).find("starting -> playing"), std::string::npos) << e.what();
  }
  EXPECT_EQ(m.state(), S::kStarting);
  m.enter(S::kLoading);
  EXPECT_THROW(m.enter(S::kCalibrating), InternalError);  // a stage inside a stage
  EXPECT_EQ(m.state(), S::kLoading);
}

TEST(DaemonState, FailGoesThroughTheTableToo) {
  StateMachine m;
  m.enter(S::kStopping);
  EXPECT_THROW(m.fail("loading the scene", "boom", S::kPlaying), InternalError);
  EXPECT_EQ(m.state(), S::kStopping);
  EXPECT_TRUE(m.snapshot().lastError.empty());  // a refused fail() records nothing

  StateMachine n;
  n.enter(S::kCalibrating);
  n.fail("calibrating", "no camera", S::kStarting);
  EXPECT_EQ(n.state(), S::kStarting);
  EXPECT_EQ(n.snapshot().lastError, "no camera");
  EXPECT_EQ(n.snapshot().lastErrorStage, "calibrating");
}

TEST(DaemonState, ALaterSuccessOfTheFailedStageClearsTheErrorAnotherDoesNot) {
  StateMachine m;
  m.enter(S::kLoading);
  m.fail("loading the scene", "no such scene", S::kError);
  m.succeeded("regenerating the ray textures");
  EXPECT_EQ(m.snapshot().lastError, "no such scene");  // another stage's success: still wrong
  m.succeeded("loading the scene");
  EXPECT_TRUE(m.snapshot().lastError.empty());
  EXPECT_TRUE(m.snapshot().lastErrorStage.empty());
}

TEST(DaemonState, NothingLeavesStoppingAndEveryOtherStateMayFailOrStop) {
  const S all[] = {S::kStarting, S::kCalibrating, S::kRegenerating, S::kLoading,
                   S::kPlaying,  S::kPaused,      S::kError,        S::kStopping};
  for (S from : all) {
    EXPECT_TRUE(StateMachine::legal(from, S::kStopping)) << daemonStateName(from);
    if (from == S::kStopping) continue;
    EXPECT_TRUE(StateMachine::legal(from, S::kError)) << daemonStateName(from);
    EXPECT_FALSE(StateMachine::legal(S::kStopping, from)) << daemonStateName(from);
  }
  // A working state is left, never re-entered from itself.
  for (S working : {S::kCalibrating, S::kRegenerating, S::kLoading})
    EXPECT_FALSE(StateMachine::legal(working, working)) << daemonStateName(working);
}

}  // namespace
}  // namespace parallax::daemon
