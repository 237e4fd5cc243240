#include "daemon/parallaxd/simhw_child.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <signal.h>
#include <spawn.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <thread>

#include "calibration/capture/calibration_captures.h"
#include "calibration/capture/checkerboard_calibration.h"
#include "calibration/capture/checkerboard_captures.h"
#include "calibration/display/display_model_json.h"
#include "calibration/simulation/camera_truth.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/photometric_truth.h"
#include "calibration/simulation/simulated_session.h"
#include "common/private_folder.h"
#include "daemon/parallaxd/ray_texture_cache.h"

extern char** environ;

namespace parallax::daemon {

std::string SimhwChild::findBinary() {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) throw std::runtime_error("cannot find parallaxd's own path: " + ec.message());
  // Installed side by side, or in the build tree: daemon/parallaxd and hw/parallax-simhw.
  for (const std::filesystem::path& candidate :
       {self.parent_path() / "parallax-simhw",
        self.parent_path().parent_path() / "hw" / "parallax-simhw"}) {
    if (::access(candidate.c_str(), X_OK) == 0) return candidate.string();
  }
  throw std::runtime_error(fmt::format(
      "parallax-simhw not found next to {}: build it or configure [hardware]", self.string()));
}

std::string SimhwChild::folderFor(const std::string& cacheDir, const DisplayModel& nominal,
                                  int seed) {
  // The name for a reader (a display file may name itself anything: kept to a plain word), the
  // hash of every parameter for the key (the same preset with other overrides differs).
  std::string name;
  for (char c : nominal.name.substr(0, 40))
    name += std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' ? c : '_';
  if (name.empty()) name = "display";
  return fmt::format("{}/simulated-display/{}-{}/seed-{}", cacheDir, name,
                     hashHex(displayContentHash(nominal)), seed);
}

SimhwChild::SimhwChild(const DisplayModel& nominal, const HardwareConfig& hardware,
                       const std::string& socketPath, const std::string& cacheDir, const Part& part)
    : socketPath_(socketPath), folder_(folderFor(cacheDir, nominal, hardware.seed)) {
  // The seeded truth and camera rig, as `parallax simulate` makes them: a 640×360 camera with
  // the default's field of view at five stations spread over four times the module row's half
  // width. The outermost modules light only the far side of the observer line; spread that
  // far, each is photographed from three stations or more.
  GroundTruthOptions truthOptions;
  truthOptions.seed = static_cast<std::uint64_t>(hardware.seed);
  const DisplayModel truth = makeGroundTruth(nominal, truthOptions);
  CameraRigOptions rig;
  double rowHalfWidth = 0.0;
  for (const OpticalModule& m : nominal.modules)
    rowHalfWidth = std::max(rowHalfWidth, std::abs(m.position.x()));
  rig.stations = 5;
  rig.spanM = std::max(1.0, 4.0 * rowHalfWidth);
  rig.intrinsics = CameraIntrinsics::centred(640, 360, 2100.0 * 640.0 / 1920.0, -0.04);
  SimulatedRig camera =
      makeSimulatedRig(truth, rig, static_cast<std::uint64_t>(hardware.seed) * 7919 + 1);
  std::filesystem::create_directories(folder_);
  // The daemon gets what an installer gives it: camera.json with the intrinsics the camera's
  // own checkerboard pictures give (kept beside it), never its truth. The link carries no
  // checkerboard pictures, so the camera is calibrated here, once, before the daemon uses it.
  // 20 pictures (~0.2 s): with 12 the end-to-end views lost 1–3 dB against the true intrinsics
  // (cx 0.56 px off), with 20 0.4–2.3 dB.
  CheckerboardShotOptions shots;
  shots.pictures = 20;
  const CheckerboardCaptures board =
      simulateCheckerboardCaptures(camera.truth, CheckerboardBoard{}, shots);
  saveCheckerboardCaptures(board, folder_);
  const CheckerboardCalibration cameraFit = calibrateFromCheckerboard(
      board.pictures, board.board, rig.intrinsics.width, rig.intrinsics.height);
  camera.metadata.intrinsics = cameraFit.intrinsics;
  camera.metadata.intrinsicsCovariance = cameraFit.covariance;
  spdlog::info(
      "simulated camera calibrated from {} checkerboard pictures: fx {:.2f} fy {:.2f} cx {:.2f} cy "
      "{:.2f} "
      "k1 {:.4f} k2 {:.4f}, {:.3f} px RMS",
      cameraFit.used.size(), cameraFit.intrinsics.fx, cameraFit.intrinsics.fy,
      cameraFit.intrinsics.cx, cameraFit.intrinsics.cy, cameraFit.intrinsics.k1,
      cameraFit.intrinsics.k2, cameraFit.rmsPx);
  saveDisplayModel(truth, groundTruthPath());
  saveCameraTruth(camera.truth, folder_ + "/camera_truth.json");
  saveCameraMetadata(camera.metadata, cameraMetadataPath());

  arguments_ = {findBinary(), "--exit-with-parent", "--socket", socketPath_,
                "--truth",    groundTruthPath(),    "--camera", folder_ + "/camera_truth.json"};
  if (!part.modules.empty()) {
    arguments_.push_back("--link-modules");
    arguments_.push_back(fmt::format("{}", fmt::join(part.modules, ",")));
  }
  if (!part.room.empty()) {
    arguments_.push_back("--room");
    arguments_.push_back(part.room);
  }
  for (const std::string& fault : hardware.faults) {
    arguments_.push_back("--fault");
    arguments_.push_back(fault);
  }
  if (hardware.photometricVariation) {
    // Seeded with the ground truth's seed; for tests and reports only, as the ground truth.
    PhotometricTruthOptions photometric;
    photometric.seed = static_cast<std::uint64_t>(hardware.seed);
    savePhotometricTruth(makePhotometricTruth(static_cast<int>(truth.modules.size()), photometric),
                         photometricTruthPath());
    arguments_.push_back("--photometric-truth");
    arguments_.push_back(photometricTruthPath());
  }
  if (!hardware.dump.empty()) {
    arguments_.push_back("--dump");
    arguments_.push_back(hardware.dump);
  }
  start();
}

SimhwChild::~SimhwChild() { stop(); }

void SimhwChild::start() {
  std::vector<char*> argv;
  for (std::string& a : arguments_) argv.push_back(a.data());
  argv.push_back(nullptr);
  // A stale socket of ours is replaced; anything else at the path (another user's socket, a
  // symlink) is refused, never deleted.
  if (socketPathInUse(socketPath_)) ::unlink(socketPath_.c_str());
  // parallaxd blocks SIGTERM & co. for its sigwait thread and ignores SIGPIPE; the child must
  // start with neither, or it could not be stopped with SIGTERM.
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  sigset_t none, defaults;
  sigemptyset(&none);
  sigemptyset(&defaults);
  sigaddset(&defaults, SIGPIPE);
  sigaddset(&defaults, SIGXFSZ);
  posix_spawnattr_setsigmask(&attributes, &none);
  posix_spawnattr_setsigdefault(&attributes, &defaults);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
  const int rc = ::posix_spawn(&pid_, argv[0], nullptr, &attributes, argv.data(), environ);
  posix_spawnattr_destroy(&attributes);
  if (rc != 0)
    throw std::runtime_error(fmt::format("cannot start {}: {}", argv[0], std::strerror(rc)));
  spdlog::info("simulated display: {} (pid {}) on {}", arguments_[0], pid_, socketPath_);
  // Faults armed at start fire once: a restarted simulator comes back healthy.
  for (size_t i = 0; i + 1 < arguments_.size();) {
    if (arguments_[i] == "--fault") {
      arguments_.erase(arguments_.begin() + static_cast<long>(i),
                       arguments_.begin() + static_cast<long>(i) + 2);
    } else {
      ++i;
    }
  }
}

bool SimhwChild::superviseOnce() {
  if (pid_ <= 0) return false;
  int status = 0;
  if (::waitpid(pid_, &status, WNOHANG) != pid_) return false;
  spdlog::warn("simulated display (pid {}) {} {}; starting it again", pid_,
               WIFSIGNALED(status) ? "died of signal" : "exited with",
               WIFSIGNALED(status) ? WTERMSIG(status) : WEXITSTATUS(status));
  pid_ = -1;
  ++restarts_;
  start();
  return true;
}

void SimhwChild::stop() {
  if (pid_ <= 0) return;
  ::kill(pid_, SIGTERM);
  int status = 0;
  // Up to 5 s: it writes its --dump on the way out.
  for (int i = 0; i < 500; ++i) {
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      return;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  spdlog::warn("simulated display (pid {}) did not stop; killing it", pid_);
  ::kill(pid_, SIGKILL);
  ::waitpid(pid_, &status, 0);
  pid_ = -1;
}

}  // namespace parallax::daemon
