#include "daemon/parallaxd/daemon_state.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/check.h"

namespace parallax::daemon {

std::string_view daemonStateName(DaemonState state) {
  switch (state) {
    case DaemonState::kStarting:
      return "starting";
    case DaemonState::kCalibrating:
      return "calibrating";
    case DaemonState::kRegenerating:
      return "regenerating";
    case DaemonState::kLoading:
      return "loading";
    case DaemonState::kPlaying:
      return "playing";
    case DaemonState::kPaused:
      return "paused";
    case DaemonState::kError:
      return "error";
    case DaemonState::kStopping:
      return "stopping";
  }
  return "unknown";
}

// Every transition the daemon makes, and only those (rows: from, columns: to). Staying in a
// resting state is a transition too (a failed reload keeps `playing`); a working state
// (calibrating, regenerating, loading) is entered once per stage and always left.
//   - A stage (calibrate, regenerate, load) starts from start-up or from a resting state.
//   - A calibration regenerates the textures of its fit before it installs it.
//   - A stage ends in the state it came from (`starting` during start-up, else what the
//     modules show: playing, paused, or error when there is nothing to show).
//   - A scene that loaded plays (or stays paused); start-up ends playing or in error.
//   - Anything may fail into error and may stop; nothing leaves stopping.
namespace {
constexpr int kStates = 8;
static_assert(static_cast<int>(DaemonState::kStopping) == kStates - 1, "one row per state");
constexpr bool kAllowed[kStates][kStates] = {
    // to: start  calib  regen  load   play   pause  error  stop
    {true, true, true, true, false, false, true, true},       // from starting
    {true, false, true, false, true, true, true, true},       // from calibrating
    {true, false, false, false, true, true, true, true},      // from regenerating
    {true, false, false, false, true, true, true, true},      // from loading
    {false, true, true, true, true, true, true, true},        // from playing
    {false, true, true, true, true, true, true, true},        // from paused
    {false, true, true, true, true, true, true, true},        // from error
    {false, false, false, false, false, false, false, true},  // from stopping
};
}  // namespace

bool StateMachine::legal(DaemonState from, DaemonState to) {
  return kAllowed[static_cast<int>(from)][static_cast<int>(to)];
}

void StateMachine::moveTo(DaemonState next) {
  // A bug in the conductor, not a user error: CHECK-style, naming both states.
  if (!legal(state_, next)) {
    throw InternalError(fmt::format("check failed: illegal daemon transition {} -> {}",
                                    daemonStateName(state_), daemonStateName(next)));
  }
  if (next != state_)
    spdlog::info("state: {} -> {}", daemonStateName(state_), daemonStateName(next));
  state_ = next;
  since_ = std::chrono::steady_clock::now();
}

void StateMachine::enter(DaemonState next, std::string stage) {
  std::lock_guard lock(mutex_);
  moveTo(next);
  stage_ = std::move(stage);
}

void StateMachine::setStage(std::string stage) {
  std::lock_guard lock(mutex_);
  stage_ = std::move(stage);
}

void StateMachine::fail(const std::string& stage, const std::string& error, DaemonState fallback) {
  std::lock_guard lock(mutex_);
  spdlog::error("{} failed: {} (now {})", stage, error, daemonStateName(fallback));
  moveTo(fallback);
  lastError_ = error;
  lastErrorStage_ = stage;
  stage_.clear();
}

void StateMachine::succeeded(const std::string& stage) {
  std::lock_guard lock(mutex_);
  if (lastError_.empty() || lastErrorStage_ != stage) return;
  spdlog::info("{}: works again (was: {})", stage, lastError_);
  lastError_.clear();
  lastErrorStage_.clear();
}

DaemonState StateMachine::state() const {
  std::lock_guard lock(mutex_);
  return state_;
}

StateSnapshot StateMachine::snapshot() const {
  std::lock_guard lock(mutex_);
  StateSnapshot s;
  s.state = state_;
  s.stage = stage_;
  s.lastError = lastError_;
  s.lastErrorStage = lastErrorStage_;
  s.secondsInState =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - since_).count();
  return s;
}

}  // namespace parallax::daemon
