// parallax simulate [--display FILE|default|demo] --seed S --out DIR
//                   [--stations N] [--span M] [--camera-resolution WxH] [--noise-px P]
//                   [--truth-transfer T] [--truth-curvature K] [--synthetic] [--boards N]
// Makes a seeded ground truth from the nominal display and what a calibration session would
// record of it, into DIR:
//   nominal.json        the nominal display the session starts from
//   camera.json         the camera's picture size and response, tape-measured stations, fiducial
//                       places — and its intrinsics only when there are no checkerboard pictures
//   checkerboard.json, checkerboard/board_NN.png   the camera's pictures of a checkerboard
//                       (--boards N, default 12; 0 = none), what its intrinsics are calibrated from
//   patterns.json, set*.png   the pictures of every station and module group
//   (calibration_captures.h)
// and, for the simulator and tests only (a calibration never opens them):
//   ground_truth.json   the perturbed display
//   camera_truth.json   the camera's true intrinsics, station poses and sensor (parallax-simhw
//   --camera)
// The true camera is the datasheet's (cameraOfSize) with a seeded manufacturing spread
// (cameraAsBuilt), so the checkerboard calibration has something to find.
// --synthetic writes decoded.json instead of pictures: correspondences straight from the
// truth with --noise-px of camera noise (synthetic_observations.h), for fast experiments on
// large displays. --noise-px only applies there; the pictures carry sensor noise instead.

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>

#include "calibration/camera/observations_json.h"
#include "calibration/display/display_model_json.h"
#include "calibration/display/display_presets.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/simulated_session.h"
#include "calibration/simulation/synthetic_observations.h"
#include "common/input_error.h"
#include "common/progress_bar.h"
#include "common/width_height.h"
#include "daemon/cli/commands.h"
#include "daemon/cli/stage_log.h"

namespace parallax::cli {
namespace {

struct SimulateArgs {
  std::string display = "demo";
  std::uint64_t seed = 1;
  std::string out;
  int stations = 5;
  double spanM = 3.2;
  std::string cameraResolution = "1280x720";
  double noisePx = 0.3;
  std::string truthTransfer;
  std::optional<double> truthCurvature;
  bool synthetic = false;
  int boards = 12;
};

// A camera of the given size with the default's field of view (fx = 2100 at 1920 px wide).
CameraIntrinsics cameraOfSize(const std::string& resolution) {
  const auto [width, height] = parseWidthHeight(resolution, "--camera-resolution");
  if (width < 64 || height < 64 || width > 8192 || height > 8192) {
    throw InputError({"", "--camera-resolution", 0}, "sides must be 64..8192");
  }
  return CameraIntrinsics::centred(width, height, 2100.0 * width / 1920.0, -0.04);
}

void runSimulate(const SimulateArgs& args, const CLI::App& command) {
  // Options that would otherwise be ignored or give a session nothing can be fitted from.
  if (command.count("--noise-px") && !args.synthetic) {
    throw InputError(
        {"", "--noise-px", 0},
        "applies only with --synthetic (the pictures carry the camera's sensor noise)");
  }
  if (args.stations < 1 || args.stations > 64)
    throw InputError({"", "--stations", 0}, fmt::format("must be 1..64, got {}", args.stations));
  if (args.stations > 1 && !(std::isfinite(args.spanM) && args.spanM > 0.0)) {
    throw InputError({"", "--span", 0},
                     fmt::format("must be > 0 m with {} stations (they would all stand in one "
                                 "place), got {}",
                                 args.stations, args.spanM));
  }
  const DisplayModel nominal = resolveDisplay(args.display);
  GroundTruthOptions truthOptions;
  truthOptions.seed = args.seed;
  if (!args.truthTransfer.empty()) {
    ScreenTransfer transfer;
    if (!parseTransfer(args.truthTransfer, &transfer)) {
      throw InputError({"", "--truth-transfer", 0}, "must be conical or linear");
    }
    truthOptions.transfer = transfer;
  }
  truthOptions.curvature = args.truthCurvature;
  const DisplayModel truth = makeGroundTruth(nominal, truthOptions);

  CameraRigOptions rig;
  rig.stations = args.stations;
  rig.spanM = args.spanM;
  const std::uint64_t rigSeed = args.seed * 7919 + 1;  // independent of the truth's stream
  rig.intrinsics = cameraAsBuilt(cameraOfSize(args.cameraResolution), rigSeed);
  if (args.boards < 0 || args.boards > 200) throw InputError({"", "--boards", 0}, "must be 0..200");
  const SimulatedRig camera = makeSimulatedRig(truth, rig, rigSeed);

  std::error_code ec;
  std::filesystem::create_directories(args.out, ec);
  if (ec) throw InputError({args.out, "", 0}, "cannot create the output folder: " + ec.message());
  saveDisplayModel(truth, args.out + "/ground_truth.json");
  saveDisplayModel(nominal, args.out + "/nominal.json");
  saveCameraTruth(camera.truth, args.out + "/camera_truth.json");
  const std::string header = fmt::format(
      "simulated display \"{}\" (seed {}): {} modules, truth k = {:.5f} 1/m, {} transfer; {} "
      "camera stations, camera {}x{}\n",
      nominal.name, args.seed, truth.modules.size(), truth.screen.curvature,
      transferName(truth.screen.transfer), args.stations, rig.intrinsics.width,
      rig.intrinsics.height);
  const std::string where = std::filesystem::absolute(args.out).string();
  if (args.synthetic) {
    SyntheticOptions sim;
    sim.seed = rigSeed;
    sim.rig = rig;
    sim.noisePx = args.noisePx;
    const SyntheticCalibration data = simulateObservations(truth, sim);
    saveObservations(data.observations, args.out);
    std::cout << header
              << fmt::format(
                     "  synthetic decode (no pictures), noise {} px: {} correspondences, {} stripe "
                     "centres, {} fiducial sightings\n"
                     "  written to {}: nominal.json, camera.json, decoded.json; ground_truth.json, "
                     "camera_truth.json (simulator and tests only)\n",
                     args.noisePx, data.observations.correspondences.size(),
                     data.observations.stripes.size(), data.observations.fiducialSightings.size(),
                     where);
    return;
  }
  // The pictures take a minute or more on demo: a bar with the time left, then the steps that
  // cannot report their progress by name and time.
  const int steps = args.boards > 0 ? 3 : 2;
  SimulatedSessionOptions session;
  std::optional<ProgressBar> bar;
  session.onPicture = [&](int, int total) {
    if (!bar) bar.emplace(fmt::format("simulate [1/{}] {} pattern pictures", steps, total), total);
    bar->advance();
  };
  CalibrationCaptures captures = renderSession(truth, camera.truth, camera.metadata, session);
  if (bar) bar->finish();
  StageLog stages("simulate", steps);
  stages.skip();  // step 1 was the bar
  if (args.boards > 0) {
    stages.begin(fmt::format("{} checkerboard pictures", args.boards));
    CheckerboardShotOptions shots;
    shots.pictures = args.boards;
    captures.checkerboard = simulateCheckerboardCaptures(camera.truth, CheckerboardBoard{}, shots);
    captures.camera.intrinsicsKnown = false;  // a real installation learns them from the board
  }
  stages.begin("writing the pictures");
  saveCaptures(captures, args.out);
  stages.end();
  size_t pictures = 0;
  for (const StationCaptures& s : captures.stations)
    pictures += s.columnFrames.size() + s.rowFrames.size();
  std::cout << header
            << fmt::format(
                   "  {} pictures from {} station{} ({} sets: each station × module group){}\n"
                   "  written to {}: nominal.json, camera.json, patterns.json, set*.png{}; "
                   "ground_truth.json, camera_truth.json (simulator and tests only)\n",
                   pictures, args.stations, args.stations == 1 ? "" : "s", captures.stations.size(),
                   args.boards > 0
                       ? fmt::format(", {} checkerboard pictures (camera.json without intrinsics)",
                                     args.boards)
                       : "",
                   where, args.boards > 0 ? ", checkerboard.json, checkerboard/" : "");
}

}  // namespace

void addSimulateCommand(CLI::App& app) {
  auto args = std::make_shared<SimulateArgs>();
  CLI::App* command = app.add_subcommand(
      "simulate", "make a seeded ground-truth display and the calibration pictures of it");
  command->add_option("--display", args->display,
                      "nominal display: JSON file or built-in name (default, demo)");
  command->add_option("--seed", args->seed, "seed: the same seed gives the same files");
  command->add_option("--out", args->out, "output folder")->required();
  command->add_option("--stations", args->stations, "camera stations along the observer line");
  command->add_option("--span", args->spanM, "distance from the first to the last station (m)");
  command->add_option("--camera-resolution", args->cameraResolution,
                      "calibration camera WIDTHxHEIGHT (field of view fixed)");
  command->add_option("--noise-px", args->noisePx,
                      "camera noise (σ, px) of --synthetic correspondences");
  command->add_option("--truth-transfer", args->truthTransfer,
                      "screen transfer of the ground truth (conical, linear)");
  command->add_option("--truth-curvature", args->truthCurvature,
                      "curvature k of the ground truth's screen (1/m)");
  command->add_flag("--synthetic", args->synthetic,
                    "write decoded.json (synthetic correspondences) instead of pictures");
  command->add_option(
      "--boards", args->boards,
      "checkerboard pictures for the camera's intrinsics (0: none, camera.json then carries them)");
  command->callback([args, command] { runSimulate(*args, *command); });
}

}  // namespace parallax::cli
