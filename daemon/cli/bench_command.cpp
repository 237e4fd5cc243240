// parallax bench tracer [--display default] [--module I] [--frames N] [--scenes
// cornell,shapes,statue] Prints, per scene, ms a frame of one module (1024×768 on the `default`
// display) with each Embree traversal, beside the paper's GTX 960 figures and beside the raw Embree
// cost of tracing exactly the same rays with no shading; then Mrays/s by ray type. Figures only: it
// never fails on time.

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <chrono>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <thread>

#include "calibration/display/display_presets.h"
#include "calibration/display/ray_textures.h"
#include "common/input_error.h"
#include "common/process_cpu_time.h"
#include "daemon/cli/commands.h"
#include "tracer/physical_scene.h"
#include "tracer/ray_log.h"
#include "tracer/scene_source.h"
#include "tracer/whitted_integrator.h"

namespace parallax::cli {
namespace {

struct BenchArgs {
  std::string display = "default";
  int module = -1;
  int frames = 5;
  std::string scenes = "cornell,shapes,statue";
  int tileWidth = RenderOptions{}.tileWidth;
  int tileHeight = RenderOptions{}.tileHeight;
  bool renderOnly = false;
};

struct Timing {
  double wallMs = 0.0;
  double cpuMsPerCore = 0.0;
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// One frame into `frame` (allocated by an earlier, untimed render, as a display loop reuses it).
Timing timeOneFrame(const PhysicalScene& scene, const RayTextures& textures,
                    const RenderOptions& options, Frame* frame) {
  const double cores = std::max(1u, std::thread::hardware_concurrency());
  const double cpu0 = processCpuMs();
  const auto start = std::chrono::steady_clock::now();
  renderFrameInto(scene, textures, options, frame);
  return {
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count(),
      (processCpuMs() - cpu0) / cores};
}

Timing timeFrames(const PhysicalScene& scene, const RayTextures& textures,
                  const RenderOptions& options, int frames) {
  std::vector<double> wall, cpu;
  Frame frame;
  renderFrameInto(scene, textures, options, &frame);
  for (int i = 0; i < frames; ++i) {
    const Timing t = timeOneFrame(scene, textures, options, &frame);
    wall.push_back(t.wallMs);
    cpu.push_back(t.cpuMsPerCore);
  }
  return {median(wall), median(cpu)};
}

// The three traversals' full frames, one frame of each in turn (round-robin), so that a slow
// minute slows all three alike. Timed one traversal after the other, their columns came from
// different minutes and the winner changed from run to run. Returns each traversal's median and,
// in *streamOverPacket, the median over rounds of stream / packet16 (CPU time): the figure that
// chooses between the two.
std::map<Traversal, Timing> timeTraversals(const PhysicalScene& scene, const RayTextures& textures,
                                           const RenderOptions& options, int frames,
                                           double* streamOverPacket) {
  constexpr Traversal kAll[] = {Traversal::kSingle, Traversal::kPacket16, Traversal::kStream};
  std::map<Traversal, std::vector<double>> wall, cpu;
  std::vector<double> ratio;
  Frame frame;
  renderFrameInto(scene, textures, options, &frame);
  for (int i = 0; i < frames; ++i) {
    for (Traversal t : kAll) {
      RenderOptions o = options;
      o.traversal = t;
      const Timing timing = timeOneFrame(scene, textures, o, &frame);
      wall[t].push_back(timing.wallMs);
      cpu[t].push_back(timing.cpuMsPerCore);
    }
    ratio.push_back(cpu[Traversal::kStream].back() / cpu[Traversal::kPacket16].back());
  }
  *streamOverPacket = median(ratio);
  std::map<Traversal, Timing> timing;
  for (Traversal t : kAll) timing[t] = {median(wall[t]), median(cpu[t])};
  return timing;
}

Timing timeReplay(const PhysicalScene& scene, const RayLog& log, Traversal traversal, RayKind kind,
                  int frames, long* rays) {
  std::vector<double> wall, cpu;
  const double cores = std::max(1u, std::thread::hardware_concurrency());
  for (int i = 0; i < frames; ++i) {
    double traceCpu = 0.0;
    wall.push_back(replayRayLog(scene, log, traversal, kind, rays, &traceCpu));
    cpu.push_back(traceCpu / cores);
  }
  return {median(wall), median(cpu)};
}

// The chosen traversal's full frame and the raw replay of its rays, alternating frame by frame:
// on a shared machine a slow minute then slows both, and the ratio of each pair stays honest
// (timed one after the other, the two medians came from different minutes and the ratio of
// the same binary moved between 2.0 and 2.6).
struct Paired {
  Timing full, raw;
  double ratioWall = 0.0, ratioCpu = 0.0;  // median of the per-frame ratios
};

Paired timePaired(const PhysicalScene& scene, const RayTextures& textures,
                  const RenderOptions& options, const RayLog& log, int frames, long* rays) {
  const double cores = std::max(1u, std::thread::hardware_concurrency());
  std::vector<double> fullWall, fullCpu, rawWall, rawCpu, ratioWall, ratioCpu;
  Frame frame;
  renderFrameInto(scene, textures, options, &frame);
  for (int i = 0; i < frames; ++i) {
    const Timing full = timeOneFrame(scene, textures, options, &frame);
    fullWall.push_back(full.wallMs);
    fullCpu.push_back(full.cpuMsPerCore);
    double traceCpu = 0.0;
    rawWall.push_back(
        replayRayLog(scene, log, Traversal::kPacket16, RayKind::kAll, rays, &traceCpu));
    rawCpu.push_back(traceCpu / cores);
    ratioWall.push_back(fullWall.back() / rawWall.back());
    ratioCpu.push_back(fullCpu.back() / rawCpu.back());
  }
  return {{median(fullWall), median(fullCpu)},
          {median(rawWall), median(rawCpu)},
          median(ratioWall),
          median(ratioCpu)};
}

// Per phase, ms a frame on the rendering threads divided by their number.
std::vector<double> phaseBreakdown(const PhysicalScene& scene, const RayTextures& textures,
                                   RenderOptions options, int frames) {
  options.timePhases = true;
  const double cores = std::max(1u, std::thread::hardware_concurrency());
  std::vector<double> ms(kRenderPhases, 0.0);
  Frame frame;
  for (int i = 0; i < frames; ++i) {
    RenderCounters counters;
    renderFrameInto(scene, textures, options, &frame, &counters);
    for (int p = 0; p < kRenderPhases; ++p)
      ms[static_cast<size_t>(p)] += counters.phaseThreadMs[p] / cores / frames;
  }
  return ms;
}

// The renderer's defaults with the tile size asked for.
RenderOptions benchOptions(const BenchArgs& args) {
  RenderOptions options;
  options.tileWidth = args.tileWidth;
  options.tileHeight = args.tileHeight;
  options.validate();
  return options;
}

// --render-only: the chosen traversal's frames and nothing else (no replay, no other traversal),
// so that a sampling profiler run over it (tools/profile_tracer.sh) splits a frame's time between
// Embree and the rest. On a VM whose speed drifts from minute to minute that split is steadier
// than any pair of ms figures: both sides are sampled over the same seconds.
void renderOnly(const BenchArgs& args, const DisplayModel& model, const RayTextures& textures,
                const std::vector<std::string>& names) {
  for (const std::string& name : names) {
    const Scene scene = resolveScene(name);
    const PhysicalScene physical(scene, model.displayableBox);
    const RenderOptions options = benchOptions(args);
    const Timing t = timeFrames(physical, textures, options, args.frames);
    std::cout << fmt::format(
        "{:<8} {} frames, {} traversal: median {:.1f} ms wall, {:.1f} ms cpu per core\n", name,
        args.frames, traversalName(options.traversal), t.wallMs, t.cpuMsPerCore);
  }
}

void runBenchTracer(const BenchArgs& args) {
  if (args.frames < 1 || args.frames > 1000)
    throw InputError({"", "--frames", 0}, "must be in 1..1000");
  const DisplayModel model = resolveDisplay(args.display);
  const int module = args.module >= 0 ? args.module : static_cast<int>(model.modules.size() / 2);
  if (module >= static_cast<int>(model.modules.size())) {
    throw InputError({"", "--module", 0}, fmt::format("must be 0..{}", model.modules.size() - 1));
  }
  const RayTextures textures = generateRayTextures(model, module);
  const std::map<std::string, double> paperMs = {
      {"cornell", 146.0}, {"shapes", 205.0}, {"statue", 1085.0}};
  std::vector<std::string> names;
  std::stringstream list(args.scenes);
  for (std::string name; std::getline(list, name, ',');) names.push_back(name);

  std::cout << fmt::format(
      "tracer bench: display \"{}\", module {} ({}x{}, {} unmasked pixels), median of {} frames, "
      "{} threads\n",
      model.name, module, textures.width(), textures.height(), textures.validCount(), args.frames,
      std::thread::hardware_concurrency());
  if (args.renderOnly) {
    renderOnly(args, model, textures, names);
    return;
  }
  std::cout << "(wall-clock on a shared machine: other builds running at the same time make these "
               "noisy)\n\n";
  std::cout << "wall = median wall-clock ms a frame; cpu = process CPU ms / cores (what two idle "
               "cores would take)\n";
  std::cout << fmt::format(
      "{:<8} {:>5} {:>7} | {:>7} {:>7} {:>7} | {:>7} {:>7} | {:>7} {:>7} | {:>5} {:>5} | {:>6}\n",
      "scene", "tris", "rays", "single", "pack16", "stream", "chosen", "chosen", "raw16", "raw16",
      "ratio", "ratio", "paper");
  std::cout << fmt::format(
      "{:<8} {:>5} {:>7} | {:>7} {:>7} {:>7} | {:>7} {:>7} | {:>7} {:>7} | {:>5} {:>5} | {:>6}\n",
      "", "", "/frame", "cpu", "cpu", "cpu", "wall", "cpu", "wall", "cpu", "wall", "cpu", "GTX960");
  struct PerKind {
    std::string scene;
    long rays[3];
    double ms[3];
  };
  std::vector<PerKind> kinds;
  std::vector<std::pair<std::string, std::vector<double>>> phases;
  std::vector<std::string> explains;
  std::vector<std::string> choices;  // per scene: stream / packet16
  for (const std::string& name : names) {
    const Scene scene = resolveScene(name);
    const PhysicalScene physical(scene, model.displayableBox);
    const RenderOptions options = benchOptions(args);
    RenderCounters counters;
    renderFrame(physical, textures, options, &counters);  // warm-up (caches, TBB workers, textures)
    double streamOverPacket = 0.0;
    const std::map<Traversal, Timing> timing =
        timeTraversals(physical, textures, options, args.frames, &streamOverPacket);
    choices.push_back(fmt::format("{} {:.2f}", name, streamOverPacket));
    RayLog log;
    renderFrame(physical, textures, options, nullptr, &log);
    long rays = 0;
    const Paired paired = timePaired(physical, textures, options, log, args.frames, &rays);
    const Timing& chosen = paired.full;
    const Timing& raw = paired.raw;
    phases.push_back({name, phaseBreakdown(physical, textures, options, args.frames)});
    const auto paper = paperMs.find(name);
    std::cout << fmt::format(
        "{:<8} {:>5} {:>6}k | {:>7.1f} {:>7.1f} {:>7.1f} | {:>7.1f} {:>7.1f} | {:>7.1f} {:>7.1f} | "
        "{:>5.2f} {:>5.2f} | {:>6}\n",
        name, physical.counters().trianglesBuilt, rays / 1000,
        timing.at(Traversal::kSingle).cpuMsPerCore, timing.at(Traversal::kPacket16).cpuMsPerCore,
        timing.at(Traversal::kStream).cpuMsPerCore, chosen.wallMs, chosen.cpuMsPerCore, raw.wallMs,
        raw.cpuMsPerCore, paired.ratioWall, paired.ratioCpu,
        paper == paperMs.end() ? std::string("-") : fmt::format("{:.0f}", paper->second));
    PerKind k{name, {0, 0, 0}, {0, 0, 0}};
    int i = 0;
    for (RayKind kind : {RayKind::kPrimary, RayKind::kShadow, RayKind::kSecondary}) {
      k.ms[i] =
          timeReplay(physical, log, options.traversal, kind, args.frames, &k.rays[i]).cpuMsPerCore;
      ++i;
    }
    kinds.push_back(k);
    std::string e = fmt::format("{} (left out / ran):\n", name);
    for (const std::string& line : physical.features().explain()) e += line + "\n";
    for (const std::string& line : counters.lines()) e += line + "\n";
    explains.push_back(e);
  }
  std::cout << fmt::format(
      "\nchosen traversal: {}. ratio = chosen full frame / raw packet16 intersection of the same "
      "rays (no shading;\n"
      "each logged batch copied into packets right before its Embree call, the copy timed alone "
      "and subtracted),\n"
      "the median of per-frame ratios, full frame and replay alternating. chosen and raw16: "
      "medians of those frames.\n"
      "single, pack16, stream: one frame of each in turn; stream / pack16 CPU time, median over "
      "those rounds: {}\n",
      traversalName(RenderOptions{}.traversal), fmt::join(choices, ", "));
  std::cout << fmt::format(
      "\nMrays/s by ray type (raw {} replay of one frame's rays, CPU time per core):\n",
      traversalName(RenderOptions{}.traversal));
  std::cout << fmt::format("{:<8} {:>20} {:>20} {:>20}\n", "scene", "primary", "shadow",
                           "reflect+refract");
  for (const PerKind& k : kinds) {
    std::string cells[3];
    for (int i = 0; i < 3; ++i) {
      cells[i] = k.rays[i] == 0
                     ? std::string("-")
                     : fmt::format("{:.1f} ({}k)", static_cast<double>(k.rays[i]) / (k.ms[i] * 1e3),
                                   k.rays[i] / 1000);
    }
    std::cout << fmt::format("{:<8} {:>20} {:>20} {:>20}\n", k.scene, cells[0], cells[1], cells[2]);
  }
  std::cout << "\nwhere a frame's time goes (chosen traversal, ms a frame: time on the rendering "
               "threads / their\n"
               "number; timed in separate frames, the phase clock itself adds about 2%):\n";
  std::cout << fmt::format("{:<8}", "scene");
  for (int p = 0; p < kRenderPhases; ++p)
    std::cout << fmt::format(" {:>9}", renderPhaseName(static_cast<RenderPhase>(p)));
  std::cout << fmt::format(" | {:>7} {:>7}\n", "Embree", "other");
  for (const auto& [scene, ms] : phases) {
    std::cout << fmt::format("{:<8}", scene);
    for (double v : ms) std::cout << fmt::format(" {:>9.1f}", v);
    const double embree = ms[static_cast<size_t>(RenderPhase::kIntersect)] +
                          ms[static_cast<size_t>(RenderPhase::kOcclude)];
    double total = 0.0;
    for (double v : ms) total += v;
    std::cout << fmt::format(" | {:>7.1f} {:>7.1f}\n", embree, total - embree);
  }
  std::cout << "\nper-frame counters:\n";
  for (const std::string& e : explains) std::cout << e;
}

}  // namespace

void addBenchCommand(CLI::App& app) {
  CLI::App* bench = app.add_subcommand("bench", "print performance figures (never pass/fail)");
  bench->require_subcommand(1);
  auto args = std::make_shared<BenchArgs>();
  CLI::App* tracer = bench->add_subcommand(
      "tracer", "ms a frame of the paper's three scenes, by traversal, vs raw Embree");
  tracer->add_option("--display", args->display,
                     "display JSON file or built-in name (default: default)");
  tracer->add_option("--module", args->module, "module index (default: the middle one)");
  tracer->add_option("--frames", args->frames, "frames to time per figure (median)");
  tracer->add_option("--scenes", args->scenes, "comma-separated scene names or model files");
  tracer->add_option("--tile-width", args->tileWidth, "tile width in pixels (TBB task size)");
  tracer->add_option("--tile-height", args->tileHeight, "tile height in pixels");
  tracer->add_flag(
      "--render-only", args->renderOnly,
      "only render the frames with the chosen traversal (for a profiler: tools/profile_tracer.sh)");
  tracer->callback([args] { runBenchTracer(*args); });
  addBenchTextureSubcommand(bench);
  addBenchDaemonSubcommand(bench);
  addBenchClusterSubcommand(bench);
}

}  // namespace parallax::cli
