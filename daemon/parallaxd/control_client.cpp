#include "daemon/parallaxd/control_client.h"

#include <fmt/format.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "common/input_error.h"
#include "common/private_folder.h"

namespace parallax::daemon {

std::string exchangeControlLine(const std::string& socketPath, const std::string& line,
                                double timeoutSeconds) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (socketPath.size() >= sizeof addr.sun_path)
    throw InputError({"", "socket", 0}, "path too long");
  std::memcpy(addr.sun_path, socketPath.c_str(), socketPath.size() + 1);
  // Never talk to a socket another user could have put there (common/private_folder.h).
  checkSocketToConnect(socketPath);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error(std::string("socket: ") + std::strerror(errno));
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd);
    throw ControlUnreachable(
        fmt::format("no daemon at {} ({}): is parallaxd running?", socketPath, why));
  }
  const std::string out = line + "\n";
  if (::send(fd, out.data(), out.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(out.size())) {
    ::close(fd);
    throw std::runtime_error("the daemon closed the connection");
  }
  std::string reply;
  char buffer[4096];
  while (reply.find('\n') == std::string::npos) {
    pollfd p{fd, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(timeoutSeconds * 1000.0));
    if (ready < 0 && errno == EINTR) continue;
    if (ready == 0) {
      ::close(fd);
      throw std::runtime_error(fmt::format("no reply within {} s", timeoutSeconds));
    }
    const ssize_t n = ::recv(fd, buffer, sizeof buffer, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    reply.append(buffer, static_cast<size_t>(n));
  }
  ::close(fd);
  if (reply.empty()) throw std::runtime_error("the daemon closed the connection without a reply");
  return reply.substr(0, reply.find('\n'));
}

nlohmann::json askDaemon(const std::string& socketPath, const nlohmann::json& request,
                         double timeoutSeconds) {
  return nlohmann::json::parse(exchangeControlLine(socketPath, request.dump(), timeoutSeconds),
                               nullptr, false);
}

std::optional<nlohmann::json> tryAskDaemon(const std::string& socketPath,
                                           const nlohmann::json& request, double timeoutSeconds) {
  try {
    return askDaemon(socketPath, request, timeoutSeconds);
  } catch (const std::runtime_error&) {
    return std::nullopt;
  }
}

}  // namespace parallax::daemon
