#pragma once
// The control socket: a Unix stream socket, mode 0600 (only the daemon's user may steer the
// display), speaking line-delimited JSON — one request object a line, one reply object a
// line. Each client is served by its own thread (up to kMaxClients at once), so a slow
// `calibrate` on one connection does not hold up `status` on another. A line longer than
// kMaxRequestBytes or one that is not a JSON object gets an error reply; the connection and
// the daemon go on.

#include <atomic>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

namespace parallax::daemon {

class ControlServer {
 public:
  static constexpr size_t kMaxRequestBytes = 64 * 1024;
  static constexpr int kMaxClients = 16;
  using Handler = std::function<nlohmann::json(const nlohmann::json&)>;

  // Creates the socket's folder (0700) when missing, refuses to take over a socket another
  // daemon answers on, replaces a stale one. Throws std::runtime_error with the reason.
  ControlServer(std::string path, Handler handler);
  // Stops accepting, closes every client, removes the socket file.
  ~ControlServer();
  ControlServer(const ControlServer&) = delete;
  ControlServer& operator=(const ControlServer&) = delete;

  const std::string& path() const { return path_; }

  // One reply line for one request line (exposed for tests and the fuzz target).
  static std::string replyTo(const std::string& line, const Handler& handler);

 private:
  void acceptLoop();
  void serveClient(int fd);
  void reapFinishedClients();

  std::string path_;
  Handler handler_;
  int listenFd_ = -1;
  int wakePipe_[2] = {-1, -1};
  std::atomic<bool> stopping_{false};
  std::atomic<int> clients_{0};
  std::mutex clientsMutex_;
  std::list<int> clientFds_;
  struct Client {
    std::thread thread;
    std::shared_ptr<std::atomic<bool>> done;
  };
  std::list<Client> clientThreads_;  // finished ones are joined at the next accept
  std::thread acceptThread_;
};

}  // namespace parallax::daemon
