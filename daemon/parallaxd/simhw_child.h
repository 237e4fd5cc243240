#pragma once
// The simulated display parallaxd starts for itself when the config names no hardware: a
// `parallax-simhw` child (found next to the parallaxd binary) on a socket in the daemon's
// runtime folder, photographing a seeded ground truth (calibration/simulation/ground_truth.h) with
// a seeded camera rig (calibration/simulation/simulated_session.h). The daemon is given only the
// camera's metadata (camera.json: intrinsics calibrated from the camera's own checkerboard
// pictures, tape-measured stations), never the truth; the truth files are written beside it for
// tests and reports, in a folder keyed by the nominal display and the seed (two daemons on
// different displays with one seed and cache must not overwrite each other's truth):
//   F = <cache_dir>/simulated-display/<display name>-<display content hash>/seed-N
//   F/{ground_truth,camera_truth,camera,checkerboard}.json, F/checkerboard/board_NN.png
//   F/photometric_truth.json   ([hardware] photometric_variation: its modules differ in
//       response, colour, brightness, vignetting)
// `status` names F (`simulated_display`).
// If it dies (a crash fault, a kill), it is
// started again on the same socket — the simulated equivalent of a module rebooting — and the
// link reconnects by itself. Stopped with SIGTERM (then SIGKILL after a grace period).

#include <sys/types.h>

#include <string>
#include <vector>

#include "calibration/display/display_model.h"
#include "daemon/parallaxd/daemon_config.h"

namespace parallax::daemon {

class SimhwChild {
 public:
  // One rank's part of a simulated display in a cluster: the modules its link reaches (display
  // indices; empty: all) and the room where the ranks' simulators show each other's modules to
  // their cameras (hw/simulator/shared_room.h).
  struct Part {
    std::vector<int> modules;
    std::string room;
  };
  // Throws std::runtime_error when the binary is missing or the child cannot start.
  SimhwChild(const DisplayModel& nominal, const HardwareConfig& hardware,
             const std::string& socketPath, const std::string& cacheDir, const Part& part = {});
  ~SimhwChild();
  SimhwChild(const SimhwChild&) = delete;
  SimhwChild& operator=(const SimhwChild&) = delete;

  const std::string& socketPath() const { return socketPath_; }
  // The camera metadata a calibration of this simulated display starts from.
  std::string cameraMetadataPath() const { return folder_ + "/camera.json"; }
  std::string groundTruthPath() const { return folder_ + "/ground_truth.json"; }
  std::string photometricTruthPath() const { return folder_ + "/photometric_truth.json"; }
  const std::string& folder() const { return folder_; }
  static std::string folderFor(const std::string& cacheDir, const DisplayModel& nominal, int seed);
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
  std::string folder_;
  pid_t pid_ = -1;
  int restarts_ = 0;
};

}  // namespace parallax::daemon
