#include "daemon/parallaxd/conductor.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <thread>

#include "calibration/display/display_model_json.h"
#include "calibration/display/display_presets.h"
#include "common/atomic_file.h"
#include "common/input_error.h"
#include "daemon/parallaxd/calibration_stage.h"
#include "daemon/parallaxd/installer_patterns.h"
#include "daemon/parallaxd/module_renderer.h"
#include "hw/camera/calibration_capture.h"
#include "hw/link/link_transport.h"
#include "scripts/scene_argument.h"
#include "tracer/observer_view.h"

namespace parallax::daemon {
namespace {

// The scene argument as a script path: a library name ("cornell") or a .lua file. The daemon
// plays scripts only, because only they hot-reload and take parameters.
std::string scriptPathOf(const std::string& argument) {
  if (const std::string library = librarySceneScript(argument); !library.empty()) return library;
  if (isSceneScript(argument)) return argument;
  throw InputError(
      {"", "scene", 0},
      fmt::format(
          "\"{}\" is not a scene script: give a library name (cornell, shapes, statue, orbit) "
          "or a .lua file",
          argument));
}

}  // namespace

Conductor::Conductor(ConductorOptions options)
    : options_(std::move(options)),
      nominal_(nominalDisplayOf(options_.config.display)),
      calibration_(nominal_),
      calibrationSource_("nominal (uncalibrated)"),
      store_(options_.config.calibrationFilePath()),
      cache_(options_.config.cacheDirPath()) {
  options_.render.validate();
  publish();
}

Conductor::~Conductor() = default;

// ---- the conductor thread -----------------------------------------------------------------

void Conductor::run(const std::atomic<bool>& stop) {
  try {
    startUp();
  } catch (const std::exception& e) {
    state_.fail("starting", e.what(), DaemonState::kError);
  }
  if (options_.onReady) options_.onReady();
  while (!stop.load() && !shutdown_.load()) {
    if (options_.onHeartbeat) options_.onHeartbeat();
    drainJobs(Clock::now() + timeToNextTurn());
    if (stop.load() || shutdown_.load()) break;
    turn();
    publish();
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
      if (!installed->refused.empty())
        state_.fail("loading the calibration", installed->refused + "; using " + installed->source,
                    DaemonState::kStarting);
    }
  } catch (const InputError& e) {
    state_.fail("loading the calibration", e.what(), DaemonState::kStarting);
  }
  if (!haveCalibration && options_.config.calibration.autoCalibrate && link_)
    calibrate(std::nullopt);
  if (texturesVersion_ == 0) regenerate(calibration_);
  if (textures_.size() == nominal_.modules.size()) {
    try {
      loadScene(options_.config.scene.script, options_.config.scene.parameters);
    } catch (const std::exception&) {
      // In status as the last error; a `load` request can bring a scene later.
    }
  }
  publish();
}

bool Conductor::connectLink(int timeoutMs) {
  lastLinkTry_ = Clock::now();
  const auto deadline = Clock::now() + std::chrono::milliseconds(timeoutMs);
  do {
    try {
      link_ = std::make_unique<hw::LinkClient>(hw::createLinkTransport(options_.linkSpec),
                                               options_.link);
      linkSessions_ = link_->sessions();
      lastLinkActivity_ = Clock::now();
      linkError_.clear();
      const auto& modules = link_->modules();
      spdlog::info("link: {} with {} modules", link_->transportName(), modules.size());
      if (modules.size() != nominal_.modules.size()) {
        linkError_ = fmt::format("the link has {} modules but the display has {}", modules.size(),
                                 nominal_.modules.size());
      }
      for (size_t i = 0; i < modules.size() && linkError_.empty() && i < nominal_.modules.size();
           ++i) {
        const hw::DeviceInfo& info = modules[i].info;
        const OpticalModule& m = nominal_.modules[i];
        if (static_cast<int>(info.width) != m.width || static_cast<int>(info.height) != m.height) {
          linkError_ =
              fmt::format("module {} ({}) takes {}x{} frames but the display model says {}x{}", i,
                          info.serial, info.width, info.height, m.width, m.height);
        }
      }
      if (!linkError_.empty()) {
        state_.fail("connecting", linkError_, DaemonState::kError);
        link_.reset();
        return false;
      }
      needsPush_ = !currentImages_.empty();
      return true;
    } catch (const std::exception& e) {
      linkError_ = e.what();
    }
    if (Clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  } while (Clock::now() < deadline);
  spdlog::warn("link: {} (will retry)", linkError_);
  return false;
}

DaemonState Conductor::showingState() const {
  if (script_ == nullptr && overlay_.empty()) return DaemonState::kError;
  return paused_ || !overlay_.empty() ? DaemonState::kPaused : DaemonState::kPlaying;
}

void Conductor::calibrate(std::optional<int> onlyModule) {
  const DaemonState back = script_ ? showingState() : DaemonState::kStarting;
  // Reset before the state says "calibrating", which is when a `cancel` is accepted.
  cancel_ = shutdown_.load();
  calibrationCancelled_ = false;
  state_.enter(DaemonState::kCalibrating,
               onlyModule ? fmt::format("module {}", *onlyModule) : "all modules");
  publish();
  try {
    if (!link_) throw std::runtime_error("no link to the modules: " + linkError_);
    const CalibrationRun run = calibrateThroughLink(
        *link_, nominal_, onlyModule ? calibration_ : nominal_, options_.config.calibration,
        onlyModule,
        [this](const std::string& stage) {
          state_.setStage(stage);
          if (options_.onHeartbeat) options_.onHeartbeat();
          publish();
        },
        &cancel_);
    lastCalibrationSummary_ = run.summary;
    // Textures first: if they cannot be made, the old calibration stays installed.
    regenerate(run.model);
    if (texturesHash_ == displayContentHash(run.model)) {
      try {
        store_.install(run.model);  // returns only once the calibration is on disk
      } catch (const std::exception&) {
        regenerate(calibration_);  // not kept, so not shown: back to the installed one
        throw;
      }
      calibration_ = run.model;
      calibrationSource_ = store_.path();
      // The fit's report beside the calibration it describes, for the installer.
      writeFileAtomically(store_.path() + ".report.txt", run.summary + "\n" + run.report);
      spdlog::info("calibration installed: {} (report: {}.report.txt)\n{}", store_.path(),
                   store_.path(), run.summary);
    }
    // Whatever the modules showed during the patterns is gone: show the scene again.
    needsPush_ = true;
    renderedTexturesVersion_ = 0;
  } catch (const hw::CalibrationCancelled& e) {
    // Asked for (`cancel`): not a failure, so no last_error; the scene comes back.
    spdlog::info("{}; the installed calibration stays ({})", e.what(), calibrationSource_);
    calibrationCancelled_ = true;
    needsPush_ = !currentImages_.empty();
  } catch (const std::exception& e) {
    state_.fail("calibrating", e.what(), back);
    needsPush_ = !currentImages_.empty();  // the patterns may have replaced our frames
  }
  if (state_.state() == DaemonState::kCalibrating)
    state_.enter(back == DaemonState::kStarting ? DaemonState::kStarting : back);
}

void Conductor::regenerate(const DisplayModel& model) {
  const DaemonState back = script_ ? showingState() : DaemonState::kError;
  state_.enter(DaemonState::kRegenerating, "ray textures");
  publish();
  try {
    RayTextureCacheStats stats;
    std::vector<RayTextures> textures =
        cache_.texturesFor(model, &stats, [this](int done, int total) {
          state_.setStage(fmt::format("ray textures: module {} of {}", done, total));
          if (options_.onHeartbeat) options_.onHeartbeat();  // a long stage is not a hang
        });
    textures_ = std::move(textures);
    cacheStats_ = stats;
    texturesHash_ = displayContentHash(model);
    ++texturesVersion_;
    spdlog::info("ray textures {}: {} from the cache, {} generated", hashHex(texturesHash_),
                 stats.loaded, stats.generated);
    if (back != DaemonState::kError) state_.enter(back);
  } catch (const std::exception& e) {
    state_.fail("regenerating the ray textures", e.what(), back);
  }
}

void Conductor::loadScene(const std::string& argument,
                          const std::map<std::string, double>& parameters) {
  const DaemonState back = script_ ? showingState() : DaemonState::kError;
  state_.enter(DaemonState::kLoading, argument);
  publish();
  try {
    ScriptOptions so;
    so.parameters = parameters;
    so.quiet = true;
    auto next = std::make_unique<ScriptedScene>(scriptPathOf(argument), so);
    script_ = std::move(next);
    sceneArgument_ = argument;
    sceneError_.clear();
    sceneTime_ = 0.0;
    renderedSceneVersion_ = 0;
    overlay_.clear();
    nextFrameDue_ = Clock::now();
    spdlog::info("scene: {} ({})", argument, script_->script().animated() ? "animated" : "static");
    state_.enter(paused_ ? DaemonState::kPaused : DaemonState::kPlaying);
  } catch (const std::exception& e) {
    // In last_error; scene_error stays about the scene that plays.
    state_.fail("loading the scene", e.what(), back);
    throw;
  }
}

std::chrono::milliseconds Conductor::timeToNextTurn() const {
  using std::chrono::milliseconds;
  const auto idle = milliseconds(std::min(250, options_.keepAliveMs));
  if (state_.state() != DaemonState::kPlaying || !script_ || !script_->script().animated())
    return idle;
  const auto left = std::chrono::duration_cast<milliseconds>(nextFrameDue_ - Clock::now());
  return std::clamp(left, milliseconds(0), idle);
}

void Conductor::turn() {
  if (!link_ && Clock::now() - lastLinkTry_ > std::chrono::seconds(2)) connectLink(0);
  if (state_.state() == DaemonState::kPlaying && script_ && overlay_.empty()) {
    if (script_->reloadIfChanged() == ScriptedScene::Reload::kFailed) {
      sceneError_ = script_->lastError();
      spdlog::error("scene reload failed, the previous version keeps playing: {}", sceneError_);
    }
    const bool animated = script_->script().animated();
    bool due = !animated;
    if (animated && Clock::now() >= nextFrameDue_) {
      // Frame pacing: the animation follows the wall clock; periods that passed while the
      // previous frame was still being made are dropped (counted), not made up for.
      const double period = 1.0 / options_.config.scene.fps;
      const double late = std::chrono::duration<double>(Clock::now() - nextFrameDue_).count();
      const auto missed = static_cast<uint64_t>(std::floor(late / period));
      stats_.droppedFrames += missed;
      const double step = period * static_cast<double>(missed + 1);
      nextFrameDue_ +=
          std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(step));
      if (renderedSceneVersion_ != 0) sceneTime_ += step;
      if (!script_->setTime(sceneTime_)) sceneError_ = script_->lastError();
      due = true;
    }
    if (due && textures_.size() == nominal_.modules.size() &&
        (script_->version() != renderedSceneVersion_ ||
         texturesVersion_ != renderedTexturesVersion_)) {
      renderAndPush();
    }
  }
  keepLinkAlive();
  if (needsPush_ && link_ && !currentImages_.empty()) {
    ++stats_.resendsAfterReconnect;
    push(currentImages_);
  }
}

void Conductor::renderAndPush() {
  const auto started = Clock::now();
  try {
    const PhysicalScene physical(script_->scene(), calibration_.displayableBox);
    DisplayFrame frame = renderDisplayFrame(physical, textures_, options_.render);
    stats_.render.add(frame.renderMs);
    stats_.encode.add(frame.encodeMs);
    ++stats_.displayFrames;
    lastCounters_ = frame.counters;
    currentImages_ = std::move(frame.images);
    renderedSceneVersion_ = script_->version();
    renderedTexturesVersion_ = texturesVersion_;
  } catch (const std::exception& e) {
    // Nothing of a failed frame reaches the modules: they keep the last complete one.
    ++stats_.renderFailures;
    sceneError_ = e.what();
    renderedSceneVersion_ = script_->version();
    spdlog::error("render failed, the modules keep the previous frame: {}", e.what());
    return;
  }
  if (link_) {
    push(currentImages_);
    stats_.latency.add(std::chrono::duration<double, std::milli>(Clock::now() - started).count());
  } else {
    needsPush_ = true;
  }
}

void Conductor::push(const std::vector<std::shared_ptr<const hw::Image>>& images) {
  const auto started = Clock::now();
  needsPush_ = false;
  try {
    for (size_t i = 0; i < images.size(); ++i) link_->submit(static_cast<int>(i), images[i]);
    link_->flush();
  } catch (const std::exception& e) {
    spdlog::error("push failed: {}", e.what());
    needsPush_ = true;
  }
  for (const hw::FrameOutcome& o : link_->takeOutcomes()) {
    switch (o.status) {
      case hw::FrameStatus::kDelivered:
        ++stats_.moduleFramesSent;
        break;
      case hw::FrameStatus::kSkippedUnchanged:
        ++stats_.moduleFramesUnchanged;
        break;
      case hw::FrameStatus::kFailed:
        ++stats_.moduleFramesFailed;
        needsPush_ = true;  // try again on the next turn (the link may be back by then)
        break;
      default:
        break;
    }
  }
  stats_.push.add(std::chrono::duration<double, std::milli>(Clock::now() - started).count());
  lastLinkActivity_ = Clock::now();
  if (link_->sessions() != linkSessions_) {
    // The link reconnected during the push: LinkClient resent what was in flight, but a
    // module that restarted may have lost frames delivered before; send them all again.
    linkSessions_ = link_->sessions();
    needsPush_ = true;
  }
}

void Conductor::keepLinkAlive() {
  if (!link_) return;
  if (Clock::now() - lastLinkActivity_ >= std::chrono::milliseconds(options_.keepAliveMs)) {
    link_->ping();  // reconnects by itself when the link dropped
    lastLinkActivity_ = Clock::now();
  }
  if (link_->sessions() != linkSessions_) {
    // The link came back: the modules behind it may have restarted blank. Send them the
    // current frames again (LinkClient forgot their content, so nothing is skipped).
    spdlog::warn("link: reconnected (session {}); sending the current frames again",
                 link_->sessions());
    linkSessions_ = link_->sessions();
    needsPush_ = !currentImages_.empty();
  }
}

void Conductor::showOverlay(const std::string& kind, std::optional<int> module) {
  std::vector<std::shared_ptr<const hw::Image>> images = currentImages_;
  images.resize(nominal_.modules.size());
  for (size_t i = 0; i < nominal_.modules.size(); ++i) {
    const OpticalModule& m = nominal_.modules[i];
    const int index = static_cast<int>(i);
    if (!module || index == *module) {
      images[i] =
          encodeForLink(kind == "identify" ? identifyFrame(m.width, m.height, index, m.mirror)
                                           : testCardFrame(m.width, m.height, index, m.mirror));
    } else if (!images[i] || images[i]->width != m.width || images[i]->height != m.height) {
      images[i] = encodeForLink(Frame(m.width, m.height));  // nothing shown there yet: black
    }
  }
  currentImages_ = std::move(images);
  overlay_ = kind;
  renderedSceneVersion_ = 0;  // `play` renders the scene again
  state_.enter(DaemonState::kPaused, kind);
  if (link_) push(currentImages_);
}

void Conductor::finishInFlight() {
  if (!link_) return;
  try {
    link_->flush();
  } catch (const std::exception& e) {
    spdlog::warn("link: {}", e.what());
  }
  link_->takeOutcomes();
}

// ---- requests -------------------------------------------------------------------------------

nlohmann::json Conductor::handle(const nlohmann::json& request) {
  const std::string name = request.value("request", "");
  if (name == "status") {
    std::lock_guard lock(publishedMutex_);
    return publishedStatus_;
  }
  if (name == "stats") {
    std::lock_guard lock(publishedMutex_);
    return publishedStats_;
  }
  if (name == "shutdown") {
    shutdown_ = true;
    cancel_ = true;
    jobsChanged_.notify_all();
    return {{"ok", true}, {"message", "stopping"}};
  }
  if (name == "cancel") {
    // Answered at once: the conductor thread is inside the calibration. It stops at the next
    // picture, stage or solver iteration; the installed calibration stays.
    if (state_.snapshot().state != DaemonState::kCalibrating) {
      return {{"ok", false}, {"error", "nothing to cancel: the daemon is not calibrating"}};
    }
    cancel_ = true;
    return {{"ok", true}, {"message", "cancelling the calibration; the installed one stays"}};
  }
  auto job = std::make_shared<Job>();
  job->request = request;
  std::future<nlohmann::json> reply = job->reply.get_future();
  {
    // Queued even during a long start-up stage: answered once the loop runs.
    std::lock_guard lock(jobsMutex_);
    if (!acceptingJobs_ || shutdown_.load())
      return {{"ok", false}, {"error", "the daemon is stopping"}};
    jobs_.push_back(job);
  }
  jobsChanged_.notify_all();
  return reply.get();
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
        return !jobs_.empty() || pendingConfig_ || pendingConfigPath_ || shutdown_.load();
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
    if (configPath) {
      try {
        applyConfig(loadDaemonConfig(*configPath));
      } catch (const std::exception& e) {
        state_.fail("reloading the config (the old one stays)", e.what(), state_.state());
      }
    } else if (config) {
      applyConfig(*config);
    } else if (job) {
      nlohmann::json reply;
      try {
        reply = dispatch(job->request);
      } catch (const std::exception& e) {
        reply = {{"ok", false}, {"error", e.what()}};
      }
      publish();
      job->reply.set_value(std::move(reply));
    } else {
      return;  // the deadline passed (or shutdown)
    }
    if (shutdown_.load() || Clock::now() >= until) return;
  }
}

void Conductor::applyConfig(const DaemonConfig& config) {
  const DaemonConfig& old = options_.config;
  std::vector<std::string> needRestart;
  if (config.display.file != old.display.file || config.display.preset != old.display.preset ||
      config.display.modules != old.display.modules || config.display.width != old.display.width ||
      config.display.height != old.display.height) {
    needRestart.push_back("display");
  }
  if (config.hardware.kind != old.hardware.kind || config.hardware.socket != old.hardware.socket ||
      config.hardware.vid != old.hardware.vid || config.hardware.pid != old.hardware.pid) {
    needRestart.push_back("hardware");
  }
  if (config.controlSocketPath() != old.controlSocketPath()) needRestart.push_back("daemon.socket");
  if (config.cacheDirPath() != old.cacheDirPath()) needRestart.push_back("daemon.cache_dir");
  if (config.calibrationFilePath() != old.calibrationFilePath())
    needRestart.push_back("calibration.file");
  const bool sceneChanged =
      config.scene.script != old.scene.script || config.scene.parameters != old.scene.parameters;
  if (!needRestart.empty()) {
    // Check what the restart will build before stopping anything that works.
    try {
      config.validate();
      const DisplayModel display = nominalDisplayOf(config.display);
      linkSpecOf(config.hardware, static_cast<int>(display.modules.size()));
    } catch (const std::exception& e) {
      state_.fail("reloading the config (the old one stays)", e.what(), state_.state());
      return;
    }
    spdlog::info("config: [{}] changed: building the daemon again", fmt::join(needRestart, "], ["));
    restartWith_ = config;
    shutdown_ = true;
    return;
  }
  DaemonConfig applied = old;
  applied.scene = config.scene;
  applied.calibration.camera = config.calibration.camera;
  applied.calibration.autoCalibrate = config.calibration.autoCalibrate;
  applied.logLevel = config.logLevel;
  options_.config = applied;
  spdlog::set_level(spdlog::level::from_str(applied.logLevel));
  spdlog::info("config reloaded");
  if (sceneChanged) {
    try {
      loadScene(config.scene.script, config.scene.parameters);
    } catch (const std::exception&) {
      // Reported in status; the old scene plays on.
    }
  }
}

nlohmann::json Conductor::dispatch(const nlohmann::json& request) {
  const std::string name = request.value("request", "");
  auto optionalModule = [&](const char* key) -> std::optional<int> {
    if (!request.contains(key)) return std::nullopt;
    if (!request[key].is_number_integer()) throw InputError({"", key, 0}, "must be a module index");
    const int m = request[key].get<int>();
    if (m < 0 || m >= static_cast<int>(nominal_.modules.size())) {
      throw InputError({"", key, 0},
                       fmt::format("no module {} (0..{})", m, nominal_.modules.size() - 1));
    }
    return m;
  };
  auto ok = [](nlohmann::json j = nlohmann::json::object()) {
    j["ok"] = true;
    return j;
  };

  if (name == "calibrate") {
    const std::optional<int> module = optionalModule("module");
    const std::string before = state_.snapshot().lastError;
    const uint64_t hashBefore = texturesHash_;
    calibrate(module);
    if (texturesHash_ == hashBefore) {
      const StateSnapshot s = state_.snapshot();
      if (calibrationCancelled_) {
        return {{"ok", false},
                {"error", "calibration cancelled; the installed one stays: " + calibrationSource_}};
      }
      return {{"ok", false},
              {"error", s.lastError.empty() || s.lastError == before ? "calibration not installed"
                                                                     : s.lastError}};
    }
    return ok({{"calibration", calibrationSource_},
               {"hash", hashHex(texturesHash_)},
               {"summary", lastCalibrationSummary_}});
  }
  if (name == "rollback") {
    const DisplayModel previous = store_.rollback(nominal_);
    regenerate(previous);
    if (texturesHash_ != displayContentHash(previous))
      throw std::runtime_error(state_.snapshot().lastError);
    calibration_ = previous;
    calibrationSource_ = store_.path() + " (rolled back)";
    return ok({{"calibration", calibrationSource_}, {"hash", hashHex(texturesHash_)}});
  }
  if (name == "load") {
    if (!request.contains("scene") || !request["scene"].is_string())
      throw InputError({"", "scene", 0}, "load needs \"scene\"");
    std::map<std::string, double> parameters;
    if (request.contains("parameters") && request["parameters"].is_object()) {
      for (const auto& [k, v] : request["parameters"].items()) {
        if (!v.is_number()) throw InputError({"", "parameters." + k, 0}, "must be a number");
        parameters[k] = v.get<double>();
      }
    }
    loadScene(request["scene"].get<std::string>(), parameters);
    return ok({{"scene", sceneArgument_}});
  }
  if (name == "play") {
    if (!script_) throw std::runtime_error("no scene loaded: " + sceneError_);
    paused_ = false;
    overlay_.clear();
    nextFrameDue_ = Clock::now();
    state_.enter(DaemonState::kPlaying);
    return ok();
  }
  if (name == "pause") {
    if (!script_) throw std::runtime_error("no scene loaded");
    paused_ = true;
    state_.enter(DaemonState::kPaused);
    return ok();
  }
  if (name == "set") {
    if (!script_) throw std::runtime_error("no scene loaded");
    if (!request.contains("name") || !request["name"].is_string())
      throw InputError({"", "name", 0}, "set needs \"name\"");
    if (!request.contains("value") || !request["value"].is_number())
      throw InputError({"", "value", 0}, "set needs a number \"value\"");
    const std::string parameter = request["name"].get<std::string>();
    if (!script_->setParameter(parameter, request["value"].get<double>())) {
      sceneError_ = script_->lastError();
      throw std::runtime_error("the scene kept its previous state: " + sceneError_);
    }
    options_.config.scene.parameters[parameter] = request["value"].get<double>();
    return ok();
  }
  if (name == "frame") return writeModuleFrame(request);
  if (name == "view") return writeObserverView(request);
  if (name == "reload") {
    if (!options_.config.sourceFile.empty())
      applyConfig(loadDaemonConfig(options_.config.sourceFile));
    if (script_ && script_->reloadIfChanged() == ScriptedScene::Reload::kFailed) {
      sceneError_ = script_->lastError();
      throw std::runtime_error("scene reload failed, the previous version keeps playing: " +
                               sceneError_);
    }
    return ok(
        {{"config", options_.config.sourceFile.empty() ? "built-in" : options_.config.sourceFile}});
  }
  if (name == "identify" || name == "testcard") {
    if (textures_.empty() && nominal_.modules.empty()) throw std::runtime_error("no display");
    showOverlay(name, name == "identify" ? optionalModule("module") : std::nullopt);
    return ok({{"message", "`play` returns to the scene"}});
  }
  throw InputError({"", "request", 0},
                   fmt::format("unknown request \"{}\" (status, calibrate, cancel, load, play, "
                               "pause, set, frame, view, stats, "
                               "reload, shutdown, identify, testcard, rollback)",
                               name));
}

nlohmann::json Conductor::writeModuleFrame(const nlohmann::json& request) {
  if (!request.contains("module") || !request["module"].is_number_integer()) {
    throw InputError({"", "module", 0}, "frame needs \"module\"");
  }
  const int m = request["module"].get<int>();
  if (m < 0 || m >= static_cast<int>(currentImages_.size())) {
    throw InputError(
        {"", "module", 0},
        fmt::format("no frame for module {} ({} modules show frames)", m, currentImages_.size()));
  }
  const std::string path =
      request.contains("path") && request["path"].is_string()
          ? request["path"].get<std::string>()
          : moduleFrameStem(options_.config.cacheDirPath() + "/frames", m) + ".png";
  std::error_code ec;
  std::filesystem::create_directories(std::filesystem::path(path).parent_path(), ec);
  hw::writePng(*currentImages_[static_cast<size_t>(m)], path);
  return {{"ok", true}, {"path", std::filesystem::absolute(path).string()}, {"module", m}};
}

nlohmann::json Conductor::writeObserverView(const nlohmann::json& request) {
  if (!request.contains("x") || !request["x"].is_number())
    throw InputError({"", "x", 0}, "view needs a number \"x\" (m)");
  if (currentImages_.size() != calibration_.modules.size())
    throw std::runtime_error("the modules show no frames yet");
  const double x = request["x"].get<double>();
  if (!std::isfinite(x) || std::abs(x) > 100.0)
    throw InputError({"", "x", 0}, "must be within ±100 m");
  ObserverViewOptions vo;
  if (request.contains("width")) vo.width = request["width"].get<int>();
  if (request.contains("height")) vo.height = request["height"].get<int>();
  vo.validate();
  const Eigen::Vector3d viewer(x, calibration_.observer.y, calibration_.observer.z);
  // From what the modules show (8-bit), back in linear light: the view includes quantisation.
  std::vector<Frame> shown;
  shown.reserve(currentImages_.size());
  for (const auto& image : currentImages_) shown.push_back(frameShownBy(*image));
  const Frame view = synthesizeObserverView(calibration_, shown, viewer, vo);
  const std::string path =
      request.contains("path") && request["path"].is_string()
          ? request["path"].get<std::string>()
          : fmt::format("{}/views/view_x{:+.3f}.png", options_.config.cacheDirPath(), x);
  std::error_code ec;
  std::filesystem::create_directories(std::filesystem::path(path).parent_path(), ec);
  writePng(view, path);
  return {{"ok", true}, {"path", std::filesystem::absolute(path).string()}, {"x", x}};
}

nlohmann::json Conductor::statusJson() const {
  const StateSnapshot s = state_.snapshot();
  nlohmann::json j = {
      {"ok", true},
      {"state", daemonStateName(s.state)},
      {"stage", s.stage},
      {"seconds_in_state", s.secondsInState},
      {"display", {{"name", nominal_.name}, {"modules", nominal_.modules.size()}}},
      {"calibration", {{"source", calibrationSource_}, {"hash", hashHex(texturesHash_)}}},
      {"ray_textures", {{"from_cache", cacheStats_.loaded}, {"generated", cacheStats_.generated}}},
      {"link", {{"up", link_ != nullptr}, {"sessions", linkSessions_}, {"error", linkError_}}},
      {"fps", options_.config.scene.fps}};
  if (!s.lastError.empty()) j["last_error"] = {{"stage", s.lastErrorStage}, {"error", s.lastError}};
  if (script_) {
    j["scene"] = {{"name", sceneArgument_},
                  {"animated", script_->script().animated()},
                  {"time", sceneTime_},
                  {"reloads", script_->reloads()},
                  {"failed_reloads", script_->failedReloads()}};
    nlohmann::json params = nlohmann::json::object();
    for (const ScriptParameter& p : script_->script().parameters()) params[p.name] = p.value;
    j["scene"]["parameters"] = params;
  }
  if (!sceneError_.empty()) j["scene_error"] = sceneError_;
  if (!overlay_.empty()) j["showing"] = overlay_;
  return j;
}

nlohmann::json Conductor::statsJson() const {
  nlohmann::json j = stats_.toJson();
  j["ok"] = true;
  j["summary"] = stats_.summary();
  j["render_counters"] = lastCounters_.lines();
  if (link_) {
    const hw::LinkStats& l = link_->stats();
    j["link"] = {{"submitted", l.submitted},
                 {"delivered", l.delivered},
                 {"skipped_unchanged", l.skipped},
                 {"failed", l.failed},
                 {"retries", l.retries},
                 {"reconnects", l.reconnects},
                 {"bytes_sent", l.payloadBytesSent},
                 {"sessions", link_->sessions()}};
  }
  return j;
}

void Conductor::publish() {
  nlohmann::json status = statusJson(), stats = statsJson();
  std::lock_guard lock(publishedMutex_);
  publishedStatus_ = std::move(status);
  publishedStats_ = std::move(stats);
}

}  // namespace parallax::daemon
