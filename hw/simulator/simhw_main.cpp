// parallax-simhw: simulated optical modules and a calibration camera behind the link protocol,
// served on a Unix socket (DESIGN.md, "Processes and interfaces").
//
//   parallax-simhw --socket /tmp/simhw.sock [--display demo|default|file.json]
//                  [--modules N --resolution WxH] [--fault 3:drop:2 ...] [--dump DIR]
//                  [--truth ground_truth.json --camera camera_truth.json
//                   [--photometric-truth photometric_truth.json]]
// With --truth and --camera (the files `parallax simulate` writes) the camera photographs the
// ground-truth display from its true pose at the requested station
// (hw/simulator/calibration_physics.h); the modules are then the truth's. With
// --photometric-truth they also show their light as that truth says (response, black,
// primaries, falloff), and the camera answers colour captures in colour.
// With --link-modules (one rank's simulator in a cluster, issue 23) the link serves only those
// modules of the truth (display indices, in that order); with --room the camera also sees the
// other modules, as the other ranks' simulators write them there (hw/simulator/shared_room.h).

#include <fmt/format.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>

#include "calibration/display/display_model_json.h"
#include "calibration/display/display_presets.h"
#include "calibration/simulation/camera_truth.h"
#include "common/input_error.h"
#include "common/version.h"
#include "common/width_height.h"
#include "hw/simulator/calibration_physics.h"
#include "hw/simulator/camera_feed.h"
#include "hw/simulator/fault_spec.h"
#include "hw/simulator/shared_room.h"
#include "hw/simulator/simhw_server.h"
#include "hw/simulator/simulated_hardware.h"

namespace {

std::atomic<bool> gStop{false};
void onSignal(int) { gStop.store(true); }

struct Args {
  std::string socket;
  std::string display;
  int modules = 0;
  std::string resolution;
  std::vector<std::string> faults;
  std::string dump;
  std::string truth, camera, photometricTruth;
  std::vector<int> linkModules;
  std::string room;
  std::string cameraFeed, cameraFeedStation;
  bool cameraFeedAutoExposure = false;
  uint32_t maxChunk = 4u << 20;
  bool exitWithParent = false;
};

int run(const Args& args) {
  using namespace parallax;
  hw::SimulatedHardwareOptions options;
  options.maxChunkSize = args.maxChunk;
  if (!args.photometricTruth.empty() && args.truth.empty()) {
    throw InputError({"", "--photometric-truth", 0}, "needs --truth and --camera");
  }
  if (args.truth.empty() != args.camera.empty()) {
    throw InputError({"", args.truth.empty() ? "--truth" : "--camera", 0},
                     "the calibration physics needs both --truth and --camera");
  }
  std::unique_ptr<hw::CameraPhysics> physics;
  std::shared_ptr<hw::SharedRoom> room;
  std::string displaySource = args.display;
  std::optional<DisplayModel> truth;
  if (!args.truth.empty()) {
    if (!args.display.empty())
      throw InputError({"", "--display", 0}, "not with --truth: the modules are the truth's");
    truth = loadDisplayModel(args.truth);
    displaySource = args.truth;
  }
  if ((!args.linkModules.empty() || !args.room.empty()) && !truth) {
    throw InputError({"", args.room.empty() ? "--link-modules" : "--room", 0},
                     "needs the calibration physics (--truth, --camera)");
  }
  if (!args.room.empty() && args.linkModules.empty())
    throw InputError({"", "--room", 0}, "needs --link-modules (which modules are this one's)");
  if (!args.cameraFeed.empty() && !args.linkModules.empty())
    throw InputError({"", "--camera-feed", 0}, "not with --link-modules");
  if (!displaySource.empty()) {
    const DisplayModel model = truth ? *truth : resolveDisplay(displaySource);
    options.modules = static_cast<int>(model.modules.size());
    if (!args.linkModules.empty()) options.modules = static_cast<int>(args.linkModules.size());
    std::vector<bool> seen(model.modules.size(), false);
    for (int m : args.linkModules) {
      if (m < 0 || m >= static_cast<int>(model.modules.size()) || seen[static_cast<size_t>(m)]) {
        throw InputError({"", "--link-modules", 0},
                         fmt::format("module {}: not a module of {} (0..{}), or given twice", m,
                                     displaySource, model.modules.size() - 1));
      }
      seen[static_cast<size_t>(m)] = true;
    }
    options.width = model.modules.front().width;
    options.height = model.modules.front().height;
    for (size_t i = 0; i < model.modules.size(); ++i) {
      if (model.modules[i].width != options.width || model.modules[i].height != options.height) {
        throw InputError({displaySource, fmt::format("modules[{}].width", i), 0},
                         "parallax-simhw needs every module at the same resolution");
      }
    }
  }
  if (args.modules > 0) options.modules = args.modules;
  if (!args.resolution.empty()) {
    const WidthHeight size = parseWidthHeight(args.resolution, "--resolution");
    options.width = size.width;
    options.height = size.height;
  }
  if (truth) {
    if (args.modules > 0 || !args.resolution.empty()) {
      throw InputError({"", "--modules", 0}, "not with --truth: the modules are the truth's");
    }
    std::optional<PhotometricTruth> photometry;
    if (!args.photometricTruth.empty()) photometry = loadPhotometricTruth(args.photometricTruth);
    physics = std::make_unique<hw::CalibrationPhysics>(*truth, loadCameraTruth(args.camera),
                                                       std::move(photometry));
    if (!args.linkModules.empty()) {
      // A rank's simulator: its link's modules are some of the display's; the camera sees the
      // rest in the room (or dark, without one).
      room = std::make_shared<hw::SharedRoom>(args.room.empty() ? std::string() : args.room,
                                              args.linkModules);
      physics = std::make_unique<hw::RoomPhysics>(std::move(physics),
                                                  static_cast<int>(truth->modules.size()), room);
    }
  }
  if (!args.cameraFeed.empty() && !truth) {
    throw InputError({"", "--camera-feed", 0}, "needs the calibration physics (--truth, --camera)");
  }
  hw::SimulatedHardware hardware(options, std::move(physics));
  if (room && !args.room.empty()) {
    hardware.setOnShown([&hardware, &room] { room->update(hardware); });
    hardware.setOnModeChanged([&hardware, &room] { room->update(hardware); });
  }
  std::unique_ptr<hw::CameraFeed> feed;
  if (!args.cameraFeed.empty()) {
    feed = std::make_unique<hw::CameraFeed>(
        hw::CameraFeedOptions{args.cameraFeed, args.cameraFeedStation, args.cameraFeedAutoExposure},
        std::make_unique<hw::CalibrationPhysics>(*truth, loadCameraTruth(args.camera)));
    const auto showFeed = [&hardware, &feed] {
      std::vector<hw::Image> frames;
      for (int i = 0; i < hardware.moduleCount(); ++i) frames.push_back(hardware.shownFrame(i));
      feed->shown(std::move(frames));
    };
    hardware.setOnShown(showFeed);
    showFeed();  // a camera gives pictures before anything is shown: the dark screen
  }
  for (const std::string& text : args.faults) {
    const hw::FaultSpec spec = hw::parseFaultSpec(text);
    if (spec.module >= hardware.moduleCount()) {
      throw InputError({"", "--fault", 0}, fmt::format("\"{}\": no module {} (there are {})", text,
                                                       spec.module, hardware.moduleCount()));
    }
    hardware.arm(spec.module, spec.fault);
  }

  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  std::signal(SIGPIPE, SIG_IGN);
  // Started by parallaxd: stop with it even when it is killed outright (SIGKILL, a crash), so no
  // simulator is left running that nothing will ever stop.
  if (args.exitWithParent) {
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (::getppid() == 1) gStop.store(true);  // the parent died before prctl
  }
  std::fprintf(stderr, "parallax-simhw: %d modules of %dx%d on %s%s\n", hardware.moduleCount(),
               options.width, options.height, args.socket.c_str(),
               truth ? " (camera: calibration physics of the ground truth)" : "");
  hw::SimhwServer server(hardware);
  const hw::ConnectionEnd end = server.listenAndServe(args.socket, gStop);
  if (end == hw::ConnectionEnd::kCrashRequested) std::abort();

  if (!args.dump.empty()) {
    std::filesystem::create_directories(args.dump);
    int written = 0;
    for (int i = 0; i < hardware.moduleCount(); ++i) {
      if (hardware.shownFrame(i).empty()) continue;
      hw::writePng(hardware.shownFrame(i), fmt::format("{}/module_{:03d}.png", args.dump, i));
      ++written;
    }
    // The swap lock's record: when each module switched to which display frame.
    hardware.writePresents(args.dump + "/presents.tsv");
    std::fprintf(stderr, "parallax-simhw: wrote %d frames and presents.tsv to %s\n", written,
                 args.dump.c_str());
  }
  for (int i = 0; i < hardware.moduleCount(); ++i) {
    const hw::ModuleCounters& c = hardware.counters(i);
    if (c.framesRejected || c.chunksDropped || c.bytesFlipped || c.acksStalled) {
      std::fprintf(stderr,
                   "parallax-simhw: module %d: %llu shown, %llu rejected, %llu chunks dropped, "
                   "%llu flipped, %llu acks stalled\n",
                   i, static_cast<unsigned long long>(c.framesShown),
                   static_cast<unsigned long long>(c.framesRejected),
                   static_cast<unsigned long long>(c.chunksDropped),
                   static_cast<unsigned long long>(c.bytesFlipped),
                   static_cast<unsigned long long>(c.acksStalled));
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"parallax-simhw: simulated optical modules and calibration camera",
               "parallax-simhw"};
  app.footer("Exit codes: 0 stopped cleanly, 1 runtime failure, 2 usage error.");
  const std::string describe = parallax::parallaxGitDescribe();
  app.set_version_flag("--version",
                       "parallax-simhw " + parallax::parallaxVersion() +
                           (describe.empty() ? "" : " (" + describe + ")"),
                       "print the version and exit");
  Args args;
  app.add_option("--socket", args.socket, "Unix socket path to listen on")->required();
  app.add_option("--display", args.display, "display model (demo, default or a JSON file)");
  app.add_option("--modules", args.modules, "number of modules (overrides --display)");
  app.add_option("--resolution", args.resolution, "module resolution WIDTHxHEIGHT");
  app.add_option("--fault", args.faults, "inject MODULE:KIND[:COUNT[:PARAM]] (repeatable)");
  app.add_option("--dump", args.dump, "on exit, save each module's last frame as PNG here");
  app.add_option("--truth", args.truth,
                 "ground-truth display for the camera's calibration physics (with --camera)");
  app.add_option("--camera", args.camera,
                 "camera truth (camera_truth.json: intrinsics, true station poses, sensor)");
  app.add_option("--camera-feed", args.cameraFeed,
                 "with --truth/--camera: also write the camera's picture of what the modules show "
                 "to this PNG whenever it changes (a streaming camera's source)");
  app.add_option("--camera-feed-station", args.cameraFeedStation,
                 "the file naming the feed camera's station (default: station 0)");
  app.add_flag("--camera-feed-auto-exposure", args.cameraFeedAutoExposure,
               "the feed camera's exposure follows the scene, lagging a picture");
  app.add_option("--photometric-truth", args.photometricTruth,
                 "the modules' photometric truth (photometric_truth.json; with --truth)");
  app.add_option("--link-modules", args.linkModules,
                 "with --truth: the link serves only these modules of it (display indices, in "
                 "order): one rank's simulator in a cluster")
      ->delimiter(',');
  app.add_option("--room", args.room,
                 "with --link-modules: the folder where the simulators of one display share what "
                 "their modules show, so that each camera sees every module");
  app.add_option("--max-chunk", args.maxChunk, "largest chunk the modules accept (bytes)");
  app.add_flag("--exit-with-parent", args.exitWithParent,
               "stop when the process that started this one ends (parallaxd's own simulator)");
  try {
    app.parse(argc, argv);
    return run(args);
  } catch (const CLI::Success& e) {
    return app.exit(e);  // --help, --version
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return 2;  // a usage error, as every Parallax program (README, "Exit codes")
  } catch (const std::exception& e) {
    std::fprintf(stderr, "parallax-simhw: %s\n", e.what());
    return 1;
  }
}
