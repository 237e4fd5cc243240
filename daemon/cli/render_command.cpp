// parallax render [--display FILE|default|demo] --scene NAME|FILE|SCRIPT.lua [--set name=value]
//                 [--time T] [--module I|all] [--out DIR]
//                 [--explain] [--float] [--traversal single|packet16|stream] [--spp N]
//                 [--frames N [--fps F] [--no-frame-cache]]
//                 [--time A:B [--fps F]]
// Ray traces module frames of a scene through the display's ray textures and writes them as
// sRGB PNG (and float EXR with --float). --explain prints what the scene needs, what ran and
// what was left out, with the per-frame counters. --spp N (a square): N sub-pixel rays a pixel.
// --frames N plays an animated script from --time on, N frames at --fps, as the daemon does
// (through the frame cache unless --no-frame-cache), and writes the last; --explain then also
// says what the cache held and saved. --time A:B writes the whole sequence instead: the frames
// at t = A, A + 1/F, ... up to B, each into OUT/frame_NNNN/ (a folder `parallax view --frames`
// reads; `view --sweep` plays a folder of them as the viewer walks).

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>

#include "calibration/display/display_presets.h"
#include "calibration/display/ray_textures.h"
#include "common/input_error.h"
#include "common/process_cpu_time.h"
#include "common/progress_bar.h"
#include "daemon/cli/commands.h"
#include "daemon/cli/module_argument.h"
#include "daemon/cli/sweep_video.h"
#include "scripts/scene_argument.h"
#include "scripts/scene_script.h"
#include "tracer/frame_cache.h"
#include "tracer/physical_scene.h"
#include "tracer/scene_source.h"
#include "tracer/supersampled_render.h"
#include "tracer/whitted_integrator.h"

namespace parallax::cli {
namespace {

struct RenderArgs {
  std::string display = "demo";
  std::string scene;
  std::string module = "all";
  std::string out = "parallax-render";  // never the current folder itself (README)
  std::string traversal;
  bool explain = false;
  bool floatOutput = false;
  std::vector<std::string> sets;  // --set name=value (scene scripts)
  std::string time = "0";         // --time T, or A:B for a sequence (animated scene scripts)
  int samplesPerPixel = 1;        // --spp N
  int frames = 1;                 // --frames N: an animation, as the daemon plays it
  double fps = 30.0;
  bool noFrameCache = false;
};

// The animation a render plays: `frames` frames from `start` at `fps`; every one written
// (--time A:B) or only the last (--frames N).
struct Animation {
  double start = 0.0;
  int frames = 1;
  bool writeEvery = false;
};

// --frames N or --time A:B: the script played frame after frame over the chosen modules,
// through the frame cache as parallaxd does (or in full with --no-frame-cache).
void runAnimation(const RenderArgs& args, const Animation& animation, const DisplayModel& model,
                  const std::vector<int>& indices, const RenderOptions& options) {
  const char* option = animation.writeEvery ? "--time" : "--frames";
  if (animation.frames < 2 || animation.frames > 100000)
    throw InputError({"", option, 0}, "must make 2..100000 frames");
  if (!(args.fps > 0.0 && args.fps <= 240.0))
    throw InputError({"", "--fps", 0}, "must be in (0, 240]");
  if (options.samplesPerPixel != 1)
    throw InputError({"", "--spp", 0},
                     fmt::format("{} renders one sample a pixel, as the daemon", option));
  std::string path = librarySceneScript(args.scene);
  if (path.empty()) path = args.scene;
  if (!isSceneScript(path)) throw InputError({"", option, 0}, "needs a scene script (.lua)");
  ScriptOptions scriptOptions;
  scriptOptions.parameters = parseParameterSettings(args.sets);
  std::unique_ptr<SceneScript> script = SceneScript::loadFile(path, scriptOptions);
  if (!script->animated())
    throw InputError({path, "update", 0},
                     fmt::format("{} needs an animated script (one with update)", option));
  std::vector<RayTextures> textures;
  for (int index : indices) textures.push_back(generateRayTextures(model, index));

  std::error_code ec;
  std::filesystem::create_directories(args.out, ec);
  if (ec) throw InputError({args.out, "", 0}, "cannot create the output folder: " + ec.message());
  FrameCache cache;
  std::unique_ptr<PhysicalScene> last;
  std::vector<Frame> frames(textures.size());
  RenderCounters total;
  ProgressBar progress("frames", animation.frames);
  const auto write = [&](const std::string& folder) {
    std::filesystem::create_directories(folder, ec);
    if (ec) throw InputError({folder, "", 0}, "cannot create the folder: " + ec.message());
    for (size_t m = 0; m < frames.size(); ++m) {
      const std::string stem = moduleFrameStem(folder, indices[m]);
      writePng(frames[m], stem + ".png");
      if (args.floatOutput) writeExr(frames[m], stem + ".exr");
    }
  };
  double renderMs = 0.0;
  for (int f = 0; f < animation.frames; ++f) {
    const auto frameStart = std::chrono::steady_clock::now();
    script->setTime(animation.start + f / args.fps);
    const Scene& scene = script->scene();
    auto built = std::make_unique<PhysicalScene>(
        scene, model.displayableBox, args.noFrameCache ? nullptr : &cache.dynamicInstances(scene),
        last.get());
    PhysicalScene& physical = *built;
    const bool cached = !args.noFrameCache && cache.prepare(physical, textures, 1, options);
    RenderCounters counters;
    const double cpuStart = processCpuMs();
    for (size_t m = 0; m < textures.size(); ++m) {
      RenderCounters moduleCounters;
      if (cached) {
        renderFrameInto(physical, textures[m], options, cache.view(m), &frames[m], &moduleCounters);
      } else {
        renderFrameInto(physical, textures[m], options, &frames[m], &moduleCounters);
      }
      counters += moduleCounters;
    }
    if (cached) cache.count(counters);
    if (!args.noFrameCache) cache.reportFrameCost(processCpuMs() - cpuStart);
    total += counters;
    last = std::move(built);  // its textures serve the next frame
    renderMs +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - frameStart)
            .count();
    if (animation.writeEvery) write(sequenceFrameFolder(args.out, f));
    progress.advance();
  }
  progress.finish();
  if (!animation.writeEvery) write(args.out);
  std::cout << fmt::format(
      "script \"{}\" on display \"{}\": {} frames of {} module(s) from t = {} s at {} fps, {} "
      "{}\n",
      script->name(), model.name, animation.frames, indices.size(), animation.start, args.fps,
      animation.writeEvery ? "each written to" : "the last written to",
      animation.writeEvery ? std::filesystem::absolute(args.out).string() + "/frame_NNNN/"
                           : std::filesystem::absolute(args.out).string());
  std::cout << fmt::format(
      "  {:.1f} ms a display frame on average (scene build, frame cache "
      "and render; frame cache {})\n",
      renderMs / animation.frames, args.noFrameCache ? "off" : "on");
  if (!args.explain) return;
  std::cout << fmt::format("counters over {} frames:\n", animation.frames);
  for (const std::string& line : total.lines()) std::cout << line << "\n";
  if (!args.noFrameCache) {
    for (const std::string& line : cache.stats().lines()) std::cout << line << "\n";
  }
}

void runRender(const RenderArgs& args) {
  const DisplayModel model = resolveDisplay(args.display);
  const std::vector<int> indices = parseModuleArgument(args.module, model.modules.size());
  RenderOptions options;
  if (!args.traversal.empty() && !parseTraversal(args.traversal.c_str(), &options.traversal)) {
    throw InputError({"", "--traversal", 0}, "must be single, packet16 or stream");
  }
  options.samplesPerPixel = args.samplesPerPixel;
  options.timePhases = args.explain;  // where the time went, for --explain (about 2% slower)
  try {
    options.validate();
  } catch (const InputError& e) {
    throw InputError({"", "--spp", 0}, e.reason());
  }
  // --time T, or A:B for a sequence at --fps (both ends included, up to rounding).
  double time = 0.0;
  if (args.time.find(':', 1) != std::string::npos) {
    const auto [a, b] = parseRange(args.time, "--time");
    if (args.frames != 1) throw InputError({"", "--frames", 0}, "give --frames or --time A:B");
    if (!(b > a)) throw InputError({"", "--time", 0}, "A:B needs B after A");
    if (!(args.fps > 0.0 && args.fps <= 240.0))
      throw InputError({"", "--fps", 0}, "must be in (0, 240]");
    const double count = std::floor((b - a) * args.fps + 1e-9) + 1.0;
    if (count > 100000) throw InputError({"", "--time", 0}, "more than 100000 frames");
    return runAnimation(args, {a, static_cast<int>(count), true}, model, indices, options);
  }
  try {
    size_t used = 0;
    time = std::stod(args.time, &used);
    if (used != args.time.size() || !std::isfinite(time)) throw std::invalid_argument("");
  } catch (const std::exception&) {
    throw InputError({"", "--time", 0},
                     fmt::format("\"{}\": expected seconds, or A:B for a sequence", args.time));
  }
  if (args.frames != 1)
    return runAnimation(args, {time, args.frames, false}, model, indices, options);
  const Scene scene = loadSceneArgument(args.scene, args.sets, time);
  const PhysicalScene physical(scene, model.displayableBox);
  for (const std::string& w : physical.warnings()) std::cerr << "parallax: warning: " << w << "\n";

  std::error_code ec;
  std::filesystem::create_directories(args.out, ec);
  if (ec) throw InputError({args.out, "", 0}, "cannot create the output folder: " + ec.message());

  ProgressBar progress("render", static_cast<std::int64_t>(indices.size()));
  RenderCounters total;
  double renderMs = 0.0;
  for (int index : indices) {
    const RayTextures textures = generateRayTextures(model, index);
    RenderCounters counters;
    const auto start = std::chrono::steady_clock::now();
    const Frame frame = renderFrame(physical, model, index, textures, options, &counters);
    renderMs +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    total += counters;
    const std::string stem = moduleFrameStem(args.out, index);
    writePng(frame, stem + ".png");
    if (args.floatOutput) writeExr(frame, stem + ".exr");
    progress.advance();
  }
  progress.finish();
  const SceneBuildCounters& b = physical.counters();
  std::cout << fmt::format(
      "scene \"{}\" on display \"{}\": {} module frame(s) of {}x{} written to {}\n", scene.name,
      model.name, indices.size(), model.modules[static_cast<size_t>(indices[0])].width,
      model.modules[static_cast<size_t>(indices[0])].height,
      std::filesystem::absolute(args.out).string());
  std::cout << fmt::format("  {:.1f} ms a frame on average ({} traversal), BVH build {:.1f} ms\n",
                           renderMs / static_cast<double>(indices.size()),
                           traversalName(options.traversal), b.buildMs);
  if (!args.explain) return;
  std::cout << "scene analysis (what runs and what is left out):\n";
  for (const std::string& line : physical.features().explain()) std::cout << line << "\n";
  std::cout << fmt::format(
      "geometry: {} triangles drawn, {} in the BVH; {} degenerate dropped, {} outside B_P dropped, "
      "{} clipped to B_P\n",
      b.trianglesIn, b.trianglesBuilt, b.trianglesDegenerate, b.trianglesOutside,
      b.trianglesClipped);
  std::cout << fmt::format(
      "vertex normals left out on {} flat mesh(es): they equal the face normals\n",
      b.flatNormalMeshes);
  std::cout << fmt::format(
      "textures: {} loaded, {} failed (fallback colour), {} never read (unused)\n",
      b.texturesLoaded, b.texturesFailed, b.texturesSkipped);
  std::cout << fmt::format("counters over {} frame(s):\n", indices.size());
  for (const std::string& line : total.lines()) std::cout << line << "\n";
}

}  // namespace

void addRenderCommand(CLI::App& app) {
  auto args = std::make_shared<RenderArgs>();
  CLI::App* command =
      app.add_subcommand("render", "ray trace module frames of a scene (PNG, EXR with --float)");
  command->add_option("--display", args->display,
                      "display JSON file or built-in name (default, demo)");
  command
      ->add_option(
          "--scene", args->scene,
          "built-in scene (cornell, shapes, statue, xyz), a scene script (.lua) or a model file")
      ->required();
  command->add_option("--set", args->sets, "scene script parameter name=value (repeatable)");
  command->add_option("--time", args->time,
                      "animation time in seconds (scene scripts); A:B writes the frames from A to "
                      "B at --fps, each into OUT/frame_NNNN/");
  command->add_option("--module", args->module, "module index, or all");
  command->add_option("--out", args->out, "output folder (default: parallax-render/)");
  command->add_option("--traversal", args->traversal, "Embree traversal: single, packet16, stream");
  command->add_option("--spp", args->samplesPerPixel,
                      "anti-aliasing: sub-pixel rays a pixel, a square (1, 4, 9, ...)");
  command->add_flag("--explain", args->explain,
                    "print what ran, what was left out, and the counters");
  command->add_flag("--float", args->floatOutput, "also write float EXR frames");
  command->add_option("--frames", args->frames,
                      "play an animated script for N frames from --time (the last is written)");
  command->add_option("--fps", args->fps,
                      "with --frames or --time A:B: frames a second of animation time");
  command->add_flag("--no-frame-cache", args->noFrameCache,
                    "with --frames: render every frame in full");
  command->callback([args] { runRender(*args); });
}

}  // namespace parallax::cli
