// parallax simulate [--display FILE|default|demo] --seed S --out DIR
//                   [--stations N] [--span M] [--noise-px P] [--truth-transfer T] [--truth-curvature K]
// Makes a seeded ground truth from the nominal display and what a calibration session would
// capture of it, into DIR:
//   ground_truth.json  the perturbed display (only tests and reports open it)
//   nominal.json       the nominal display the session starts from
//   camera.json        camera intrinsics, tape-measured station centres, fiducial places
//   decoded.json       the decoded correspondences, stripe centres and fiducial sightings
// The captures are produced by the synthetic decoder (calibration/synthetic_observations.h):
// the image renderer and OpenCV decoding are not part of this command yet.

#include <filesystem>
#include <iostream>
#include <memory>

#include <fmt/format.h>

#include "calibration/display_model_json.h"
#include "calibration/display_presets.h"
#include "calibration/ground_truth.h"
#include "calibration/observations_json.h"
#include "calibration/synthetic_observations.h"
#include "common/input_error.h"
#include "daemon/cli/commands.h"

namespace parallax::cli {
namespace {

struct SimulateArgs {
  std::string display = "demo";
  std::uint64_t seed = 1;
  std::string out;
  int stations = 5;
  double spanM = 3.2;
  double noisePx = 0.3;
  std::string truthTransfer;
  std::optional<double> truthCurvature;
};

void runSimulate(const SimulateArgs& args) {
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

  SyntheticOptions sim;
  sim.seed = args.seed * 7919 + 1;  // independent of the truth's stream
  sim.rig.stations = args.stations;
  sim.rig.spanM = args.spanM;
  sim.noisePx = args.noisePx;
  const SyntheticCalibration data = simulateObservations(truth, sim);

  std::error_code ec;
  std::filesystem::create_directories(args.out, ec);
  if (ec) throw InputError({args.out, "", 0}, "cannot create the output folder: " + ec.message());
  saveDisplayModel(truth, args.out + "/ground_truth.json");
  saveDisplayModel(nominal, args.out + "/nominal.json");
  saveObservations(data.observations, args.out);
  std::cout << fmt::format(
      "simulated display \"{}\" (seed {}): {} modules, truth k = {:.5f} 1/m, {} transfer\n"
      "  {} camera stations, noise {} px: {} correspondences, {} stripe centres, {} fiducial sightings\n"
      "  written to {}: ground_truth.json (for tests and reports only), nominal.json, camera.json, decoded.json\n",
      nominal.name, args.seed, truth.modules.size(), truth.screen.curvature,
      transferName(truth.screen.transfer), args.stations, args.noisePx,
      data.observations.correspondences.size(), data.observations.stripes.size(),
      data.observations.fiducialSightings.size(), std::filesystem::absolute(args.out).string());
}

}  // namespace

void addSimulateCommand(CLI::App& app) {
  auto args = std::make_shared<SimulateArgs>();
  CLI::App* command = app.add_subcommand(
      "simulate", "make a seeded ground-truth display and the calibration captures of it");
  command->add_option("--display", args->display, "nominal display: JSON file or built-in name (default, demo)");
  command->add_option("--seed", args->seed, "seed: the same seed gives the same files");
  command->add_option("--out", args->out, "output folder")->required();
  command->add_option("--stations", args->stations, "camera stations along the observer line");
  command->add_option("--span", args->spanM, "distance from the first to the last station (m)");
  command->add_option("--noise-px", args->noisePx, "camera noise (σ, px)");
  command->add_option("--truth-transfer", args->truthTransfer, "screen transfer of the ground truth (conical, linear)");
  command->add_option("--truth-curvature", args->truthCurvature, "curvature k of the ground truth's screen (1/m)");
  command->callback([args] { runSimulate(*args); });
}

}  // namespace parallax::cli
