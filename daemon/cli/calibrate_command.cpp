// parallax calibrate --captures DIR --nominal FILE|default|demo --out calib.json
// parallax calibrate --link auto|simhw:SOCKET --camera-metadata camera.json --nominal ...
//                    --out calib.json [--camera link|opencv:SPEC|folder:DIR
//                    [--allow-auto-exposure] [--station-command CMD]] [--stations 0,2,4]
//                    [--save-captures DIR]
// parallax calibrate --camera folder:DIR --camera-metadata camera.json --nominal ... --out ...
//                    (offline: the pictures taken by hand earlier, every one in DIR)
//        common:     [--report] [--truth gt.json [--camera-truth camera_truth.json]] [--transfer
//        conical|linear]
//                    [--threads N] [--pixel-step N]
// Fits the display to a calibration session — never its ground truth —, starting from the
// nominal display, through the same pipeline as parallaxd (daemon/parallaxd/
// calibration_pipeline.h: one set of defaults, one store). The session is either a captures folder
// (calibration_captures.h: the pictures, patterns.json and camera.json, decoded here; or
// decoded.json from `parallax simulate --synthetic`) or taken now through the link: the modules
// show the patterns, the camera (described by camera.json: intrinsics, response, tape-measured
// stations) photographs them at every station (hw/camera/calibration_capture.h) with the camera
// --camera names. A captures folder with checkerboard pictures (checkerboard_captures.h) gives the
// camera's intrinsics first (cv::calibrateCamera); without them camera.json's intrinsics are used.
// The result is written atomically (temporary file, then rename) and the previous calibration is
// kept as calib.json.previous; a calibration that fails its own quality checks is not installed.
// --truth adds error-against-truth columns to the report, and the camera's (camera_truth.json
// beside it, or --camera-truth) to the checkerboard calibration's; the fit never sees them.

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <atomic>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <iostream>
#include <memory>
#include <set>

#include "calibration/camera/observations_json.h"
#include "calibration/capture/calibration_captures.h"
#include "calibration/capture/checkerboard_calibration.h"
#include "calibration/display/display_model_json.h"
#include "calibration/display/display_presets.h"
#include "calibration/display/ray_error.h"
#include "calibration/fit/display_fit.h"
#include "calibration/fit/fit_report.h"
#include "calibration/simulation/camera_truth.h"
#include "common/input_error.h"
#include "daemon/cli/calibrate_progress.h"
#include "daemon/cli/commands.h"
#include "daemon/parallaxd/calibration_pipeline.h"
#include "daemon/parallaxd/calibration_store.h"
#include "hw/camera/calibration_capture.h"
#include "hw/camera/camera_name.h"
#include "hw/link/link_client.h"
#include "hw/link/link_factory.h"

namespace parallax::cli {
namespace {

// Ctrl-C or SIGTERM while calibrating: the pictures and the fit stop at their next step, so the
// modules are handed back in playback mode and the camera unlocked (killed outright, a real
// display would be left showing a pattern), and nothing is installed.
std::atomic<bool> gInterrupted{false};
static_assert(std::atomic<bool>::is_always_lock_free, "set from a signal handler");
extern "C" void onInterrupt(int) { gInterrupted.store(true); }

class InterruptStopsCalibration {
 public:
  InterruptStopsCalibration() {
    gInterrupted = false;
    previousInt_ = std::signal(SIGINT, onInterrupt);
    previousTerm_ = std::signal(SIGTERM, onInterrupt);
  }
  ~InterruptStopsCalibration() {
    std::signal(SIGINT, previousInt_);
    std::signal(SIGTERM, previousTerm_);
  }
  InterruptStopsCalibration(const InterruptStopsCalibration&) = delete;
  InterruptStopsCalibration& operator=(const InterruptStopsCalibration&) = delete;

 private:
  void (*previousInt_)(int);
  void (*previousTerm_)(int);
};

struct CalibrateArgs {
  std::string captures;
  std::string link;
  std::string saveCaptures;
  std::string nominal = "demo";
  std::string out;
  bool report = false;
  std::string truth;
  std::string cameraTruth;
  std::string transfer;
  std::string photometric = "off";  // --photometric (only), --photometric=on
  // The pipeline's own defaults, changed by the flags.
  daemon::CalibrationSettings settings;
};

// Asks the operator at the terminal to move the camera to a station (no rig command given).
void promptForStation(const CameraMetadata& camera, int station) {
  const CameraStation& s = camera.stations.at(static_cast<size_t>(station));
  std::cout << fmt::format(
                   "move the camera to station {} (x {:.3f} m, y {:.3f} m, z {:.3f} m), aim it at "
                   "the screen centre and press Enter",
                   station, s.tapeCentre.x(), s.tapeCentre.y(), s.tapeCentre.z())
            << std::flush;
  std::string line;
  if (!std::getline(std::cin, line))
    throw std::runtime_error(fmt::format("station {}: no answer on the terminal", station));
}

// A ground truth must describe the same display as the nominal: checked before the fit, so a
// wrong file costs nothing.
void requireMatchingTruth(const DisplayModel& truth, const DisplayModel& nominal,
                          const std::string& path) {
  if (truth.modules.size() != nominal.modules.size()) {
    throw InputError({path, "modules", 0},
                     fmt::format("the ground truth has {} modules, the nominal display {}",
                                 truth.modules.size(), nominal.modules.size()));
  }
  for (size_t m = 0; m < truth.modules.size(); ++m) {
    if (truth.modules[m].width != nominal.modules[m].width ||
        truth.modules[m].height != nominal.modules[m].height) {
      throw InputError({path, fmt::format("modules[{}]", m), 0},
                       fmt::format("{}x{} pixels, the nominal's module has {}x{}",
                                   truth.modules[m].width, truth.modules[m].height,
                                   nominal.modules[m].width, nominal.modules[m].height));
    }
  }
}

// Captures of another display must not be fitted to this nominal (a 4-module session against
// a 6-module nominal would leave two modules never seen and install nonsense): the modules the
// session shows must be exactly the nominal's, named with both counts.
void requireModulesOfNominal(const std::set<int>& shown, const DisplayModel& nominal,
                             const std::string& file, const char* field) {
  const int expected = static_cast<int>(nominal.modules.size());
  const bool all = static_cast<int>(shown.size()) == expected && !shown.empty() &&
                   *shown.begin() == 0 && *shown.rbegin() == expected - 1;
  if (all) return;
  std::vector<int> missing;
  for (int m = 0; m < expected; ++m)
    if (!shown.count(m)) missing.push_back(m);
  throw InputError(
      {file, field, 0},
      fmt::format("the captures show {} modules ({}) but the nominal display \"{}\" has {}{}: "
                  "captures of a different display?",
                  shown.size(),
                  shown.empty() ? std::string("none")
                                : fmt::format("{}..{}", *shown.begin(), *shown.rbegin()),
                  nominal.name, expected,
                  missing.empty() ? std::string()
                                  : fmt::format(" (never shown: {})", fmt::join(missing, ", "))));
}

// The observations of the session and the file to blame for bad data in them.
// The stages `parallax calibrate` will go through, for CalibrateProgress's count.
int stagesOf(const CalibrateArgs& args) {
  namespace fs = std::filesystem;
  if (args.captures.empty()) return args.saveCaptures.empty() ? 3 : 4;  // capture, (save,) ...
  if (!fs::exists(args.captures + "/patterns.json") && fs::exists(args.captures + "/decoded.json"))
    return 2;                                                              // load, fit
  return fs::exists(args.captures + "/" + kCheckerboardFileName) ? 4 : 3;  // load, (camera,) ...
}

// Through the link, the link stays open in `link` for the photometric stage.
CalibrationObservations sessionObservations(const CalibrateArgs& args, const DisplayModel& nominal,
                                            const CameraIntrinsics* cameraTruth,
                                            CalibrateProgress& stages, std::string* source,
                                            std::unique_ptr<hw::LinkClient>* link,
                                            daemon::PipelineProgress* linkProgress) {
  namespace fs = std::filesystem;
  if (!args.captures.empty()) {
    if (!fs::exists(args.captures + "/patterns.json") &&
        fs::exists(args.captures + "/decoded.json")) {
      *source = args.captures + "/decoded.json";
      stages.plain("load the decoded correspondences (no pictures): " + *source);
      CalibrationObservations observations = loadObservations(args.captures);
      stages.end();
      std::set<int> shown;
      for (const Correspondence& c : observations.correspondences) shown.insert(c.module);
      requireModulesOfNominal(shown, nominal, *source, "correspondences");
      return observations;
    }
    *source = args.captures + "/patterns.json";
    stages.plain("load the pictures: " + args.captures);
    CalibrationCaptures captures = loadCaptures(args.captures);
    std::set<int> shown;
    for (const StationCaptures& station : captures.stations)
      shown.insert(station.group.begin(), station.group.end());
    requireModulesOfNominal(shown, nominal, *source, "stations[].group");
    if (captures.checkerboard) {
      try {
        stages.plain(fmt::format("camera intrinsics: {} checkerboard pictures",
                                 captures.checkerboard->pictures.size()));
        const CheckerboardCalibration camera = calibrateCapturesCamera(&captures);
        stages.end();
        std::cout << formatCheckerboardCalibration(camera, cameraTruth);
      } catch (const InputError& e) {
        throw e.location().file.empty() ? e.inFile(args.captures + "/" + kCheckerboardFileName) : e;
      }
    } else {
      stages.end();
      std::cout << "camera intrinsics from camera.json (no checkerboard pictures)\n";
    }
    try {
      return daemon::decodePictures(captures, nominal, args.settings, stages.decode());
    } catch (const InputError& e) {
      throw e.location().file.empty() ? e.inFile(*source) : e;
    }
  }
  *source = args.settings.cameraMetadata;
  const CameraMetadata camera = loadCameraMetadata(args.settings.cameraMetadata);
  // Without --link, a folder: camera's pictures taken earlier (runCalibrate allows no other).
  const bool offline = args.link.empty();
  requireKnownIntrinsics(camera, args.settings.cameraMetadata,
                         offline ? "calibrating from a folder" : "calibrating through the link");
  if (!offline) {
    hw::LinkSelection selection;
    selection.spec = args.link;
    hw::SelectedLink chosen = hw::selectLink(selection);
    std::cout << chosen.note << "\n";
    *link = std::make_unique<hw::LinkClient>(std::move(chosen.transport));
  }
  daemon::PipelineProgress progress = stages.capture();
  progress.pictureRequest = [](const hw::PictureRequest& r) {
    std::cout << fmt::format("\npicture {}: {} is on the screen: take it and save it as {}\n",
                             r.index + 1, r.shows, r.path)
              << std::flush;
  };
  progress.note = [](const std::string& line) { std::cerr << line << "\n"; };
  progress.moveCamera = [camera](int station) { promptForStation(camera, station); };
  // What the photometric stage needs after this function (the rest refers to its locals).
  linkProgress->note = progress.note;
  linkProgress->moveCamera = progress.moveCamera;
  progress.captured = [&stages, &args](const hw::CaptureSyncStats& stats) {
    stages.end();
    std::cout << args.settings.camera << ": " << stats.describe() << "\n";
  };
  const CalibrationCaptures captures = daemon::capturePictures(
      link->get(), nominal, args.settings, progress, [] { return gInterrupted.load(); });
  if (!args.saveCaptures.empty()) {
    stages.plain("save the pictures: " + args.saveCaptures);
    saveCaptures(captures, args.saveCaptures);
    stages.end();
  }
  return daemon::decodePictures(captures, nominal, args.settings, stages.decode());
}

void runCalibrate(CalibrateArgs args) {
  // A folder: camera's pictures, all taken, calibrate without the link (offline).
  const bool folderOffline =
      args.captures.empty() && args.link.empty() && args.settings.camera.rfind("folder:", 0) == 0;
  if (args.captures.empty() == args.link.empty() && !folderOffline) {
    throw InputError({"", "--captures", 0},
                     "give either --captures DIR or --link SPEC (with --camera-metadata "
                     "camera.json), or --camera folder:DIR for pictures taken by hand");
  }
  if (args.captures.empty() && args.settings.cameraMetadata.empty()) {
    throw InputError({"", "--camera-metadata", 0},
                     fmt::format("{} needs the camera's metadata (camera.json: intrinsics, "
                                 "stations)",
                                 folderOffline ? "--camera folder:DIR" : "--link"));
  }
  args.settings.photometric = daemon::parsePhotometricMode(args.photometric, "--photometric");
  if (args.settings.photometric != daemon::PhotometricMode::kOff && args.link.empty()) {
    throw InputError({"", "--photometric", 0},
                     "needs --link: the flat fields are shown by the modules and photographed now");
  }
  args.settings.validate("--");
  const DisplayModel nominal = resolveDisplay(args.nominal);
  // Colours only: the installed geometry stays and only the camera is placed again.
  const bool colourOnly = args.settings.photometric == daemon::PhotometricMode::kOnly;
  DisplayModel start = nominal;
  if (colourOnly) {
    const std::optional<daemon::StoredCalibration> installed =
        daemon::CalibrationStore(args.out).loadFor(nominal);
    if (!installed) {
      throw InputError({args.out, "", 0},
                       "--photometric (colours only) keeps the installed geometric calibration, "
                       "and there is none: calibrate the geometry first (or --photometric=on)");
    }
    start = installed->model;
  }
  std::optional<DisplayModel> truth;
  if (!args.truth.empty()) {
    truth = loadDisplayModel(args.truth);
    requireMatchingTruth(*truth, nominal, args.truth);
  }
  const InterruptStopsCalibration interrupt;
  // The true camera, for the report only: --camera-truth, else camera_truth.json beside --truth.
  std::optional<CameraIntrinsics> cameraTruth;
  namespace fs = std::filesystem;
  std::string cameraTruthPath = args.cameraTruth;
  if (cameraTruthPath.empty() && !args.truth.empty()) {
    const fs::path beside = fs::path(args.truth).parent_path() / "camera_truth.json";
    std::error_code ec;
    if (fs::exists(beside, ec)) cameraTruthPath = beside.string();
  }
  if (!cameraTruthPath.empty()) cameraTruth = loadCameraTruth(cameraTruthPath).intrinsics;
  std::string source;
  CalibrateProgress stages(stagesOf(args));
  std::unique_ptr<hw::LinkClient> link;
  daemon::PipelineProgress linkProgress;
  const CalibrationObservations observations = sessionObservations(
      args, nominal, cameraTruth ? &*cameraTruth : nullptr, stages, &source, &link, &linkProgress);
  stages.end();
  std::cout << fmt::format("{} correspondences, {} stripe centres, {} fiducial sightings\n",
                           observations.correspondences.size(), observations.stripes.size(),
                           observations.fiducialSightings.size());
  if (observations.cameraResponse)
    std::cout << describeCameraResponse(*observations.cameraResponse) << "\n";
  daemon::CalibrationSettings settings = args.settings;
  if (!args.transfer.empty()) {
    ScreenTransfer transfer;
    if (!parseTransfer(args.transfer, &transfer))
      throw InputError({"", "--transfer", 0}, "must be conical or linear");
    settings.transfer = transfer;
  }
  FitResult result;
  try {
    result = daemon::fitObservations(start, observations, settings, std::nullopt, stages.fit(),
                                     [] { return gInterrupted.load(); });
  } catch (const InputError& e) {
    throw e.location().file.empty() ? e.inFile(source) : e;
  }
  stages.end();
  if (result.stopped)
    throw std::runtime_error(
        fmt::format("interrupted during the fit; {} was left untouched", args.out));

  std::cout << formatFitSummary(result);
  if (args.report && !colourOnly) std::cout << formatFitReport(result, truth ? &*truth : nullptr);
  if (truth && !colourOnly) std::cout << formatTruthHeadline(result, *truth, nominal);
  if (!result.passesQualityChecks()) {
    throw std::runtime_error(
        fmt::format("the calibration failed its quality checks; {} was left untouched", args.out));
  }
  const DisplayModel model = colourOnly ? start : result.model;
  // The photometric stage, on the geometry just fitted (or kept), with the camera where the
  // fit placed it; a failure installs nothing, the geometry included.
  std::optional<daemon::PhotometricRun> photometry;
  if (settings.photometric != daemon::PhotometricMode::kOff) {
    const std::vector<int> stations = daemon::photographedStations(observations);
    std::optional<ProgressBar> bar;
    daemon::PipelineProgress flat = linkProgress;
    flat.pictures = [&bar](int done, int total) {
      if (!bar) bar.emplace("flat fields", total);
      if (done > 0) bar->advance();
    };
    try {
      photometry =
          daemon::calibratePhotometry(*link, model, stations, daemon::fittedPoses(result, stations),
                                      settings, flat, [] { return gInterrupted.load(); });
    } catch (const hw::CalibrationCancelled&) {
      throw std::runtime_error(
          fmt::format("interrupted during the flat fields; {} was left untouched", args.out));
    } catch (const std::exception& e) {
      throw std::runtime_error(fmt::format("{}; {} was left untouched", e.what(), args.out));
    }
    if (bar) bar->finish();
    std::cout << photometry->summary << "\n";
    if (args.report) std::cout << photometry->report;
  }
  // The daemon's store: the old files become .previous only if they verify, and the new ones
  // are reported installed only once they are on disk.
  const daemon::CalibrationStore store(args.out);
  const daemon::StoredCalibration installed =
      photometry ? store.install(model, daemon::CalibrationStore::Photometry::kReplace,
                                 photometry->calibration.correction)
                 : store.install(model);
  std::cout << fmt::format("calibration installed: {}{}\n", args.out,
                           fs::exists(args.out + ".previous")
                               ? fmt::format(" (previous kept as {}.previous)", args.out)
                               : "");
  if (installed.photometry) {
    std::cout << fmt::format("photometric correction {}: {}\n",
                             photometry ? "installed" : "kept (carried over to the new geometry)",
                             installed.photometrySource);
  }
}

}  // namespace

void addCalibrateCommand(CLI::App& app) {
  auto args = std::make_shared<CalibrateArgs>();
  CLI::App* command =
      app.add_subcommand("calibrate", "fit the display model to a calibration session's captures");
  command->add_option("--captures", args->captures,
                      "captures folder (camera.json, patterns.json and pictures, or decoded.json)");
  command->add_option("--link", args->link,
                      "calibrate through the link: auto, simhw:SOCKET or usb[...]");
  command->add_option("--camera", args->settings.camera,
                      "with --link: the camera taking the pictures: link (default; the one behind "
                      "the link), opencv:SPEC (/dev/video0, an index, a GStreamer pipeline "
                      "ending in appsink, a stream URL, gphoto2) or folder:DIR (pictures taken "
                      "by hand, saved into DIR as the tool names them; without --link, from "
                      "the pictures already there)");
  command->add_option("--camera-metadata", args->settings.cameraMetadata,
                      "with --link: the camera's metadata (camera.json: intrinsics, stations)");
  command->add_flag("--allow-auto-exposure", args->settings.allowAutoExposure,
                    "use a camera whose exposure, gain, white balance or focus does not lock "
                    "(a warning; each picture's exposure is measured)");
  command->add_option("--station-command", args->settings.stationCommand,
                      "a camera not behind the link: run this before each station's pictures "
                      "({station} is its number; default: ask at the terminal)");
  command
      ->add_option("--stations", args->settings.stations,
                   "with --link: the stations to photograph from (default: all)")
      ->delimiter(',');
  command->add_option("--save-captures", args->saveCaptures,
                      "with --link: also save the pictures as a captures folder");
  command
      ->add_option("--pixel-step", args->settings.pixelStep,
                   "decode every n-th camera pixel each way")
      ->capture_default_str();
  command->add_option("--nominal", args->nominal, "nominal display: JSON file or built-in name");
  command->add_option("--out", args->out, "calibrated display JSON to write")->required();
  command->add_flag("--report", args->report, "print the per-module table");
  command->add_flag("--photometric{only}", args->photometric,
                    "with --link: calibrate the modules' colours (flat fields) on the installed "
                    "geometry (--photometric), or the geometry and the colours "
                    "(--photometric=on); the correction goes beside --out");
  command->add_option(
      "--truth", args->truth,
      "ground truth JSON: adds error columns to the report (never used by the fit)");
  command->add_option("--camera-truth", args->cameraTruth,
                      "the camera's truth (camera_truth.json; default: beside --truth): adds its "
                      "error to the camera report");
  command->add_option("--transfer", args->transfer,
                      "assumed screen transfer (default: the nominal's)");
  command->add_option("--threads", args->settings.threads, "solver threads");
  command->add_flag("--allow-partial", args->settings.gate.allowPartial,
                    "install the modules that pass the gate; the others are held at their "
                    "nominal calibration and named");
  command->add_option("--max-error-px", args->settings.gate.worstPx,
                      "gate: largest predicted worst ray error of any module (module px)");
  command->add_option("--max-observer-mm", args->settings.gate.worstObserverMm,
                      "gate: largest predicted worst error where rays meet the observer line (mm)");
  command->callback([args] {
    CalibrateArgs given = *args;
    // The old form, --camera camera.json, named the metadata: it still does.
    if (!hw::isCameraName(given.settings.camera) && given.settings.camera.ends_with(".json") &&
        given.settings.cameraMetadata.empty()) {
      given.settings.cameraMetadata = given.settings.camera;
      given.settings.camera = "link";
    }
    runCalibrate(given);
  });
}

}  // namespace parallax::cli
