// parallax raytex [--display FILE|default|demo] --out DIR [--module I|all]
// Generates each module's constant ray textures and writes them as EXR (origins, directions,
// mask) through OpenImageIO.

#include <fmt/format.h>

#include <filesystem>
#include <iostream>
#include <memory>

#include "calibration/display/display_presets.h"
#include "calibration/display/ray_textures.h"
#include "common/input_error.h"
#include "common/progress_bar.h"
#include "daemon/cli/commands.h"
#include "daemon/cli/module_argument.h"
#include "daemon/cli/ray_texture_files.h"

namespace parallax::cli {
namespace {

struct RaytexArgs {
  std::string display = "demo";
  std::string out;
  std::string module = "all";
};

void runRaytex(const RaytexArgs& args) {
  const DisplayModel model = resolveDisplay(args.display);
  const std::vector<int> indices = parseModuleArgument(args.module, model.modules.size());
  std::error_code ec;
  std::filesystem::create_directories(args.out, ec);
  if (ec) throw InputError({args.out, "", 0}, "cannot create the output folder: " + ec.message());

  ProgressBar progress("raytex", static_cast<std::int64_t>(indices.size()));
  long valid = 0, total = 0;
  for (int index : indices) {
    const RayTextures textures = generateRayTextures(model, index);
    writeRayTextureFiles(textures, args.out, model.modules[static_cast<size_t>(index)].id);
    valid += textures.validCount();
    total += static_cast<long>(textures.rays().size());
    progress.advance();
  }
  progress.finish();
  std::cout << fmt::format(
      "ray textures of {} module(s) of display \"{}\" written to {}\n"
      "  {} of {} pixels carry a ray ({:.1f}%), the rest are masked\n"
      "  files: module_NNN_origins.exr, module_NNN_directions.exr, module_NNN_mask.exr\n",
      indices.size(), model.name, std::filesystem::absolute(args.out).string(), valid, total,
      100.0 * static_cast<double>(valid) / static_cast<double>(total));
}

}  // namespace

void addRaytexCommand(CLI::App& app) {
  auto args = std::make_shared<RaytexArgs>();
  CLI::App* command =
      app.add_subcommand("raytex", "write the constant ray textures of a display as EXR");
  command->add_option("--display", args->display,
                      "display JSON file or built-in name (default, demo)");
  command->add_option("--out", args->out, "output folder")->required();
  command->add_option("--module", args->module, "module index, or all");
  command->callback([args] { runRaytex(*args); });
}

}  // namespace parallax::cli
