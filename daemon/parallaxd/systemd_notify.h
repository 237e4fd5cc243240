#pragma once
// parallaxd's side of the systemd service protocol, through libsystemd's sd_notify (sd_notify(3)):
// READY=1 once the start-up stages have finished, RELOADING=1 (with MONOTONIC_USEC) ... READY=1
// around a reload, STOPPING=1, STATUS= with the state and stage (what `systemctl status`
// shows), WATCHDOG=1 at half of WatchdogSec. Outside systemd ($NOTIFY_SOCKET unset) every call
// is a no-op.

#include <chrono>
#include <mutex>
#include <optional>
#include <string>

#include "daemon/parallaxd/daemon_state.h"

namespace parallax::daemon {

class SystemdNotifier {
 public:
  SystemdNotifier();  // reads the environment once
  bool enabled() const { return enabled_; }
  // False when the message could not be sent (logged as a warning).
  bool notify(const std::string& state) const;
  bool ready() const { return notify("READY=1"); }
  // RELOADING=1 with the monotonic time it began (systemd 253 and later want both).
  bool reloading() const;
  bool stopping() const { return notify("STOPPING=1"); }
  // STATUS=text, sent only when it differs from the last one sent (callers poll the state).
  void status(const std::string& text);
  // Sends WATCHDOG=1 when half the interval has passed since the last one; cheap otherwise.
  void watchdog();
  std::optional<std::chrono::microseconds> watchdogInterval() const { return watchdogInterval_; }

 private:
  bool enabled_ = false;
  std::optional<std::chrono::microseconds> watchdogInterval_;
  std::mutex mutex_;  // the watchdog and status are fed from the conductor and the supervisor
  std::chrono::steady_clock::time_point lastWatchdog_;
  std::string lastStatus_;
};

// The STATUS= line for a state: "playing", "calibrating: pictures: 2 of 8",
// "error: loading the scene: <why>". One line: `systemctl status` shows the first only.
std::string serviceStatusOf(const StateSnapshot& state);

}  // namespace parallax::daemon
