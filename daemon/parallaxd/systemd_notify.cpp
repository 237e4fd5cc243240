#include "daemon/parallaxd/systemd_notify.h"

#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>

namespace parallax::daemon {

SystemdNotifier::SystemdNotifier() {
  if (const char* path = std::getenv("NOTIFY_SOCKET");
      path && *path && std::strlen(path) < sizeof(sockaddr_un{}.sun_path)) {
    socketPath_ = path;
  }
  const char* usec = std::getenv("WATCHDOG_USEC");
  const char* pid = std::getenv("WATCHDOG_PID");
  if (usec && (!pid || std::strtoll(pid, nullptr, 10) == ::getpid())) {
    const long long us = std::strtoll(usec, nullptr, 10);
    if (us > 0) watchdogInterval_ = std::chrono::microseconds(us);
  }
  lastWatchdog_ = std::chrono::steady_clock::now();
}

bool SystemdNotifier::notify(const std::string& state) const {
  if (socketPath_.empty()) return false;
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, socketPath_.data(), socketPath_.size());
  if (addr.sun_path[0] == '@') addr.sun_path[0] = '\0';  // abstract namespace
  const socklen_t length =
      static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + socketPath_.size());
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  const ssize_t sent = ::sendto(fd, state.data(), state.size(), MSG_NOSIGNAL,
                                reinterpret_cast<const sockaddr*>(&addr), length);
  ::close(fd);
  if (sent != static_cast<ssize_t>(state.size())) {
    spdlog::warn("sd_notify: cannot send \"{}\" to {}", state, socketPath_);
    return false;
  }
  return true;
}

void SystemdNotifier::watchdog() {
  if (!watchdogInterval_ || socketPath_.empty()) return;
  const auto now = std::chrono::steady_clock::now();
  if (now - lastWatchdog_ < *watchdogInterval_ / 2) return;
  lastWatchdog_ = now;
  notify("WATCHDOG=1");
}

}  // namespace parallax::daemon
