#pragma once
// parallax-simhw as a child process (PARALLAX_SIMHW_PATH), for tests of the real process model.

#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "hw/link/link_client.h"
#include "hw/link/socket_transport.h"

extern char** environ;

namespace parallax::hw {

class SimhwProcess {
 public:
  // `arguments` follow "--socket PATH".
  explicit SimhwProcess(std::vector<std::string> arguments, std::string path = "") : path_(path) {
    static int counter = 0;
    if (path_.empty()) {
      path_ =
          (std::filesystem::temp_directory_path() / ("plx-simhw-proc-" + std::to_string(getpid()) +
                                                     "-" + std::to_string(counter++) + ".sock"))
              .string();
    }
    std::vector<std::string> args = {PARALLAX_SIMHW_PATH, "--socket", path_};
    args.insert(args.end(), arguments.begin(), arguments.end());
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    EXPECT_EQ(posix_spawn(&pid_, PARALLAX_SIMHW_PATH, nullptr, nullptr, argv.data(), environ), 0);
  }
  ~SimhwProcess() { stop(); }

  int stop() {
    if (pid_ <= 0) return status_;
    kill(pid_, SIGTERM);
    kill(pid_, SIGCONT);  // a test may have stopped it
    waitpid(pid_, &status_, 0);
    pid_ = 0;
    return status_;
  }
  // Waits for the process to exit by itself; returns its wait status.
  int waitExit() {
    waitpid(pid_, &status_, 0);
    pid_ = 0;
    return status_;
  }
  const std::string& path() const { return path_; }
  pid_t pid() const { return pid_; }

 private:
  std::string path_;
  pid_t pid_ = 0;
  int status_ = 0;
};

// The executable loads ~260 shared libraries (OpenImageIO's plugins among them): more than a
// second to start on a loaded two-core machine, so wait generously.
inline std::unique_ptr<LinkClient> connectWhenUp(const std::string& path, LinkOptions options) {
  for (int i = 0; i < 3000; ++i) {
    try {
      return std::make_unique<LinkClient>(std::make_unique<SocketTransport>(path), options);
    } catch (const std::runtime_error&) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  ADD_FAILURE() << "parallax-simhw did not come up on " << path;
  return nullptr;
}

}  // namespace parallax::hw
