// parallax bench daemon [--display demo,default] [--seconds 10] [--fps 30] [--frame-cache on,off]
//                       [--scene orbit|FILE.lua]
// The daemon measured as it runs: starts the real parallaxd (which starts its own simulated
// display), plays the animated scripts/scenes/orbit.lua for --seconds and reads the daemon's
// own `stats` over the control socket — per display frame: render, encode, push and end-to-end
// latency, the frame rate reached against the target, dropped frames — plus the CPU time and
// peak memory of parallaxd and of the simulator from /proc; with the frame cache on and off
// (one daemon each, one after the other) and their ratio, and what the cache held and saved. Then
// one frame of the static cornell.lua, and `parallax ctl status` end to end (100 runs). Figures
// only; nothing passes or fails on time.

#include <fcntl.h>
#include <fmt/format.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
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

struct BenchDaemonArgs {
  std::string displays = "demo,default";
  double seconds = 10.0;
  double fps = 30.0;
  std::string frameCache = "on,off";
  std::string footprint = "on";
  std::string scene = "orbit";  // the animated script played
};

// What one run measured: display frames a second, and parallaxd's CPU time a display frame
// (which, unlike the frame rate, hardly depends on what else the machine runs).
struct PlayFigures {
  double fps = 0.0;
  double cpuMsPerFrame = 0.0;
};

// CPU seconds (user + system), peak and current resident MiB of a process, from /proc.
struct ProcessUse {
  double cpuSeconds = 0.0, peakMiB = 0.0, residentMiB = 0.0;
};
ProcessUse processUse(pid_t pid) {
  ProcessUse u;
  std::ifstream stat(fmt::format("/proc/{}/stat", pid));
  std::string text((std::istreambuf_iterator<char>(stat)), {});
  const size_t close = text.rfind(')');
  if (close != std::string::npos) {
    std::istringstream fields(text.substr(close + 2));
    std::string f;
    for (int i = 3; i <= 15 && fields >> f; ++i) {
      if (i == 14 || i == 15)
        u.cpuSeconds += std::stod(f) / static_cast<double>(::sysconf(_SC_CLK_TCK));
    }
  }
  std::ifstream status(fmt::format("/proc/{}/status", pid));
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmHWM:", 0) == 0) u.peakMiB = std::stod(line.substr(6)) / 1024.0;
    if (line.rfind("VmRSS:", 0) == 0) u.residentMiB = std::stod(line.substr(6)) / 1024.0;
  }
  return u;
}

pid_t childOf(pid_t parent) {
  std::ifstream children(fmt::format("/proc/{}/task/{}/children", parent, parent));
  pid_t child = -1;
  children >> child;
  return child;
}

// Median and 95th percentile of `ms`, "median 3.1 ms, p95 4.0 ms".
std::string medianAndP95(std::vector<double> ms) {
  std::sort(ms.begin(), ms.end());
  const auto at = [&](double q) {
    return ms[static_cast<size_t>(q * static_cast<double>(ms.size() - 1))];
  };
  return fmt::format("median {:.1f} ms, p95 {:.1f} ms", at(0.5), at(0.95));
}

// Wall time of `program ctl --socket S status` from spawn to exit, stdout discarded.
double timeCtlStatus(const std::string& program, const std::string& socket) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  std::vector<char*> argv = {const_cast<char*>(program.c_str()), const_cast<char*>("ctl"),
                             const_cast<char*>("--socket"),      const_cast<char*>(socket.c_str()),
                             const_cast<char*>("status"),        nullptr};
  const auto t0 = Clock::now();
  pid_t pid = -1;
  const int spawned = ::posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) throw std::runtime_error("cannot start " + program);
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw std::runtime_error(program + " ctl status failed");
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// `parallax ctl status` as a user runs it (the light front: process start to exit), the same
// through the whole tool (parallax-tools, for comparison) and the socket exchange alone.
void benchCtlRoundTrip(const std::string& socket) {
  constexpr int kRuns = 100;
  const std::string front = siblingBinary("parallax");
  const std::string tools = siblingBinary("parallax-tools");
  std::vector<double> frontMs, toolsMs, socketMs;
  for (int i = 0; i < kRuns; ++i) frontMs.push_back(timeCtlStatus(front, socket));
  for (int i = 0; i < kRuns / 10; ++i) toolsMs.push_back(timeCtlStatus(tools, socket));
  for (int i = 0; i < kRuns; ++i) {
    const auto t0 = Clock::now();
    askOrNull(socket, {{"request", "status"}});
    socketMs.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  }
  std::cout << fmt::format(
      "  `parallax ctl status` end to end ({} runs): {}; through parallax-tools ({} runs): {}; "
      "the socket exchange alone: {}\n",
      kRuns, medianAndP95(frontMs), kRuns / 10, medianAndP95(toolsMs), medianAndP95(socketMs));
}

// Plays the animated script on `display`; returns the frame rate and CPU time a frame. The first
// run of a display also times cornell.lua and `parallax ctl status`.
PlayFigures benchOne(const std::string& display, const BenchDaemonArgs& args, bool frameCache,
                     bool footprint, bool firstRun) {
  const fs::path work =
      fs::temp_directory_path() / fmt::format("parallax-bench-daemon-{}", ::getpid());
  fs::create_directories(work);
  const std::string socket = (work / "ctl.sock").string();
  const std::string script = sceneForConfig(args.scene);
  const std::string cache = benchCacheDir(work.string());
  {
    std::ofstream config(work / "parallax.toml");
    config << fmt::format(
        "[display]\npreset = \"{}\"\n[scene]\nscript = \"{}\"\nfps = {}\nframe_cache = {}\n"
        "footprint = {}\n[calibration]\nauto = false\nfile = \"{}\"\n"
        "[daemon]\nsocket = \"{}\"\ncache_dir = \"{}\"\nlog_level = \"warn\"\n",
        display, script, args.fps, frameCache, footprint, (work / "calibration.json").string(),
        socket, cache);
  }
  std::string daemonPath = siblingBinary("parallaxd");
  const std::string configPath = (work / "parallax.toml").string();
  std::vector<char*> argv = {daemonPath.data(), const_cast<char*>("--config"),
                             const_cast<char*>(configPath.c_str()), nullptr};
  pid_t pid = -1;
  if (::posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ) != 0)
    throw std::runtime_error("cannot start parallaxd");
  const auto started = Clock::now();
  PlayFigures figures;
  try {
    nlohmann::json first = waitForStats(
        socket, [](const nlohmann::json& s) { return s.value("display_frames", 0) >= 2; },
        "the first frames", 1800, pid);
    const double startup = std::chrono::duration<double>(Clock::now() - started).count();
    const pid_t simhw = childOf(pid);
    const ProcessUse d0 = processUse(pid), s0 = simhw > 0 ? processUse(simhw) : ProcessUse{};
    const auto t0 = Clock::now();
    std::this_thread::sleep_for(std::chrono::duration<double>(args.seconds));
    // A display slower than the window (default: tens of seconds a frame) is timed over at
    // least two frames rather than reported as 0 fps.
    const double firstCount = first["display_frames"].get<double>();
    const nlohmann::json last = waitForStats(
        socket,
        [firstCount](const nlohmann::json& s) {
          return s["display_frames"].get<double>() >= firstCount + 2;
        },
        "two frames in the window", 1800, pid);
    const double dt = std::chrono::duration<double>(Clock::now() - t0).count();
    const ProcessUse d1 = processUse(pid), s1 = simhw > 0 ? processUse(simhw) : ProcessUse{};
    const double frames =
        last["display_frames"].get<double>() - first["display_frames"].get<double>();
    const double dropped =
        last["dropped_frames"].get<double>() - first["dropped_frames"].get<double>();
    const nlohmann::json status = askOrNull(socket, {{"request", "status"}});
    figures.fps = frames / dt;
    figures.cpuMsPerFrame = 1000.0 * (d1.cpuSeconds - d0.cpuSeconds) / std::max(frames, 1.0);
    std::cout << fmt::format(
        "{} (frame cache {}, footprint {}): {} modules; start-up to the second frame {:.1f} s (ray "
        "textures: {} from the cache, {} generated)\n",
        display, frameCache ? "on" : "off", footprint ? "on" : "off",
        status["display"]["modules"].get<int>(), startup,
        status["ray_textures"]["from_cache"].get<int>(),
        status["ray_textures"]["generated"].get<int>());
    std::cout << fmt::format(
        "  {} (animated, target {} fps) over {:.1f} s: {:.2f} fps, {} dropped; per display "
        "frame: render {:.1f} ms, "
        "encode {:.1f} ms, push {:.1f} ms, end to end {:.1f} ms, parallaxd CPU {:.0f} ms\n",
        args.scene, args.fps, dt, frames / dt, dropped,
        windowMeanMs(first["timings"]["render"], last["timings"]["render"]),
        windowMeanMs(first["timings"]["encode"], last["timings"]["encode"]),
        windowMeanMs(first["timings"]["push"], last["timings"]["push"]),
        windowMeanMs(first["timings"]["end_to_end"], last["timings"]["end_to_end"]),
        figures.cpuMsPerFrame);
    std::cout << fmt::format(
        "  CPU: parallaxd {:.2f} cores, simulator {:.2f} cores; peak memory: parallaxd {:.0f} MiB "
        "({:.0f} MiB resident at the end), simulator {:.0f} MiB\n",
        (d1.cpuSeconds - d0.cpuSeconds) / dt, (s1.cpuSeconds - s0.cpuSeconds) / dt, d1.peakMiB,
        d1.residentMiB, s1.peakMiB);
    if (frameCache && last.contains("frame_cache")) {
      for (const auto& line : last["frame_cache"]["lines"])
        std::cout << line.get<std::string>() << "\n";
    }
    if (footprint && last.contains("live_pixels"))
      std::cout << last["live_pixels"]["line"].get<std::string>() << "\n";
    if (first.contains("link") && last.contains("link")) {
      // What crossed the link in the window: whole frames, and patches of what could change.
      const auto delta = [&](const char* key) {
        return last["link"].value(key, 0.0) - first["link"].value(key, 0.0);
      };
      const double perFrame = 1.0 / std::max(frames, 1.0) / (1 << 20);
      std::cout << fmt::format(
          "  link: {:.1f} MiB a display frame sent, {:.1f} MiB left out by {:.0f} patch frame(s) "
          "({:.0f} refused, sent whole)\n",
          delta("bytes_sent") * perFrame, delta("patch_bytes_saved") * perFrame, delta("patches"),
          delta("patches_refused"));
    }
    if (!firstRun) {
      askOrNull(socket, {{"request", "shutdown"}});
      ::waitpid(pid, nullptr, 0);
      fs::remove_all(work);
      return figures;
    }
    // The static scene: one frame, then nothing to send.
    const nlohmann::json before = askOrNull(socket, {{"request", "stats"}});
    askOrNull(socket, {{"request", "load"}, {"scene", "cornell"}});
    const double count0 = before["display_frames"].get<double>();
    const nlohmann::json after = waitForStats(
        socket,
        [count0](const nlohmann::json& s) { return s["display_frames"].get<double>() > count0; },
        "the cornell frame", 600, pid);
    std::cout << fmt::format(
        "  cornell.lua (static): render {:.1f} ms, encode {:.1f} ms, push {:.1f} ms, end to end "
        "{:.1f} ms\n",
        after["timings"]["render"]["last_ms"].get<double>(),
        after["timings"]["encode"]["last_ms"].get<double>(),
        after["timings"]["push"]["last_ms"].get<double>(),
        after["timings"]["end_to_end"]["last_ms"].get<double>());
    benchCtlRoundTrip(socket);
  } catch (...) {
    ::kill(pid, SIGTERM);
    ::waitpid(pid, nullptr, 0);
    fs::remove_all(work);
    throw;
  }
  askOrNull(socket, {{"request", "shutdown"}});
  int status = 0;
  ::waitpid(pid, &status, 0);
  fs::remove_all(work);
  return figures;
}

void runBenchDaemon(const BenchDaemonArgs& args) {
  std::stringstream list(args.displays);
  std::cout << fmt::format("bench daemon: {} hardware threads, load average at start: ",
                           std::thread::hardware_concurrency());
  std::cout << loadAverage() << "\n";
  const auto onOff = [](const std::string& text, const char* option) {
    std::vector<bool> settings;
    std::stringstream items(text);
    for (std::string s; std::getline(items, s, ',');) {
      if (s != "on" && s != "off") throw InputError({"", option, 0}, "on and/or off");
      settings.push_back(s == "on");
    }
    if (settings.empty()) throw InputError({"", option, 0}, "on and/or off");
    return settings;
  };
  const std::vector<bool> caches = onOff(args.frameCache, "--frame-cache");
  const std::vector<bool> footprints = onOff(args.footprint, "--footprint");
  // Two daemons one after the other: the frame rates drift with the machine's load, the CPU
  // time a frame much less.
  const auto ratio = [](const std::string& what, const PlayFigures& on, const PlayFigures& off) {
    std::cout << fmt::format(
        "  {} on/off {:.2f} / {:.2f} fps = {:.2f}x; parallaxd CPU a frame {:.0f} / {:.0f} ms = "
        "{:.2f}x less\n",
        what, on.fps, off.fps, on.fps / off.fps, on.cpuMsPerFrame, off.cpuMsPerFrame,
        off.cpuMsPerFrame / on.cpuMsPerFrame);
  };
  for (std::string display; std::getline(list, display, ',');) {
    if (display != "demo" && display != "default")
      throw InputError({"", "--display", 0}, "demo and/or default");
    // [cache][footprint]
    PlayFigures figures[2][2];
    bool ran[2][2] = {};
    bool first = true;
    for (bool cache : caches) {
      for (bool footprint : footprints) {
        figures[cache][footprint] = benchOne(display, args, cache, footprint, first);
        ran[cache][footprint] = true;
        first = false;
      }
    }
    const bool cache = caches.front(), footprint = footprints.front();
    if (ran[1][footprint] && ran[0][footprint])
      ratio(display + ": frame cache", figures[1][footprint], figures[0][footprint]);
    if (ran[cache][1] && ran[cache][0])
      ratio(display + ": footprint", figures[cache][1], figures[cache][0]);
  }
}

}  // namespace

void addBenchDaemonSubcommand(CLI::App* bench) {
  auto args = std::make_shared<BenchDaemonArgs>();
  CLI::App* command = bench->add_subcommand(
      "daemon", "parallaxd per display frame: render, encode, push, latency, fps, CPU, memory");
  command->add_option("--display", args->displays, "comma-separated: demo, default");
  command->add_option("--seconds", args->seconds, "how long to play the animated scene");
  command->add_option("--fps", args->fps, "target frame rate");
  command->add_option("--scene", args->scene,
                      "the animated script to play: a library name or a .lua file");
  command->add_option("--frame-cache", args->frameCache,
                      "on, off or both (on,off: one daemon each, the ratio)");
  command->add_option("--footprint", args->footprint,
                      "trace and encode only the pixels that can show the scene: on, off or "
                      "both (on,off: one daemon each, the ratio)");
  command->callback([args] { runBenchDaemon(*args); });
}

}  // namespace parallax::cli
