// A calibration through the daemon says where it is, stage by stage and in order (issue 20:
// `calibrate`'s bar jumped from 0% to 100%): the pictures counted up to their total, then the
// picture sets decoded, then every step of the fit, then the ray textures of the new model,
// each counted to its end — what `status` shows at every step.

#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <filesystem>
#include <optional>
#include <regex>
#include <thread>

#include "../hw/sim_fixture.h"
#include "calibration/capture/calibration_captures.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/simulated_session.h"
#include "daemon/parallaxd/conductor.h"
#include "hw/simulator/calibration_physics.h"

namespace parallax::daemon {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kModules = 4, kWidth = 64, kHeight = 48;

// One counted stage as `status` shows it: "decoding: picture set 2 of 4" → {1, 2, 4}.
struct Count {
  int stage = -1;  // index in kStages
  int done = 0, total = 0;
};

const std::regex kStages[] = {
    std::regex(R"(pictures: (\d+) of (\d+))"),
    std::regex(R"(decoding: picture set (\d+) of (\d+))"),
    std::regex(R"(fitting: step (\d+) of (\d+), .*)"),
    std::regex(R"(ray textures: module (\d+) of (\d+))"),
};

std::optional<Count> countOf(const std::string& stage) {
  for (int i = 0; i < 4; ++i) {
    std::smatch m;
    if (std::regex_match(stage, m, kStages[i]))
      return Count{i, std::stoi(m[1].str()), std::stoi(m[2].str())};
  }
  return std::nullopt;
}

TEST(CalibrationStages, StatusCountsEachStageToItsEndInOrder) {
  const fs::path folder = fs::temp_directory_path() / ("plx-stages-" + std::to_string(::getpid()));
  fs::remove_all(folder);
  fs::create_directories(folder);
  DisplayConfig display;
  display.modules = kModules;
  display.width = kWidth;
  display.height = kHeight;
  const DisplayModel truth = makeGroundTruth(nominalDisplayOf(display), GroundTruthOptions{});
  // A sound rig (calibration_install_test's): the fit passes the gate, so the ray textures of
  // the new model follow.
  CameraRigOptions rig;
  rig.stations = 5;
  rig.spanM = 2.0;
  rig.intrinsics = CameraIntrinsics::centred(640, 360, 2100.0 * 640.0 / 1920.0);
  const SimulatedRig camera = makeSimulatedRig(truth, rig, 3);
  const std::string cameraPath = (folder / "camera.json").string();
  saveCameraMetadata(camera.metadata, cameraPath);
  hw::SimulatedHardwareOptions o;
  o.modules = kModules;
  o.width = kWidth;
  o.height = kHeight;
  hw::InProcessSimhw sim(o, std::make_unique<hw::CalibrationPhysics>(truth, camera.truth));

  std::unique_ptr<Conductor> conductor;
  std::atomic<bool> stop{false}, ready{false}, recording{false};
  std::vector<std::string> seen;  // distinct consecutive stages, written on the conductor thread
  ConductorOptions options;
  options.config.display = display;
  options.config.scene.script = "cornell";
  options.config.cacheDir = (folder / "cache").string();
  options.config.calibration.file = (folder / "calibration.json").string();
  options.config.calibration.autoCalibrate = false;
  options.config.calibration.cameraMetadata = cameraPath;
  options.linkSpec = sim.spec();
  options.keepAliveMs = 100;
  options.onReady = [&] { ready = true; };
  // The heartbeat follows every change of stage, once it is published.
  options.onHeartbeat = [&] {
    if (!recording) return;
    const std::string stage = conductor->handle({{"request", "status"}})["stage"];
    if (seen.empty() || seen.back() != stage) seen.push_back(stage);
  };
  conductor = std::make_unique<Conductor>(options);
  std::thread thread([&] { conductor->run(stop); });
  for (int i = 0; i < 6000 && !ready; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_TRUE(ready.load());
  recording = true;
  const json reply = conductor->handle({{"request", "calibrate"}});
  recording = false;
  stop = true;
  thread.join();
  conductor.reset();
  fs::remove_all(folder);
  ASSERT_EQ(reply["ok"], true) << reply.dump();

  // Every counted stage in order, each counted up by one from its first report to its total.
  std::string all;
  for (const std::string& s : seen) all += s + "\n";
  Count last;
  std::array<bool, 4> ended{};
  for (const std::string& stage : seen) {
    const std::optional<Count> c = countOf(stage);
    if (!c) continue;  // the state's own words ("all modules", "ray textures")
    ASSERT_GE(c->stage, last.stage) << "a stage went back:\n" << all;
    if (c->stage == last.stage) {
      ASSERT_EQ(c->total, last.total) << all;
      ASSERT_EQ(c->done, last.done + 1) << "counted by one:\n" << all;
    } else {
      ASSERT_TRUE(last.stage < 0 || last.done == last.total) << "a stage left unfinished:\n" << all;
      ASSERT_LE(c->done, 1) << "a stage's first report:\n" << all;
    }
    if (c->done == c->total) ended[static_cast<size_t>(c->stage)] = true;
    last = *c;
  }
  for (int i = 0; i < 4; ++i)
    EXPECT_TRUE(ended[static_cast<size_t>(i)]) << "stage " << i << ":\n" << all;
  // The fit's last step is the gate.
  EXPECT_NE(all.find("quality gate"), std::string::npos) << all;
}

}  // namespace
}  // namespace parallax::daemon
