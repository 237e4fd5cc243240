#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>

#include "common/check.h"
#include "common/input_error.h"
#include "daemon/parallaxd/conductor.h"  // IWYU pragma: associated
#include "daemon/parallaxd/module_renderer.h"
#include "daemon/parallaxd/output_file.h"
#include "scripts/scene_argument.h"
#include "scripts/scene_script.h"
#include "tracer/observer_view.h"

// The control socket's requests on the daemon's side: the entry that checks a request against
// the table (control_request_table.cpp) and one handler per request.

namespace parallax::daemon {
namespace {

using Reply = nlohmann::json;

Reply ok(Reply j = Reply::object()) {
  j["ok"] = true;
  return j;
}

Reply refused(const std::string& why) { return {{"ok", false}, {"error", why}}; }

}  // namespace

const std::map<std::string_view, Conductor::Handler>& Conductor::handlers() {
  using C = Conductor;
  // One handler a request of the table (control_request_table.cpp), by its name; the
  // constructor checks that both name the same requests.
  static const std::map<std::string_view, Handler> byName = {
      {"status", &C::answerStatus},
      {"stats", &C::answerStats},
      {"calibrate", &C::answerCalibrate},
      {"cancel", &C::answerCancel},
      {"rollback", &C::answerRollback},
      {"load", &C::answerLoad},
      {"play", &C::answerPlay},
      {"pause", &C::answerPause},
      {"set", &C::answerSet},
      {"frame", &C::answerFrame},
      {"view", &C::answerView},
      {"reload", &C::answerReload},
      {"identify", &C::answerIdentify},
      {"testcard", &C::answerTestcard},
      {"scenes", &C::answerScenes},
      {"panel", &C::answerPanel},
      {"shutdown", &C::answerShutdown},
  };
  return byName;
}

bool Conductor::handles(std::string_view request) { return handlers().contains(request); }

void Conductor::checkEveryRequestHasAHandler() {
  for (const RequestSpec& spec : controlRequests()) {
    if (!handles(spec.name))
      throw InternalError(fmt::format("check failed: request \"{}\" has no handler", spec.name));
  }
  PARALLAX_CHECK_OP(handlers().size(), ==, controlRequests().size());  // no handler left over
}

Reply Conductor::handle(const Reply& request) {
  std::shared_ptr<Job> job;
  try {
    const std::string name =
        request.contains("request") && request["request"].is_string() ? request["request"] : "";
    const RequestSpec* spec = findControlRequest(name);
    if (spec == nullptr) throw InputError({"", "request", 0}, unknownRequestMessage(name));
    RequestArgs args = parseRequestArgs(*spec, request, static_cast<int>(nominal_.modules.size()));
    // Answered at once: from the published snapshot, or a flag the conductor thread polls.
    const Handler handler = handlers().at(spec->name);
    if (spec->served == Served::kAtOnce) return (this->*handler)(args);
    job = std::make_shared<Job>(Job{handler, std::move(args), request, {}});
  } catch (const std::exception& e) {
    return refused(e.what());
  }
  std::future<Reply> reply = job->reply.get_future();
  {
    // Queued even during a long start-up stage: answered once the loop runs.
    std::lock_guard lock(jobsMutex_);
    if (!acceptingJobs_ || stopAsked()) return refused("the daemon is stopping");
    jobs_.push_back(job);
  }
  jobsChanged_.notify_all();
  return reply.get();
}

// ---- answered at once (any thread) ----------------------------------------------------------

Reply Conductor::answerStatus(const RequestArgs&) {
  std::lock_guard lock(publishedMutex_);
  return publishedStatus_;
}

Reply Conductor::answerStats(const RequestArgs&) {
  std::lock_guard lock(publishedMutex_);
  return publishedStats_;
}

Reply Conductor::answerShutdown(const RequestArgs&) {
  shutdown_ = true;
  cancel_ = true;
  jobsChanged_.notify_all();
  return ok({{"message", "stopping"}});
}

Reply Conductor::answerScenes(const RequestArgs&) {
  // The library's scripts by name, as `load` takes them (scene_argument.h: librarySceneScript).
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& entry :
       std::filesystem::directory_iterator(ScriptOptions::defaultSceneLibrary(), ec)) {
    const std::string stem = entry.path().stem().string();
    if (entry.path().extension() == ".lua" && !librarySceneScript(stem).empty())
      names.push_back(stem);
  }
  std::sort(names.begin(), names.end());
  return ok({{"scenes", names}, {"library", ScriptOptions::defaultSceneLibrary()}});
}

void Conductor::setPanel(std::string url, std::string problem) {
  std::lock_guard lock(publishedMutex_);
  panelUrl_ = std::move(url);
  panelProblem_ = std::move(problem);
}

Reply Conductor::answerPanel(const RequestArgs&) {
  std::lock_guard lock(publishedMutex_);
  if (panelUrl_.empty()) return refused("no control panel: " + panelProblem_);
  return ok({{"url", panelUrl_}});
}

Reply Conductor::answerCancel(const RequestArgs&) {
  // The conductor thread is inside the calibration. It stops at the next picture, stage or
  // solver iteration; the installed calibration stays.
  if (state_.snapshot().state != DaemonState::kCalibrating)
    return refused("nothing to cancel: the daemon is not calibrating");
  cancel_ = true;
  return ok({{"message", "cancelling the calibration; the installed one stays"}});
}

// ---- queued to the conductor thread ---------------------------------------------------------

Reply Conductor::answerCalibrate(const RequestArgs& args) {
  // In a cluster the other ranks take rank 0's steps (conductor_cluster_calibration.cpp).
  if (clustered() && !cluster_->isConductor()) return followCalibration();
  const CalibrationStepsDone stepsDone{this};  // however this ends
  std::optional<PhotometricMode> photometric;
  if (args.has("photometric"))
    photometric = parsePhotometricMode(args.string("photometric"), "photometric");
  const StageResult result = calibrate(args.module("module"), photometric);
  if (!result.done()) return refused(result.error);
  return ok({{"calibration", calibrationSource_},
             {"hash", hashHex(texturesHash_)},
             {"summary", result.summary},
             {"photometry", photometryJson()}});
}

Reply Conductor::answerRollback(const RequestArgs&) {
  if (clustered()) {
    if (!cluster_->isConductor()) return followCalibration();
    const CalibrationStepsDone stepsDone{this};
    try {
      installOnEveryRank(nullptr);
    } catch (const RanksSilent&) {
      throw;
    } catch (const std::exception& e) {
      return refused(e.what());
    }
    return ok({{"calibration", calibrationSource_},
               {"hash", hashHex(texturesHash_)},
               {"photometry", photometryJson()}});
  }
  // The previous version, geometry and photometry, is checked before anything changes.
  const CalibrationStore::Files before = store_.files();
  const StoredCalibration previous = store_.rollback(nominal_);
  const StageResult result = regenerate(previous.model);
  if (!result.done()) {
    store_.restore(before);  // not played, so not installed: the files as they were
    return refused(result.error);
  }
  calibration_ = previous.model;
  calibrationSource_ = store_.path() + " (rolled back)";
  applyPhotometry(previous.photometry, previous.photometrySource);
  photometryRefused_.clear();
  return ok({{"calibration", calibrationSource_},
             {"hash", hashHex(texturesHash_)},
             {"photometry", photometryJson()}});
}

Reply Conductor::answerLoad(const RequestArgs& args) {
  const StageResult result = loadScene(args.string("scene"), args.numberMap("parameters"));
  if (!result.done()) return refused(result.error);
  return ok({{"scene", sceneArgument_}});
}

Reply Conductor::answerPlay(const RequestArgs&) {
  if (!script_) return refused("no scene loaded: " + sceneError_);
  paused_ = false;
  overlay_.clear();
  nextFrameDue_ = Clock::now();
  state_.enter(DaemonState::kPlaying);
  return ok();
}

Reply Conductor::answerPause(const RequestArgs&) {
  if (!script_) return refused("no scene loaded");
  paused_ = true;
  state_.enter(DaemonState::kPaused);
  return ok();
}

Reply Conductor::answerSet(const RequestArgs& args) {
  if (!script_) return refused("no scene loaded");
  const std::string parameter = args.string("name");
  const double value = args.number("value");
  if (!script_->setParameter(parameter, value)) {
    sceneError_ = script_->lastError();
    return refused("the scene kept its previous state: " + sceneError_);
  }
  options_.config.scene.parameters[parameter] = value;
  return ok();
}

Reply Conductor::answerFrame(const RequestArgs& args) {
  const int m = *args.module("module");
  // From the rank that owns the module (every rank takes part; only rank 0 writes the file).
  const std::vector<std::shared_ptr<const hw::Image>> images = gatherImages({m});
  if (!cluster_->isConductor()) return ok();
  if (!images[static_cast<size_t>(m)]) {
    throw InputError({"", "module", 0},
                     fmt::format("no frame for module {}: it shows none yet", m));
  }
  std::string path = args.string("path");
  if (path.empty()) {
    const std::string folder =
        std::filesystem::absolute(options_.config.cacheDirPath() + "/frames").string();
    std::filesystem::create_directories(folder);  // the daemon's own folder
    path = moduleFrameStem(folder, m) + ".png";
  }
  const std::shared_ptr<const hw::Image> shown = images[static_cast<size_t>(m)];
  writeOutputFile(path, "path", [&](const std::string& file) { hw::writePng(*shown, file); });
  return ok({{"path", path}, {"module", m}});
}

Reply Conductor::answerView(const RequestArgs& args) {
  std::vector<int> every(nominal_.modules.size());
  for (size_t i = 0; i < every.size(); ++i) every[i] = static_cast<int>(i);
  const std::vector<std::shared_ptr<const hw::Image>> images = gatherImages(every);
  if (!cluster_->isConductor()) return ok();
  for (const auto& image : images) {
    if (!image) return refused("the modules show no frames yet");
  }
  const double x = args.number("x");
  ObserverViewOptions vo;
  vo.width = args.integer("width", vo.width);
  vo.height = args.integer("height", vo.height);
  vo.validate();
  std::string path = args.string("path");
  if (path.empty()) {
    const std::string folder =
        std::filesystem::absolute(options_.config.cacheDirPath() + "/views").string();
    std::filesystem::create_directories(folder);  // the daemon's own folder
    path = fmt::format("{}/view_x{:+.3f}.png", folder, x);
  }
  const Eigen::Vector3d viewer(x, calibration_.observer.y, calibration_.observer.z);
  // From what the modules show (8-bit), back in linear light: the view includes quantisation.
  // Through a photometric correction, as its model says the corrected module shows it.
  std::vector<Frame> shown;
  shown.reserve(images.size());
  for (size_t i = 0; i < images.size(); ++i) {
    const hw::Image& image = *images[i];
    const auto decode = [&](const ModuleEncoder& encoder) {
      const bool corrected =
          overlay_.empty() && image.width == encoder.width() && image.height == encoder.height();
      return corrected ? encoder.decode(image.pixels) : frameShownBy(image);
    };
    if (!photometry_) {
      shown.push_back(frameShownBy(image));
    } else if (clustered()) {
      // Another rank's module: its encoder is made here, from the same correction.
      shown.push_back(decode(ModuleEncoder(photometry_->modules[i], nominal_.modules[i].width,
                                           nominal_.modules[i].height)));
    } else {
      shown.push_back(decode(encoders_[i]));
    }
  }
  const Frame view = synthesizeObserverView(calibration_, shown, viewer, vo);
  writeOutputFile(path, "path", [&](const std::string& file) { writePng(view, file); });
  return ok({{"path", path}, {"x", x}});
}

Reply Conductor::answerReload(const RequestArgs&) {
  if (!options_.config.sourceFile.empty()) {
    try {
      reloadFromFile(options_.config.sourceFile);
    } catch (const std::exception& e) {
      spdlog::error("reloading the config failed (the old one stays): {}", e.what());
      throw;
    }
  }
  if (script_ && script_->reloadIfChanged() == ScriptedScene::Reload::kFailed) {
    sceneError_ = script_->lastError();
    return refused("scene reload failed, the previous version keeps playing: " + sceneError_);
  }
  return ok(
      {{"config", options_.config.sourceFile.empty() ? "built-in" : options_.config.sourceFile}});
}

Reply Conductor::answerIdentify(const RequestArgs& args) {
  if (nominal_.modules.empty()) return refused("no display");
  showOverlay("identify", args.module("module"));
  return ok({{"message", "`play` returns to the scene"}});
}

Reply Conductor::answerTestcard(const RequestArgs&) {
  if (nominal_.modules.empty()) return refused("no display");
  showOverlay("testcard", std::nullopt);
  return ok({{"message", "`play` returns to the scene"}});
}

}  // namespace parallax::daemon
