#include "daemon/parallaxd/systemd_notify.h"

#include <spdlog/spdlog.h>
#include <systemd/sd-daemon.h>
#include <time.h>

#include <cstdlib>
#include <cstring>

namespace parallax::daemon {

SystemdNotifier::SystemdNotifier() {
  const char* socket = std::getenv("NOTIFY_SOCKET");
  enabled_ = socket && *socket;
  // Only when $WATCHDOG_PID is unset or ours: a child must not feed its parent's watchdog.
  uint64_t usec = 0;
  if (sd_watchdog_enabled(0, &usec) > 0 && usec > 0)
    watchdogInterval_ = std::chrono::microseconds(usec);
  lastWatchdog_ = std::chrono::steady_clock::now();
}

bool SystemdNotifier::notify(const std::string& state) const {
  if (!enabled_) return false;
  const int sent = sd_notify(0, state.c_str());
  if (sent <= 0) {
    spdlog::warn("sd_notify: cannot send \"{}\": {}", state,
                 sent < 0 ? std::strerror(-sent) : "no $NOTIFY_SOCKET");
    return false;
  }
  return true;
}

bool SystemdNotifier::reloading() const {
  timespec now{};
  ::clock_gettime(CLOCK_MONOTONIC, &now);
  const long long usec = static_cast<long long>(now.tv_sec) * 1'000'000 + now.tv_nsec / 1000;
  return notify("RELOADING=1\nMONOTONIC_USEC=" + std::to_string(usec));
}

void SystemdNotifier::status(const std::string& text) {
  if (!enabled_) return;
  std::lock_guard lock(mutex_);
  if (text == lastStatus_) return;
  if (notify("STATUS=" + text)) lastStatus_ = text;
}

void SystemdNotifier::watchdog() {
  if (!watchdogInterval_ || !enabled_) return;
  {
    std::lock_guard lock(mutex_);
    const auto now = std::chrono::steady_clock::now();
    if (now - lastWatchdog_ < *watchdogInterval_ / 2) return;
    lastWatchdog_ = now;
  }
  notify("WATCHDOG=1");
}

std::string serviceStatusOf(const StateSnapshot& state) {
  std::string line(daemonStateName(state.state));
  if (state.state == DaemonState::kError && !state.lastError.empty()) {
    line += ": " + (state.lastErrorStage.empty() ? state.lastError
                                                 : state.lastErrorStage + ": " + state.lastError);
  } else if (!state.stage.empty()) {
    line += ": " + state.stage;
  }
  for (char& c : line)
    if (c == '\n' || c == '\r') c = ' ';
  return line;
}

}  // namespace parallax::daemon
