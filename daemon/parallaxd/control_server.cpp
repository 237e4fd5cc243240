#include "daemon/parallaxd/control_server.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <poll.h>
#include <spdlog/spdlog.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include "common/input_error.h"

namespace parallax::daemon {
namespace {

sockaddr_un addressOf(const std::string& path) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.size() >= sizeof addr.sun_path)
    throw std::runtime_error("control socket path too long: " + path);
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  return addr;
}

bool someoneListens(const std::string& path) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  const sockaddr_un addr = addressOf(path);
  const bool up = ::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0;
  ::close(fd);
  return up;
}

bool writeAll(int fd, const std::string& text) {
  size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::send(fd, text.data() + done, text.size() - done, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<size_t>(n);
  }
  return true;
}

nlohmann::json errorReply(const std::string& why) { return {{"ok", false}, {"error", why}}; }

}  // namespace

ControlServer::ControlServer(std::string path, Handler handler, ControlServerLimits limits)
    : path_(std::move(path)), handler_(std::move(handler)), limits_(limits) {
  namespace fs = std::filesystem;
  const fs::path folder = fs::path(path_).parent_path();
  if (!folder.empty() && !fs::exists(folder)) {
    std::error_code ec;
    fs::create_directories(folder, ec);
    if (ec)
      throw std::runtime_error(fmt::format("cannot create {}: {}", folder.string(), ec.message()));
    ::chmod(folder.c_str(), 0700);
  }
  if (fs::exists(fs::symlink_status(path_))) {
    if (someoneListens(path_))
      throw std::runtime_error("another daemon already answers on " + path_);
    fs::remove(path_);  // stale: its daemon is gone
  }
  listenFd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (listenFd_ < 0) throw std::runtime_error(std::string("socket: ") + std::strerror(errno));
  const sockaddr_un addr = addressOf(path_);
  // The umask makes the file 0600 from the moment it exists: no window in which another user
  // could connect before a chmod.
  const mode_t oldMask = ::umask(0177);
  const int bound = ::bind(listenFd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr);
  const int bindErrno = errno;
  ::umask(oldMask);
  if (bound != 0 || ::listen(listenFd_, 64) != 0) {
    const std::string why = std::strerror(bound != 0 ? bindErrno : errno);
    ::close(listenFd_);
    throw std::runtime_error(fmt::format("cannot listen on {}: {}", path_, why));
  }
  ::chmod(path_.c_str(), 0600);
  if (::pipe2(wakePipe_, O_CLOEXEC) != 0) throw std::runtime_error("pipe2 failed");
  acceptThread_ = std::thread([this] { acceptLoop(); });
  spdlog::info("control socket: {}", path_);
}

ControlServer::~ControlServer() {
  stopping_ = true;
  const char byte = 'x';
  [[maybe_unused]] const ssize_t n = ::write(wakePipe_[1], &byte, 1);
  if (acceptThread_.joinable()) acceptThread_.join();
  {
    std::lock_guard lock(connectionsMutex_);
    for (auto& c : connections_) {
      if (c->fd >= 0) ::shutdown(c->fd, SHUT_RDWR);  // wakes their poll()
    }
  }
  for (auto& c : connections_) c->thread.join();
  ::close(listenFd_);
  ::close(wakePipe_[0]);
  ::close(wakePipe_[1]);
  std::error_code ec;
  std::filesystem::remove(path_, ec);
}

void ControlServer::acceptLoop() {
  while (!stopping_.load()) {
    pollfd fds[2] = {{listenFd_, POLLIN, 0}, {wakePipe_[0], POLLIN, 0}};
    if (::poll(fds, 2, -1) < 0) {
      if (errno == EINTR) continue;
      spdlog::error("control socket: poll: {}", std::strerror(errno));
      return;
    }
    if (fds[1].revents) return;
    if (!(fds[0].revents & POLLIN)) continue;
    const int fd = ::accept4(listenFd_, nullptr, nullptr, SOCK_CLOEXEC);
    if (fd < 0) continue;
    ucred peer{};
    socklen_t peerSize = sizeof peer;
    ::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &peer, &peerSize);
    // A client that stops reading its replies cannot hold a thread for ever.
    const timeval sendTimeout{10, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &sendTimeout, sizeof sendTimeout);

    std::lock_guard lock(connectionsMutex_);
    reapFinishedClients();
    int total = 0, fromPeer = 0;
    for (const auto& c : connections_) {
      if (c->evicted || c->done.load()) continue;
      ++total;
      if (c->peer == peer.pid) ++fromPeer;
    }
    const bool room = (fromPeer < limits_.maxPerClient || evictIdle(peer.pid)) &&
                      (total < limits_.maxConnections || evictIdle(std::nullopt));
    if (!room) {
      writeAll(fd, errorReply(fmt::format("too many clients busy with requests (at most {}, {} "
                                          "from one process)",
                                          limits_.maxConnections, limits_.maxPerClient))
                           .dump() +
                       "\n");
      ::close(fd);
      continue;
    }
    auto connection = std::make_unique<Connection>();
    connection->fd = fd;
    connection->peer = peer.pid;
    connection->lastByte = Clock::now();
    Connection& c = *connection;
    connections_.push_back(std::move(connection));
    c.thread = std::thread([this, &c] {
      serveClient(c);
      c.done = true;
    });
  }
}

bool ControlServer::evictIdle(std::optional<pid_t> peer) {
  Connection* victim = nullptr;
  for (auto& c : connections_) {
    if (c->evicted || c->done.load() || c->inRequest || c->fd < 0) continue;
    if (peer && c->peer != *peer) continue;
    // Bytes waiting that its thread has not read yet: a request on its way, not idleness.
    int waiting = 0;
    if (::ioctl(c->fd, FIONREAD, &waiting) == 0 && waiting > 0) continue;
    if (!victim || c->lastByte < victim->lastByte) victim = c.get();
  }
  if (!victim) return false;
  victim->evicted = true;
  // Never blocks (a client that reads nothing must not stall the accept thread).
  const std::string notice =
      errorReply("closed: a new client needed the place of this idle one").dump() + "\n";
  [[maybe_unused]] const ssize_t sent =
      ::send(victim->fd, notice.data(), notice.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  ::shutdown(victim->fd, SHUT_RDWR);  // its thread sees the end and closes it
  return true;
}

void ControlServer::reapFinishedClients() {
  for (auto it = connections_.begin(); it != connections_.end();) {
    if ((*it)->done.load()) {
      (*it)->thread.join();
      it = connections_.erase(it);
    } else {
      ++it;
    }
  }
}

std::string ControlServer::replyTo(const std::string& line, const Handler& handler) {
  nlohmann::json reply;
  nlohmann::json request = nlohmann::json::parse(line, nullptr, /*allow_exceptions=*/false);
  if (request.is_discarded()) {
    reply = errorReply(
        "malformed request: not JSON (one JSON object a line, e.g. {\"request\": \"status\"})");
  } else if (!request.is_object() || !request.contains("request") ||
             !request["request"].is_string()) {
    reply = errorReply("malformed request: expected an object with a string \"request\"");
  } else {
    try {
      reply = handler(request);
    } catch (const std::exception& e) {
      reply = errorReply(e.what());
    }
  }
  // Replies may quote user input (a bad scene path); never let invalid UTF-8 break the line.
  return reply.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

void ControlServer::serveClient(Connection& c) {
  const int fd = c.fd;
  std::string buffer;
  bool discarding = false;  // inside an oversized line: drop bytes up to its newline
  Clock::time_point lineBegan{};
  char chunk[4096];
  std::string closing;  // why the server ends the connection (sent to the client)
  while (!stopping_.load()) {
    // Wait for bytes until the idle deadline, or the unfinished line's deadline.
    Clock::time_point deadline;
    {
      std::lock_guard lock(connectionsMutex_);
      if (c.evicted) break;
      deadline = buffer.empty() && !discarding ? c.lastByte + limits_.idleTimeout
                                               : lineBegan + limits_.partialLineTimeout;
    }
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) {
      closing = buffer.empty() && !discarding
                    ? fmt::format("closed: idle for {} s", limits_.idleTimeout.count() / 1000.0)
                    : fmt::format("closed: a request line unfinished after {} s",
                                  limits_.partialLineTimeout.count() / 1000.0);
      break;
    }
    pollfd p{fd, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(std::min<long long>(left, 1000)));
    if (ready < 0 && errno == EINTR) continue;
    if (ready < 0) break;
    if (ready == 0) continue;
    const ssize_t n = ::recv(fd, chunk, sizeof chunk, 0);
    if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
    if (n <= 0) break;
    {
      // A chunk with a complete line is a request: from here until its reply is written the
      // connection is not idle and keeps its place.
      std::lock_guard lock(connectionsMutex_);
      if (c.evicted) break;
      c.lastByte = Clock::now();
      c.inRequest = std::memchr(chunk, '\n', static_cast<size_t>(n)) != nullptr;
    }
    bool alive = true;
    for (ssize_t i = 0; i < n && alive; ++i) {
      const char ch = chunk[i];
      if (ch == '\n') {
        if (!discarding && !buffer.empty() && buffer != "\r")
          alive = writeAll(fd, replyTo(buffer, handler_));
        buffer.clear();
        discarding = false;
      } else if (!discarding) {
        if (buffer.empty()) lineBegan = Clock::now();
        buffer.push_back(ch);
        if (buffer.size() > kMaxRequestBytes) {
          alive = writeAll(
              fd, errorReply(fmt::format("request too large (over {} bytes)", kMaxRequestBytes))
                          .dump() +
                      "\n");
          buffer.clear();
          discarding = true;
        }
      }
    }
    {
      std::lock_guard lock(connectionsMutex_);
      c.inRequest = false;
      c.lastByte = Clock::now();  // idle from the reply on, not from the request
    }
    if (!alive) break;
  }
  if (!closing.empty()) writeAll(fd, errorReply(closing).dump() + "\n");
  std::lock_guard lock(connectionsMutex_);
  ::close(fd);
  c.fd = -1;
}

}  // namespace parallax::daemon
