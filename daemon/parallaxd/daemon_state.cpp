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

bool StateMachine::legal(DaemonState from, DaemonState to) {
  using S = DaemonState;
  if (to == S::kStopping || to == S::kError || from == to) return true;
  switch (to) {
    case S::kStarting:
      return from != S::kStopping;  // back after a start-up stage
    // Calibrating needs the link, which every state but stopping has.
    case S::kCalibrating:
      return from != S::kStopping;
    // New textures follow a new calibration (or start-up, or a rollback).
    case S::kRegenerating:
      return from != S::kStopping;
    // A scene loads after textures exist or when asked for while showing something.
    case S::kLoading:
      return from != S::kStopping && from != S::kStarting;
    case S::kPlaying:
    case S::kPaused:
      return from != S::kStopping && from != S::kStarting;
    default:
      return false;
  }
}

void StateMachine::enter(DaemonState next, std::string stage) {
  std::lock_guard lock(mutex_);
  if (!legal(state_, next)) {
    throw InternalError(fmt::format("illegal daemon transition {} -> {}", daemonStateName(state_),
                                    daemonStateName(next)));
  }
  if (next != state_)
    spdlog::info("state: {} -> {}", daemonStateName(state_), daemonStateName(next));
  state_ = next;
  stage_ = std::move(stage);
  since_ = std::chrono::steady_clock::now();
}

void StateMachine::setStage(std::string stage) {
  std::lock_guard lock(mutex_);
  stage_ = std::move(stage);
}

void StateMachine::fail(const std::string& stage, const std::string& error, DaemonState fallback) {
  std::lock_guard lock(mutex_);
  spdlog::error("{} failed: {} (now {})", stage, error, daemonStateName(fallback));
  lastError_ = error;
  lastErrorStage_ = stage;
  state_ = fallback;
  stage_.clear();
  since_ = std::chrono::steady_clock::now();
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
