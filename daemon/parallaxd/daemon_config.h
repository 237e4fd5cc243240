#pragma once
// parallaxd's configuration (parallax.toml, README "The daemon"). Every key is optional; with
// no file at all the daemon runs the built-in `demo` display on a simulator it starts itself.
//
//   [display]      preset = "demo" | "default"   or   file = "display.json"
//                  modules = 4, resolution = [128, 96]         (preset overrides, for tests)
//   [hardware]     kind = "sim" | "usb"
//                  sim: socket = "/path"  (a running parallax-simhw; omitted → parallaxd starts
//                       its own with a seeded ground truth: seed = 7; for tests also
//                       faults = ["2:disconnect"], dump = "dir" (frames the modules showed))
//                  usb: vid = 0x1d50, pid = 0x6150, [hardware.modules] "SERIAL" = index
//   [calibration]  file = "calibration.json", camera = "camera.json", auto = true
//   [scene]        script = "cornell" | "scene.lua", fps = 30, [scene.parameters] name = value
//   [daemon]       socket = "...", cache_dir = "...", log_level = "info"

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "calibration/display/display_model.h"
#include "common/input_error.h"

namespace parallax::daemon {

struct DisplayConfig {
  std::string preset = "demo";  // used when file is empty
  std::string file;
  std::optional<int> modules;
  std::optional<int> width, height;
};

struct HardwareConfig {
  std::string kind = "sim";         // "sim" or "usb"
  std::string socket;               // sim: empty → start our own parallax-simhw
  int seed = 7;                     // our own simulator's ground-truth seed
  std::vector<std::string> faults;  // our own simulator: parallax-simhw --fault specs (tests)
  std::string dump;                 // our own simulator: where it saves what the modules show
  int vid = 0, pid = 0;             // usb
  std::map<std::string, int> serialToModule;  // usb
};

struct CalibrationConfig {
  std::string file;           // the installed calibration (empty: in cache_dir)
  std::string camera;         // camera metadata (intrinsics, tape-measured stations)
  bool autoCalibrate = true;  // calibrate at start when there is no valid calibration
};

struct SceneConfig {
  std::string script = "cornell";
  double fps = 30.0;
  std::map<std::string, double> parameters;
};

struct DaemonConfig {
  std::string sourceFile;  // empty: the built-in defaults
  DisplayConfig display;
  HardwareConfig hardware;
  CalibrationConfig calibration;
  SceneConfig scene;
  std::string controlSocket;  // empty → defaultControlSocketPath()
  std::string cacheDir;       // empty → defaultCacheDir()
  std::string logLevel = "info";

  // Throws InputError naming the key (no line: values set in code).
  void validate() const;
  std::string controlSocketPath() const;
  std::string cacheDirPath() const;
  std::string calibrationFilePath() const;
};

// The nominal display the config names (a built-in preset with its overrides, or a file).
DisplayModel nominalDisplayOf(const DisplayConfig& display);

// The link the hardware section names: "usb:VID:PID:SERIAL,..." (serials in module order) or
// "simhw:PATH"; empty for a simulator parallaxd starts itself. InputError naming the key when
// the serial map does not cover modules 0..modules-1 exactly once.
std::string linkSpecOf(const HardwareConfig& hardware, int modules);

// Reads and validates a config file; throws InputError naming the file, the key and its line.
DaemonConfig loadDaemonConfig(const std::string& path);
// The same from text (tests; `name` stands for the file in errors).
DaemonConfig parseDaemonConfig(const std::string& text, const std::string& name);

// Where `parallaxd` with no config listens and `parallax ctl` looks with no argument:
// $XDG_RUNTIME_DIR/parallax/parallaxd.sock, else /tmp/parallax-$UID/parallaxd.sock.
std::string defaultControlSocketPath();
// $XDG_CACHE_HOME/parallax, else $HOME/.cache/parallax, else /tmp/parallax-$UID/cache.
std::string defaultCacheDir();

}  // namespace parallax::daemon
