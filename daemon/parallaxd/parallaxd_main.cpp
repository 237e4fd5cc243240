// parallaxd: the daemon (DESIGN.md, "Processes and interfaces"; README, "The daemon").
//
//   parallaxd [--config parallax.toml]
//
// Without a config: the built-in `demo` display on a simulator it starts itself, the control
// socket at the per-user default path that `parallax ctl` finds with no argument. SIGTERM and
// SIGINT stop cleanly (frames in flight finished, socket removed, the simulator stopped);
// SIGHUP reloads the config (what cannot change in place builds the pipeline again). Logs go
// to stderr (the journal under systemd); with $NOTIFY_SOCKET it speaks sd_notify (READY,
// WATCHDOG, RELOADING, STOPPING).

#include <signal.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <thread>

#include "common/input_error.h"
#include "daemon/parallaxd/conductor.h"
#include "daemon/parallaxd/control_server.h"
#include "daemon/parallaxd/daemon_config.h"
#include "daemon/parallaxd/simhw_child.h"
#include "daemon/parallaxd/systemd_notify.h"

namespace {

using namespace parallax::daemon;

// One life of the pipeline: simulator (when configured), conductor, control socket and the
// signal thread, from one config. Returns the config to build it again from when a SIGHUP
// reload changed what cannot change under a running loop (display, hardware, socket, ...).
std::optional<DaemonConfig> runPipeline(DaemonConfig config, const std::string& configPath,
                                        const sigset_t& signals, SystemdNotifier& notifier) {
  const parallax::DisplayModel nominal = nominalDisplayOf(config.display);
  std::string linkSpec = linkSpecOf(config.hardware, static_cast<int>(nominal.modules.size()));
  std::unique_ptr<SimhwChild> simulator;
  std::string simulatorCamera;
  if (linkSpec.empty()) {
    const std::string folder =
        std::filesystem::path(config.controlSocketPath()).parent_path().string();
    std::filesystem::create_directories(folder);
    simulator = std::make_unique<SimhwChild>(nominal, config.hardware, folder + "/simhw.sock",
                                             config.cacheDirPath());
    linkSpec = simulator->linkSpec();
    // What a real installation measures once; the daemon never sees the simulator's truth.
    // Kept apart from the config, so a reload that names no camera still has it.
    simulatorCamera = simulator->cameraMetadataPath();
  }

  std::atomic<bool> stop{false};
  ConductorOptions options;
  options.config = config;
  options.linkSpec = linkSpec;
  options.simulatorCamera = simulatorCamera;
  options.onReady = [&notifier] {
    notifier.ready();
    spdlog::info("parallaxd ready");
  };
  options.onHeartbeat = [&notifier] { notifier.watchdog(); };
  Conductor conductor(options);
  auto control = std::make_unique<ControlServer>(
      config.controlSocketPath(),
      [&conductor](const nlohmann::json& r) { return conductor.handle(r); });

  std::thread signalThread([&] {
    const timespec tick{0, 200'000'000};
    while (!stop.load()) {
      siginfo_t info{};
      const int s = ::sigtimedwait(&signals, &info, &tick);
      if (s == SIGTERM || s == SIGINT) {
        spdlog::info("{}: stopping", s == SIGTERM ? "SIGTERM" : "SIGINT");
        stop = true;
      } else if (s == SIGHUP) {
        if (configPath.empty()) {
          spdlog::info("SIGHUP: no config file to reload");
        } else {
          conductor.reloadConfigFrom(configPath);
        }
      }
      if (conductor.shutdownRequested()) stop = true;
      if (simulator && !stop.load()) simulator->superviseOnce();
    }
  });

  conductor.run(stop);
  if (!conductor.restartWith()) notifier.stopping();
  stop = true;
  signalThread.join();
  control.reset();  // removes the socket
  if (simulator) simulator->stop();
  return conductor.restartWith();
}

int run(const std::string& configPath) {
  DaemonConfig config = configPath.empty() ? DaemonConfig{} : loadDaemonConfig(configPath);
  config.validate();
  spdlog::set_level(spdlog::level::from_str(config.logLevel));

  // Signals are taken by one thread with sigwait, never by handlers: every other thread
  // inherits this mask, so no library call is interrupted at a random point. (Between two
  // lives of the pipeline they stay pending for the next signal thread.)
  sigset_t signals;
  sigemptyset(&signals);
  for (int s : {SIGTERM, SIGINT, SIGHUP, SIGCHLD}) sigaddset(&signals, s);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  ::signal(SIGPIPE, SIG_IGN);

  SystemdNotifier notifier;
  std::optional<DaemonConfig> next = config;
  while (next) {
    next = runPipeline(*next, configPath, signals, notifier);
    if (next) {
      notifier.notify("RELOADING=1");
      spdlog::set_level(spdlog::level::from_str(next->logLevel));
    }
  }
  spdlog::info("parallaxd stopped");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("parallaxd"));
  CLI::App app{"parallaxd: calibrates the display, traces the scene, pushes frames to the modules"};
  std::string config;
  app.add_option("--config", config,
                 "parallax.toml (default: built-in demo display on a simulator)");
  try {
    app.parse(argc, argv);
    return run(config);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const parallax::InputError& e) {
    std::fprintf(stderr, "parallaxd: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "parallaxd: error: %s\n", e.what());
    return 1;
  }
}
