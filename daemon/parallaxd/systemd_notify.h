#pragma once
// The sd_notify protocol, written out: a datagram "READY=1", "WATCHDOG=1", "STOPPING=1" or
// "STATUS=..." to the Unix socket named by $NOTIFY_SOCKET (a leading '@' is the abstract
// namespace). Ten lines of socket code instead of a libsystemd dependency for three messages;
// outside systemd ($NOTIFY_SOCKET unset) every call is a no-op. The watchdog interval comes
// from $WATCHDOG_USEC (only when $WATCHDOG_PID is unset or ours); ping at half of it.

#include <chrono>
#include <optional>
#include <string>

namespace parallax::daemon {

class SystemdNotifier {
 public:
  SystemdNotifier();  // reads the environment once
  bool enabled() const { return !socketPath_.empty(); }
  // False when the datagram could not be sent (logged once per kind of failure).
  bool notify(const std::string& state) const;
  bool ready() const { return notify("READY=1"); }
  bool stopping() const { return notify("STOPPING=1"); }
  bool status(const std::string& text) const { return notify("STATUS=" + text); }
  // Sends WATCHDOG=1 when half the interval has passed since the last one; cheap otherwise.
  void watchdog();
  std::optional<std::chrono::microseconds> watchdogInterval() const { return watchdogInterval_; }

 private:
  std::string socketPath_;
  std::optional<std::chrono::microseconds> watchdogInterval_;
  std::chrono::steady_clock::time_point lastWatchdog_;
};

}  // namespace parallax::daemon
