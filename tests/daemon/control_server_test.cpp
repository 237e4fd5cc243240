// The control socket as clients see it: mode 0600, one JSON reply a line for every request
// line, error replies for malformed or oversized requests with the connection still usable,
// several clients at once, and a second daemon refused on a live socket.

#include "daemon/parallaxd/control_server.h"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <filesystem>
#include <thread>

namespace parallax::daemon {
namespace {

std::string tempSocket(const char* name) {
  const auto folder =
      std::filesystem::temp_directory_path() / ("plx-ctl-" + std::to_string(::getpid()));
  std::filesystem::create_directories(folder);
  return (folder / name).string();
}

class Client {
 public:
  explicit Client(const std::string& path) {
    fd_ = ::socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
  }
  ~Client() { ::close(fd_); }
  bool connected() const { return connected_; }
  void send(const std::string& bytes) {
    ASSERT_EQ(::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL),
              static_cast<ssize_t>(bytes.size()));
  }
  nlohmann::json reply() {
    while (buffer_.find('\n') == std::string::npos) {
      char chunk[4096];
      const ssize_t n = ::recv(fd_, chunk, sizeof chunk, 0);
      if (n <= 0) return nullptr;
      buffer_.append(chunk, static_cast<size_t>(n));
    }
    const std::string line = buffer_.substr(0, buffer_.find('\n'));
    buffer_.erase(0, line.size() + 1);
    return nlohmann::json::parse(line);
  }

 private:
  int fd_ = -1;
  bool connected_ = false;
  std::string buffer_;
};

// A handler that answers like the daemon's: echoes the request name, fails on "boom".
nlohmann::json echo(const nlohmann::json& r) {
  if (r["request"] == "boom") throw std::runtime_error("boom failed");
  if (r["request"] == "slow") std::this_thread::sleep_for(std::chrono::milliseconds(300));
  return {{"ok", true}, {"echo", r["request"]}};
}

TEST(ControlServer, SocketIsOnlyForItsUser) {
  const std::string path = tempSocket("mode.sock");
  ControlServer server(path, echo);
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_TRUE(S_ISSOCK(st.st_mode));
  EXPECT_EQ(st.st_mode & 0777, 0600u);
}

TEST(ControlServer, AnswersGoodBadAndOversizedRequestsAndGoesOn) {
  const std::string path = tempSocket("requests.sock");
  ControlServer server(path, echo);
  Client c(path);
  ASSERT_TRUE(c.connected());
  c.send("{\"request\": \"status\"}\n");
  nlohmann::json r = c.reply();
  EXPECT_EQ(r["ok"], true);
  EXPECT_EQ(r["echo"], "status");

  for (const std::string bad : {"not json\n", "[1, 2]\n", "{\"request\": 5}\n",
                                "{\"cmd\": \"status\"}\n", "{\"request\": \"boom\"}\n"}) {
    c.send(bad);
    r = c.reply();
    ASSERT_TRUE(r.is_object()) << bad;
    EXPECT_EQ(r["ok"], false) << bad;
    EXPECT_FALSE(r["error"].get<std::string>().empty()) << bad;
  }
  // Oversized: one error reply, the rest of that line is skipped, the next line is served.
  c.send(std::string(ControlServer::kMaxRequestBytes + 10, 'x') + "\n{\"request\": \"after\"}\n");
  r = c.reply();
  EXPECT_EQ(r["ok"], false);
  EXPECT_NE(r["error"].get<std::string>().find("too large"), std::string::npos);
  r = c.reply();
  EXPECT_EQ(r["echo"], "after");
  // Invalid UTF-8 in a request still gets a well-formed reply line.
  c.send("{\"request\": \"\xff\xfe\"}\n");
  EXPECT_TRUE(c.reply().is_object());
}

TEST(ControlServer, ServesSeveralClientsAtOnce) {
  const std::string path = tempSocket("many.sock");
  ControlServer server(path, echo);
  // A slow request on one connection does not hold up the others.
  Client slow(path);
  slow.send("{\"request\": \"slow\"}\n");
  std::vector<std::thread> threads;
  std::atomic<int> answered{0};
  for (int i = 0; i < 8; ++i) {
    threads.emplace_back([&, i] {
      Client c(path);
      for (int k = 0; k < 20; ++k) {
        c.send("{\"request\": \"r" + std::to_string(i) + "\"}\n");
        if (c.reply()["echo"] == "r" + std::to_string(i)) ++answered;
      }
    });
  }
  for (std::thread& t : threads) t.join();
  EXPECT_EQ(answered.load(), 160);
  EXPECT_EQ(slow.reply()["echo"], "slow");
}

TEST(ControlServer, RefusesALiveSocketAndReplacesAStaleOne) {
  const std::string path = tempSocket("live.sock");
  {
    ControlServer first(path, echo);
    EXPECT_THROW(ControlServer(path, echo), std::runtime_error);
  }
  EXPECT_FALSE(std::filesystem::exists(path));  // removed on the way out
  // A socket file left by a daemon that died: nobody answers, so it is replaced.
  const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  ::close(fd);
  ControlServer again(path, echo);
  Client c(path);
  c.send("{\"request\": \"x\"}\n");
  EXPECT_EQ(c.reply()["echo"], "x");
}

}  // namespace
}  // namespace parallax::daemon
