#pragma once
// parallaxd as a cluster (issue 23), measured as it runs: `mpirun --oversubscribe -np N
// parallaxd` on the demo display (each rank with a simulator of its modules) plays an animated
// scene; from the daemon's own stats and every rank's report, per display frame: rank 0 telling
// the turn (broadcast), each rank's render and push, agreeing on the frame, agreeing to present
// and the Present (the swap lock), the reports; the skew between the first and the last module's
// switch from the simulators' records. From such jobs, a model of the display frame rate of
// `default` on N nodes of C cores. Shared by `parallax bench cluster` and the report's cluster
// section. On one machine the ranks share its cores: correctness and overhead, not speed.

#include <cmath>
#include <string>
#include <vector>

namespace parallax::cli {

struct ClusterJobOptions {
  int ranks = 1;
  std::string displayKeys;  // extra [display] keys over the demo preset (lines, each "k = v\n")
  int modules = 16;         // the display's modules with those keys
  double seconds = 15.0;    // the measured window
  std::string scene = "orbit";
  std::string sceneSource;  // when set: the job plays this Lua text, not `scene`
  double fps = 30.0;
};

// The exchanges alone: `ranks` ranks of one 16x12 module each at 240 fps, playing one small
// moving ball, where building the scene, rendering and pushing cost ~0.1 ms a rank (a scene
// like orbit costs each rank ~1 ms of CPU a frame to build, which 3 ranks on 2 cores wait on).
ClusterJobOptions syncOnlyJob(int ranks, double seconds);

// What one job measured, per display frame (ms) unless said otherwise.
struct ClusterJobFigures {
  int ranks = 0;
  int modules = 0;
  double fps = 0.0, frames = 0.0;
  double broadcast = 0.0, agree = 0.0, present = 0.0, report = 0.0;
  // What the cluster adds to a display frame: rank 0's turn less the slowest rank's own work
  // (render and push). NaN from a parallaxd that does not measure it.
  double overhead = 0.0;
  std::vector<double> workPerRank;  // each rank's own part of a frame (scene, render, push)
  std::vector<double> renderPerRank, pushPerRank;
  double cpuMsPerModuleFrame = 0.0;  // every rank's parallaxd CPU time / module frames
  double pushMsPerModule = 0.0;      // the slowest rank's push / its modules
  std::vector<double> skewsMs;       // per Present: the last module's switch - the first's
  // Rank 0's waits on the exchanges (tell, agree, present, report): the slowest rank's extra
  // render and push time included.
  double waits() const { return broadcast + agree + present + report; }
  // The sync overhead a display frame: `overhead` where measured, else the waits.
  double sync() const { return std::isnan(overhead) ? waits() : overhead; }
};

// Runs one job to its end (shutdown); throws when mpirun cannot start or the daemon fails (its
// log on standard error).
ClusterJobFigures runClusterJob(const ClusterJobOptions& options);

// The q-quantile of `ms` (NaN when empty).
double quantileMs(std::vector<double> ms, double q);

// `default` (72 modules of 1024x768) on N nodes of C cores, from measured jobs.
struct ClusterModel {
  static constexpr int kModules = 72;
  static constexpr double kPixels = 1024.0 * 768.0;
  double coreMsPerModule = 0.0;      // a module frame's CPU, scaled to default's pixels
  double pushMsPerModule = 0.0;      // likewise
  double syncPerRankMs = 0.0;        // the sync a display frame per extra rank (a star)
  double networkMs = 4 * 2 * 0.025;  // 4 exchanges a frame, there and back, 25 us each
  // The measurement the figures come from, for the assumptions' text.
  double measuredCpuMs = 0.0, pixelScale = 1.0;
  int measuredRanks = 1;

  // From the jobs on the display of `pixelsPerModule` (the fewest ranks: least oversubscribed)
  // and a sync-only job of `syncRanks` ranks.
  static ClusterModel from(const std::vector<ClusterJobFigures>& runs,
                           const ClusterJobFigures& syncOnly, double pixelsPerModule);
  double predictFps(int nodes, int cores) const;
  std::string assumptions(const std::string& scene) const;
  static const std::vector<int>& nodeCounts();  // 1 ... 72
};

}  // namespace parallax::cli
