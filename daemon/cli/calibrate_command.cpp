// parallax calibrate --captures DIR --nominal FILE|default|demo --out calib.json
//                    [--report] [--truth gt.json] [--transfer conical|linear] [--threads N]
// Fits the display to what DIR holds of a calibration session (camera.json, decoded.json) —
// never its ground truth — starting from the nominal display. The result is written
// atomically (temporary file, then rename) and the previous calibration is kept as
// calib.json.previous; a calibration that fails its own quality checks is not installed.
// --truth adds error-against-truth columns to the report; the fit never sees that file.

#include <filesystem>
#include <iostream>
#include <memory>

#include <fmt/format.h>

#include "calibration/display_fit.h"
#include "calibration/display_model_json.h"
#include "calibration/display_presets.h"
#include "calibration/fit_report.h"
#include "calibration/observations_json.h"
#include "common/input_error.h"
#include "common/progress_bar.h"
#include "daemon/cli/commands.h"

namespace parallax::cli {
namespace {

struct CalibrateArgs {
  std::string captures;
  std::string nominal = "demo";
  std::string out;
  bool report = false;
  std::string truth;
  std::string transfer;
  int threads = 2;
};

void runCalibrate(const CalibrateArgs& args) {
  const DisplayModel nominal = resolveDisplay(args.nominal);
  const CalibrationObservations observations = loadObservations(args.captures);
  FitOptions options;
  options.threads = args.threads;
  if (!args.transfer.empty()) {
    ScreenTransfer transfer;
    if (!parseTransfer(args.transfer, &transfer)) throw InputError({"", "--transfer", 0}, "must be conical or linear");
    options.transfer = transfer;
  }
  // Three solves of up to maxIterations each; the bar counts iterations and finishes early.
  ProgressBar progress("calibrate", 3L * options.maxIterations);
  options.onIteration = [&progress](int, double) { progress.advance(); };
  FitResult result;
  try {
    result = fitDisplay(nominal, observations, options);
  } catch (const InputError& e) {
    throw e.location().file.empty() ? e.inFile(args.captures + "/decoded.json") : e;
  }
  progress.finish();

  std::cout << formatFitSummary(result);
  if (args.report) {
    std::optional<DisplayModel> truth;
    if (!args.truth.empty()) truth = loadDisplayModel(args.truth);
    if (truth && truth->modules.size() != result.model.modules.size()) {
      throw InputError({args.truth, "modules", 0}, "the ground truth has a different number of modules");
    }
    std::cout << formatFitReport(result, truth ? &*truth : nullptr);
  }
  if (!result.passesQualityChecks()) {
    throw std::runtime_error(fmt::format("the calibration failed its quality checks; {} was left untouched", args.out));
  }
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(args.out, ec)) {
    fs::copy_file(args.out, args.out + ".previous", fs::copy_options::overwrite_existing, ec);
    if (ec) throw InputError({args.out, "", 0}, "cannot keep the previous calibration: " + ec.message());
  }
  saveDisplayModel(result.model, args.out);
  std::cout << fmt::format("calibration installed: {}{}\n", args.out,
                           fs::exists(args.out + ".previous") ? fmt::format(" (previous kept as {}.previous)", args.out) : "");
}

}  // namespace

void addCalibrateCommand(CLI::App& app) {
  auto args = std::make_shared<CalibrateArgs>();
  CLI::App* command = app.add_subcommand("calibrate", "fit the display model to a calibration session's captures");
  command->add_option("--captures", args->captures, "capture folder (camera.json, decoded.json)")->required();
  command->add_option("--nominal", args->nominal, "nominal display: JSON file or built-in name");
  command->add_option("--out", args->out, "calibrated display JSON to write")->required();
  command->add_flag("--report", args->report, "print the per-module table");
  command->add_option("--truth", args->truth, "ground truth JSON: adds error columns to the report (never used by the fit)");
  command->add_option("--transfer", args->transfer, "assumed screen transfer (default: the nominal's)");
  command->add_option("--threads", args->threads, "solver threads");
  command->callback([args] { runCalibrate(*args); });
}

}  // namespace parallax::cli
