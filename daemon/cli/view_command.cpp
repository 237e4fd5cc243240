// parallax view [--display FILE|default|demo] --frames DIR --x X [--y Y] [--z Z] [--out v.png]
//               [--size WxH] [--traced-scene NAME|FILE]
// parallax view ... --frames DIR --sweep X0:X1 [--sweep-frames N] [--fps F] --out sweep.mp4
// What a viewer at x on the observer line (or anywhere with --y/--z) sees, assembled from the
// module frames in DIR (module_NNN.png or .exr, as `parallax render` writes them) through the
// display physics. With --traced-scene it also traces the same view directly and prints the
// PSNR between the two over the part of the screen the modules light for that viewer.
// With --photometric-truth (a simulated display's photometric_truth.json) the frames' 8-bit
// codes become the light those modules send (their response, colours, black and vignetting)
// instead of an ideal sRGB module's: what a viewer of that simulated display sees.
// With --sweep the viewer walks the observer line from X0 to X1 (N views, evenly spaced, both
// ends included) and the views become a video (sweep_video.h): the display's parallax in motion.
// When --frames holds a frame sequence (render --time A:B: frame_NNNN/ folders) the scene plays
// along, one of its frames a view; otherwise it is frozen.

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>

#include "calibration/display/display_presets.h"
#include "calibration/simulation/photometric_truth.h"
#include "common/input_error.h"
#include "common/progress_bar.h"
#include "common/width_height.h"
#include "daemon/cli/commands.h"
#include "daemon/cli/sweep_video.h"
#include "scripts/scene_argument.h"
#include "tracer/observer_view.h"
#include "tracer/physical_scene.h"
#include "tracer/whitted_integrator.h"

namespace parallax::cli {
namespace {

struct ViewArgs {
  std::string display = "demo";
  std::string frames;
  double x = 0.0;
  std::optional<double> y, z;
  std::string out = "parallax-view/view.png";  // never the current folder itself (README)
  std::string size = "640x360";
  std::string tracedScene;
  std::string photometricTruth;
  std::string sweep;  // X0:X1
  int sweepFrames = 90;
  bool sweepFramesGiven = false;
  double fps = 30.0;
};

// The light module i sends for the 8-bit codes of `frame`, by the photometric truth.
Frame lightOf(const PhotometricTruth& truth, int module, const Frame& frame) {
  const std::vector<std::uint8_t> codes = frame.toSrgb8();  // the PNG's bytes again
  const cv::Mat light = truth.emittedLight(module, frame.width, frame.height, codes.data());
  Frame out(frame.width, frame.height);
  for (int y = 0; y < frame.height; ++y)
    for (int x = 0; x < frame.width; ++x) {
      const cv::Vec3f v = light.at<cv::Vec3f>(y, x);
      out.at(x, y) = Rgb(v[0], v[1], v[2]);
    }
  return out;
}

std::vector<Frame> readModuleFrames(const DisplayModel& model, const std::string& directory) {
  std::vector<Frame> frames;
  for (size_t i = 0; i < model.modules.size(); ++i) {
    const std::string stem = moduleFrameStem(directory, static_cast<int>(i));
    const std::string path = std::filesystem::exists(stem + ".exr") ? stem + ".exr" : stem + ".png";
    if (!std::filesystem::exists(path)) {
      throw InputError({path, "", 0},
                       fmt::format("module {} has no frame (expected {}.png or .exr)", i, stem));
    }
    Frame frame = readFrame(path);
    const OpticalModule& m = model.modules[i];
    if (frame.width != m.width || frame.height != m.height) {
      throw InputError({path, "", 0}, fmt::format("is {}x{} but module {} is {}x{}", frame.width,
                                                  frame.height, i, m.width, m.height));
    }
    frames.push_back(std::move(frame));
  }
  return frames;
}

void runView(const ViewArgs& args) {
  const DisplayModel model = resolveDisplay(args.display);
  ObserverViewOptions options;
  const WidthHeight size = parseWidthHeight(args.size, "--size");
  options.width = size.width;
  options.height = size.height;
  options.validate();
  std::optional<std::pair<double, double>> sweep;
  if (!args.sweep.empty()) {
    sweep = parseRange(args.sweep, "--sweep");
    if (!args.tracedScene.empty())
      throw InputError({"", "--traced-scene", 0}, "applies to one view, not to --sweep");
    if (args.sweepFrames < 2 || args.sweepFrames > 100000)
      throw InputError({"", "--sweep-frames", 0}, "must be in 2..100000");
  }
  const Eigen::Vector3d viewer(sweep ? sweep->first : args.x, args.y.value_or(model.observer.y),
                               args.z.value_or(model.observer.z));
  // Each coordinate blamed on its own option, with the daemon's range (display_model.h).
  const char* options3[3] = {"--x", "--y", "--z"};
  if (sweep) options3[0] = "--sweep";
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(viewer[i]) || std::abs(viewer[i]) > kMaxDisplayExtentM) {
      throw InputError({"", options3[i], 0}, fmt::format("must be a number within ±{} m, got {}",
                                                         kMaxDisplayExtentM, viewer[i]));
    }
  }
  if (sweep && std::abs(sweep->second) > kMaxDisplayExtentM) {
    throw InputError({"", "--sweep", 0}, fmt::format("must be a number within ±{} m, got {}",
                                                     kMaxDisplayExtentM, sweep->second));
  }
  if (!(viewer.z() > 0.0)) {
    throw InputError({"", "--z", 0}, "the viewer must stand in front of the screen (z > 0)");
  }
  // A sequence (render --time A:B) plays along the sweep, one of its frames a view.
  const std::vector<std::string> sequence = sequenceFrameFolders(args.frames);
  if (!sequence.empty() && !sweep) {
    throw InputError({args.frames, "--frames", 0},
                     "holds a frame sequence: give one of its frame_NNNN folders, or --sweep");
  }
  std::optional<PhotometricTruth> truth;
  if (!args.photometricTruth.empty()) {
    truth = loadPhotometricTruth(args.photometricTruth);
    if (truth->modules.size() != model.modules.size()) {
      throw InputError({args.photometricTruth, "modules", 0},
                       fmt::format("has {} modules; the display has {}", truth->modules.size(),
                                   model.modules.size()));
    }
  }
  const auto shown = [&](const std::string& folder) {
    std::vector<Frame> frames = readModuleFrames(model, folder);
    if (truth) {
      for (size_t i = 0; i < frames.size(); ++i)
        frames[i] = lightOf(*truth, static_cast<int>(i), frames[i]);
    }
    return frames;
  };
  const std::filesystem::path parent = std::filesystem::path(args.out).parent_path();
  if (!parent.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(parent, ec);
    if (ec)
      throw InputError({parent.string(), "", 0},
                       "cannot create the output folder: " + ec.message());
  }
  if (sweep) {
    const int views = sequence.empty() ? args.sweepFrames : static_cast<int>(sequence.size());
    if (sequence.size() == 1)
      throw InputError({args.frames, "--frames", 0}, "a sequence of one frame: nothing to play");
    if (!sequence.empty() && args.sweepFramesGiven && args.sweepFrames != views) {
      throw InputError({"", "--sweep-frames", 0},
                       fmt::format("{}: the sequence in --frames has {} frames, one a view",
                                   args.sweepFrames, views));
    }
    SweepVideo video(args.out, options.width, options.height, args.fps);
    ProgressBar progress(fmt::format("sweep: {} views", views), views);
    std::vector<Frame> frames = sequence.empty() ? shown(args.frames) : std::vector<Frame>{};
    for (int i = 0; i < views; ++i) {
      const double t = static_cast<double>(i) / (views - 1);
      Eigen::Vector3d at = viewer;
      at.x() = sweep->first + t * (sweep->second - sweep->first);
      if (!sequence.empty()) frames = shown(sequence[static_cast<size_t>(i)]);
      video.add(synthesizeObserverView(model, frames, at, options));
      progress.advance();
    }
    progress.finish();
    video.close();
    std::cout << fmt::format(
        "sweep from x = {:.3f} to {:.3f} m: {} views of {}x{} at {} fps ({}) written to {}\n",
        sweep->first, sweep->second, video.frames(), options.width, options.height, args.fps,
        video.codec(), std::filesystem::absolute(args.out).string());
    return;
  }
  const std::vector<Frame> frames = shown(args.frames);
  std::vector<float> coverage;
  const Frame view = synthesizeObserverView(model, frames, viewer, options, &coverage);
  writePng(view, args.out);
  const long covered =
      std::count_if(coverage.begin(), coverage.end(), [](float w) { return w >= 0.5f; });
  std::cout << fmt::format(
      "view from ({:.3f}, {:.3f}, {:.3f}) m written to {} ({}x{}); the modules light {:.1f}% "
      "of the screen for this viewer\n",
      viewer.x(), viewer.y(), viewer.z(), std::filesystem::absolute(args.out).string(),
      options.width, options.height,
      100.0 * static_cast<double>(covered) / static_cast<double>(coverage.size()));
  if (!args.tracedScene.empty()) {
    const PhysicalScene scene(loadSceneArgument(args.tracedScene, {}, 0.0), model.displayableBox);
    const Frame traced =
        renderFrame(scene, observerViewRays(model, viewer, options), RenderOptions{});
    const std::string tracedPath =
        std::filesystem::path(args.out).replace_extension("").string() + "_traced.png";
    writePng(traced, tracedPath);
    std::cout << fmt::format("traced reference written to {}; PSNR over the lit part: {:.2f} dB\n",
                             tracedPath, psnrDb(view, traced, &coverage));
  }
}

}  // namespace

void addViewCommand(CLI::App& app) {
  auto args = std::make_shared<ViewArgs>();
  CLI::App* command =
      app.add_subcommand("view", "what a viewer sees, assembled from module frames");
  command->add_option("--display", args->display,
                      "display JSON file or built-in name (default, demo)");
  command
      ->add_option("--frames", args->frames,
                   "folder with module_NNN.png (or .exr) frames, or with --sweep a frame "
                   "sequence (render --time A:B)")
      ->required();
  CLI::Option* x =
      command->add_option("--x", args->x, "viewer position along the observer line (m)");
  CLI::Option* sweep = command->add_option(
      "--sweep", args->sweep,
      "X0:X1: a video (--out .mp4, .mkv or .avi) of a viewer walking the observer line");
  x->excludes(sweep);
  CLI::Option* sweepFrames =
      command->add_option("--sweep-frames", args->sweepFrames,
                          "views in the sweep, both ends included (default 90; with a frame "
                          "sequence in --frames: one a frame)");
  sweepFrames->needs(sweep);
  command->add_option("--fps", args->fps, "the sweep video's frame rate (default 30)")
      ->needs(sweep);
  command->add_option("--y", args->y, "viewer height (m); default: the observer line's");
  command->add_option("--z", args->z, "viewer distance (m); default: the observer line's");
  command->add_option("--out", args->out, "output PNG (default: parallax-view/view.png)");
  command->add_option("--size", args->size, "view resolution WIDTHxHEIGHT (spans the screen)");
  command->add_option("--traced-scene", args->tracedScene,
                      "also trace this scene directly and print the PSNR");
  command->add_option("--photometric-truth", args->photometricTruth,
                      "a simulated display's photometric_truth.json: the frames' codes shown by "
                      "those modules (8-bit PNG frames)");
  command->callback([args, x, sweep, sweepFrames] {
    if (x->count() == 0 && sweep->count() == 0) throw CLI::RequiredError("--x or --sweep");
    args->sweepFramesGiven = sweepFrames->count() > 0;
    runView(*args);
  });
}

}  // namespace parallax::cli
