#pragma once
// The control socket: a Unix stream socket, mode 0600 (only the daemon's user may steer the
// display), speaking line-delimited JSON — one request object a line, one reply object a
// line. Each client is served by its own thread, so a slow `calibrate` on one connection does
// not hold up `status` on another. A line longer than kMaxRequestBytes or one that is not a
// JSON object gets an error reply; the connection and the daemon go on.
//
// Connections that hold a place without using it cannot lock anyone out: a connection idle
// for idleTimeout, or with a line begun and not finished within partialLineTimeout, is closed
// (with a reply saying why); and a newcomer beyond the per-client (same process) or total
// limit takes the place of the longest-idle connection that is not inside a request. Only
// when every place is inside a request is a newcomer refused.

#include <sys/types.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>

namespace parallax::daemon {

struct ControlServerLimits {
  int maxConnections = 64;                               // all clients together
  int maxPerClient = 16;                                 // from one process (the peer's pid)
  std::chrono::milliseconds idleTimeout{60'000};         // no byte received (outside a request)
  std::chrono::milliseconds partialLineTimeout{10'000};  // from a line's first byte to its end
};

class ControlServer {
 public:
  static constexpr size_t kMaxRequestBytes = 64 * 1024;
  using Handler = std::function<nlohmann::json(const nlohmann::json&)>;

  // Creates the socket's folder (0700) when missing, refuses to take over a socket another
  // daemon answers on, replaces a stale one. Throws std::runtime_error with the reason.
  ControlServer(std::string path, Handler handler, ControlServerLimits limits = {});
  // Stops accepting, closes every client, removes the socket file.
  ~ControlServer();
  ControlServer(const ControlServer&) = delete;
  ControlServer& operator=(const ControlServer&) = delete;

  const std::string& path() const { return path_; }

  // One reply line for one request line (exposed for tests and the fuzz target).
  static std::string replyTo(const std::string& line, const Handler& handler);

 private:
  using Clock = std::chrono::steady_clock;
  struct Connection {
    int fd = -1;
    pid_t peer = 0;
    Clock::time_point lastByte;  // guarded by connectionsMutex_, as are the flags
    bool inRequest = false;      // a handler runs for it: never evicted
    bool evicted = false;        // its place was given to a newcomer; its thread ends
    std::atomic<bool> done{false};
    std::thread thread;
  };

  void acceptLoop();
  void serveClient(Connection& c);
  // connectionsMutex_ held: closes the longest-idle connection not inside a request (of
  // `peer` only, when given) to make a place; false when there is none.
  bool evictIdle(std::optional<pid_t> peer);
  void reapFinishedClients();  // connectionsMutex_ held

  std::string path_;
  Handler handler_;
  ControlServerLimits limits_;
  int listenFd_ = -1;
  int wakePipe_[2] = {-1, -1};
  std::atomic<bool> stopping_{false};
  std::mutex connectionsMutex_;
  std::list<std::unique_ptr<Connection>> connections_;  // finished ones reaped at each accept
  std::thread acceptThread_;
};

}  // namespace parallax::daemon
