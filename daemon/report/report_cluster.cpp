// The cluster (issue 23) as a trade-off: the rank count against the sync overhead it costs a
// display frame, and the frame rate modelled from what one rank's module frame costs.
// `mpirun --oversubscribe` jobs on the demo display at the report's scale (cli/cluster_job.h,
// the same jobs as `parallax bench cluster`), a sync-only job of tiny modules, then the
// modelled frame rates of `default` on 1-72 nodes.

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <exception>

#include "common/progress_bar.h"
#include "daemon/cli/cluster_job.h"
#include "daemon/report/report.h"

namespace parallax::report {
namespace {

constexpr const char* kTitle = "Cluster: rank count against sync overhead and frame rate";
constexpr const char* kScene = "orbit";

std::string maxOf(const std::vector<double>& ms) {
  return ms.empty() ? "-" : fixed(*std::max_element(ms.begin(), ms.end()), 1);
}

std::string quantile(const std::vector<double>& ms, double q) {
  const double v = cli::quantileMs(ms, q);
  return std::isfinite(v) ? fixed(v, 3) : "-";
}

}  // namespace

void writeClusterSection(Report& report) {
  const bool quick = report.options().quick;
  const std::vector<int> rankCounts = quick ? std::vector<int>{1, 2} : std::vector<int>{1, 2, 3};
  const double seconds = quick ? 3.0 : 10.0;
  const double scale = report.options().scale;
  const int width = std::max(16, static_cast<int>(std::lround(512 * scale)));
  const int height = std::max(12, static_cast<int>(std::lround(384 * scale)));
  constexpr int kModules = 16;

  std::vector<cli::ClusterJobFigures> runs;
  cli::ClusterJobFigures syncOnly;
  ProgressBar progress("cluster", static_cast<std::int64_t>(rankCounts.size()) + 1);
  try {
    for (int ranks : rankCounts) {
      cli::ClusterJobOptions job;
      job.ranks = ranks;
      job.modules = kModules;
      job.displayKeys = fmt::format("resolution = [{}, {}]\n", width, height);
      job.seconds = seconds;
      job.scene = kScene;
      runs.push_back(cli::runClusterJob(job));
      progress.advance();
    }
    syncOnly = cli::runClusterJob(cli::syncOnlyJob(rankCounts.back(), seconds));
    progress.advance();
  } catch (const std::exception& e) {
    progress.finish();
    report.absent(kTitle, fmt::format("the cluster jobs did not run: {}", e.what()));
    return;
  }
  progress.finish();

  Table measured{{"job", "ranks", "modules", "display frames/s", "render ms (slowest rank)",
                  "push ms (slowest rank)", "broadcast ms", "agree ms", "present ms", "report ms",
                  "sync ms a frame", "swap skew median ms", "swap skew p95 ms"},
                 {},
                 fmt::format("means over a {:g} s window of a running job (after its first 3 "
                             "display frames); the ranks and their simulators share this "
                             "machine's cores",
                             seconds)};
  const auto row = [&](const std::string& name, const cli::ClusterJobFigures& f) {
    measured.rows.push_back({name, std::to_string(f.ranks), std::to_string(f.modules),
                             fixed(f.fps, 2), maxOf(f.renderPerRank), maxOf(f.pushPerRank),
                             fixed(f.broadcast, 3), fixed(f.agree, 3), fixed(f.present, 3),
                             fixed(f.report, 3), fixed(f.sync(), 3), quantile(f.skewsMs, 0.5),
                             quantile(f.skewsMs, 0.95)});
  };
  for (const cli::ClusterJobFigures& f : runs)
    row(fmt::format("{} at {}x{}", kScene, width, height), f);
  row("sync only (16x12)", syncOnly);

  const cli::ClusterModel model =
      cli::ClusterModel::from(runs, syncOnly, static_cast<double>(width) * height);
  Table predicted{{"nodes", "modules a node", "2 cores fps", "16 cores fps", "64 cores fps"}, {}};
  std::vector<PlotSeries> series;
  for (int cores : {2, 16, 64}) series.push_back({fmt::format("{} cores", cores), {}, {}, true});
  for (int nodes : cli::ClusterModel::nodeCounts()) {
    std::vector<std::string> cells = {
        std::to_string(nodes), std::to_string((cli::ClusterModel::kModules + nodes - 1) / nodes)};
    int k = 0;
    for (int cores : {2, 16, 64}) {
      const double fps = model.predictFps(nodes, cores);
      cells.push_back(fixed(fps, 2));
      series[static_cast<size_t>(k++)].add(nodes, fps);
    }
    predicted.rows.push_back(cells);
  }

  report.heading(kTitle);
  report.text(fmt::format(
      "`mpirun --oversubscribe -np N parallaxd` plays `{}.lua` on the demo display ({} modules "
      "of {}x{}), each rank rendering and pushing its own modules to its own simulator, then a "
      "job of one 16x12 module a rank measures the exchanges alone. Per display frame: rank 0 "
      "tells the turn (broadcast), the ranks agree that every one rendered (waits for the "
      "slowest render), agree to present and send the Present of the swap lock (waits for the "
      "slowest push), and report. The same jobs as `parallax bench cluster`.",
      kScene, kModules, width, height));
  report.table("cluster", measured);
  report.bullet(fmt::format(
      "The sync overhead alone with {} ranks: {:.3f} ms a display frame (the issue's target: "
      "at most 1 ms on one machine); on a loaded machine it is mostly waiting for a rank the "
      "scheduler parked.",
      syncOnly.ranks, syncOnly.sync()));
  report.text(
      fmt::format("Modelled display frame rate of `default` ({} modules of 1024x768) on "
                  "N nodes of C cores. Assumptions: {}.",
                  cli::ClusterModel::kModules, model.assumptions(kScene)));
  report.table("cluster_model", predicted);
  report.figure("cluster_model", {.title = "cluster: modelled frame rate of the default display",
                                  .xLabel = "nodes",
                                  .yLabel = "display frames / s",
                                  .logX = true,
                                  .series = series});
}

}  // namespace parallax::report
