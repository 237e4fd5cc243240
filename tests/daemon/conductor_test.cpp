// The conductor against the simulated hardware, in process (a small demo display: 4 modules of
// 64×48): a static scene is rendered and pushed once; frames whose bytes did not change are not
// re-sent; a module whose link drops and returns gets its frame back; bad scenes, bad reloads
// and bad requests leave the old scene on the modules and are reported; a calibration cancelled
// halfway leaves the installed calibration and brings the scene back.

#include "daemon/parallaxd/conductor.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <thread>

#include "../hw/sim_fixture.h"
#include "calibration/capture/calibration_captures.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/simulated_session.h"
#include "hw/simulator/calibration_physics.h"
#include "tracer/frame.h"

namespace parallax::daemon {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kModules = 4, kWidth = 64, kHeight = 48;

const char* kScene = R"(
px.name("box")
px.param{name = "unused", default = 1, min = 0, max = 10, description = "changes nothing"}
local red = px.diffuse{name = "red", color = {0.8, 0.2, 0.1}}
local floor = px.diffuse{name = "floor", color = {0.6, 0.6, 0.6}}
px.box{size = {1, 1, 1}, material = red, name = "box", transform = px.translate(0, 0.5, 0) * px.rotate_y(0.4)}
px.plane{width = 4, height = 3, material = floor, transform = px.rotate_x(-math.pi / 2)}
px.directional{direction = {0.3, -0.5, -1}, color = {0.9, 0.9, 0.9}}
px.background({0.1, 0.1, 0.2})
px.world_box{min = {-2, 0, -1.25}, max = {2, 2.25, 1.25}}
)";

class ConductorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = fs::temp_directory_path() /
              ("plx-conductor-" + std::to_string(::getpid()) + "-" +
               ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(folder_);
    fs::create_directories(folder_);
    script_ = (folder_ / "box.lua").string();
    writeScript(kScene);
    hw::SimulatedHardwareOptions o;
    o.modules = kModules;
    o.width = kWidth;
    o.height = kHeight;
    sim_ = std::make_unique<hw::InProcessSimhw>(o);
  }
  void TearDown() override {
    stopConductor();
    fs::remove_all(folder_);
  }

  void writeScript(const std::string& text) { std::ofstream(script_) << text; }

  void startConductor() {
    ConductorOptions o;
    o.config.display.modules = kModules;
    o.config.display.width = kWidth;
    o.config.display.height = kHeight;
    o.config.scene.script = script_;
    o.config.cacheDir = (folder_ / "cache").string();
    o.config.calibration.autoCalibrate = false;
    o.config.calibration.cameraMetadata = camera_;
    o.linkSpec = sim_->spec();
    o.link = link_;
    o.keepAliveMs = 100;
    o.onReady = [this] { ready_ = true; };
    conductor_ = std::make_unique<Conductor>(o);
    thread_ = std::thread([this] { conductor_->run(stop_); });
    for (int i = 0; i < 3000 && !ready_; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    ASSERT_TRUE(ready_.load());
  }
  void stopConductor() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  json ask(const json& request) { return conductor_->handle(request); }
  json stats() { return ask({{"request", "stats"}}); }
  // Waits until `done(stats)` holds (the loop publishes after every turn).
  json waitFor(const std::function<bool(const json&)>& done, int ms = 10000) {
    json s;
    for (int i = 0; i < ms / 10; ++i) {
      s = stats();
      if (done(s)) return s;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ADD_FAILURE() << "timed out; stats: " << s.dump();
    return s;
  }
  // What module m currently shows according to the daemon (its `frame` request).
  std::vector<uint8_t> daemonFrame(int m) {
    const json r = ask({{"request", "frame"},
                        {"module", m},
                        {"path", (folder_ / ("f" + std::to_string(m) + ".png")).string()}});
    EXPECT_EQ(r["ok"], true) << r.dump();
    return readFrame(r["path"].get<std::string>()).toSrgb8();
  }

  fs::path folder_;
  std::string script_;
  std::string camera_;  // camera.json for calibrating (empty: the daemon cannot calibrate)
  hw::LinkOptions link_ = [] {
    hw::LinkOptions o;
    o.ackTimeoutMs = 1000;
    o.reconnectAttempts = 20;
    o.reconnectDelayMs = 10;
    o.linkDownRetryMs = 0;
    return o;
  }();
  std::unique_ptr<hw::InProcessSimhw> sim_;
  std::unique_ptr<Conductor> conductor_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> ready_{false};
};

TEST_F(ConductorTest, StaticScenePushedOnceAndShownAsRendered) {
  startConductor();
  EXPECT_EQ(ask({{"request", "status"}})["state"], "playing");
  waitFor([](const json& s) { return s["module_frames_sent"] == kModules; });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // several loop turns
  const json s = stats();
  EXPECT_EQ(s["display_frames"], 1);
  EXPECT_EQ(s["module_frames_sent"], kModules);
  std::vector<std::vector<uint8_t>> frames;
  for (int m = 0; m < kModules; ++m) frames.push_back(daemonFrame(m));
  stopConductor();
  sim_->stop();
  for (int m = 0; m < kModules; ++m) {
    EXPECT_EQ(sim_->hardware().counters(m).framesShown, 1u) << m;
    EXPECT_EQ(sim_->hardware().shownFrame(m).pixels, frames[static_cast<size_t>(m)]) << m;
  }
  // The scene is really there: a frame of one colour would be an empty render.
  const auto& px = frames[1];
  EXPECT_NE(std::count(px.begin(), px.end(), px[0]), static_cast<long>(px.size()));
}

TEST_F(ConductorTest, UnchangedFramesAreNotResent) {
  startConductor();
  waitFor([](const json& s) { return s["module_frames_sent"] == kModules; });
  // A parameter the scene does not use: rebuilt and rendered again, same bytes, not sent.
  EXPECT_EQ(ask({{"request", "set"}, {"name", "unused"}, {"value", 3}})["ok"], true);
  json s = waitFor([](const json& st) { return st["display_frames"] == 2; });
  s = waitFor([](const json& st) { return st["module_frames_unchanged_not_sent"] == kModules; });
  EXPECT_EQ(s["module_frames_sent"], kModules);
  // The same for a hot reload that changes nothing visible.
  writeScript(std::string(kScene) + "\n-- a comment\n");
  s = waitFor([](const json& st) {
    return st["display_frames"] == 3 && st["module_frames_unchanged_not_sent"] == 2 * kModules;
  });
  EXPECT_EQ(s["module_frames_sent"], kModules);
  stopConductor();
  sim_->stop();
  for (int m = 0; m < kModules; ++m) EXPECT_EQ(sim_->hardware().counters(m).framesShown, 1u);
}

TEST_F(ConductorTest, AReconnectingModuleGetsItsFrameBack) {
  startConductor();
  waitFor([](const json& s) { return s["module_frames_sent"] == kModules; });
  const std::vector<uint8_t> shown = daemonFrame(2);
  // The link drops (the simulator goes away) and comes back: the idle keep-alive notices, the
  // link reconnects, and the current frames go out again — without a new render.
  sim_->stop();
  sim_->start();
  const json s = waitFor([](const json& st) { return st["module_frames_sent"] == 2 * kModules; });
  EXPECT_GE(s["resends_after_reconnect"].get<int>(), 1);
  EXPECT_EQ(s["display_frames"], 1);
  stopConductor();
  sim_->stop();
  EXPECT_EQ(sim_->hardware().counters(2).framesShown, 2u);
  EXPECT_EQ(sim_->hardware().shownFrame(2).pixels, shown);
}

TEST_F(ConductorTest, BadScenesAndReloadsKeepTheOldSceneUp) {
  startConductor();
  waitFor([](const json& s) { return s["module_frames_sent"] == kModules; });
  const std::vector<uint8_t> before = daemonFrame(0);

  json r = ask({{"request", "load"}, {"scene", (folder_ / "missing.lua").string()}});
  EXPECT_EQ(r["ok"], false);
  json status = ask({{"request", "status"}});
  EXPECT_EQ(status["state"], "playing");
  EXPECT_EQ(status["scene"]["name"], script_);
  EXPECT_EQ(status["last_error"]["stage"], "loading the scene");

  // A broken edit of the playing script: reported with its line, the old version plays on.
  writeScript("px.name(\"box\")\nlocal x = = 1\n");
  for (int i = 0; i < 300; ++i) {
    status = ask({{"request", "status"}});
    if (status.contains("scene_error")) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(status.contains("scene_error")) << status.dump();
  EXPECT_NE(status["scene_error"].get<std::string>().find(":2"), std::string::npos)
      << status["scene_error"];
  EXPECT_EQ(status["state"], "playing");
  EXPECT_EQ(daemonFrame(0), before);

  // Requests that make no sense get an error, not a crash.
  for (const json& bad :
       {json{{"request", "frame"}, {"module", 99}}, json{{"request", "view"}},
        json{{"request", "set"}, {"name", "nope"}, {"value", 1}}, json{{"request", "dance"}},
        json{{"request", "rollback"}}, json{{"request", "identify"}, {"module", -1}}}) {
    r = ask(bad);
    EXPECT_EQ(r["ok"], false) << bad.dump();
    EXPECT_TRUE(r.contains("error")) << bad.dump();
  }
  EXPECT_EQ(ask({{"request", "status"}})["state"], "playing");
}

// `status` says what is wrong now: a scene that failed to load is in last_error until a scene
// loads (issue 20: an old error stayed after a later success).
TEST_F(ConductorTest, AnErrorLeavesStatusOnceItsStageWorksAgain) {
  startConductor();
  waitFor([](const json& s) { return s["module_frames_sent"] == kModules; });
  EXPECT_EQ(ask({{"request", "load"}, {"scene", (folder_ / "missing.lua").string()}})["ok"], false);
  EXPECT_EQ(ask({{"request", "status"}})["last_error"]["stage"], "loading the scene");
  EXPECT_EQ(ask({{"request", "load"}, {"scene", script_}})["ok"], true);
  const json status = ask({{"request", "status"}});
  EXPECT_FALSE(status.contains("last_error")) << status.dump();
  EXPECT_EQ(status["state"], "playing");
}

TEST_F(ConductorTest, InstallerPatternsPauseAndViews) {
  startConductor();
  waitFor([](const json& s) { return s["module_frames_sent"] == kModules; });
  const std::vector<uint8_t> scene0 = daemonFrame(0), scene1 = daemonFrame(1);
  // identify 1: module 1 shows its number, the others keep the scene.
  EXPECT_EQ(ask({{"request", "identify"}, {"module", 1}})["ok"], true);
  EXPECT_EQ(ask({{"request", "status"}})["state"], "paused");
  EXPECT_EQ(daemonFrame(0), scene0);
  EXPECT_NE(daemonFrame(1), scene1);
  EXPECT_EQ(ask({{"request", "testcard"}})["ok"], true);
  EXPECT_NE(daemonFrame(0), scene0);
  // play: back to the scene, the same bytes as before.
  EXPECT_EQ(ask({{"request", "play"}})["ok"], true);
  waitFor([](const json& s) { return s["display_frames"] == 2; });
  EXPECT_EQ(daemonFrame(0), scene0);
  EXPECT_EQ(ask({{"request", "pause"}})["ok"], true);
  EXPECT_EQ(ask({{"request", "status"}})["state"], "paused");

  const json v = ask({{"request", "view"},
                      {"x", 0.25},
                      {"width", 80},
                      {"height", 45},
                      {"path", (folder_ / "v.png").string()}});
  ASSERT_EQ(v["ok"], true) << v.dump();
  const Frame view = readFrame(v["path"].get<std::string>());
  EXPECT_EQ(view.width, 80);
  EXPECT_EQ(view.height, 45);
}

TEST_F(ConductorTest, RaytexturesComeFromTheCacheTheSecondTime) {
  startConductor();
  EXPECT_EQ(ask({{"request", "status"}})["ray_textures"]["generated"], kModules);
  stopConductor();
  conductor_.reset();
  stop_ = false;
  ready_ = false;
  startConductor();
  const json status = ask({{"request", "status"}});
  EXPECT_EQ(status["ray_textures"]["from_cache"], kModules);
  EXPECT_EQ(status["ray_textures"]["generated"], 0);
}

TEST_F(ConductorTest, CancelledCalibrationKeepsTheInstalledOneAndBringsTheSceneBack) {
  // A simulator whose camera photographs a seeded ground truth of this display.
  DisplayConfig display;
  display.modules = kModules;
  display.width = kWidth;
  display.height = kHeight;
  const DisplayModel truth = makeGroundTruth(nominalDisplayOf(display), GroundTruthOptions{});
  CameraRigOptions rig;
  rig.stations = 2;
  rig.intrinsics = CameraIntrinsics::centred(240, 136, 262.0);
  const SimulatedRig camera = makeSimulatedRig(truth, rig, 3);
  camera_ = (folder_ / "camera.json").string();
  saveCameraMetadata(camera.metadata, camera_);
  sim_.reset();
  hw::SimulatedHardwareOptions o;
  o.modules = kModules;
  o.width = kWidth;
  o.height = kHeight;
  sim_ = std::make_unique<hw::InProcessSimhw>(
      o, std::make_unique<hw::CalibrationPhysics>(truth, camera.truth));
  startConductor();
  waitFor([](const json& s) { return s["module_frames_sent"] == kModules; });
  const std::vector<uint8_t> before = daemonFrame(1);
  const json statusBefore = ask({{"request", "status"}});
  EXPECT_EQ(ask({{"request", "cancel"}})["ok"], false) << "nothing runs yet";

  json reply;
  std::thread calibrating([&] { reply = ask({{"request", "calibrate"}}); });
  // Cancel once a few pictures are taken: the modules show patterns by then.
  json status;
  for (int i = 0; i < 2000; ++i) {
    status = ask({{"request", "status"}});
    const std::string stage = status["stage"];
    if (status["state"] == "calibrating" && stage.rfind("pictures: 3", 0) == 0) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(status["state"], "calibrating") << status.dump();
  const json cancelled = ask({{"request", "cancel"}});
  calibrating.join();
  EXPECT_EQ(cancelled["ok"], true) << cancelled.dump();
  EXPECT_EQ(reply["ok"], false) << reply.dump();
  EXPECT_NE(reply["error"].get<std::string>().find("cancelled"), std::string::npos) << reply.dump();

  // Nothing installed, nothing reported as a failure, and the scene is back on the modules.
  const json after = ask({{"request", "status"}});
  EXPECT_EQ(after["state"], "playing") << after.dump();
  EXPECT_EQ(after["calibration"], statusBefore["calibration"]);
  EXPECT_FALSE(after.contains("last_error")) << after.dump();
  EXPECT_FALSE(fs::exists(folder_ / "cache" / "calibration.json"));
  // The patterns replaced the scene on the modules: it is pushed again.
  waitFor([](const json& s) { return s["module_frames_sent"] >= 2 * kModules; });
  EXPECT_EQ(daemonFrame(1), before);
  stopConductor();
  sim_->stop();
  EXPECT_EQ(sim_->hardware().shownFrame(1).pixels, before);
}

// Every request is checked against the request table before it runs: unknown keys are refused
// naming the key, integers are range-checked before they are narrowed (module 4294967299 is not
// module 3, -4294967296 not module 0), and a view's size is an integer in range (issue 18,
// items 11 and 17).
TEST_F(ConductorTest, RequestsAreCheckedAgainstTheTable) {
  startConductor();
  waitFor([](const json& s) { return s["module_frames_sent"] == kModules; });
  auto refusedNaming = [&](const json& request, const std::string& key) {
    const json r = ask(request);
    EXPECT_EQ(r["ok"], false) << request.dump() << " -> " << r.dump();
    const std::string error = r.value("error", "");
    EXPECT_EQ(error.rfind(key + ":", 0), 0u) << request.dump() << " -> " << error;
  };
  const std::string out = (folder_ / "f.png").string();
  refusedNaming({{"request", "frame"}, {"module", 4294967299ull}, {"path", out}}, "module");
  refusedNaming({{"request", "frame"}, {"module", -4294967296ll}, {"path", out}}, "module");
  refusedNaming({{"request", "frame"}, {"module", 1.5}, {"path", out}}, "module");
  refusedNaming({{"request", "calibrate"}, {"module", -4294967296ll}}, "module");
  refusedNaming({{"request", "identify"}, {"module", 4294967297ull}}, "module");
  refusedNaming({{"request", "frame"}, {"module", 0}, {"pth", out}}, "pth");
  refusedNaming({{"request", "status"}, {"verbose", true}}, "verbose");
  refusedNaming({{"request", "view"}, {"x", 0.1}, {"width", 1e10}}, "width");
  refusedNaming({{"request", "view"}, {"x", 0.1}, {"width", "big"}}, "width");
  refusedNaming({{"request", "view"}, {"x", 0.1}, {"height", 4294967296ull}}, "height");
  refusedNaming({{"request", "set"}, {"name", "unused"}, {"value", "3"}}, "value");
  refusedNaming({{"request", "load"}, {"scene", "cornell"}, {"parameters", {{"a", "x"}}}},
                "parameters.a");
  refusedNaming({{"request", "dance"}}, "request");
  EXPECT_FALSE(fs::exists(out));
  EXPECT_EQ(ask({{"request", "status"}})["state"], "playing");
  EXPECT_FALSE(ask({{"request", "status"}}).contains("showing")) << "identify must not have run";

  // The error and the help list the table, all of it.
  const std::string unknown = ask({{"request", "dance"}})["error"];
  const std::string help = controlRequestHelp();
  for (const RequestSpec& spec : controlRequests()) {
    EXPECT_NE(unknown.find(std::string(spec.name)), std::string::npos) << spec.name;
    EXPECT_NE(help.find("  " + std::string(spec.name)), std::string::npos) << spec.name;
    EXPECT_TRUE(Conductor::handles(spec.name)) << spec.name;
  }
  EXPECT_EQ(controlRequests().size(), 17u);
  EXPECT_FALSE(Conductor::handles("dance"));
  EXPECT_NO_THROW(Conductor::checkEveryRequestHasAHandler());
}

// `frame` and `view` write where a client says, but never through a symlink, never into a
// folder they would have to create, never relative to the daemon's working folder (issue 18,
// item 12).
TEST_F(ConductorTest, OutputPathsDoNotFollowLinksOrCreateFolders) {
  startConductor();
  waitFor([](const json& s) { return s["module_frames_sent"] == kModules; });
  const fs::path victim = folder_ / "victim.txt";
  std::ofstream(victim) << "keep me";
  fs::create_symlink(victim, folder_ / "link.png");
  json r = ask({{"request", "frame"}, {"module", 0}, {"path", (folder_ / "link.png").string()}});
  EXPECT_EQ(r["ok"], false) << r.dump();
  EXPECT_NE(r.value("error", "").find("symbolic link"), std::string::npos) << r.dump();
  std::ifstream in(victim);
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in), {}), "keep me");

  r = ask(
      {{"request", "view"}, {"x", 0.0}, {"path", (folder_ / "no" / "such" / "v.png").string()}});
  EXPECT_EQ(r["ok"], false) << r.dump();
  EXPECT_FALSE(fs::exists(folder_ / "no"));

  r = ask({{"request", "frame"}, {"module", 0}, {"path", "relative.png"}});
  EXPECT_EQ(r["ok"], false) << r.dump();
  EXPECT_NE(r.value("error", "").find("absolute"), std::string::npos) << r.dump();
  EXPECT_FALSE(fs::exists("relative.png"));

  // A plain absolute path works, and so does the default one in the cache folder.
  r = ask({{"request", "frame"}, {"module", 0}, {"path", (folder_ / "ok.png").string()}});
  EXPECT_EQ(r["ok"], true) << r.dump();
  EXPECT_TRUE(fs::is_regular_file(folder_ / "ok.png"));
  r = ask({{"request", "frame"}, {"module", 1}});
  ASSERT_EQ(r["ok"], true) << r.dump();
  EXPECT_TRUE(fs::is_regular_file(r["path"].get<std::string>()));
  // An existing file is replaced.
  r = ask({{"request", "frame"}, {"module", 2}, {"path", (folder_ / "ok.png").string()}});
  EXPECT_EQ(r["ok"], true) << r.dump();
}

// `status` tells the truth about the link: down, with the reason, while the modules are gone;
// up again once they are back (issue 18, item 10).
TEST_F(ConductorTest, StatusSaysWhenTheLinkIsDown) {
  link_.reconnectAttempts = 2;  // a dead link is noticed in a few keep-alives
  startConductor();
  waitFor([](const json& s) { return s["module_frames_sent"] == kModules; });
  json status = ask({{"request", "status"}});
  EXPECT_EQ(status["link"]["up"], true) << status.dump();
  sim_->stop();
  for (int i = 0; i < 1000; ++i) {
    status = ask({{"request", "status"}});
    if (status["link"]["up"] == false) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(status["link"]["up"], false) << status.dump();
  EXPECT_EQ(status["link"]["health"], "down") << status.dump();
  EXPECT_FALSE(status["link"]["error"].get<std::string>().empty()) << status.dump();
  sim_->start();
  for (int i = 0; i < 1000; ++i) {
    status = ask({{"request", "status"}});
    if (status["link"]["up"] == true) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(status["link"]["up"], true) << status.dump();
  EXPECT_EQ(status["link"]["error"], "") << status.dump();
}

// A frame the link cannot deliver is re-sent on every turn until it gets through; `stats`
// counts it as one failed module frame, and the re-sends apart (issue 18, item 18).
TEST_F(ConductorTest, AFailedFrameIsCountedOnceHoweverOftenItIsResent) {
  link_.reconnectAttempts = 1;
  link_.linkDownRetryMs = 50;  // many failing re-sends while the modules are away
  startConductor();
  waitFor([](const json& s) { return s["module_frames_sent"] == kModules; });
  sim_->stop();
  // A visible edit while the modules are away: one new frame, which the link cannot deliver.
  std::string edited = kScene;
  edited.replace(edited.find("{0.1, 0.1, 0.2}"), 15, "{0.3, 0.1, 0.2}");
  writeScript(edited);
  json s = waitFor([](const json& st) { return st["failed_resends"].get<int>() >= 3 * kModules; });
  EXPECT_EQ(s["display_frames"], 2) << s.dump();
  EXPECT_EQ(s["module_frames_failed"], kModules) << s.dump();
  sim_->start();
  s = waitFor([](const json& st) { return st["module_frames_sent"] == 2 * kModules; });
  EXPECT_EQ(s["module_frames_failed"], kModules) << s.dump();
}

}  // namespace
}  // namespace parallax::daemon
