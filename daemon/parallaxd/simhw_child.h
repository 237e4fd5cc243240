#pragma once
// The simulated display parallaxd starts for itself when the config names no hardware: a
// `parallax-simhw` child (found next to the parallaxd binary) on a socket in the daemon's
// runtime folder, with a seeded ground truth. If it dies (a crash fault, a kill), it is
// started again on the same socket — the simulated equivalent of a module rebooting — and the
// link reconnects by itself. Stopped with SIGTERM (then SIGKILL after a grace period).

#include <sys/types.h>

#include <string>
#include <vector>

#include "calibration/display_model.h"
#include "daemon/parallaxd/daemon_config.h"

namespace parallax::daemon {

class SimhwChild {
 public:
  // Throws std::runtime_error when the binary is missing or the child cannot start.
  SimhwChild(const DisplayModel& nominal, const HardwareConfig& hardware, const std::string& socketPath);
  ~SimhwChild();
  SimhwChild(const SimhwChild&) = delete;
  SimhwChild& operator=(const SimhwChild&) = delete;

  const std::string& socketPath() const { return socketPath_; }
  std::string linkSpec() const { return "simhw:" + socketPath_; }
  pid_t pid() const { return pid_; }
  // Restarts the child if it has exited (call now and then); returns true if it did.
  bool superviseOnce();
  int restarts() const { return restarts_; }
  void stop();

  // parallax-simhw beside the running executable (argv[0] is not trusted: /proc/self/exe).
  static std::string findBinary();

 private:
  void start();

  std::vector<std::string> arguments_;
  std::string socketPath_;
  pid_t pid_ = -1;
  int restarts_ = 0;
};

}  // namespace parallax::daemon
