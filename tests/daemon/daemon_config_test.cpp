// parallax.toml: what a user writes is read as meant, and every mistake is refused with the
// file, the key and the line at fault.

#include "daemon/parallaxd/daemon_config.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include "daemon/parallaxd/calibration_pipeline.h"

namespace parallax::daemon {
namespace {

InputError errorOf(const std::string& text) {
  try {
    parseDaemonConfig(text, "parallax.toml");
  } catch (const InputError& e) {
    return e;
  }
  ADD_FAILURE() << "accepted:\n" << text;
  return InputError({}, "");
}

TEST(DaemonConfig, NoFileMeansDemoOnItsOwnSimulator) {
  const DaemonConfig c = parseDaemonConfig("", "empty.toml");
  EXPECT_EQ(c.display.preset, "demo");
  EXPECT_EQ(c.hardware.kind, "sim");
  EXPECT_TRUE(c.hardware.socket.empty());
  EXPECT_EQ(c.scene.script, "cornell");
  EXPECT_FALSE(c.controlSocketPath().empty());
  EXPECT_EQ(linkSpecOf(c.hardware, 16), "");  // parallaxd starts its own simulator
  EXPECT_EQ(nominalDisplayOf(c.display).modules.size(), 16u);
}

TEST(DaemonConfig, ReadsEverySection) {
  const DaemonConfig c = parseDaemonConfig(R"(
[display]
preset = "demo"
modules = 4
resolution = [64, 48]
[hardware]
kind = "usb"
vid = 0x1d50
pid = 0x6150
[hardware.modules]
"B" = 1
"A" = 0
[calibration]
file = "/var/lib/parallax/calibration.json"
camera = "camera.json"
auto = false
[scene]
script = "orbit"
fps = 24
[scene.parameters]
speed = 0.5
[daemon]
socket = "/run/parallax/ctl.sock"
cache_dir = "/var/cache/parallax"
log_level = "debug"
)",
                                           "parallax.toml");
  EXPECT_EQ(*c.display.modules, 4);
  EXPECT_EQ(*c.display.width, 64);
  const DisplayModel nominal = nominalDisplayOf(c.display);
  EXPECT_EQ(nominal.modules.size(), 4u);
  EXPECT_EQ(nominal.modules[0].width, 64);
  EXPECT_EQ(linkSpecOf(c.hardware, 2), "usb:1d50:6150:A,B");
  EXPECT_FALSE(c.calibration.autoCalibrate);
  EXPECT_EQ(c.calibrationFilePath(), "/var/lib/parallax/calibration.json");
  EXPECT_DOUBLE_EQ(c.scene.fps, 24.0);
  EXPECT_DOUBLE_EQ(c.scene.parameters.at("speed"), 0.5);
  EXPECT_EQ(c.controlSocketPath(), "/run/parallax/ctl.sock");
  EXPECT_EQ(c.logLevel, "debug");
}

TEST(DaemonConfig, ErrorsNameTheKeyAndTheLine) {
  struct Case {
    std::string text, key;
    int line;
  };
  const std::vector<Case> cases = {
      {"[scene]\nfps = \"fast\"\n", "scene.fps", 2},
      {"[scene]\n\nfps = 1000\n", "scene.fps", 3},
      {"[display]\npreset = \"huge\"\n", "display.preset", 2},
      {"[display]\nresolution = [64]\n", "display.resolution", 2},
      {"[hardware]\nkind = \"serial\"\n", "hardware.kind", 2},
      {"[hardware]\nkind = \"sim\"\nvid = 1\n", "hardware.vid", 3},
      {"[hardware]\nkind = \"usb\"\nvid = 1\n", "hardware.pid", 2},
      {"[daemon]\nlog_level = \"loud\"\n", "daemon.log_level", 2},
      {"[daemon]\nsokcet = \"/tmp/x\"\n", "daemon.sokcet", 2},  // a typo is not silently ignored
      {"[scene]\nscript = \"cornell\"\n[scene.parameters]\ndepth = \"deep\"\n",
       "scene.parameters.depth", 4},
      {"[calibration]\nauto = 1\n", "calibration.auto", 2},
      {"[panel]\naddress = \"localhost\"\n", "panel.address", 2},  // an address, not a name
      {"[panel]\nenabled = true\nport = 70000\n", "panel.port", 3},
      {"[panel]\nprot = 8000\n", "panel.prot", 2},
      {"title = \"x\"\n", "title", 1},
      {"[hardware]\nkind = \"usb\"\nvid = 1\npid = 2\n[hardware.modules]\nA = 0\nB = 1\nC = 0\n",
       "hardware.modules.\"C\"", 8},  // two devices mapped to one module
      {"[link]\nack_timeout_ms = 0\n", "link.ack_timeout_ms", 2},
      {"[link]\nstall_limit_ms = \"3 s\"\n", "link.stall_limit_ms", 2},
      {"[link]\nstall_limt_ms = 3000\n", "link.stall_limt_ms", 2},
      {"[link]\nconnect_timeout_ms = 0\n", "link.connect_timeout_ms", 2},
      {"[link]\ndown_retry_budget_ms = 0\n", "link.down_retry_budget_ms", 2},
      {"[link]\nlink_down_retry_ms = 5000\nlink_down_retry_max_ms = 2000\n",
       "link.link_down_retry_max_ms", 3},  // the pauses grow: the most below the first
  };
  for (const Case& c : cases) {
    const InputError e = errorOf(c.text);
    EXPECT_EQ(e.location().file, "parallax.toml") << c.text;
    EXPECT_EQ(e.location().field, c.key) << c.text << " -> " << e.what();
    EXPECT_EQ(e.location().line, c.line) << c.text << " -> " << e.what();
  }
}

// [link]: the link's timeouts reach LinkOptions; omitted keys keep its defaults.
TEST(DaemonConfig, LinkTimeoutsAreRead) {
  const DaemonConfig defaults = parseDaemonConfig("", "parallax.toml");
  EXPECT_TRUE(defaults.link == hw::LinkOptions{});
  const DaemonConfig c = parseDaemonConfig(
      "[link]\nack_timeout_ms = 500\nmax_retries = 1\nstall_limit_ms = 1500\n"
      "capture_timeout_ms = 60000\nreconnect_attempts = 2\nreconnect_delay_ms = 10\n"
      "link_down_retry_ms = 200\nlink_down_retry_max_ms = 4000\nconnect_timeout_ms = 5000\n"
      "down_retry_budget_ms = 250\npatch_frames = false\n",
      "parallax.toml");
  EXPECT_EQ(c.link.ackTimeoutMs, 500);
  EXPECT_EQ(c.link.maxRetries, 1);
  EXPECT_EQ(c.link.stallLimitMs, 1500);
  EXPECT_EQ(c.link.captureTimeoutMs, 60000);
  EXPECT_EQ(c.link.reconnectAttempts, 2);
  EXPECT_EQ(c.link.reconnectDelayMs, 10);
  EXPECT_EQ(c.link.linkDownRetryMs, 200);
  EXPECT_EQ(c.link.linkDownRetryMaxMs, 4000);
  EXPECT_EQ(c.link.connectTimeoutMs, 5000);
  EXPECT_EQ(c.link.downRetryBudgetMs, 250);
  EXPECT_FALSE(c.link.patchFrames);
  EXPECT_TRUE(defaults.link.patchFrames);
  EXPECT_EQ(c.link.chunkSize, hw::LinkOptions{}.chunkSize);
  // A change needs a restart (the link is made once).
  EXPECT_EQ(sectionsNeedingRestart(defaults, c), std::vector<std::string>{"link"});
  // A default that no longer fits a key the file sets is named too.
  const InputError e = errorOf("[link]\nlink_down_retry_ms = 20000\n");
  EXPECT_EQ(e.location().file, "parallax.toml");
  EXPECT_EQ(e.location().field, "link.link_down_retry_max_ms") << e.what();
}

TEST(DaemonConfig, ThePanelIsOnAndOnLoopbackUnlessConfigured) {
  const DaemonConfig defaults = parseDaemonConfig("", "parallax.toml");
  EXPECT_TRUE(defaults.panel.enabled);
  EXPECT_EQ(defaults.panel.address, "127.0.0.1");
  EXPECT_EQ(defaults.panel.port, 8470);
  const DaemonConfig c =
      parseDaemonConfig("[panel]\nenabled = false\naddress = \"::1\"\nport = 0\n", "parallax.toml");
  EXPECT_FALSE(c.panel.enabled);
  EXPECT_EQ(c.panel.address, "::1");
  EXPECT_EQ(c.panel.port, 0);
  // Its own section for a reload: the panel is rebuilt with the pipeline.
  EXPECT_EQ(sectionsNeedingRestart(defaults, c), std::vector<std::string>{"panel"});
  // The token lives with the installed calibration (the state folder).
  const DaemonConfig state = parseDaemonConfig(
      "[calibration]\nfile = \"/var/lib/parallax/calibration.json\"\n", "parallax.toml");
  EXPECT_EQ(state.stateDirPath(), "/var/lib/parallax");
  // So do the reports it links, unless the config names their folder.
  EXPECT_EQ(state.reportsDirPath(), "/var/lib/parallax/reports");
  const DaemonConfig reports = parseDaemonConfig(
      "[calibration]\nfile = \"/var/lib/parallax/calibration.json\"\n"
      "[panel]\nreports = \"/srv/reports\"\n",
      "parallax.toml");
  EXPECT_EQ(reports.reportsDirPath(), "/srv/reports");
  EXPECT_EQ(sectionsNeedingRestart(state, reports), std::vector<std::string>{"panel"});
}

TEST(DaemonConfig, SyntaxErrorsNameTheLine) {
  const InputError e = errorOf("[scene]\nfps = 30\nscript = \"cornell\n");
  EXPECT_EQ(e.location().line, 3) << e.what();
}

TEST(DaemonConfig, SerialMapErrorsFoundAgainstTheDisplayNameTheFileAndLine) {
  const DaemonConfig c = parseDaemonConfig(
      "[hardware]\nkind = \"usb\"\nvid = 1\npid = 2\n[hardware.modules]\nA = 0\nB = 5\n",
      "parallax.toml");
  try {
    linkSpecOf(c.hardware, 2);
    FAIL() << "module 5 of a 2-module display was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.location().file, "parallax.toml");
    EXPECT_EQ(e.location().line, 7) << e.what();
    EXPECT_NE(std::string(e.what()).find("\"B\""), std::string::npos) << e.what();
  }
}

TEST(DaemonConfig, SerialMapMustCoverEveryModuleOnce) {
  HardwareConfig h;
  h.kind = "usb";
  h.vid = 1;
  h.pid = 2;
  h.serialToModule = {{"A", 0}, {"B", 0}};
  EXPECT_THROW(linkSpecOf(h, 2), InputError);
  h.serialToModule = {{"A", 0}};
  EXPECT_THROW(linkSpecOf(h, 2), InputError);
  h.serialToModule = {{"A", 0}, {"B", 5}};
  EXPECT_THROW(linkSpecOf(h, 2), InputError);
}

TEST(DaemonConfig, MissingFileIsNamed) {
  try {
    loadDaemonConfig("/nonexistent/parallax.toml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.location().file, "/nonexistent/parallax.toml");
  }
}

// A config that is a FIFO would block the daemon's start or a reload for ever: refused at once.
TEST(DaemonConfig, OnlyARegularFileIsReadAsTheConfig) {
  const std::string fifo = ::testing::TempDir() + "parallax_config_fifo.toml";
  ::unlink(fifo.c_str());
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  for (const std::string& path : {fifo, ::testing::TempDir(), std::string("/dev/zero")}) {
    try {
      loadDaemonConfig(path);
      ADD_FAILURE() << path << " was read as a config";
    } catch (const InputError& e) {
      EXPECT_EQ(e.location().file, path) << e.what();
    }
  }
  ::unlink(fifo.c_str());
}

// A reload restarts the daemon for every change it cannot apply in place, found by comparing
// whole sections: fields that were once compared one by one (seed, faults, the serial map)
// restart it too, and what is applied in place (scene, camera, log level) does not.
TEST(DaemonConfig, ReloadRestartsForAnyChangeOutsideTheInPlaceList) {
  const DaemonConfig running = parseDaemonConfig("[daemon]\nsocket = \"/tmp/a.sock\"\n", "a");
  auto restartFor = [&](const std::string& text) {
    return sectionsNeedingRestart(running, parseDaemonConfig(text, "b"));
  };
  const std::string socket = "[daemon]\nsocket = \"/tmp/a.sock\"\n";
  EXPECT_TRUE(restartFor(socket).empty());
  using Sections = std::vector<std::string>;
  EXPECT_EQ(restartFor(socket + "[hardware]\nseed = 8\n"), Sections{"hardware"});
  EXPECT_EQ(restartFor(socket + "[hardware]\nfaults = [\"1:disconnect\"]\n"), Sections{"hardware"});
  EXPECT_EQ(restartFor(socket + "[hardware]\ndump = \"/tmp/d\"\n"), Sections{"hardware"});
  EXPECT_EQ(restartFor(socket + "[display]\nmodules = 4\n"), Sections{"display"});
  EXPECT_EQ(restartFor(socket + "[calibration]\nfile = \"/tmp/c.json\"\n"),
            Sections{"calibration"});
  EXPECT_EQ(restartFor("[daemon]\nsocket = \"/tmp/b.sock\"\n"), Sections{"daemon"});
  // In place: nothing to restart for.
  EXPECT_TRUE(restartFor(socket + "[calibration]\ncamera = \"/tmp/cam.json\"\nauto = false\n"
                                  "[scene]\nscript = \"shapes\"\nfps = 10\n")
                  .empty());
  EXPECT_TRUE(restartFor(socket + "log_level = \"debug\"\n").empty());
  // An omitted key and its default are the same config.
  DaemonConfig explicitCache = running;
  explicitCache.cacheDir = running.cacheDirPath();
  EXPECT_TRUE(sectionsNeedingRestart(running, explicitCache).empty());

  HardwareConfig usb;
  usb.kind = "usb";
  usb.vid = 1;
  usb.pid = 2;
  DaemonConfig a = running, b = running;
  a.hardware = b.hardware = usb;
  b.hardware.serialToModule = {{"SERIAL", 0}};
  EXPECT_EQ(sectionsNeedingRestart(a, b), Sections{"hardware"});

  const DaemonConfig applied = withInPlaceChanges(
      running, parseDaemonConfig(socket + "[calibration]\ncamera = \"/tmp/cam.json\"\n", "b"));
  EXPECT_EQ(applied.calibration.cameraMetadata, "/tmp/cam.json");
  EXPECT_EQ(applied.sourceFile, "a");
}

// A display too large to hold is refused from the config, naming the key, before anything of
// its size is allocated (issue 18, item 9).
TEST(DaemonConfig, DisplaySizeIsBoundedBeforeAllocation) {
  InputError e = errorOf("[display]\nmodules = 1024\nresolution = [8192, 8192]\n");
  EXPECT_EQ(e.location().field, "display.modules") << e.what();
  EXPECT_NE(std::string(e.what()).find("modules × resolution"), std::string::npos) << e.what();
  e = errorOf("[display]\npreset = \"default\"\nresolution = [8192, 8192]\n");
  EXPECT_EQ(e.location().field, "display.resolution") << e.what();
  // The largest built-in display fits.
  EXPECT_NO_THROW(parseDaemonConfig("[display]\npreset = \"default\"\n", "ok.toml"));
}

// [calibration] camera names the camera (camera_name.h); its metadata has its own key. The old
// form, camera = "x.json", still names the metadata; anything else is refused with its line.
TEST(DaemonConfig, CalibrationCameraByNameAndItsSettings) {
  const DaemonConfig c = parseDaemonConfig(
      "[calibration]\ncamera = \"opencv:/dev/video2\"\ncamera_metadata = \"/etc/cam.json\"\n"
      "pixel_step = 3\nallow_auto_exposure = true\nstation_command = \"rig {station}\"\n",
      "p.toml");
  EXPECT_EQ(c.calibration.cameraName, "opencv:/dev/video2");
  EXPECT_EQ(c.calibration.cameraMetadata, "/etc/cam.json");
  EXPECT_EQ(c.calibration.pixelStep, 3);
  EXPECT_TRUE(c.calibration.allowAutoExposure);
  EXPECT_EQ(c.calibration.stationCommand, "rig {station}");
  const DaemonConfig defaults = parseDaemonConfig("", "p.toml");
  EXPECT_EQ(defaults.calibration.cameraName, "link");
  const DaemonConfig old = parseDaemonConfig("[calibration]\ncamera = \"cam.json\"\n", "p.toml");
  EXPECT_EQ(old.calibration.cameraName, "link");
  EXPECT_EQ(old.calibration.cameraMetadata, "cam.json");
  for (const std::string& bad :
       {std::string("[calibration]\n\ncamera = \"webcam\"\n"),
        std::string("[calibration]\n\ncamera = \"opencv:\"\n"),
        std::string("[calibration]\n\ncamera = \"a.json\"\ncamera_metadata = \"b.json\"\n")}) {
    try {
      parseDaemonConfig(bad, "p.toml");
      ADD_FAILURE() << bad;
    } catch (const InputError& e) {
      EXPECT_EQ(e.location().field, "calibration.camera") << e.what();
      EXPECT_EQ(e.location().line, 3) << e.what();
    }
  }
  try {
    parseDaemonConfig("[calibration]\npixel_step = 0\n", "p.toml");
    ADD_FAILURE() << "pixel_step 0";
  } catch (const InputError& e) {
    EXPECT_EQ(e.location().field, "calibration.pixel_step") << e.what();
  }
  // The camera and its settings apply at the next calibration, without a restart.
  EXPECT_TRUE(sectionsNeedingRestart(defaults, c).empty());
}

// The quality gate's limits and allow_partial (issue 17): the pipeline's settings carry them,
// they apply at the next calibration, and a limit that cannot gate is refused with its line.
TEST(DaemonConfig, CalibrationGateLimits) {
  const DaemonConfig defaults = parseDaemonConfig("", "p.toml");
  const CalibrationSettings byDefault = settingsOf(defaults.calibration, false);
  EXPECT_EQ(byDefault.gate.worstPx, GateLimits{}.worstPx);
  EXPECT_EQ(byDefault.gate.worstObserverMm, GateLimits{}.worstObserverMm);
  EXPECT_FALSE(byDefault.gate.allowPartial);
  const DaemonConfig c = parseDaemonConfig(
      "[calibration]\nmax_error_px = 1.5\nmax_observer_mm = 40\nallow_partial = true\n", "p.toml");
  const CalibrationSettings set = settingsOf(c.calibration, false);
  EXPECT_EQ(set.gate.worstPx, 1.5);
  EXPECT_EQ(set.gate.worstObserverMm, 40.0);
  EXPECT_TRUE(set.gate.allowPartial);
  EXPECT_TRUE(sectionsNeedingRestart(defaults, c).empty());
  for (const auto& [bad, field] :
       {std::pair{"[calibration]\n\nmax_error_px = 0\n", "calibration.max_error_px"},
        {"[calibration]\n\nmax_observer_mm = -3\n", "calibration.max_observer_mm"},
        {"[calibration]\n\nmax_observer_mm = \"15\"\n", "calibration.max_observer_mm"},
        {"[calibration]\n\nallow_partial = 1\n", "calibration.allow_partial"}}) {
    const InputError e = errorOf(bad);
    EXPECT_EQ(e.location().field, field) << e.what();
    EXPECT_EQ(e.location().line, 3) << e.what();
  }
}

// Issue 21: the photometric calibration's switch (in place, like the camera) and the simulated
// display's photometric variation (a new simulator: a restart).
TEST(DaemonConfig, PhotometricCalibrationAndSimulatedVariation) {
  const DaemonConfig defaults = parseDaemonConfig("", "p.toml");
  EXPECT_EQ(defaults.calibration.photometric, "auto");
  EXPECT_FALSE(defaults.hardware.photometricVariation);
  const DaemonConfig c = parseDaemonConfig(
      "[hardware]\nphotometric_variation = true\n[calibration]\nphotometric = \"on\"\n", "p.toml");
  EXPECT_TRUE(c.hardware.photometricVariation);
  EXPECT_EQ(c.calibration.photometric, "on");
  EXPECT_EQ(sectionsNeedingRestart(defaults, c), std::vector<std::string>{"hardware"});
  const InputError bad = errorOf("[calibration]\n\nphotometric = \"yes\"\n");
  EXPECT_EQ(bad.location().field, "calibration.photometric") << bad.what();
  EXPECT_EQ(bad.location().line, 3) << bad.what();
  const InputError usb =
      errorOf("[hardware]\nkind = \"usb\"\nvid = 1\npid = 2\nphotometric_variation = true\n");
  EXPECT_EQ(usb.location().field, "hardware.photometric_variation") << usb.what();
}

}  // namespace
}  // namespace parallax::daemon
