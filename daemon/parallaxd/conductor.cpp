#include "daemon/parallaxd/conductor.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <thread>

#include "common/check.h"
#include "common/input_error.h"
#include "hw/link/link_transport.h"

// The conductor's life: start-up, the loop's turns between queued requests, config reloads.
// The stages are in conductor_calibration.cpp, the render loop in conductor_render_loop.cpp,
// the requests in conductor_requests.cpp, status in conductor_status.cpp.

namespace parallax::daemon {

Conductor::Conductor(ConductorOptions options)
    : options_(std::move(options)),
      singleProcess_(options_.cluster ? nullptr : std::make_unique<SingleProcess>()),
      cluster_(options_.cluster ? options_.cluster : singleProcess_.get()),
      nominal_(nominalDisplayOf(options_.config.display)),
      ownership_(options_.ownership
                     ? *options_.ownership
                     : ModuleOwnership::single(static_cast<int>(nominal_.modules.size()))),
      owned_(ownership_.modulesOf(cluster_->rank())),
      calibration_(nominal_),
      calibrationSource_("nominal (uncalibrated)"),
      store_(options_.config.calibrationFileOfRank(cluster_->rank())),
      cache_(options_.config.cacheDirPath()) {
  PARALLAX_CHECK_OP(ownership_.ranks(), ==, cluster_->size());
  PARALLAX_CHECK_OP(ownership_.modules(), ==, static_cast<int>(nominal_.modules.size()));
  options_.render.validate();
  checkEveryRequestHasAHandler();
  publish();
}

Conductor::~Conductor() = default;

void Conductor::run(const std::atomic<bool>& stop) {
  stop_ = &stop;
  // A signal (not a `shutdown` request) also ends a wait for a rank that does not answer.
  cluster_->setInterrupt([&stop] { return stop.load(); });
  try {
    startUp();
  } catch (const std::exception& e) {
    state_.fail("starting", e.what(), DaemonState::kError);
  }
  startingUp_ = false;
  try {
    // Every rank has started (a rank that builds its ray textures takes its time).
    gatherRankReports(kStartUpTimeoutMs);
    if (!cluster_->isConductor()) {
      follow();
    } else {
      if (options_.onReady) options_.onReady();
      if (calibrateClusterAtStart_) calibrateCluster();
      while (!stopAsked()) {
        if (options_.onHeartbeat) options_.onHeartbeat();
        drainJobs(Clock::now() + timeToNextTurn());
        if (stopAsked()) break;
        turn();
        if (const std::optional<std::string> line = lossReport_.take(stats_, Clock::now()))
          spdlog::warn("{}", *line);
        publish();
      }
      stopOthers();
    }
  } catch (const RanksSilent& e) {
    endJob(e);
  }
  state_.enter(DaemonState::kStopping);
  finishInFlight();
  // Requests that arrived too late get an answer, not a broken promise.
  std::deque<std::shared_ptr<Job>> left;
  {
    std::lock_guard lock(jobsMutex_);
    acceptingJobs_ = false;
    left.swap(jobs_);
  }
  for (auto& job : left) job->reply.set_value({{"ok", false}, {"error", "the daemon is stopping"}});
  publish();
}

bool Conductor::stopAsked() const { return shutdown_.load() || (stop_ && stop_->load()); }

void Conductor::startUp() {
  state_.setStage("connecting to the modules");
  publish();
  connectLink(options_.connectTimeoutMs);

  // Calibration: the installed one if it describes this display, else calibrate (when
  // configured to), else the nominal model with the reason in `status`.
  bool haveCalibration = false;
  try {
    if (std::optional<StoredCalibration> installed = store_.loadFor(nominal_)) {
      calibration_ = std::move(installed->model);
      calibrationSource_ = installed->source;
      haveCalibration = true;
      spdlog::info("calibration: {}", installed->source);
      photometryRefused_ = installed->photometryRefused;
      try {
        applyPhotometry(installed->photometry, installed->photometrySource);
      } catch (const InputError& e) {
        photometryRefused_ = e.what();
      }
      if (!photometryRefused_.empty())
        state_.fail("loading the calibration",
                    "photometric correction refused: " + photometryRefused_,
                    DaemonState::kStarting);
      if (!installed->refused.empty())
        state_.fail("loading the calibration", installed->refused + "; using " + installed->source,
                    DaemonState::kStarting);
    }
  } catch (const InputError& e) {
    state_.fail("loading the calibration", e.what(), DaemonState::kStarting);
  }
  bool haveTextures = false;
  if (!haveCalibration && options_.config.calibration.autoCalibrate && link_ && !clustered())
    haveTextures = calibrate(std::nullopt).done();
  // A cluster calibrates as `calibrate` does, once every rank follows rank 0 (run()): until
  // then every rank makes the nominal display's textures.
  calibrateClusterAtStart_ = !haveCalibration && options_.config.calibration.autoCalibrate &&
                             link_ && clustered() && cluster_->isConductor();
  if (!haveCalibration && clustered() && cluster_->isConductor() && !calibrateClusterAtStart_)
    spdlog::warn("no installed calibration: the cluster plays the nominal display{}",
                 link_ ? "" : " (no link on rank 0 to calibrate through)");
  // A stop (signal or `shutdown`) during a stage ends start-up there: nothing more is built.
  if (stopAsked()) return;
  if (!haveTextures) haveTextures = regenerate(calibration_).done();
  if (stopAsked()) return;
  // A scene that does not load is in status as the last error; a `load` can bring one later.
  if (haveTextures) loadScene(options_.config.scene.script, options_.config.scene.parameters);
  if (state_.state() == DaemonState::kStarting) state_.enter(DaemonState::kError);
  publish();
}

void Conductor::applyPhotometry(const std::optional<DisplayColourCorrection>& photometry,
                                const std::string& source) {
  std::vector<ModuleEncoder> encoders;
  if (photometry) {
    if (photometry->modules.size() != nominal_.modules.size()) {
      throw InputError({source, "modules", 0},
                       fmt::format("has {} modules; this display has {}",
                                   photometry->modules.size(), nominal_.modules.size()));
    }
    // Checked for every module (the same verdict on every rank), kept for this rank's own.
    for (size_t i = 0; i < nominal_.modules.size(); ++i) {
      try {
        ModuleEncoder encoder(photometry->modules[i], nominal_.modules[i].width,
                              nominal_.modules[i].height);
        if (ownership_.ownerOf(static_cast<int>(i)) == cluster_->rank())
          encoders.push_back(std::move(encoder));
      } catch (const InputError& e) {
        throw InputError({source, fmt::format("modules[{}].{}", i, e.location().field), 0},
                         e.reason());
      }
    }
  }
  photometry_ = photometry;
  encoders_ = std::move(encoders);
  ++encodersVersion_;
  photometrySource_ = photometry ? source : "";
  // Frames already shown were encoded with the old correction: render them again.
  renderedTexturesVersion_ = 0;
  if (photometry) spdlog::info("photometric correction: {}", source);
}

CalibrationSettings Conductor::calibrationSettings() const {
  CalibrationSettings settings =
      settingsOf(options_.config.calibration, options_.simulatorPhotometric);
  if (settings.cameraMetadata.empty()) settings.cameraMetadata = options_.simulatorCamera;
  return settings;
}

bool Conductor::connectLink(int timeoutMs) {
  lastLinkTry_ = Clock::now();
  const std::string errorBefore = linkError_;
  const auto deadline = Clock::now() + std::chrono::milliseconds(timeoutMs);
  do {
    try {
      link_ = std::make_unique<hw::LinkClient>(hw::createLinkTransport(options_.linkSpec),
                                               options_.link);
      linkSessions_ = link_->sessions();
      lastLinkActivity_ = Clock::now();
      linkError_.clear();
      const auto& modules = link_->modules();
      spdlog::info("link: up: {} with {} modules", link_->transportName(), modules.size());
      if (modules.size() != owned_.size()) {
        linkError_ = clustered()
                         ? fmt::format("the link of {} has {} modules",
                                       ownership_.describe(cluster_->rank()), modules.size())
                         : fmt::format("the link has {} modules but the display has {}",
                                       modules.size(), nominal_.modules.size());
      }
      for (size_t i = 0; i < modules.size() && linkError_.empty() && i < owned_.size(); ++i) {
        const hw::DeviceInfo& info = modules[i].info;
        const OpticalModule& m = nominal_.modules[static_cast<size_t>(owned_[i])];
        if (static_cast<int>(info.width) != m.width || static_cast<int>(info.height) != m.height) {
          linkError_ =
              fmt::format("module {} ({}) takes {}x{} frames but the display model says {}x{}",
                          owned_[i], info.serial, info.width, info.height, m.width, m.height);
        }
      }
      if (!linkError_.empty()) {
        state_.fail(kConnecting, linkError_, DaemonState::kError);
        link_.reset();
        linkHealth_ = LinkHealth::kDown;
        return false;
      }
      linkHealth_ = LinkHealth::kUp;
      needsPush_ = !currentImages_.empty();
      state_.succeeded(kConnecting);
      return true;
    } catch (const std::exception& e) {
      linkError_ = e.what();
    }
    if (Clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  } while (Clock::now() < deadline);
  // Logged when it goes down or fails differently, not at every retry (every 2 s).
  if (linkHealth_ != LinkHealth::kDown || linkError_ != errorBefore)
    spdlog::warn("link: down: {} (retrying every 2 s)", linkError_);
  linkHealth_ = LinkHealth::kDown;
  return false;
}

void Conductor::reloadConfig(DaemonConfig config) {
  {
    std::lock_guard lock(jobsMutex_);
    pendingConfig_ = std::move(config);
  }
  jobsChanged_.notify_all();
}

void Conductor::reloadConfigFrom(std::string path) {
  {
    std::lock_guard lock(jobsMutex_);
    pendingConfigPath_ = std::move(path);
  }
  jobsChanged_.notify_all();
}

void Conductor::drainJobs(Clock::time_point until) {
  while (true) {
    std::shared_ptr<Job> job;
    std::optional<DaemonConfig> config;
    std::optional<std::string> configPath;
    {
      std::unique_lock lock(jobsMutex_);
      jobsChanged_.wait_until(lock, until, [&] {
        return !jobs_.empty() || pendingConfig_ || pendingConfigPath_ || stopAsked();
      });
      if (pendingConfigPath_) {
        configPath = std::move(pendingConfigPath_);
        pendingConfigPath_.reset();
      } else if (pendingConfig_) {
        config = std::move(pendingConfig_);
        pendingConfig_.reset();
      } else if (!jobs_.empty()) {
        job = jobs_.front();
        jobs_.pop_front();
      }
    }
    if (config && clustered()) {
      // The other ranks would not see it: a cluster reloads from the config file only.
      spdlog::error("config: a cluster reloads its config file only (SIGHUP or `reload`)");
      config.reset();
      continue;
    }
    if (configPath) {
      tellOthers({{"step", "config"}, {"path", *configPath}});
      try {
        reloadFromFile(*configPath);
      } catch (const std::exception& e) {
        state_.fail(kReloadingConfig, e.what(), state_.state());
      }
    } else if (config) {
      applyConfig(*config);
    } else if (job) {
      nlohmann::json reply;
      tellOthers({{"step", "request"}, {"request", job->request}});
      try {
        reply = (this->*job->handler)(job->args);
      } catch (const std::exception& e) {
        reply = {{"ok", false}, {"error", e.what()}};
      }
      try {
        reply = agreeOnReply(std::move(reply));
      } catch (const RanksSilent& e) {
        job->reply.set_value({{"ok", false}, {"error", e.what()}});
        throw;
      }
      publish();
      job->reply.set_value(std::move(reply));
    } else {
      return;  // the deadline passed (or a stop)
    }
    if (stopAsked() || Clock::now() >= until) return;
  }
}

void Conductor::reloadFromFile(const std::string& path) {
  spdlog::info("config: reloading {}", path);
  if (options_.onReloading) options_.onReloading();
  const auto reloaded = [this] {
    if (!restartWith_ && options_.onReloaded) options_.onReloaded();
  };
  try {
    applyConfig(loadDaemonConfig(path));
  } catch (...) {
    reloaded();
    throw;
  }
  reloaded();
}

void Conductor::applyConfig(const DaemonConfig& config) {
  const std::vector<std::string> needRestart = sectionsNeedingRestart(options_.config, config);
  if (!needRestart.empty()) {
    // Check what the restart will build before stopping anything that works.
    try {
      config.validate();
      const DisplayModel display = nominalDisplayOf(config.display);
      linkSpecOf(config.hardware, static_cast<int>(display.modules.size()));
    } catch (const std::exception& e) {
      state_.fail(kReloadingConfig, e.what(), state_.state());
      return;
    }
    spdlog::info("config: [{}] changed: building the daemon again", fmt::join(needRestart, "], ["));
    restartWith_ = config;
    shutdown_ = true;
    return;
  }
  const bool sceneChanged = !(config.scene == options_.config.scene);
  options_.config = withInPlaceChanges(options_.config, config);
  spdlog::set_level(spdlog::level::from_str(options_.config.logLevel));
  spdlog::info("config reloaded");
  state_.succeeded(kReloadingConfig);
  // A scene that does not load is reported in status; the old one plays on.
  if (sceneChanged) loadScene(config.scene.script, config.scene.parameters);
}

}  // namespace parallax::daemon
