#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/atomic_file.h"
#include "common/input_error.h"
#include "daemon/parallaxd/calibration_pipeline.h"
#include "daemon/parallaxd/cluster_pattern_screen.h"
#include "daemon/parallaxd/conductor.h"  // IWYU pragma: associated
#include "hw/camera/calibration_capture.h"
#include "scripts/scene_argument.h"

// The conductor's stages: calibrate (and install), regenerate the ray textures, load a scene.
// Each returns what it ended with; each leaves the state machine where it came from
// (restingState) unless it is what changes it (a scene that loaded plays).

namespace parallax::daemon {
namespace {

// The scene argument as a script path: a library name ("cornell") or a .lua file. The daemon
// plays scripts only, because only they hot-reload and take parameters.
std::string scriptPathOf(const std::string& argument) {
  if (const std::string library = librarySceneScript(argument); !library.empty()) return library;
  if (isSceneScript(argument)) return argument;
  throw InputError({"", "scene", 0},
                   fmt::format("\"{}\" is not a scene script: give a library "
                               "name (cornell, shapes, statue, orbit, sentinel, walker) "
                               "or a .lua file",
                               argument));
}

}  // namespace

DaemonState Conductor::showingState() const {
  if (script_ == nullptr && overlay_.empty()) return DaemonState::kError;
  return paused_ || !overlay_.empty() ? DaemonState::kPaused : DaemonState::kPlaying;
}

DaemonState Conductor::restingState() const {
  if (script_ || !overlay_.empty()) return showingState();
  return startingUp_ ? DaemonState::kStarting : DaemonState::kError;
}

PipelineProgress Conductor::calibrationProgress() {
  PipelineProgress progress;
  progress.stage = [this](const std::string& stage) {
    state_.setStage(stage);
    publish();
    if (options_.onHeartbeat) options_.onHeartbeat();
  };
  progress.note = [](const std::string& line) { spdlog::info("{}", line); };
  return progress;
}

Conductor::StageResult Conductor::calibrate(std::optional<int> onlyModule,
                                            std::optional<PhotometricMode> photometric) {
  const DaemonState back = restingState();
  CalibrationSettings settings = calibrationSettings();
  if (photometric) settings.photometric = *photometric;
  // One module's geometry is refitted alone; its colours need the whole display's target.
  if (onlyModule && settings.photometric == PhotometricMode::kOn)
    settings.photometric = PhotometricMode::kOff;
  // Reset before the state says "calibrating", which is when a `cancel` is accepted.
  cancel_ = false;
  state_.enter(DaemonState::kCalibrating,
               settings.photometric == PhotometricMode::kOnly
                   ? "the modules' colours"
                   : (onlyModule ? fmt::format("module {}", *onlyModule) : "all modules"));
  publish();
  StageResult result;
  try {
    if (!link_) throw std::runtime_error("no link to the modules: " + linkError_);
    const bool colourOnly = settings.photometric == PhotometricMode::kOnly;
    if (colourOnly && calibrationSource_ == "nominal (uncalibrated)")
      throw std::runtime_error(
          "no geometric calibration installed: calibrate the geometry first (photometric only "
          "keeps the installed one)");
    // A cluster's patterns go to every rank's modules; the camera is rank 0's.
    std::optional<ClusterPatternScreen> screen;
    if (clustered()) {
      screen.emplace([this](const nlohmann::json& op, const std::string& payload) {
        return calibrationStep(op, payload);
      });
    }
    const CalibrationRun run = calibrateThroughLink(
        *link_, nominal_, onlyModule || colourOnly ? calibration_ : nominal_, settings, onlyModule,
        calibrationProgress(), [this] { return cancel_.load() || stopAsked(); },
        screen ? &*screen : nullptr);
    if (clustered()) {
      // Every rank installs it and makes its modules' textures, or none keeps it.
      state_.setStage("installing on every rank");
      publish();
      installOnEveryRank(&run.model);
      writeFileAtomically(store_.path() + ".report.txt", run.summary + "\n" + run.report);
      spdlog::info("calibration installed on every rank: {}\n{}", store_.path(), run.summary);
      result.summary = run.summary;
      state_.succeeded(kCalibrating);
      state_.enter(back);
      return result;
    }
    // Textures first: if they cannot be made, the old calibration stays installed.
    const StageResult textures = regenerate(run.model);
    if (textures.done()) {
      StoredCalibration installed;
      try {
        // Returns only once the calibration (and its photometry) is on disk.
        installed = run.photometry
                        ? store_.install(run.model, CalibrationStore::Photometry::kReplace,
                                         run.photometry->calibration.correction)
                        : store_.install(run.model);
        applyPhotometry(installed.photometry, installed.photometrySource);
      } catch (const std::exception&) {
        regenerate(calibration_);  // not kept, so not shown: back to the installed one
        throw;
      }
      calibration_ = run.model;
      calibrationSource_ = store_.path();
      photometryRefused_.clear();
      // The fit's report beside the calibration it describes, for the installer.
      std::string report = run.summary + "\n" + run.report;
      if (run.photometry) report += "\n" + run.photometry->summary + "\n" + run.photometry->report;
      writeFileAtomically(store_.path() + ".report.txt", report);
      spdlog::info("calibration installed: {} (report: {}.report.txt)\n{}", store_.path(),
                   store_.path(), run.summary);
      result.summary = run.summary;
      if (run.photometry) result.summary += "\n" + run.photometry->summary;
      state_.succeeded(kCalibrating);
    } else {
      result = textures;
    }
    // Whatever the modules showed during the patterns is gone: show the scene again.
    needsPush_ = true;
    renderedTexturesVersion_ = 0;
    return result;
  } catch (const hw::CalibrationCancelled& e) {
    // Asked for (`cancel`, `shutdown`, a signal): not a failure, so no last_error.
    spdlog::info("{}; the installed calibration stays ({})", e.what(), calibrationSource_);
    result.outcome = StageResult::Outcome::kCancelled;
    result.error = "calibration cancelled; the installed one stays: " + calibrationSource_;
    state_.enter(back);
  } catch (const std::exception& e) {
    result.outcome = StageResult::Outcome::kFailed;
    result.error = e.what();
    state_.fail(kCalibrating, e.what(), back);
    spdlog::warn("calibration refused, not installed; the installed one stays: {}",
                 calibrationSource_);
  }
  needsPush_ = !currentImages_.empty();  // the patterns may have replaced our frames
  return result;
}

Conductor::StageResult Conductor::regenerate(const DisplayModel& model) {
  const DaemonState back = restingState();
  state_.enter(DaemonState::kRegenerating, "ray textures");
  publish();
  try {
    RayTextureCacheStats stats;
    std::vector<RayTextures> textures =
        cache_.texturesFor(model, owned_, &stats, [this](int done, int total) {
          state_.setStage(fmt::format("ray textures: module {} of {}", done, total));
          publish();                                         // `status` says how far it got
          if (options_.onHeartbeat) options_.onHeartbeat();  // a long stage is not a hang
        });
    textures_ = std::move(textures);
    cacheStats_ = stats;
    texturesHash_ = displayContentHash(model);
    ++texturesVersion_;
    state_.succeeded(kRegenerating);
    spdlog::info("ray textures {}: {} from the cache, {} generated", hashHex(texturesHash_),
                 stats.loaded, stats.generated);
    state_.enter(back);
    return {};
  } catch (const std::exception& e) {
    state_.fail(kRegenerating, e.what(), back);
    return {StageResult::Outcome::kFailed, e.what(), {}};
  }
}

Conductor::StageResult Conductor::loadScene(const std::string& argument,
                                            const std::map<std::string, double>& parameters) {
  const DaemonState back = restingState();
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
    state_.succeeded(kLoadingScene);
    state_.enter(paused_ ? DaemonState::kPaused : DaemonState::kPlaying);
    return {};
  } catch (const std::exception& e) {
    // In last_error; scene_error stays about the scene that plays.
    state_.fail(kLoadingScene, e.what(), back);
    return {StageResult::Outcome::kFailed, e.what(), {}};
  }
}

}  // namespace parallax::daemon
