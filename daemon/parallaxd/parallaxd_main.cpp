// parallaxd: the daemon (DESIGN.md, "Processes and interfaces"; README, "The daemon").
//
//   parallaxd [--config parallax.toml]
//
// Without a config: the built-in `demo` display on a simulator it starts itself, the control
// socket at the per-user default path that `parallax ctl` finds with no argument. SIGTERM and
// SIGINT stop cleanly (frames in flight finished, socket removed, the simulator stopped);
// SIGHUP reloads the config. Logs go to stderr (the journal under systemd); with
// $NOTIFY_SOCKET it speaks sd_notify (READY, WATCHDOG, STOPPING).

#include <signal.h>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <thread>

#include "common/input_error.h"
#include "daemon/parallaxd/conductor.h"
#include "daemon/parallaxd/control_server.h"
#include "daemon/parallaxd/daemon_config.h"
#include "daemon/parallaxd/simhw_child.h"
#include "daemon/parallaxd/systemd_notify.h"

namespace {

using namespace parallax::daemon;

int run(const std::string& configPath) {
  DaemonConfig config = configPath.empty() ? DaemonConfig{} : loadDaemonConfig(configPath);
  config.validate();
  spdlog::set_level(spdlog::level::from_str(config.logLevel));

  // Signals are taken by one thread with sigwait, never by handlers: every other thread
  // inherits this mask, so no library call is interrupted at a random point.
  sigset_t signals;
  sigemptyset(&signals);
  for (int s : {SIGTERM, SIGINT, SIGHUP, SIGCHLD}) sigaddset(&signals, s);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  ::signal(SIGPIPE, SIG_IGN);

  const parallax::DisplayModel nominal = nominalDisplayOf(config.display);
  std::string linkSpec = linkSpecOf(config.hardware, static_cast<int>(nominal.modules.size()));
  std::unique_ptr<SimhwChild> simulator;
  if (linkSpec.empty()) {
    const std::string folder = std::filesystem::path(config.controlSocketPath()).parent_path().string();
    std::filesystem::create_directories(folder);
    simulator = std::make_unique<SimhwChild>(nominal, config.hardware, folder + "/simhw.sock", config.cacheDirPath());
    linkSpec = simulator->linkSpec();
    // What a real installation measures once; the daemon never sees the simulator's truth.
    if (config.calibration.camera.empty()) config.calibration.camera = simulator->cameraMetadataPath();
  }

  SystemdNotifier notifier;
  std::atomic<bool> stop{false};
  ConductorOptions options;
  options.config = config;
  options.linkSpec = linkSpec;
  options.onReady = [&notifier] {
    notifier.ready();
    spdlog::info("parallaxd ready");
  };
  options.onHeartbeat = [&notifier] { notifier.watchdog(); };
  Conductor conductor(options);
  auto control = std::make_unique<ControlServer>(config.controlSocketPath(),
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
          try {
            conductor.reloadConfig(loadDaemonConfig(configPath));
          } catch (const std::exception& e) {
            spdlog::error("SIGHUP: config not reloaded, the old one stays: {}", e.what());
          }
        }
      }
      if (conductor.shutdownRequested()) stop = true;
      if (simulator && !stop.load()) simulator->superviseOnce();
    }
  });

  conductor.run(stop);
  stop = true;
  notifier.stopping();
  signalThread.join();
  control.reset();  // removes the socket
  if (simulator) simulator->stop();
  spdlog::info("parallaxd stopped");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("parallaxd"));
  CLI::App app{"parallaxd: calibrates the display, traces the scene, pushes frames to the modules"};
  std::string config;
  app.add_option("--config", config, "parallax.toml (default: built-in demo display on a simulator)");
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
