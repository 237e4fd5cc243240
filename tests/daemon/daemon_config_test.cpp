// parallax.toml: what a user writes is read as meant, and every mistake is refused with the
// file, the key and the line at fault.

#include "daemon/parallaxd/daemon_config.h"

#include <gtest/gtest.h>

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
      {"title = \"x\"\n", "title", 1},
  };
  for (const Case& c : cases) {
    const InputError e = errorOf(c.text);
    EXPECT_EQ(e.location().file, "parallax.toml") << c.text;
    EXPECT_EQ(e.location().field, c.key) << c.text << " -> " << e.what();
    EXPECT_EQ(e.location().line, c.line) << c.text << " -> " << e.what();
  }
}

TEST(DaemonConfig, SyntaxErrorsNameTheLine) {
  const InputError e = errorOf("[scene]\nfps = 30\nscript = \"cornell\n");
  EXPECT_EQ(e.location().line, 3) << e.what();
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

}  // namespace
}  // namespace parallax::daemon
