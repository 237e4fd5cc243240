// parallax bench cluster [--ranks 1,2,3] [--seconds 15] [--scene orbit] [--fps 30] [--sync-only]
// parallaxd as a cluster (issue 23), measured as it runs (cluster_job.h): jobs of 1, 2, 3 ranks
// on the demo display, per display frame: broadcast, each rank's render and push, agree,
// present, report, and the swap lock's skew. Then the sync overhead alone: the same exchanges on a
// display of one 16x12 module a rank, where rendering and pushing cost next to nothing (for each
// rank count of 2 and more). Last, from the
// measured CPU time a module frame and the sync overhead, a table of predicted display frame rates
// for `default` (72 modules of 1024x768) on 1-72 nodes of 2, 16 and 64 cores, with its assumptions.
// On one machine the ranks share its cores: correctness and overhead, not speed. Figures only;
// nothing passes or fails on time.

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <iostream>
#include <sstream>
#include <thread>

#include "common/input_error.h"
#include "daemon/cli/bench_daemon_client.h"
#include "daemon/cli/cluster_job.h"
#include "daemon/cli/commands.h"

namespace parallax::cli {
namespace {

struct BenchClusterArgs {
  std::string ranks = "1,2,3";
  double seconds = 15.0;
  std::string scene = "orbit";
  double fps = 30.0;
  bool syncOnly = false;  // only the sync-only jobs (no demo jobs, no model)
};

// The demo display the runs play.
constexpr int kDemoModules = 16;
constexpr double kDemoPixels = 512.0 * 384.0;

std::string percentile(const std::vector<double>& ms, double q) {
  if (ms.empty()) return "-";
  return fmt::format("{:.3f}", quantileMs(ms, q));
}

ClusterJobOptions jobOptions(const BenchClusterArgs& args, int ranks) {
  ClusterJobOptions o;
  o.ranks = ranks;
  o.modules = kDemoModules;
  o.seconds = args.seconds;
  o.scene = args.scene;
  o.fps = args.fps;
  return o;
}

void printRun(const ClusterJobFigures& f) {
  std::vector<std::string> render, push;
  for (double ms : f.renderPerRank) render.push_back(fmt::format("{:.1f}", ms));
  for (double ms : f.pushPerRank) push.push_back(fmt::format("{:.1f}", ms));
  std::cout << fmt::format(
      "  {} rank(s), {} modules: {:.2f} fps over {:.0f} display frames; per display frame (ms): "
      "broadcast {:.3f}, render per rank [{}], push per rank [{}], agree {:.3f} (waits for the "
      "slowest render), present {:.3f} (waits for the slowest push), report {:.3f}; parallaxd CPU "
      "{:.1f} ms a module frame\n",
      f.ranks, f.modules, f.fps, f.frames, f.broadcast, fmt::join(render, ", "),
      fmt::join(push, ", "), f.agree, f.present, f.report, f.cpuMsPerModuleFrame);
  std::vector<std::string> work;
  for (double ms : f.workPerRank) work.push_back(fmt::format("{:.2f}", ms));
  if (f.ranks > 1)
    std::cout << fmt::format(
        "    rank 0's waits (broadcast + agree + present + report) {:.3f} ms; each rank's own work "
        "(scene, render, push) [{}] ms; the cluster's overhead (the turn less the slowest rank's "
        "work) {:.3f} ms\n",
        f.waits(), fmt::join(work, ", "), f.overhead);
  std::cout << fmt::format(
      "    swap lock: skew between the first and the last module's switch over {} presents: "
      "median {} ms, p95 {} ms, max {} ms\n",
      f.skewsMs.size(), percentile(f.skewsMs, 0.5), percentile(f.skewsMs, 0.95),
      percentile(f.skewsMs, 1.0));
}

void runBenchCluster(const BenchClusterArgs& args) {
  std::vector<int> rankCounts;
  std::stringstream list(args.ranks);
  for (std::string r; std::getline(list, r, ',');) {
    const int n = std::atoi(r.c_str());
    if (n < 1 || n > kDemoModules)
      throw InputError({"", "--ranks", 0}, fmt::format("rank counts in 1..{}", kDemoModules));
    rankCounts.push_back(n);
  }
  if (rankCounts.empty()) throw InputError({"", "--ranks", 0}, "e.g. 1,2,3");
  std::cout << fmt::format(
      "bench cluster: {} hardware threads (ranks oversubscribed: correctness and overhead, not "
      "speed), load average at start: {}\n",
      std::thread::hardware_concurrency(), loadAverage());

  std::vector<ClusterJobFigures> runs;
  if (!args.syncOnly) {
    std::cout << fmt::format("demo display ({} modules of 512x384), {} at {} fps:\n", kDemoModules,
                             args.scene, args.fps);
    for (int n : rankCounts) {
      runs.push_back(runClusterJob(jobOptions(args, n)));
      printRun(runs.back());
    }
  }

  // The sync overhead alone: one tiny module a rank, next to nothing to render or push; for
  // each rank count of 2 and more.
  ClusterJobFigures sync;
  for (int n : rankCounts) {
    if (n < 2 && rankCounts.size() > 1) continue;
    const ClusterJobOptions syncJob = syncOnlyJob(n, args.seconds);
    std::cout << fmt::format(
        "sync overhead alone ({} ranks, one 16x12 module each, one moving ball at {} fps):\n", n,
        syncJob.fps);
    sync = runClusterJob(syncJob);
    printRun(sync);
    std::cout << fmt::format(
        "  sync a display frame with {} ranks: {:.3f} ms (target <= 1 ms on one machine)\n", n,
        sync.sync());
  }
  if (args.syncOnly) return;

  const ClusterModel model = ClusterModel::from(runs, sync, kDemoPixels);
  std::cout << fmt::format(
      "predicted display frame rate of `default` ({} modules of 1024x768, {}) on N nodes of C "
      "cores:\n  assumptions: {}\n",
      ClusterModel::kModules, args.scene, model.assumptions(args.scene));
  std::cout << fmt::format("  {:>5} {:>9} {:>10} {:>10} {:>10}\n", "nodes", "modules", "2 cores",
                           "16 cores", "64 cores");
  for (int nodes : ClusterModel::nodeCounts()) {
    std::cout << fmt::format("  {:>5} {:>9} {:>10.2f} {:>10.2f} {:>10.2f}\n", nodes,
                             (ClusterModel::kModules + nodes - 1) / nodes,
                             model.predictFps(nodes, 2), model.predictFps(nodes, 16),
                             model.predictFps(nodes, 64));
  }
}

}  // namespace

void addBenchClusterSubcommand(CLI::App* bench) {
  auto args = std::make_shared<BenchClusterArgs>();
  CLI::App* command = bench->add_subcommand(
      "cluster",
      "parallaxd under mpirun: broadcast, render, push, agree, present per display frame, the "
      "sync overhead, the swap lock's skew, predicted frame rates of `default` on 1-72 nodes");
  command->add_option("--ranks", args->ranks, "comma-separated rank counts (default 1,2,3)");
  command->add_option("--seconds", args->seconds, "how long each job plays");
  command->add_option("--scene", args->scene, "the animated script: a library name or a .lua");
  command->add_option("--fps", args->fps, "target frame rate");
  command->add_flag("--sync-only", args->syncOnly,
                    "only the sync overhead jobs (one 16x12 module a rank), for each rank count");
  command->callback([args] { runBenchCluster(*args); });
}

}  // namespace parallax::cli
