// parallax display [--preset default|demo] [--modules N] [--resolution WxH] [--curvature K]
//                  [--transfer conical|linear] [--out f.json]
// Writes a nominal DisplayModel (to stdout without --out).

#include <fmt/format.h>

#include <iostream>
#include <memory>

#include "calibration/display/display_model_json.h"
#include "calibration/display/display_presets.h"
#include "common/input_error.h"
#include "common/width_height.h"
#include "daemon/cli/command_line.h"
#include "daemon/cli/commands.h"

namespace parallax::cli {
namespace {

struct DisplayArgs {
  std::string preset = "demo";  // every command's default display (README)
  int modules = 0;
  std::string resolution;
  double curvature = 0.0;
  bool curvatureSet = false;
  std::string transfer;
  std::string out;
};

void runDisplay(const DisplayArgs& args, const CLI::App& command) {
  NominalDisplayOptions options;
  options.preset = args.preset;
  if (command.count("--modules")) options.modules = args.modules;
  if (!args.resolution.empty()) {
    const WidthHeight size = parseWidthHeight(args.resolution, "--resolution");
    options.width = size.width;
    options.height = size.height;
  }
  if (command.count("--curvature")) options.curvature = args.curvature;
  if (!args.transfer.empty()) {
    ScreenTransfer transfer;
    if (!parseTransfer(args.transfer, &transfer)) {
      throw InputError({"", "--transfer", 0}, "must be conical or linear");
    }
    options.transfer = transfer;
  }
  const DisplayModel model = makeNominalDisplay(options);
  if (args.out.empty()) {
    std::cout << displayModelToJson(model).dump(2) << "\n";
    return;
  }
  saveDisplayModel(model, args.out);
  if (quiet()) return;
  std::cerr << fmt::format(
      "wrote {}: {} modules of {}x{}, screen {} x {} m, k = {} 1/m, "
      "{} transfer, diffusion {:.3g} deg\n",
      args.out, model.modules.size(), model.modules.front().width, model.modules.front().height,
      model.screen.width, model.screen.height, model.screen.curvature,
      transferName(model.screen.transfer), model.screen.diffusionDeg);
}

}  // namespace

void addDisplayCommand(CLI::App& app) {
  auto args = std::make_shared<DisplayArgs>();
  CLI::App* command = app.add_subcommand("display", "write a nominal display model (JSON)");
  command
      ->add_option("--preset", args->preset,
                   "built-in layout: demo (16x512x384, the default) or default (72x1024x768)")
      ->check(CLI::IsMember({"default", "demo"}));
  command->add_option("--modules", args->modules, "number of modules");
  command->add_option("--resolution", args->resolution, "module resolution WIDTHxHEIGHT");
  command->add_option("--curvature", args->curvature, "screen curvature k = 1/R (1/m); 0 is flat");
  command->add_option("--transfer", args->transfer, "screen transfer model")
      ->check(CLI::IsMember({"conical", "linear"}));
  command->add_option("--out", args->out, "output file (stdout when absent)");
  command->callback([args, command] { runDisplay(*args, *command); });
}

}  // namespace parallax::cli
