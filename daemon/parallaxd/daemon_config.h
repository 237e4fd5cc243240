#pragma once
// parallaxd's configuration (parallax.toml, README "The daemon"). Every key is optional; with
// no file at all the daemon runs the built-in `demo` display on a simulator it starts itself.
//
//   [display]      preset = "demo" | "default"   or   file = "display.json"
//                  modules = 4, resolution = [128, 96]         (preset overrides, for tests)
//   [hardware]     kind = "sim" | "usb"
//                  sim: socket = "/path"  (a running parallax-simhw; omitted → parallaxd starts
//                       its own with a seeded ground truth: seed = 7; for tests also
//                       faults = ["2:disconnect"], dump = "dir" (frames the modules showed);
//                       photometric_variation = true: its modules differ in response, colour,
//                       brightness and vignetting, seeded — calibration/simulation/
//                       photometric_truth.h)
//                  usb: vid = 0x1d50, pid = 0x6150, [hardware.modules] "SERIAL" = index
//                  present_deadline_ms = 100   (swap lock: modules later than this after the
//                       push are presented without, and reported lagging in `status`)
//   [calibration]  file = "calibration.json", auto = true,   ("{rank}" in it: the rank's number)
//                  camera = "link" | "opencv:SPEC"   (hw/camera/camera_name.h; default link)
//                  camera_metadata = "camera.json"   (intrinsics, tape-measured stations)
//                  pixel_step = 4, allow_auto_exposure = false,
//                  station_command = "move-rig {station}"   (a camera not behind the link)
//                  photometric = "auto" | "on" | "off"  (calibrate the modules' colours too;
//                       auto: when our own simulator has photometric variation)
//                  max_error_px = 3.0, max_observer_mm = 15.0, allow_partial = false
//                       (the quality gate: calibration/fit/calibration_gate.h)
//                  (camera = "x.json", the old form, is read as camera_metadata)
//   [scene]        script = "cornell" | "scene.lua", fps = 30, frame_cache = true,
//                  footprint = true,
//                  [scene.parameters] name = value
//   [daemon]       socket = "...", cache_dir = "...", log_level = "info"
//   [link]         ack_timeout_ms = 2000, max_retries = 3, stall_limit_ms = 3000,
//                  capture_timeout_ms = 30000, reconnect_attempts = 5, reconnect_delay_ms = 50,
//                  link_down_retry_ms = 1000, link_down_retry_max_ms = 16000,
//                  down_retry_budget_ms = 500, connect_timeout_ms = 1000
//                       (hw/link/link_client.h, LinkOptions; hw/link/PROTOCOL.md)
//   [cluster]      modules = [[0, 1, 2], [3, 4, 5]]   (per MPI rank, the modules it renders
//                       and pushes; omitted: contiguous blocks), timeout_ms = 30000
//                       (module_ownership.h; one rank without mpirun)
//   [panel]        enabled = true, address = "127.0.0.1", port = 8470   (control_panel.h;
//                  another address than loopback only when given here; port 0: any free one)
//                  reports = "DIR"   (the `parallax report` folders the panel serves and links
//                  the latest of; default <state folder>/reports — panel_reports.h)

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "calibration/display/display_model.h"
#include "calibration/fit/calibration_gate.h"
#include "common/input_error.h"
#include "daemon/parallaxd/control_socket_path.h"
#include "hw/link/link_client.h"

namespace parallax::daemon {

struct DisplayConfig {
  std::string preset = "demo";  // used when file is empty
  std::string file;
  std::optional<int> modules;
  std::optional<int> width, height;
  bool operator==(const DisplayConfig&) const = default;
};

struct HardwareConfig {
  std::string kind = "sim";         // "sim" or "usb"
  std::string socket;               // sim: empty → start our own parallax-simhw
  int seed = 7;                     // our own simulator's ground-truth seed
  std::vector<std::string> faults;  // our own simulator: parallax-simhw --fault specs (tests)
  std::string dump;                 // our own simulator: where it saves what the modules show
  // The swap lock (hw/link/PROTOCOL.md, "Presentation"): how long after pushing a display frame
  // the modules have to acknowledge it; the late ones are presented without, and reported.
  int presentDeadlineMs = 100;
  bool photometricVariation = false;          // our own simulator: a seeded photometric truth
  int vid = 0, pid = 0;                       // usb
  std::map<std::string, int> serialToModule;  // usb
  // Where the config wrote each serial's mapping, so errors found once the display's module
  // count is known still name the file and line.
  std::string file;
  std::map<std::string, int> serialLine;
  bool operator==(const HardwareConfig&) const = default;
};

// The calibration pipeline's settings the config can change (calibration_pipeline.h has the
// defaults; settingsOf makes the pipeline's settings from these).
struct CalibrationConfig {
  std::string file;                 // the installed calibration (empty: in cache_dir)
  std::string cameraName = "link";  // the camera by name (camera_name.h)
  std::string cameraMetadata;       // camera metadata (intrinsics, tape-measured stations)
  std::optional<int> pixelStep;     // unset: the pipeline's default
  bool allowAutoExposure = false;
  std::string stationCommand;
  bool autoCalibrate = true;  // calibrate at start when there is no valid calibration
  // "on": `calibrate` also calibrates the modules' colours (photometric), "off": geometry only,
  // "auto": on when the display is our own simulator with photometric variation.
  std::string photometric = "auto";
  // The quality gate (GateLimits): every module's predicted worst ray error within these, or the
  // calibration is refused; allow_partial installs the modules that pass and names the others.
  double maxErrorPx = GateLimits{}.worstPx;
  double maxObserverMm = GateLimits{}.worstObserverMm;
  bool allowPartial = false;
  bool operator==(const CalibrationConfig&) const = default;
};

struct SceneConfig {
  std::string script = "cornell";
  double fps = 30.0;
  // Animated scenes: keep the static geometry's primary hits and shadows between frames
  // (tracer/frame_cache.h); off renders every frame in full (benchmarks compare the two).
  bool frameCache = true;
  // Animated scenes trace and encode only the pixels that can show the scene, copying the rest
  // (daemon/parallaxd/live_pixels.h); off: every pixel (benchmarks compare the two).
  bool footprint = true;
  std::map<std::string, double> parameters;
  bool operator==(const SceneConfig&) const = default;
};

// The browser control panel (control_panel.h). On by default, on the loopback address only.
struct PanelConfig {
  bool enabled = true;
  std::string address = "127.0.0.1";  // an IPv4 or IPv6 address literal
  int port = 8470;                    // 0: any free port (`parallax ctl panel` says which)
  std::string reports;                // empty: <state folder>/reports
  bool operator==(const PanelConfig&) const = default;
};

// The ranks of `mpirun -np N parallaxd` (cluster.h, module_ownership.h). Ignored by one rank.
struct ClusterConfig {
  // Per rank, the modules its link reaches; empty: contiguous blocks in module order.
  std::vector<std::vector<int>> modules;
  // Rank 0 waits this long for a rank's answer (after its own part of the frame) before it ends
  // the job naming that rank and its modules.
  int timeoutMs = 30000;
  std::string file;  // where `modules` was written: errors found once the rank count is known
  int line = 0;
  bool operator==(const ClusterConfig&) const = default;
};

struct DaemonConfig {
  std::string sourceFile;  // empty: the built-in defaults
  DisplayConfig display;
  HardwareConfig hardware;
  CalibrationConfig calibration;
  SceneConfig scene;
  PanelConfig panel;
  ClusterConfig cluster;
  hw::LinkOptions link;       // the link's timeouts and retries ([link])
  std::string controlSocket;  // empty → defaultControlSocketPath()
  std::string cacheDir;       // empty → defaultCacheDir()
  std::string logLevel = "info";
  bool operator==(const DaemonConfig&) const = default;

  // Throws InputError naming the key (no line: values set in code).
  void validate() const;
  std::string controlSocketPath() const;
  std::string cacheDirPath() const;
  std::string calibrationFilePath() const;
  // The calibration file of one rank of a cluster: calibrationFilePath() with "{rank}" replaced
  // by its number, for ranks that share a filesystem but keep a file each, as separate nodes do.
  std::string calibrationFileOfRank(int rank) const;
  // The daemon's state: the installed calibration's folder (/var/lib/parallax as installed).
  std::string stateDirPath() const;
  // The folder of `parallax report` folders the panel serves (panel_reports.h).
  std::string reportsDirPath() const;
};

// What a running daemon takes from a reloaded config without being built again: the scene and
// its parameters, the calibration camera and its settings (all but the file), auto-calibrate,
// the log level (one list, in daemon_config.cpp). Any other difference needs a restart.
//
// The sections ("display", "hardware", "calibration", "panel", "daemon") in which `next` differs
// from `running` in something that needs a restart. Whole sections are compared (paths as
// resolved), so a field added later restarts the daemon unless it joins the in-place list.
std::vector<std::string> sectionsNeedingRestart(const DaemonConfig& running,
                                                const DaemonConfig& next);
// `running` with the in-place fields of `next`.
DaemonConfig withInPlaceChanges(const DaemonConfig& running, const DaemonConfig& next);

// The most pixels all modules together may have: what the frames, the ray textures and their
// cache cost grows with (the `default` display has 72 × 1024×768 = 57 M).
constexpr long long kMaxDisplayPixels = 128ll * 1024 * 1024;
constexpr int kMaxDisplayModules = 1024;

// The nominal display the config names (a built-in preset with its overrides, or a file).
// Throws InputError naming the key (display.modules, display.resolution, display.file) when
// the display is larger than the limits above, before anything of its size is allocated.
DisplayModel nominalDisplayOf(const DisplayConfig& display);

// The link the hardware section names: "usb:VID:PID:SERIAL,..." (serials in module order) or
// "simhw:PATH"; empty for a simulator parallaxd starts itself. InputError naming the key when
// the serial map does not cover modules 0..modules-1 exactly once.
std::string linkSpecOf(const HardwareConfig& hardware, int modules);

// Reads and validates a config file; throws InputError naming the file, the key and its line.
DaemonConfig loadDaemonConfig(const std::string& path);
// The same from text (tests; `name` stands for the file in errors).
DaemonConfig parseDaemonConfig(const std::string& text, const std::string& name);

// $XDG_CACHE_HOME/parallax, else $HOME/.cache/parallax, else /tmp/parallax-$UID/cache.
std::string defaultCacheDir();

}  // namespace parallax::daemon
