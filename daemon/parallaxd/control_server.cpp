#include "daemon/parallaxd/control_server.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <poll.h>
#include <spdlog/spdlog.h>
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

ControlServer::ControlServer(std::string path, Handler handler)
    : path_(std::move(path)), handler_(std::move(handler)) {
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
  if (bound != 0 || ::listen(listenFd_, 16) != 0) {
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
    std::lock_guard lock(clientsMutex_);
    for (int fd : clientFds_) ::shutdown(fd, SHUT_RDWR);  // wakes their recv()
  }
  for (Client& c : clientThreads_) c.thread.join();
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
    if (clients_.load() >= kMaxClients) {
      writeAll(fd,
               errorReply(fmt::format("too many clients (at most {})", kMaxClients)).dump() + "\n");
      ::close(fd);
      continue;
    }
    reapFinishedClients();
    ++clients_;
    auto done = std::make_shared<std::atomic<bool>>(false);
    std::lock_guard lock(clientsMutex_);
    clientFds_.push_back(fd);
    clientThreads_.push_back({std::thread([this, fd, done] {
                                serveClient(fd);
                                *done = true;
                              }),
                              done});
  }
}

void ControlServer::reapFinishedClients() {
  for (auto it = clientThreads_.begin(); it != clientThreads_.end();) {
    if (it->done->load()) {
      it->thread.join();
      it = clientThreads_.erase(it);
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

void ControlServer::serveClient(int fd) {
  std::string buffer;
  bool discarding = false;  // inside an oversized line: drop bytes up to its newline
  char chunk[4096];
  while (!stopping_.load()) {
    const ssize_t n = ::recv(fd, chunk, sizeof chunk, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    bool alive = true;
    for (ssize_t i = 0; i < n && alive; ++i) {
      const char c = chunk[i];
      if (c == '\n') {
        if (!discarding && !buffer.empty() && buffer != "\r")
          alive = writeAll(fd, replyTo(buffer, handler_));
        buffer.clear();
        discarding = false;
      } else if (!discarding) {
        buffer.push_back(c);
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
    if (!alive) break;
  }
  {
    std::lock_guard lock(clientsMutex_);
    clientFds_.remove(fd);
  }
  ::close(fd);
  --clients_;
}

}  // namespace parallax::daemon
