#include "daemon/cli/cluster_job.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "daemon/cli/bench_daemon_client.h"

extern char** environ;

namespace parallax::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

// Per Present: the spread of the modules' switch times over every rank's simulator record
// (hw/simulator presents.tsv, CLOCK_MONOTONIC: one clock for every process of the machine).
std::vector<double> switchSkews(const fs::path& dump, int ranks) {
  std::map<uint32_t, std::pair<int64_t, int64_t>> spread;
  for (int r = 0; r < ranks; ++r) {
    const fs::path file =
        ranks == 1 ? dump / "presents.tsv" : dump / fmt::format("rank-{}", r) / "presents.tsv";
    std::ifstream in(file);
    std::string line;
    std::getline(in, line);
    while (std::getline(in, line)) {
      std::istringstream row(line);
      uint32_t frame = 0, shows = 0;
      int module = 0, switched = 0;
      int64_t at = 0;
      row >> frame >> module >> shows >> switched >> at;
      if (!switched) continue;
      auto [it, fresh] = spread.try_emplace(frame, at, at);
      if (!fresh) {
        it->second.first = std::min(it->second.first, at);
        it->second.second = std::max(it->second.second, at);
      }
    }
  }
  std::vector<double> skews;
  for (const auto& [frame, s] : spread)
    skews.push_back(static_cast<double>(s.second - s.first) / 1e6);
  return skews;
}

// The cluster's exchanges over a window (status.cluster.sync_ms, or nothing with one rank).
double syncWindowMs(const json& before, const json& after, const char* stage) {
  if (!before.contains("cluster") || !after.contains("cluster")) return 0.0;
  return windowMeanMs(before["cluster"]["sync_ms"][stage], after["cluster"]["sync_ms"][stage]);
}

}  // namespace

ClusterJobFigures runClusterJob(const ClusterJobOptions& args) {
  const int ranks = args.ranks;
  const int modules = args.modules;
  const std::string& displayKeys = args.displayKeys;
  const fs::path work =
      fs::temp_directory_path() / fmt::format("parallax-bench-cluster-{}-{}", ::getpid(), ranks);
  fs::remove_all(work);
  fs::create_directories(work);
  const std::string socket = (work / "ctl.sock").string();
  std::string script = sceneForConfig(args.scene);
  if (!args.sceneSource.empty()) {
    script = (work / "scene.lua").string();
    std::ofstream(script) << args.sceneSource;
  }
  const std::string cache = benchCacheDir(work.string());
  {
    std::ofstream config(work / "parallax.toml");
    config << fmt::format(
        "[display]\npreset = \"demo\"\n{}[scene]\nscript = \"{}\"\nfps = {}\n"
        "[calibration]\nauto = false\nfile = \"{}\"\n[hardware]\ndump = \"{}\"\n"
        "[daemon]\nsocket = \"{}\"\ncache_dir = \"{}\"\nlog_level = \"warn\"\n"
        "[panel]\nenabled = false\n[cluster]\ntimeout_ms = 120000\n",
        displayKeys, script, args.fps, (work / "calibration.json").string(),
        (work / "dump").string(), socket, cache);
  }
  std::string launcher = "mpirun";
  std::string daemonPath = siblingBinary("parallaxd");
  const std::string configPath = (work / "parallax.toml").string();
  const std::string np = std::to_string(ranks);
  const std::string logPath = (work / "parallaxd.log").string();
  std::vector<char*> argv = {launcher.data(),
                             const_cast<char*>("--oversubscribe"),
                             const_cast<char*>("-np"),
                             const_cast<char*>(np.c_str()),
                             daemonPath.data(),
                             const_cast<char*>("--config"),
                             const_cast<char*>(configPath.c_str()),
                             nullptr};
  // Open MPI refuses to run as root unless told twice (CI containers run as root).
  std::vector<std::string> env;
  for (char** e = environ; *e; ++e) env.emplace_back(*e);
  env.emplace_back("OMPI_ALLOW_RUN_AS_ROOT=1");
  env.emplace_back("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1");
  std::vector<char*> envp;
  for (std::string& e : env) envp.push_back(e.data());
  envp.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, logPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                   0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = -1;
  const int spawned = ::posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0)
    throw std::runtime_error("cannot start mpirun: install Open MPI (openmpi-bin) to run this");

  ClusterJobFigures f;
  f.ranks = ranks;
  f.modules = modules;
  try {
    waitForStats(
        socket, [](const json& s) { return s.value("display_frames", 0) >= 3; }, "the first frames",
        1800);
    const json stats0 = askOrNull(socket, {{"request", "stats"}});
    const json status0 = askOrNull(socket, {{"request", "status"}});
    const auto t0 = Clock::now();
    std::this_thread::sleep_for(std::chrono::duration<double>(args.seconds));
    const double count0 = stats0["display_frames"].get<double>();
    const json stats1 = waitForStats(
        socket, [count0](const json& s) { return s["display_frames"].get<double>() >= count0 + 2; },
        "two frames in the window", 1800);
    const json status1 = askOrNull(socket, {{"request", "status"}});
    const double dt = std::chrono::duration<double>(Clock::now() - t0).count();
    f.frames = stats1["display_frames"].get<double>() - count0;
    f.fps = f.frames / dt;
    f.broadcast = syncWindowMs(status0, status1, "tell");
    f.agree = syncWindowMs(status0, status1, "agree");
    f.report = syncWindowMs(status0, status1, "report");
    f.overhead = status1.contains("cluster") && status1["cluster"]["sync_ms"].contains("overhead")
                     ? syncWindowMs(status0, status1, "overhead")
                     : std::numeric_limits<double>::quiet_NaN();
    f.present = windowMeanMs(stats0["timings"]["present"], stats1["timings"]["present"]);
    double cpuMs = 0.0;
    if (status1.contains("cluster")) {
      const json& r0 = status0["cluster"]["rank"];
      const json& r1 = status1["cluster"]["rank"];
      for (size_t r = 0; r < r1.size(); ++r) {
        f.renderPerRank.push_back(
            windowMeanMs(r0[r]["timings"]["render"], r1[r]["timings"]["render"]));
        const double push = windowMeanMs(r0[r]["timings"]["push"], r1[r]["timings"]["push"]);
        f.pushPerRank.push_back(push);
        if (r1[r].contains("timings") && r1[r]["timings"].contains("work"))
          f.workPerRank.push_back(windowMeanMs(r0[r]["timings"]["work"], r1[r]["timings"]["work"]));
        f.pushMsPerModule =
            std::max(f.pushMsPerModule, push / static_cast<double>(r1[r]["modules"].size()));
        cpuMs += r1[r]["cpu_ms"].get<double>() - r0[r]["cpu_ms"].get<double>();
      }
    } else {
      f.renderPerRank.push_back(
          windowMeanMs(stats0["timings"]["render"], stats1["timings"]["render"]));
      f.pushPerRank.push_back(windowMeanMs(stats0["timings"]["push"], stats1["timings"]["push"]));
      f.pushMsPerModule = f.pushPerRank.back() / modules;
      cpuMs = stats1["cpu_ms"].get<double>() - stats0["cpu_ms"].get<double>();
    }
    // The stats are rank 0's; the other ranks' last report may lag it by one turn.
    f.cpuMsPerModuleFrame = cpuMs / std::max(1.0, f.frames) / modules;
  } catch (...) {
    ::kill(pid, SIGTERM);
    ::waitpid(pid, nullptr, 0);
    std::ifstream log(logPath);
    std::cerr << "parallaxd's log:\n" << log.rdbuf();
    fs::remove_all(work);
    throw;
  }
  askOrNull(socket, {{"request", "shutdown"}});
  ::waitpid(pid, nullptr, 0);
  f.skewsMs = switchSkews(work / "dump", ranks);
  fs::remove_all(work);
  return f;
}

ClusterJobOptions syncOnlyJob(int ranks, double seconds) {
  ClusterJobOptions job;
  job.ranks = ranks;
  job.modules = ranks;
  job.displayKeys = fmt::format("modules = {}\nresolution = [16, 12]\n", ranks);
  job.seconds = seconds;
  job.scene = "ball";
  job.sceneSource =
      "px.name(\"ball\")\n"
      "local white = px.diffuse{name = \"white\", color = {0.8, 0.8, 0.8}}\n"
      "local ball = px.sphere{radius = 0.1, slices = 6, stacks = 3, material = white, "
      "name = \"ball\"}\n"
      "px.world_box{min = {-1, -1, -1}, max = {1, 1, 1}}\n"
      "function update(t, dt) px.set_transform(ball, px.translate(0.5 * math.cos(t), 0, 0)) end\n";
  job.fps = 240.0;
  return job;
}

double quantileMs(std::vector<double> ms, double q) {
  if (ms.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(ms.begin(), ms.end());
  return ms[static_cast<size_t>(q * static_cast<double>(ms.size() - 1))];
}

ClusterModel ClusterModel::from(const std::vector<ClusterJobFigures>& runs,
                                const ClusterJobFigures& syncOnly, double pixelsPerModule) {
  if (runs.empty()) throw std::invalid_argument("ClusterModel::from: no job");
  // The CPU time of a module frame from the job with the fewest ranks (least oversubscribed),
  // scaled by pixels to `default`; the push a module; the sync per extra rank.
  const ClusterJobFigures& base = *std::min_element(
      runs.begin(), runs.end(),
      [](const ClusterJobFigures& a, const ClusterJobFigures& b) { return a.ranks < b.ranks; });
  ClusterModel m;
  m.pixelScale = kPixels / pixelsPerModule;
  m.measuredCpuMs = base.cpuMsPerModuleFrame;
  m.measuredRanks = base.ranks;
  m.coreMsPerModule = base.cpuMsPerModuleFrame * m.pixelScale;
  m.pushMsPerModule = base.pushMsPerModule * m.pixelScale;
  m.syncPerRankMs = syncOnly.ranks > 1 ? syncOnly.sync() / (syncOnly.ranks - 1) : syncOnly.sync();
  return m;
}

double ClusterModel::predictFps(int nodes, int cores) const {
  const int modules = (kModules + nodes - 1) / nodes;  // the busiest node's
  const double sync = nodes > 1 ? syncPerRankMs * (nodes - 1) + networkMs : 0.0;
  const double frameMs = modules * coreMsPerModule / cores + modules * pushMsPerModule + sync;
  return 1000.0 / frameMs;
}

std::string ClusterModel::assumptions(const std::string& scene) const {
  return fmt::format(
      "a module frame of {} costs {:.1f} core-ms (measured {:.2f} with {} rank(s) on demo, x{:.1f} "
      "for the pixels) and the renderer scales with the cores; the busiest node has ceil(72/N) "
      "modules and pushes them one after the other at {:.2f} ms each (measured over the "
      "simulator's socket, x{:.1f}); sync {:.3f} ms a frame per extra rank (measured, rank 0 "
      "talks to each rank) plus {:.2f} ms of network round trips; no pipelining of render and "
      "push; the modules' own refresh rate is not a limit here",
      scene, coreMsPerModule, measuredCpuMs, measuredRanks, pixelScale, pushMsPerModule, pixelScale,
      syncPerRankMs, networkMs);
}

const std::vector<int>& ClusterModel::nodeCounts() {
  static const std::vector<int> counts = {1, 2, 3, 4, 6, 8, 9, 12, 18, 24, 36, 72};
  return counts;
}

}  // namespace parallax::cli
