// The daemon's photometric calibration (issue 21) against the in-process simulator whose
// modules show a seeded photometric truth: `calibrate` with the photometric stage installs the
// correction beside the calibration, `status` reports its figures, the frames are encoded
// through it and `rollback` takes geometry and colours back together. Bad input from the issue:
// a camera that saturates is refused with nothing installed; a dead
// module and one whose gamut is far outside the others are excluded by name, with the reason.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "../hw/sim_fixture.h"
#include "calibration/capture/calibration_captures.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/photometric_truth.h"
#include "calibration/simulation/simulated_session.h"
#include "daemon/parallaxd/calibration_store.h"
#include "daemon/parallaxd/conductor.h"
#include "hw/simulator/calibration_physics.h"
#include "tests/daemon/test_folder.h"

namespace parallax::daemon {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test_support::bytesOf;

constexpr int kModules = 4, kWidth = 64, kHeight = 48;

class PhotometricDaemon : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = test_support::freshTestFolder("plx-photometric");
    display_.modules = kModules;
    display_.width = kWidth;
    display_.height = kHeight;
    truth_ = makeGroundTruth(nominalDisplayOf(display_), GroundTruthOptions{});
    // A sound rig (five stations, a 640x360 camera), as calibration_install_test's.
    CameraRigOptions rig;
    rig.stations = 5;
    rig.spanM = 2.0;
    rig.intrinsics = CameraIntrinsics::centred(640, 360, 2100.0 * 640.0 / 1920.0);
    camera_ = makeSimulatedRig(truth_, rig, 3);
    saveCameraMetadata(camera_.metadata, (folder_ / "camera.json").string());
    PhotometricTruthOptions p;
    p.seed = 5;
    photometry_ = makePhotometricTruth(kModules, p);
  }
  void TearDown() override {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
    conductor_.reset();
    sim_.reset();
    fs::remove_all(folder_);
  }

  // The simulator with `photometry_` and the daemon, the ground truth's geometry installed as
  // its calibration (the geometric fit's own tests cover its error).
  void start() {
    CalibrationStore(calibrationPath()).install(truth_);
    hw::SimulatedHardwareOptions o;
    o.modules = kModules;
    o.width = kWidth;
    o.height = kHeight;
    sim_ = std::make_unique<hw::InProcessSimhw>(
        o, std::make_unique<hw::CalibrationPhysics>(truth_, camera_.truth, photometry_));
    ConductorOptions options;
    options.config.display = display_;
    options.config.scene.script = "cornell";
    options.config.cacheDir = (folder_ / "cache").string();
    options.config.calibration.file = calibrationPath();
    options.config.calibration.cameraMetadata = (folder_ / "camera.json").string();
    options.config.calibration.photometric = "off";
    options.config.calibration.autoCalibrate = false;
    // The geometry these colours are calibrated on is fitted from vignetted modules: across a
    // 42° lobe their brightness falls off, which the stripe decoder takes for the lobe's own
    // shape (the only part of the variation that is not uniform across a module). Their
    // stripes scatter by 1.4 mm against 0.2 without it, which the fit's σ counts: predicted
    // worst 20-130 mm on the observer line (up to 85 before the σ counted each decode's
    // leverage), beyond the default gate's 15. This test is about the colours: its gate takes
    // 250 mm.
    options.config.calibration.maxObserverMm = 250.0;
    options.linkSpec = sim_->spec();
    options.keepAliveMs = 100;
    options.onReady = [this] { ready_ = true; };
    conductor_ = std::make_unique<Conductor>(options);
    thread_ = std::thread([this] { conductor_->run(stop_); });
    for (int i = 0; i < 60000 && !ready_; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    ASSERT_TRUE(ready_.load());
    const json status = ask({{"request", "status"}});
    ASSERT_EQ(status["calibration"]["source"], calibrationPath()) << status.dump(2);
    ASSERT_EQ(status["photometry"], "none") << status.dump(2);
  }
  json ask(const json& request) { return conductor_->handle(request); }
  // Waits until the render loop has made more than `after` display frames; returns the count.
  int waitForFrames(int after) {
    for (int i = 0; i < 6000; ++i) {
      const int frames = ask({{"request", "stats"}})["display_frames"].get<int>();
      if (frames > after) return frames;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ADD_FAILURE() << "no new display frame";
    return after;
  }
  std::string calibrationPath() const { return (folder_ / "calibration.json").string(); }
  std::string photometryPath() const {
    return CalibrationStore(calibrationPath()).photometryPath();
  }

  fs::path folder_;
  DisplayConfig display_;
  DisplayModel truth_;
  SimulatedRig camera_;
  PhotometricTruth photometry_;
  std::unique_ptr<hw::InProcessSimhw> sim_;
  std::unique_ptr<Conductor> conductor_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> ready_{false};
};

TEST_F(PhotometricDaemon, CalibratedColoursAreInstalledReportedAppliedAndRolledBack) {
  start();
  int frames = waitForFrames(0);
  const json frameBefore =
      ask({{"request", "frame"}, {"module", 1}, {"path", (folder_ / "before.png").string()}});
  ASSERT_EQ(frameBefore["ok"], true) << frameBefore.dump();
  const json reply = ask({{"request", "calibrate"}, {"photometric", "on"}});
  ASSERT_EQ(reply["ok"], true) << reply.dump(2);
  const json status = ask({{"request", "status"}});
  const json& p = status["photometry"];
  ASSERT_TRUE(p.is_object()) << status.dump(2);
  EXPECT_EQ(p["source"], photometryPath());
  ASSERT_EQ(p["modules"].size(), static_cast<size_t>(kModules));
  for (const json& m : p["modules"]) {
    EXPECT_FALSE(m.contains("excluded")) << m.dump();
    EXPECT_GT(m["gain_max"].get<double>(), 1.0) << "vignetting is made up for: " << m.dump();
  }
  std::printf(
      "PHOTOMETRY | daemon, 4 modules: CIEDE2000 mean %.2f worst %.2f, non-uniformity "
      "%.1f%% (flat-field pictures)\n",
      p["delta_e_mean"].get<double>(), p["delta_e_worst"].get<double>(),
      100.0 * p["non_uniformity"].get<double>());
  EXPECT_LT(p["delta_e_mean"].get<double>(), 1.5);
  EXPECT_LT(p["non_uniformity"].get<double>(), 0.05);
  EXPECT_TRUE(fs::exists(photometryPath()));
  // The scene is encoded through the correction now.
  frames = waitForFrames(frames);
  ask({{"request", "frame"}, {"module", 1}, {"path", (folder_ / "after.png").string()}});
  EXPECT_NE(bytesOf(folder_ / "before.png"), bytesOf(folder_ / "after.png"));
  // Back to the geometric calibration alone, geometry and colours together.
  const json back = ask({{"request", "rollback"}});
  ASSERT_EQ(back["ok"], true) << back.dump(2);
  EXPECT_EQ(back["photometry"], "none");
  EXPECT_FALSE(fs::exists(photometryPath()));
  EXPECT_EQ(ask({{"request", "status"}})["photometry"], "none");
  waitForFrames(frames);
  ask({{"request", "frame"}, {"module", 1}, {"path", (folder_ / "back.png").string()}});
  EXPECT_EQ(bytesOf(folder_ / "before.png"), bytesOf(folder_ / "back.png"));
}

TEST_F(PhotometricDaemon, ASaturatingCameraIsRefusedAndNothingIsInstalled) {
  // Modules brighter than the lowest exposure the capture tries brings below full scale. The
  // camera is still placed from the patterns (every module held: their contrast is enough).
  for (ModulePhotometricTruth& m : photometry_.modules) m.primaries *= 20.0;
  start();
  const std::string calibration = bytesOf(calibrationPath());
  const json reply = ask({{"request", "calibrate"}, {"photometric", "only"}});
  ASSERT_EQ(reply["ok"], false) << reply.dump(2);
  const std::string error = reply["error"];
  EXPECT_NE(error.find("saturates"), std::string::npos) << error;
  EXPECT_NE(error.find("station"), std::string::npos) << error;
  EXPECT_EQ(bytesOf(calibrationPath()), calibration);
  EXPECT_FALSE(fs::exists(calibrationPath() + ".previous")) << "a version was installed";
  EXPECT_FALSE(fs::exists(photometryPath()));
  EXPECT_EQ(ask({{"request", "status"}})["photometry"], "none");
}

TEST_F(PhotometricDaemon, ADeadModuleAndAGamutFarOutsideAreExcludedByName) {
  // Module 2 gives no light, module 3's red leaks half into green. Their geometry was
  // calibrated while they were sound; only the colours are calibrated now.
  photometry_.modules[2].primaries.setZero();
  photometry_.modules[2].black.setZero();
  photometry_.modules[3].primaries.col(0) = Eigen::Vector3d(0.8, 0.45, 0.02);
  start();
  const json reply = ask({{"request", "calibrate"}, {"photometric", "only"}});
  ASSERT_EQ(reply["ok"], true) << reply.dump(2);
  const json p = ask({{"request", "status"}})["photometry"];
  ASSERT_TRUE(p.is_object()) << p.dump(2);
  EXPECT_FALSE(p["modules"][0].contains("excluded")) << p.dump(2);
  EXPECT_FALSE(p["modules"][1].contains("excluded")) << p.dump(2);
  ASSERT_TRUE(p["modules"][2].contains("excluded")) << p.dump(2);
  EXPECT_NE(p["modules"][2]["excluded"].get<std::string>().find("dead"), std::string::npos);
  ASSERT_TRUE(p["modules"][3].contains("excluded")) << p.dump(2);
  EXPECT_NE(p["modules"][3]["excluded"].get<std::string>().find("gamut far outside"),
            std::string::npos);
  EXPECT_NE(reply["summary"].get<std::string>().find("module 2 excluded"), std::string::npos)
      << reply.dump(2);
}

}  // namespace
}  // namespace parallax::daemon
