#pragma once
// A parallaxd child process for the process tests: started with `--config CONFIG`, its stderr
// in `log`, the environment given; killed (SIGKILL) if the test has not seen it exit.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace parallax::testing {

// This process's environment as strings, to extend or filter before starting a child.
inline std::vector<std::string> currentEnvironment() {
  std::vector<std::string> env;
  for (char** e = environ; *e; ++e) env.emplace_back(*e);
  return env;
}

class DaemonProcess {
 public:
  // `launcher`: a program parallaxd is started through, with its arguments (`mpirun -np 2`),
  // found on $PATH; empty: parallaxd itself.
  DaemonProcess(const std::filesystem::path& config, const std::filesystem::path& log,
                std::vector<std::string> env, std::vector<std::string> launcher = {})
      : log_(log), launched_(!launcher.empty()) {
    std::vector<char*> envp;
    for (std::string& e : env) envp.push_back(e.data());
    envp.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 2, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (launched_) posix_spawn_file_actions_adddup2(&actions, 2, 1);  // its own messages too
    std::vector<std::string> args = std::move(launcher);
    args.insert(args.end(), {PARALLAXD_PATH, "--config", config.string()});
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    EXPECT_EQ(posix_spawnp(&pid_, argv[0], &actions, nullptr, argv.data(), envp.data()), 0);
    posix_spawn_file_actions_destroy(&actions);
  }
  ~DaemonProcess() {
    if (pid_ > 0) {
      // A launcher forwards SIGTERM to what it started; SIGKILL would leave that running.
      if (launched_) {
        ::kill(pid_, SIGTERM);
        if (waitExit(10000) != -1) return;
      }
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  DaemonProcess(const DaemonProcess&) = delete;
  DaemonProcess& operator=(const DaemonProcess&) = delete;

  pid_t pid() const { return pid_; }
  // Exit status, waiting up to `ms`; -1 while it still runs.
  int waitExit(int ms) {
    for (int i = 0; i < ms / 10; ++i) {
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        return status;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return -1;
  }
  std::string log() const {
    std::ifstream in(log_);
    return std::string((std::istreambuf_iterator<char>(in)), {});
  }

 private:
  std::filesystem::path log_;
  bool launched_ = false;
  pid_t pid_ = -1;
};

}  // namespace parallax::testing
