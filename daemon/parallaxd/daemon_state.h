#pragma once
// The daemon's state machine (issue 8): start → calibrate (no valid calibration, or asked) →
// regenerate the ray textures → load the scene → play ⇄ pause. A stage that fails keeps the
// last good calibration, textures and scene and puts the machine in `error` with the reason,
// or back in the state it came from when there is still something good to show (a bad scene
// pushed over the control socket leaves the old one playing). Thread-safe: the control thread
// reads it for `status` while the conductor thread runs the stages.

#include <chrono>
#include <mutex>
#include <string>
#include <string_view>

namespace parallax::daemon {

enum class DaemonState {
  kStarting,
  kCalibrating,
  kRegenerating,
  kLoading,
  kPlaying,
  kPaused,
  kError,
  kStopping
};

std::string_view daemonStateName(DaemonState state);

struct StateSnapshot {
  DaemonState state = DaemonState::kStarting;
  std::string stage;      // what the current state is doing ("module 3 of 16")
  std::string lastError;  // the most recent failure, until the next one or its stage works
  std::string lastErrorStage;
  double secondsInState = 0.0;
};

class StateMachine {
 public:
  // Moves to `next` if the transition table (daemon_state.cpp) allows it; an illegal one is a
  // bug in the caller: InternalError naming both states, and the state does not change.
  void enter(DaemonState next, std::string stage = {});
  void setStage(std::string stage);
  // Records a stage failure; the state goes to `fallback` (the last good one, or kError),
  // through the same table as enter().
  void fail(const std::string& stage, const std::string& error, DaemonState fallback);
  // `stage` has now worked: its failure, if it is the one last_error holds, is over (status
  // then says what is wrong now, not what was wrong before a later success).
  void succeeded(const std::string& stage);
  DaemonState state() const;
  StateSnapshot snapshot() const;

  static bool legal(DaemonState from, DaemonState to);

 private:
  void moveTo(DaemonState next);  // mutex_ held

  mutable std::mutex mutex_;
  DaemonState state_ = DaemonState::kStarting;
  std::string stage_;
  std::string lastError_, lastErrorStage_;
  std::chrono::steady_clock::time_point since_ = std::chrono::steady_clock::now();
};

}  // namespace parallax::daemon
