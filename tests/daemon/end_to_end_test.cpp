
// The end-to-end test on simulated hardware: parallaxd starts parallax-simhw with a
// seeded ground truth, knows only the nominal `demo` display and the camera's metadata,
// calibrates through the link and the camera, and plays cornell.lua. From the frames the
// simulated modules actually received and the ground-truth physics, three viewers on the
// observer line see views that must match — PSNR ≥ 40 dB — the same views when the frames are
// rendered with the ground truth's own ray textures; frames rendered with the uncalibrated
// nominal model must be at least 10 dB worse. Both figures are printed.

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

#include "calibration/display/display_model_json.h"
#include "calibration/display/display_presets.h"
#include "calibration/display/ray_textures.h"
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

TEST(EndToEnd, CalibratedThroughTheLinkTheViewersSeeTheGroundTruthsViews) {
  const fs::path folder = fs::temp_directory_path() / fmt::format("plx-e2e-{}", ::getpid());
  fs::remove_all(folder);
  fs::create_directories(folder);
  const std::string socket = (folder / "ctl.sock").string();
  std::ofstream(folder / "parallax.toml") << fmt::format(
      "[display]\npreset = \"demo\"\n[hardware]\nkind = \"sim\"\nseed = 7\ndump = \"{0}/shown\"\n"
      "[calibration]\nauto = true\nfile = \"{0}/calibration.json\"\n[scene]\nscript = \"cornell\"\n"
      "[daemon]\nsocket = \"{1}\"\ncache_dir = \"{0}/cache\"\n",
      folder.string(), socket);
  const std::string config = (folder / "parallax.toml").string(),
                    log = (folder / "parallaxd.log").string();
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 2, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<char*> argv = {const_cast<char*>(PARALLAXD_PATH), const_cast<char*>("--config"),
                             const_cast<char*>(config.c_str()), nullptr};
  pid_t pid = -1;
  ASSERT_EQ(posix_spawn(&pid, PARALLAXD_PATH, &actions, nullptr, argv.data(), environ), 0);
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
              stats["module_frames_sent"].get<int>() >= 16 && stats["module_frames_failed"] == 0;
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_TRUE(playing) << status.dump(2) << "\n" << logText();
  std::printf("E2E | daemon calibrated through the link and played cornell.lua after %.0f s\n",
              seconds);
  ask(socket, {{"request", "shutdown"}});
  int exit = 0;
  ASSERT_EQ(::waitpid(pid, &exit, 0), pid);
  pid = -1;
  ASSERT_TRUE(WIFEXITED(exit) && WEXITSTATUS(exit) == 0) << logText();

  // The physics of the truth (the daemon never read it), the scene, three viewers.
  const DisplayModel truth =
      loadDisplayModel((folder / "cache/simulated-display/seed-7/ground_truth.json").string());
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

}  // namespace
}  // namespace parallax
