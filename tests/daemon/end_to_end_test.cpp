
// The end-to-end test on simulated hardware: parallaxd starts parallax-simhw with a
// seeded ground truth, knows only the nominal `demo` display and the camera's metadata,
// calibrates through the link and the camera, and plays cornell.lua. From the frames the
// simulated modules actually received and the ground-truth physics, three viewers on the
// observer line see views that must match — PSNR ≥ 40 dB — the same views when the frames are
// rendered with the ground truth's own ray textures; frames rendered with the uncalibrated
// nominal model must be at least 10 dB worse. Both figures are printed. The second test does the
// same on a display with photometric variation (issue 21), colours calibrated too.

#include <fcntl.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "calibration/display/colour_correction.h"
#include "calibration/display/display_model_json.h"
#include "calibration/display/display_presets.h"
#include "calibration/display/ray_textures.h"
#include "calibration/simulation/photometric_truth.h"
#include "daemon/parallaxd/control_client.h"
#include "scripts/scene_argument.h"
#include "tracer/frame.h"
#include "tracer/observer_view.h"
#include "tracer/physical_scene.h"
#include "tracer/whitted_integrator.h"

extern char** environ;

namespace parallax {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

json ask(const std::string& socket, const json& request) {
  return daemon::tryAskDaemon(socket, request).value_or(nullptr);
}

// What a module shows of a linear frame: through the link's 8-bit sRGB and back.
Frame asShown(const Frame& f) { return frameFromSrgb8(f.width, f.height, f.toSrgb8()); }

std::vector<Frame> renderWith(const DisplayModel& model, const Scene& scene) {
  const PhysicalScene physical(scene, model.displayableBox);
  std::vector<Frame> frames;
  for (size_t i = 0; i < model.modules.size(); ++i) {
    frames.push_back(asShown(
        renderFrame(physical, generateRayTextures(model, static_cast<int>(i)), RenderOptions{})));
  }
  return frames;
}

// parallaxd with `config` (its [daemon] socket at folder/ctl.sock), run until it plays with a
// calibration installed (and, with `photometric`, a photometric correction), then shut down.
// Returns the status it last answered; a failed assertion leaves it empty.
json runDaemonUntilCalibrated(const fs::path& folder, const std::string& configText,
                              bool photometric) {
  const std::string socket = (folder / "ctl.sock").string();
  std::ofstream(folder / "parallax.toml") << configText;
  const std::string config = (folder / "parallax.toml").string(),
                    log = (folder / "parallaxd.log").string();
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 2, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<char*> argv = {const_cast<char*>(PARALLAXD_PATH), const_cast<char*>("--config"),
                             const_cast<char*>(config.c_str()), nullptr};
  pid_t pid = -1;
  EXPECT_EQ(posix_spawn(&pid, PARALLAXD_PATH, &actions, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&actions);
  // A failed assertion returns early: stop the daemon (and through it its simulator) then too,
  // or they outlive the test holding ctest's output pipe and it waits out its timeout.
  struct StopOnExit {
    pid_t& pid;
    ~StopOnExit() {
      if (pid <= 0) return;
      ::kill(pid, SIGTERM);
      int ignored = 0;
      ::waitpid(pid, &ignored, 0);
    }
  } stopOnExit{pid};
  auto logText = [&] {
    std::ifstream in(log);
    return std::string((std::istreambuf_iterator<char>(in)), {});
  };

  // Calibrate, regenerate, load, play: wait for the scene on the modules under the new calibration.
  const auto start = std::chrono::steady_clock::now();
  json status, stats;
  bool playing = false;
  while (std::chrono::steady_clock::now() - start < std::chrono::minutes(10) && !playing) {
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    status = ask(socket, {{"request", "status"}});
    stats = ask(socket, {{"request", "stats"}});
    if (!status.is_object() || !stats.is_object()) continue;
    if (status.contains("last_error") && status["last_error"]["stage"] == "calibrating") break;
    playing = status["state"] == "playing" &&
              status["calibration"]["source"] != "nominal (uncalibrated)" &&
              (!photometric || status["photometry"].is_object()) &&
              stats["module_frames_sent"].get<int>() >= 16 && stats["module_frames_failed"] == 0;
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!playing) {
    ADD_FAILURE() << status.dump(2) << "\n" << logText();
    return nullptr;
  }
  std::printf("E2E | daemon calibrated through the link and played cornell.lua after %.0f s\n",
              seconds);
  ask(socket, {{"request", "shutdown"}});
  int exit = 0;
  EXPECT_EQ(::waitpid(pid, &exit, 0), pid);
  pid = -1;
  EXPECT_TRUE(WIFEXITED(exit) && WEXITSTATUS(exit) == 0) << logText();
  return status;
}

std::string configText(const fs::path& folder, const std::string& extraHardware,
                       const std::string& extraCalibration) {
  return fmt::format(
      "[display]\npreset = \"demo\"\n[hardware]\nkind = \"sim\"\nseed = 7\ndump = "
      "\"{0}/shown\"\n{2}"
      "[calibration]\nauto = true\nfile = \"{0}/calibration.json\"\n{3}[scene]\nscript = "
      "\"cornell\"\n[daemon]\nsocket = \"{1}\"\ncache_dir = \"{0}/cache\"\n",
      folder.string(), (folder / "ctl.sock").string(), extraHardware, extraCalibration);
}

TEST(EndToEnd, CalibratedThroughTheLinkTheViewersSeeTheGroundTruthsViews) {
  const fs::path folder = fs::temp_directory_path() / fmt::format("plx-e2e-{}", ::getpid());
  fs::remove_all(folder);
  fs::create_directories(folder);
  const json status = runDaemonUntilCalibrated(folder, configText(folder, "", ""), false);
  ASSERT_TRUE(status.is_object());
  EXPECT_EQ(status["photometry"], "none") << "no photometric variation: nothing to correct";

  // The physics of the truth (the daemon never read it), the scene, three viewers.
  const DisplayModel truth =
      loadDisplayModel(status["simulated_display"].get<std::string>() + "/ground_truth.json");
  const DisplayModel nominal = resolveDisplay("demo");
  const Scene scene = loadSceneArgument("cornell", {}, 0.0);
  std::vector<Frame> received;
  for (size_t i = 0; i < truth.modules.size(); ++i) {
    received.push_back(
        readFrame(moduleFrameStem((folder / "shown").string(), static_cast<int>(i)) + ".png"));
  }
  const std::vector<Frame> reference = renderWith(truth, scene);
  const std::vector<Frame> uncalibrated = renderWith(nominal, scene);
  ObserverViewOptions view;
  view.width = 320;
  view.height = 180;
  for (double x : {-0.5, 0.0, 0.5}) {
    const Eigen::Vector3d viewer(x, truth.observer.y, truth.observer.z);
    std::vector<float> coverage;
    const Frame want = synthesizeObserverView(truth, reference, viewer, view, &coverage);
    const Frame got = synthesizeObserverView(truth, received, viewer, view);
    const Frame nominalView = synthesizeObserverView(truth, uncalibrated, viewer, view);
    const double calibrated = psnrDb(got, want, &coverage),
                 uncal = psnrDb(nominalView, want, &coverage);
    std::printf(
        "E2E | viewer at x = %+.1f m: calibrated %.1f dB, nominal %.1f dB (PSNR vs the ground "
        "truth's own textures)\n",
        x, calibrated, uncal);
    EXPECT_GE(calibrated, 40.0) << "x = " << x;
    EXPECT_LE(uncal, calibrated - 10.0) << "x = " << x;
  }
  fs::remove_all(folder);
}

// The light the modules of a simulated display with photometric variation send for 8-bit frames.
std::vector<Frame> lightOf(const PhotometricTruth& truth, const std::vector<Frame>& shown) {
  std::vector<Frame> out;
  for (size_t i = 0; i < shown.size(); ++i) {
    const Frame& f = shown[i];
    const std::vector<std::uint8_t> codes = f.toSrgb8();
    const cv::Mat light = truth.emittedLight(static_cast<int>(i), f.width, f.height, codes.data());
    Frame l(f.width, f.height);
    for (int y = 0; y < f.height; ++y)
      for (int x = 0; x < f.width; ++x) {
        const cv::Vec3f v = light.at<cv::Vec3f>(y, x);
        l.at(x, y) = Rgb(v[0], v[1], v[2]);
      }
    out.push_back(std::move(l));
  }
  return out;
}

// Issue 21: the same run on a simulated display whose modules differ in response, colours,
// brightness, black and vignetting (seeded). parallaxd calibrates geometry and colours through
// the link; three viewers see, from the frames the modules received through their true
// photometry, views that must match the ideal display at the calibration's target (its gamut and
// brightness, the ground truth's geometry) — PSNR ≥ 38 dB — and the geometric calibration alone
// (the same calibrated frames, plain sRGB) must be at least 8 dB worse.
TEST(EndToEnd, PhotometricVariationCalibratedTheViewersSeeTheTargetsViews) {
  const fs::path folder = fs::temp_directory_path() / fmt::format("plx-e2e-photo-{}", ::getpid());
  fs::remove_all(folder);
  fs::create_directories(folder);
  const json status = runDaemonUntilCalibrated(
      folder, configText(folder, "photometric_variation = true\n", "photometric = \"on\"\n"), true);
  ASSERT_TRUE(status.is_object());
  const json& p = status["photometry"];
  std::printf(
      "E2E | photometric calibration (status): CIEDE2000 mean %.2f worst %.2f, non-uniformity "
      "%.1f%% on the flat-field pictures\n",
      p["delta_e_mean"].get<double>(), p["delta_e_worst"].get<double>(),
      100.0 * p["non_uniformity"].get<double>());

  const std::string simulated = status["simulated_display"];
  const DisplayModel truth = loadDisplayModel(simulated + "/ground_truth.json");
  const PhotometricTruth photometry = loadPhotometricTruth(simulated + "/photometric_truth.json");
  const DisplayModel calibrated = loadDisplayModel((folder / "calibration.json").string());
  const DisplayColourCorrection correction =
      loadColourCorrection((folder / "calibration.photometry.json").string());
  const Scene scene = loadSceneArgument("cornell", {}, 0.0);
  std::vector<Frame> received;
  for (size_t i = 0; i < truth.modules.size(); ++i) {
    received.push_back(
        readFrame(moduleFrameStem((folder / "shown").string(), static_cast<int>(i)) + ".png"));
  }
  const std::vector<Frame> corrected = lightOf(photometry, received);
  const std::vector<Frame> geometricOnly = lightOf(photometry, renderWith(calibrated, scene));
  // The ideal display: the truth's geometry, every module the target's light for the content.
  std::vector<Frame> ideal;
  {
    const PhysicalScene physical(scene, truth.displayableBox);
    for (size_t i = 0; i < truth.modules.size(); ++i) {
      Frame f =
          renderFrame(physical, generateRayTextures(truth, static_cast<int>(i)), RenderOptions{});
      for (Rgb& c : f.pixels) {
        const Eigen::Vector3d content = c.cast<double>().cwiseMax(0.0).cwiseMin(1.0);
        c = (correction.target.black + correction.target.primaries * content).cast<float>();
      }
      ideal.push_back(std::move(f));
    }
  }
  ObserverViewOptions view;
  view.width = 320;
  view.height = 180;
  for (double x : {-0.5, 0.0, 0.5}) {
    const Eigen::Vector3d viewer(x, truth.observer.y, truth.observer.z);
    std::vector<float> coverage;
    const Frame want = synthesizeObserverView(truth, ideal, viewer, view, &coverage);
    const double both = psnrDb(synthesizeObserverView(truth, corrected, viewer, view), want,
                               &coverage),
                 geometric = psnrDb(synthesizeObserverView(truth, geometricOnly, viewer, view),
                                    want, &coverage);
    std::printf(
        "E2E | viewer at x = %+.1f m: geometric + photometric %.1f dB, geometric only %.1f dB "
        "(PSNR vs the ideal display at the target)\n",
        x, both, geometric);
    EXPECT_GE(both, 38.0) << "x = " << x;
    EXPECT_LE(geometric, both - 8.0) << "x = " << x;
  }
  fs::remove_all(folder);
}

}  // namespace
}  // namespace parallax
