// parallaxd: the daemon (DESIGN.md, "Processes and interfaces"; README, "The daemon").
//
//   parallaxd [--config parallax.toml]
//   mpirun -np N parallaxd --config parallax.toml      (a cluster: cluster.h)
//
// Without a config: the built-in `demo` display on a simulator it starts itself, the control
// socket at the per-user default path that `parallax ctl` finds with no argument. SIGTERM and
// SIGINT stop cleanly (frames in flight finished, socket removed, the simulator stopped);
// SIGHUP reloads the config (what cannot change in place builds the pipeline again). Logs go
// to stderr (under systemd the journal: syslog priorities, no timestamp of ours); with
// $NOTIFY_SOCKET it speaks sd_notify (READY, STATUS, WATCHDOG, RELOADING, STOPPING).

#include <fmt/format.h>
#include <signal.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <thread>

#include "common/input_error.h"
#include "common/private_folder.h"
#include "daemon/cli/command_line.h"
#include "daemon/parallaxd/cluster.h"
#include "daemon/parallaxd/conductor.h"
#include "daemon/parallaxd/control_panel.h"
#include "daemon/parallaxd/control_server.h"
#include "daemon/parallaxd/daemon_config.h"
#include "daemon/parallaxd/instance_lock.h"
#include "daemon/parallaxd/journal_log_sink.h"
#include "daemon/parallaxd/module_ownership.h"
#include "daemon/parallaxd/panel_token.h"
#include "daemon/parallaxd/simhw_child.h"
#include "daemon/parallaxd/systemd_notify.h"

namespace {

using namespace parallax::daemon;

// A rank of the cluster stopped it: the job must end (every rank), after this rank cleaned up.
struct ClusterEnded : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Signals are taken by one thread with sigwait, never by handlers: every other thread
// inherits the mask, so no library call is interrupted at a random point. The thread exists
// from the first line of run(), before any file is read, so SIGTERM and SIGINT are answered
// at every moment of a start-up too (each start-up step checks stopRequested()).
class SignalWatcher {
 public:
  explicit SignalWatcher(const sigset_t& signals)
      : signals_(signals), thread_([this] { watch(); }) {}
  ~SignalWatcher() {
    done_ = true;
    thread_.join();
  }
  bool stopRequested() const { return stop_.load(); }
  // True once per SIGHUP received.
  bool takeReload() { return reload_.exchange(false); }

 private:
  void watch() {
    const timespec tick{0, 100'000'000};
    while (!done_.load()) {
      siginfo_t info{};
      const int s = ::sigtimedwait(&signals_, &info, &tick);
      if (s == SIGTERM || s == SIGINT) {
        spdlog::info("{}: stopping", s == SIGTERM ? "SIGTERM" : "SIGINT");
        stop_ = true;
      } else if (s == SIGHUP) {
        reload_ = true;
      }
    }
  }

  sigset_t signals_;
  std::atomic<bool> stop_{false}, reload_{false}, done_{false};
  std::thread thread_;
};

std::unique_ptr<ControlPanel> startPanel(const DaemonConfig& config, const std::string& runtime,
                                         Conductor& conductor) {
  if (!config.panel.enabled) {
    conductor.setPanel("", "it is off ([panel] enabled = false)");
    return nullptr;
  }
  try {
    ControlPanelOptions options;
    options.address = config.panel.address;
    options.port = config.panel.port;
    options.token = loadOrCreatePanelToken(config.stateDirPath());
    options.scratch = runtime + "/panel";
    options.reports = config.reportsDirPath();
    parallax::makePrivateFolder(options.scratch);
    auto panel = std::make_unique<ControlPanel>(
        options, [&conductor](const nlohmann::json& r) { return conductor.handle(r); });
    conductor.setPanel(panel->url(), "");
    spdlog::info("panel: http://{}:{}/ (`parallax ctl panel` prints the URL with its token)",
                 config.panel.address, panel->port());
    return panel;
  } catch (const std::exception& e) {
    spdlog::warn("panel: not started: {}", e.what());
    conductor.setPanel("", e.what());
    return nullptr;
  }
}

// One life of the pipeline: simulator (when configured), conductor, control socket and a
// supervising thread, from one config. Returns the config to build it again from when a
// SIGHUP reload changed what cannot change under a running loop (display, hardware, socket,
// ...).
std::optional<DaemonConfig> runPipeline(DaemonConfig config, const std::string& configPath,
                                        SignalWatcher& signals, SystemdNotifier& notifier,
                                        Cluster& cluster) {
  const bool isConductor = cluster.isConductor();
  const bool clustered = cluster.size() > 1;
  // The runtime folder is checked (ours, 0700, no symlink) and locked before anything in it
  // is touched: a second daemon stops here, with the first one's sockets intact. The other
  // ranks of a cluster have their own folder inside it (their simulators' sockets).
  const std::string top =
      std::filesystem::absolute(config.controlSocketPath()).parent_path().string();
  parallax::makePrivateFolder(top);
  const std::string folder = isConductor ? top : fmt::format("{}/rank-{}", top, cluster.rank());
  if (!isConductor) parallax::makePrivateFolder(folder);
  const InstanceLock lock(folder);
  // Only a socket of ours may be replaced; anything else at the path is refused, never deleted.
  if (isConductor) parallax::socketPathInUse(config.controlSocketPath());

  const parallax::DisplayModel nominal = nominalDisplayOf(config.display);
  const ModuleOwnership ownership =
      ModuleOwnership::of(config.cluster, static_cast<int>(nominal.modules.size()), cluster.size());
  std::string linkSpec = linkSpecOfRank(config.hardware, ownership, cluster.rank());
  std::unique_ptr<SimhwChild> simulator;
  std::string simulatorCamera, simulatorFolder;
  if (linkSpec.empty() && !ownership.modulesOf(cluster.rank()).empty()) {
    // Each rank of a cluster simulates the modules its link would reach, with its own files,
    // of one simulated display: the camera of each sees every rank's modules through the room
    // in rank 0's runtime folder (hw/simulator/shared_room.h), as one camera sees one screen.
    HardwareConfig hardware = config.hardware;
    const std::string rankFolder = clustered ? fmt::format("/rank-{}", cluster.rank()) : "";
    if (!hardware.dump.empty()) hardware.dump += rankFolder;
    SimhwChild::Part part;
    if (clustered) part = {ownership.modulesOf(cluster.rank()), top + "/simulated-room"};
    simulator = std::make_unique<SimhwChild>(nominal, hardware, folder + "/simhw.sock",
                                             config.cacheDirPath() + rankFolder, part);
    linkSpec = simulator->linkSpec();
    // What a real installation measures once; the daemon never sees the simulator's truth.
    // Kept apart from the config, so a reload that names no camera still has it.
    simulatorCamera = simulator->cameraMetadataPath();
    simulatorFolder = std::filesystem::absolute(simulator->folder()).string();
  }
  if (signals.stopRequested()) return std::nullopt;

  std::atomic<bool> stop{false};
  ConductorOptions options;
  options.cluster = &cluster;
  options.ownership = ownership;
  options.config = config;
  options.linkSpec = linkSpec;
  options.link = config.link;
  options.simulatorCamera = simulatorCamera;
  options.simulatorFolder = simulatorFolder;
  options.simulatorPhotometric = simulator != nullptr && config.hardware.photometricVariation;
  // Only rank 0 speaks to systemd and serves the control socket and the panel.
  if (isConductor) {
    options.onReady = [&notifier] {
      notifier.ready();
      spdlog::info("parallaxd ready");
    };
    options.onHeartbeat = [&notifier] { notifier.watchdog(); };
    options.onReloading = [&notifier] { notifier.reloading(); };
    options.onReloaded = [&notifier] { notifier.ready(); };
  }
  Conductor conductor(options);
  std::unique_ptr<ControlServer> control;
  std::unique_ptr<ControlPanel> panel;
  if (isConductor) {
    control = std::make_unique<ControlServer>(
        config.controlSocketPath(),
        [&conductor](const nlohmann::json& r) { return conductor.handle(r); });
    // The browser panel hands its requests to the same handler. It is a convenience: when it
    // cannot start (the port is taken, the state folder is read-only) the daemon runs on
    // without it and `parallax ctl panel` says why.
    panel = startPanel(config, folder, conductor);
  }

  std::thread supervisor([&] {
    while (!stop.load()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      if (signals.stopRequested()) stop = true;
      if (signals.takeReload()) {
        if (configPath.empty()) {
          spdlog::warn("SIGHUP: no config file to reload (started without --config)");
        } else {
          conductor.reloadConfigFrom(configPath);
        }
      }
      if (conductor.shutdownRequested()) stop = true;
      // Polled: what `systemctl status` shows follows every state that lasts 100 ms.
      if (isConductor) notifier.status(serviceStatusOf(conductor.state()));
      if (simulator && !stop.load()) simulator->superviseOnce();
    }
  });

  conductor.run(stop);
  if (!conductor.restartWith() && isConductor) notifier.stopping();
  stop = true;
  supervisor.join();
  panel.reset();
  control.reset();  // removes the socket
  if (simulator) simulator->stop();
  if (!conductor.clusterFailure().empty()) throw ClusterEnded(conductor.clusterFailure());
  if (signals.stopRequested()) return std::nullopt;
  return conductor.restartWith();
}

int run(const std::string& configPath, Cluster& cluster) {
  // Before anything else (config and display files are read next): see SignalWatcher.
  sigset_t signals;
  sigemptyset(&signals);
  for (int s : {SIGTERM, SIGINT, SIGHUP}) sigaddset(&signals, s);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  ::signal(SIGPIPE, SIG_IGN);
  // A file-size limit (or a full quota) must fail the write with EFBIG, which the store
  // reports, not kill the daemon.
  ::signal(SIGXFSZ, SIG_IGN);
  SignalWatcher watcher(signals);

  DaemonConfig config = configPath.empty() ? DaemonConfig{} : loadDaemonConfig(configPath);
  config.validate();
  spdlog::set_level(spdlog::level::from_str(config.logLevel));

  SystemdNotifier notifier;
  std::optional<DaemonConfig> next = config;
  while (next && !watcher.stopRequested()) {
    next = runPipeline(*next, configPath, watcher, notifier, cluster);
    if (next) {
      // RELOADING=1 was sent when the reload began; READY=1 follows from the new pipeline.
      spdlog::set_level(spdlog::level::from_str(next->logLevel));
    }
  }
  spdlog::info("parallaxd stopped");
  return 0;
}

}  // namespace

// A rank of a cluster that fails alone would leave the others waiting for it: the whole job
// ends (mpirun reports it) once this rank has said why.
int endOfRank(int code, Cluster* cluster) {
  if (cluster && cluster->size() > 1) cluster->abort(code);
  return code;
}

int main(int argc, char** argv) {
  parallax::daemon::setUpDaemonLogging("parallaxd");
  // Before the command line is read: MPI_Init may take its own arguments out of argv.
  std::unique_ptr<Cluster> cluster;
  try {
    cluster = joinCluster(argc, argv);
  } catch (const std::exception& e) {
    parallax::daemon::logFatal(std::string("parallaxd: error: ") + e.what());
    return 1;
  }
  const std::string self =
      cluster->size() > 1 ? fmt::format("parallaxd rank {}", cluster->rank()) : "parallaxd";
  if (cluster->size() > 1) parallax::daemon::setUpDaemonLogging(self);
  CLI::App app{"parallaxd: calibrates the display, traces the scene, pushes frames to the modules",
               "parallaxd"};
  app.footer("Exit codes: 0 stopped cleanly, 1 runtime failure, 2 bad config or usage error.");
  parallax::cli::addVersionFlag(app);
  std::string config;
  app.add_option("--config", config,
                 "parallax.toml (default: built-in demo display on a simulator)");
  try {
    app.parse(argc, argv);
    return run(config, *cluster);
  } catch (const CLI::Success& e) {
    return app.exit(e);  // --help, --version
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return endOfRank(parallax::cli::kExitUsage, cluster.get());
  } catch (const parallax::InputError& e) {
    parallax::daemon::logFatal(self + ": " + e.what());
    return endOfRank(2, cluster.get());
  } catch (const AlreadyRunning& e) {
    parallax::daemon::logFatal(self + ": " + e.what());
    return endOfRank(1, cluster.get());
  } catch (const ClusterEnded& e) {
    parallax::daemon::logFatal(self + ": " + e.what());
    return endOfRank(1, cluster.get());
  } catch (const std::exception& e) {
    parallax::daemon::logFatal(self + ": error: " + e.what());
    return endOfRank(1, cluster.get());
  }
}
