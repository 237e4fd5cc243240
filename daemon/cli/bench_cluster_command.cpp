// parallax bench cluster [--ranks 1,2,3] [--seconds 15] [--scene orbit] [--fps 30]
// parallaxd as a cluster (issue 23), measured as it runs: `mpirun --oversubscribe -np N parallaxd`
// on the demo display (each rank with a simulator of its modules) plays the animated scene; from
// the daemon's own stats and every rank's report, per display frame: rank 0 telling the turn
// (broadcast), each rank's render and push, agreeing on the frame, agreeing to present and the
// Present (the swap lock), the reports; the skew between the first and the last module's switch
// from the simulators' records. Then the sync overhead alone: the same exchanges on a display of
// one 16x12 module a rank, where rendering and pushing cost nothing. Last, from the measured CPU
// time a module frame and the sync overhead, a table of predicted display frame rates for
// `default` (72 modules of 1024x768) on 1-72 nodes of 2, 16 and 64 cores, with its assumptions.
// On one machine the ranks share its cores: correctness and overhead, not speed. Figures only;
// nothing passes or fails on time.

#include <fcntl.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
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
#include <map>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "common/input_error.h"
#include "daemon/cli/bench_daemon_client.h"
#include "daemon/cli/commands.h"

extern char** environ;

namespace parallax::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

struct BenchClusterArgs {
  std::string ranks = "1,2,3";
  double seconds = 15.0;
  std::string scene = "orbit";
  double fps = 30.0;
};

// The demo display the runs play, and the `default` display the table predicts.
constexpr int kDemoModules = 16;
constexpr double kDemoPixels = 512.0 * 384.0;
constexpr int kDefaultModules = 72;
constexpr double kDefaultPixels = 1024.0 * 768.0;

// What one run measured, per display frame (ms) unless said otherwise.
struct RunFigures {
  int ranks = 0;
  int modules = 0;
  double fps = 0.0, frames = 0.0;
  double broadcast = 0.0, agree = 0.0, present = 0.0, report = 0.0;
  std::vector<double> renderPerRank, pushPerRank;
  double cpuMsPerModuleFrame = 0.0;  // every rank's parallaxd CPU time / module frames
  double pushMsPerModule = 0.0;      // the slowest rank's push / its modules
  std::vector<double> skewsMs;       // per Present: the last module's switch - the first's
  double sync() const { return broadcast + agree + present + report; }
};

std::string percentile(std::vector<double> ms, double q) {
  if (ms.empty()) return "-";
  std::sort(ms.begin(), ms.end());
  return fmt::format("{:.3f}", ms[static_cast<size_t>(q * static_cast<double>(ms.size() - 1))]);
}

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

// One job: `mpirun -np ranks parallaxd` on `display` (extra [display] keys) playing the scene.
RunFigures runJob(int ranks, const std::string& displayKeys, int modules,
                  const BenchClusterArgs& args) {
  const fs::path work =
      fs::temp_directory_path() / fmt::format("parallax-bench-cluster-{}-{}", ::getpid(), ranks);
  fs::remove_all(work);
  fs::create_directories(work);
  const std::string socket = (work / "ctl.sock").string();
  const std::string script = sceneForConfig(args.scene);
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

  RunFigures f;
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

void printRun(const RunFigures& f) {
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
  std::cout << fmt::format(
      "    swap lock: skew between the first and the last module's switch over {} presents: "
      "median {} ms, p95 {} ms, max {} ms\n",
      f.skewsMs.size(), percentile(f.skewsMs, 0.5), percentile(f.skewsMs, 0.95),
      percentile(f.skewsMs, 1.0));
}

// Predicted display frames a second of `default` on `nodes` nodes of `cores` cores each.
double predictFps(int nodes, int cores, double coreMsPerModule, double pushMsPerModule,
                  double syncPerRankMs, double networkMs) {
  const int modules = (kDefaultModules + nodes - 1) / nodes;  // the busiest node's
  const double sync = nodes > 1 ? syncPerRankMs * (nodes - 1) + networkMs : 0.0;
  const double frameMs = modules * coreMsPerModule / cores + modules * pushMsPerModule + sync;
  return 1000.0 / frameMs;
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

  std::cout << fmt::format("demo display ({} modules of 512x384), {} at {} fps:\n", kDemoModules,
                           args.scene, args.fps);
  std::vector<RunFigures> runs;
  for (int n : rankCounts) {
    runs.push_back(runJob(n, "", kDemoModules, args));
    printRun(runs.back());
  }

  // The sync overhead alone: one tiny module a rank, nothing to render or push.
  const int most = *std::max_element(rankCounts.begin(), rankCounts.end());
  BenchClusterArgs fast = args;
  fast.fps = 240.0;
  std::cout << fmt::format("sync overhead alone ({} ranks, one 16x12 module each, {} at {} fps):\n",
                           most, args.scene, fast.fps);
  const RunFigures sync =
      runJob(most, fmt::format("modules = {}\nresolution = [16, 12]\n", most), most, fast);
  printRun(sync);
  std::cout << fmt::format(
      "  sync a display frame (broadcast + agree + present + report): {:.3f} ms (target <= 1 ms "
      "on one machine)\n",
      sync.sync());

  // The model's inputs: the CPU time of a module frame (fewest ranks: least oversubscribed),
  // scaled by pixels to `default`; the push a module; the sync per rank.
  const RunFigures& base =
      *std::min_element(runs.begin(), runs.end(),
                        [](const RunFigures& a, const RunFigures& b) { return a.ranks < b.ranks; });
  const double pixelScale = kDefaultPixels / kDemoPixels;
  const double coreMs = base.cpuMsPerModuleFrame * pixelScale;
  const double pushMs = base.pushMsPerModule * pixelScale;
  const double perRank = most > 1 ? sync.sync() / (most - 1) : sync.sync();
  constexpr double kNetworkMs = 4 * 2 * 0.025;  // 4 exchanges a frame, there and back, 25 us
  std::cout << fmt::format(
      "predicted display frame rate of `default` ({} modules of 1024x768, {}) on N nodes of C "
      "cores:\n"
      "  assumptions: a module frame costs {:.1f} core-ms (measured {:.2f} with {} rank(s) on "
      "demo, x{:.0f} for the pixels) and the renderer scales with the cores; the busiest node "
      "has ceil(72/N) modules and pushes them one after the other at {:.2f} ms each (measured "
      "over the simulator's socket, x{:.0f}); sync {:.3f} ms a frame per extra rank (measured, "
      "rank 0 talks to each rank) plus {:.2f} ms of network round trips; no pipelining of render "
      "and push; the modules' own refresh rate is not a limit here\n",
      kDefaultModules, args.scene, coreMs, base.cpuMsPerModuleFrame, base.ranks, pixelScale, pushMs,
      pixelScale, perRank, kNetworkMs);
  std::cout << fmt::format("  {:>5} {:>9} {:>10} {:>10} {:>10}\n", "nodes", "modules", "2 cores",
                           "16 cores", "64 cores");
  for (int nodes : {1, 2, 3, 4, 6, 8, 9, 12, 18, 24, 36, 72}) {
    std::cout << fmt::format("  {:>5} {:>9} {:>10.2f} {:>10.2f} {:>10.2f}\n", nodes,
                             (kDefaultModules + nodes - 1) / nodes,
                             predictFps(nodes, 2, coreMs, pushMs, perRank, kNetworkMs),
                             predictFps(nodes, 16, coreMs, pushMs, perRank, kNetworkMs),
                             predictFps(nodes, 64, coreMs, pushMs, perRank, kNetworkMs));
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
  command->callback([args] { runBenchCluster(*args); });
}

}  // namespace parallax::cli
