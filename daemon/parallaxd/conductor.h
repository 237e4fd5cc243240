#pragma once
// The conductor: owns what the display shows — the calibration, its ray textures, the scene,
// the frames on the modules, the link — and runs the stages of the state machine
// (daemon_state.h) and the render loop on one thread, the only one that touches the link
// (LinkClient is single-threaded). Requests from the control socket arrive from other threads
// and are queued to that thread between frames; `status` and `stats` are answered at once
// from a snapshot the loop publishes, so they work even while a long stage runs.
//
// It has no geometry, shading or protocol of its own: it calls calibration/, tracer/,
// scripts/ and hw/.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calibration/display/display_model.h"
#include "calibration/display/ray_textures.h"
#include "daemon/parallaxd/calibration_pipeline.h"
#include "daemon/parallaxd/calibration_store.h"
#include "daemon/parallaxd/cluster.h"
#include "daemon/parallaxd/control_request.h"
#include "daemon/parallaxd/daemon_config.h"
#include "daemon/parallaxd/daemon_state.h"
#include "daemon/parallaxd/frame_loss_report.h"
#include "daemon/parallaxd/live_pixels.h"
#include "daemon/parallaxd/loop_stats.h"
#include "daemon/parallaxd/module_ownership.h"
#include "daemon/parallaxd/ray_texture_cache.h"
#include "hw/link/image.h"
#include "hw/link/link_client.h"
#include "scripts/scripted_scene.h"
#include "tracer/frame.h"
#include "tracer/frame_cache.h"
#include "tracer/module_encoder.h"
#include "tracer/physical_scene.h"
#include "tracer/whitted_integrator.h"

namespace parallax::daemon {

struct ConductorOptions {
  DaemonConfig config;
  std::string linkSpec;  // "simhw:/path" or "usb:VID:PID[:SERIALS]"
  hw::LinkOptions link;
  RenderOptions render;
  // The camera metadata of a simulator parallaxd started itself: used when the config names no
  // camera (calibration.camera), also after a reload of a config that does not name one.
  std::string simulatorCamera;
  // That simulator shows a photometric truth: `[calibration] photometric = "auto"` calibrates
  // the modules' colours too.
  bool simulatorPhotometric = false;
  // Where that simulator's truth files are (simhw_child.h); `status` names it.
  std::string simulatorFolder;
  // The ranks driving the display together (cluster.h) and which modules this one renders and
  // pushes (its link reaches exactly those). Null / unset: one rank with every module.
  Cluster* cluster = nullptr;
  std::optional<ModuleOwnership> ownership;
  int connectTimeoutMs = 10000;  // at start (a simulator we started may take a moment)
  int keepAliveMs = 1000;        // idle link probe: how soon a reconnect is noticed
  // Called from the conductor thread: once when the first stage sequence has finished (with
  // or without error: the daemon is serving), and on every loop turn (the watchdog).
  std::function<void()> onReady;
  std::function<void()> onHeartbeat;
  // Called from the conductor thread around a reload of the config file (SIGHUP or `reload`):
  // onReloading before it is read, onReloaded once it is applied in place or refused (not when
  // it builds the pipeline again: the next pipeline's onReady follows).
  std::function<void()> onReloading;
  std::function<void()> onReloaded;
};

// What `status` says about the link: kStalled when it is connected but frames fail (not
// acknowledged, rejected), kDown when no module answers or there is no connection.
enum class LinkHealth { kUp, kStalled, kDown };
std::string_view linkHealthName(LinkHealth health);

// How a frame's images reached the link before Conductor::push: not at all, or as they were
// rendered (renderWhileSending), with what stopped that if something did.
struct SentAhead {
  bool already = false;
  std::exception_ptr error;
};

class Conductor {
 public:
  explicit Conductor(ConductorOptions options);
  ~Conductor();

  // The conductor thread: start-up stages, then the loop until `stop` or a `shutdown`
  // request; finishes the frames in flight before it returns.
  void run(const std::atomic<bool>& stop);

  // Any thread: one request (a JSON object with "request"), its reply ({"ok": ...}).
  nlohmann::json handle(const nlohmann::json& request);

  // Any thread (SIGHUP): reads the config file on the conductor thread; a file that does not
  // load is reported in `status` (last_error) and changes nothing. Then, as reloadConfig.
  void reloadConfigFrom(std::string path);
  // Any thread: applies what can change while running (scene, parameters, fps,
  // camera, auto-calibrate, log level). A changed display, hardware, socket, cache or
  // calibration file needs the pipeline built again: run() then returns with restartWith()
  // set, once the new config's display and hardware have been checked (a config that fails
  // that check changes nothing: the old one plays on).
  void reloadConfig(DaemonConfig config);

  bool shutdownRequested() const { return shutdown_.load(); }
  // Any thread: what the `panel` request answers — the control panel's URL with its token, or
  // (url empty) why there is no panel.
  void setPanel(std::string url, std::string problem);
  // After run(): the config to build the daemon again from, when a reload asked for it.
  const std::optional<DaemonConfig>& restartWith() const { return restartWith_; }
  StateSnapshot state() const { return state_.snapshot(); }
  // After run(): why the cluster's job must end (a rank died or hangs), naming the rank and its
  // modules; empty when it ended normally.
  const std::string& clusterFailure() const { return clusterFailure_; }

  // True when the conductor has a handler for the request of this name. Every request of the
  // table has one (checked when a conductor is made: InternalError otherwise).
  static bool handles(std::string_view request);
  static void checkEveryRequestHasAHandler();

 private:
  using Handler = nlohmann::json (Conductor::*)(const RequestArgs&);
  static const std::map<std::string_view, Handler>& handlers();
  struct Job {
    Handler handler;
    RequestArgs args;
    nlohmann::json request;  // as received: the other ranks of a cluster run it too
    std::promise<nlohmann::json> reply;
  };
  using Clock = std::chrono::steady_clock;
  // The stages a failure is recorded under (status: last_error.stage) and cleared by a success.
  static constexpr const char* kConnecting = "connecting";
  static constexpr const char* kCalibrating = "calibrating";
  static constexpr const char* kRegenerating = "regenerating the ray textures";
  static constexpr const char* kLoadingScene = "loading the scene";
  static constexpr const char* kReloadingConfig = "reloading the config (the old one stays)";
  // How long rank 0 waits for every rank to start (ray textures of its modules, the scene).
  static constexpr int kStartUpTimeoutMs = 15 * 60 * 1000;

  // What a stage ended with: the caller replies from this, not from side effects.
  struct StageResult {
    enum class Outcome { kDone, kCancelled, kFailed } outcome = Outcome::kDone;
    std::string error;    // kFailed: why (also in status as last_error)
    std::string summary;  // calibrate: the fit's summary
    bool done() const { return outcome == Outcome::kDone; }
  };

  // Stages (conductor thread; conductor.cpp, conductor_calibration.cpp).
  void startUp();
  bool connectLink(int timeoutMs);
  StageResult calibrate(std::optional<int> onlyModule,
                        std::optional<PhotometricMode> photometric = std::nullopt);
  // Makes `photometry` (or none) the correction every frame is encoded with; throws
  // InputError (the file, the field) for one that does not fit the display, changing nothing.
  void applyPhotometry(const std::optional<DisplayColourCorrection>& photometry,
                       const std::string& source);
  StageResult regenerate(const DisplayModel& model);
  StageResult loadScene(const std::string& script, const std::map<std::string, double>& parameters);
  // Where a stage returns to: what the modules show (playing or paused), `starting` during
  // start-up, else `error` (nothing to show; last_error says why).
  DaemonState restingState() const;
  bool stopAsked() const;  // SIGTERM/SIGINT (run's flag) or a `shutdown` request
  CalibrationSettings calibrationSettings() const;
  nlohmann::json photometryJson() const;  // status
  PipelineProgress calibrationProgress();

  // Render loop (conductor_render_loop.cpp).
  std::chrono::milliseconds timeToNextTurn() const;
  void turn();
  // What rank 0 decided in a turn (the script changed on disk, the animation's time, a frame to
  // render): every rank plays the same turn.
  // Returns the ms the ranks' reports took.
  double playTurn(const nlohmann::json& plan);
  // `workStarted`: when this rank began the turn (its share of the frame's time, work_).
  void renderAndPush(Clock::time_point workStarted);
  // Sends this rank's frames: for display frame `displayFrame` (held by the modules until it is
  // presented; waits for their acknowledgements until the deadline), or with 0 shown at once
  // (restoring a reconnected link's modules).
  void push(const std::vector<std::shared_ptr<const hw::Image>>& images, uint32_t displayFrame,
            const SentAhead& sent = {});
  // The swap lock: every rank pushes its part of the next display frame, they agree, and every
  // rank presents it on its link. Called on every rank for the same frames.
  void pushAndPresent(const std::vector<std::shared_ptr<const hw::Image>>& images,
                      const SentAhead& sent = {});
  // The display's modules that missed the last display frame's deadline, on every rank.
  std::vector<int> laggingModules() const;
  void countFailedModuleFrame(int module,
                              const std::vector<std::shared_ptr<const hw::Image>>& images);
  void keepLinkAlive();
  void showOverlay(const std::string& kind, std::optional<int> module);
  void finishInFlight();
  void noteLinkHealth(LinkHealth health, const std::string& problem);

  // The cluster (conductor_cluster.cpp). Rank 0 runs the loop and tells every other rank, step by
  // step, what to do (a request, a turn of the loop, a config reload, the stop); they follow()
  // and answer; every rank runs the same code on the same inputs, for its own modules.
  bool clustered() const { return cluster_->size() > 1; }
  void follow();
  // Rank 0: `calibrate` across the ranks, as if asked (`[calibration] auto` at start).
  void calibrateCluster();
  void tellOthers(const nlohmann::json& step);
  // Rank 0: every rank's reply to a request, merged: a rank that refused is named in the error.
  nlohmann::json agreeOnReply(nlohmann::json reply);
  // Every rank's state after a turn (link health, calibration, timings), for `status`.
  void gatherRankReports(int timeoutMs);
  nlohmann::json rankReport() const;
  // Rank 0: the images of `modules` from the ranks that own them, by module index (null where
  // the owner shows nothing yet); the other ranks send theirs and get an empty vector.
  std::vector<std::shared_ptr<const hw::Image>> gatherImages(const std::vector<int>& modules);
  void endJob(const RanksSilent& e);

  // `calibrate` and `rollback` across the ranks (conductor_cluster_calibration.cpp). Rank 0:
  // runs `op` on every rank (itself too) and returns their answers, throwing one line naming the
  // first rank that failed; "done" sends the others back to following.
  std::vector<nlohmann::json> calibrationStep(const nlohmann::json& op,
                                              const std::string& payload = {}, int timeoutMs = 0);
  void finishCalibrationSteps();
  // Rank 0: sends "done" when the request ends, however it ends.
  struct CalibrationStepsDone {
    Conductor* conductor;
    ~CalibrationStepsDone() { conductor->finishCalibrationSteps(); }
  };
  // The other ranks: the steps rank 0 sends, until "done"; the request's reply.
  nlohmann::json followCalibration();
  nlohmann::json takeCalibrationStep(const nlohmann::json& op, const std::string& payload);
  nlohmann::json takeFilesStep(const nlohmann::json& op);
  // Rank 0: makes `model` (null: each rank's previous calibration, the same everywhere) the
  // calibration every rank plays, or leaves every rank on the one it had, and throws why.
  // Returns its content hash.
  std::string installOnEveryRank(const DisplayModel* model);
  // A calibration being installed on this rank, until it is committed or undone.
  struct PendingCalibration {
    DisplayModel model;
    std::optional<StoredCalibration> stored;  // what the files step left installed
    // The store's files before this rank wrote them (undo: exactly these again, .previous too).
    std::optional<CalibrationStore::Files> filesBefore;
    bool texturesMade = false;
    std::vector<RayTextures> oldTextures;
    uint64_t oldTexturesHash = 0;
  };
  std::optional<PendingCalibration> pending_;
  void stopOthers();
  nlohmann::json clusterJson() const;  // status

  // Requests (conductor_requests.cpp): one handler each, named in the request table.
  nlohmann::json answerStatus(const RequestArgs&);
  nlohmann::json answerStats(const RequestArgs&);
  nlohmann::json answerShutdown(const RequestArgs&);
  nlohmann::json answerCancel(const RequestArgs&);
  nlohmann::json answerCalibrate(const RequestArgs& args);
  nlohmann::json answerRollback(const RequestArgs&);
  nlohmann::json answerLoad(const RequestArgs& args);
  nlohmann::json answerPlay(const RequestArgs&);
  nlohmann::json answerPause(const RequestArgs&);
  nlohmann::json answerSet(const RequestArgs& args);
  nlohmann::json answerFrame(const RequestArgs& args);
  nlohmann::json answerView(const RequestArgs& args);
  nlohmann::json answerReload(const RequestArgs&);
  nlohmann::json answerIdentify(const RequestArgs& args);
  nlohmann::json answerTestcard(const RequestArgs&);
  nlohmann::json answerScenes(const RequestArgs&);
  nlohmann::json answerPanel(const RequestArgs&);

  // Status (conductor_status.cpp): built on the conductor thread, published for any thread.
  nlohmann::json statusJson() const;
  nlohmann::json statsJson() const;
  void publish();

  void drainJobs(Clock::time_point until);
  // Reads and applies the config file between onReloading and onReloaded; throws when it
  // does not load (the old config stays).
  void reloadFromFile(const std::string& path);
  void applyConfig(const DaemonConfig& config);
  DaemonState showingState() const;  // playing or paused, whichever we were in

  ConductorOptions options_;
  std::unique_ptr<Cluster> singleProcess_;  // when options_.cluster is null
  Cluster* cluster_ = nullptr;
  StateMachine state_;
  DisplayModel nominal_;
  ModuleOwnership ownership_;
  // This rank's modules: its local module i (textures_, encoders_, currentImages_, the link's
  // module i) is the display's module owned_[i].
  std::vector<int> owned_;
  std::vector<nlohmann::json> rankReports_;  // rank 0: the last report of every rank
  // The cluster's exchanges, per display frame: rank 0 telling the turn, the verdict on the
  // frame (waits for the slowest rank's render too), the reports (after every rank's Present).
  StageTiming tellTiming_, agreeTiming_, reportTiming_;
  // Per display frame, what the cluster adds to it: rank 0's turn (from telling it to the last
  // report) less the slowest rank's own work (work_ of every rank's report). The exchanges and
  // the waits to be scheduled alone, whatever the scene costs to render.
  StageTiming overheadTiming_;
  // This rank's own part of a display frame: building the scene, rendering, pushing.
  StageTiming work_;
  // Tell + report on turns without a frame (every rank idle): the messaging alone.
  StageTiming idleSyncTiming_;
  std::string clusterFailure_;
  DisplayModel calibration_;  // the installed calibration, or the nominal when there is none
  std::string calibrationSource_;
  CalibrationStore store_;
  // The installed photometric correction and its encoders (one a module; empty: plain sRGB).
  std::optional<DisplayColourCorrection> photometry_;
  std::vector<ModuleEncoder> encoders_;  // this rank's modules (as textures_)
  uint64_t encodersVersion_ = 0;         // counts the changes of encoders_
  std::string photometrySource_;
  std::string photometryRefused_;  // why a photometry file beside the calibration is not used
  RayTextureCache cache_;
  RayTextureCacheStats cacheStats_;
  std::vector<RayTextures> textures_;  // this rank's modules, in owned_'s order
  uint64_t texturesVersion_ = 0;
  uint64_t texturesHash_ = 0;

  std::unique_ptr<ScriptedScene> script_;
  std::string sceneArgument_;
  std::string sceneError_;  // the last failed reload/load/update, kept for `status`
  uint64_t renderedSceneVersion_ = 0, renderedTexturesVersion_ = 0;
  double sceneTime_ = 0.0;
  Clock::time_point nextFrameDue_;
  bool paused_ = false;
  std::string overlay_;  // "", "identify", "testcard"

  std::unique_ptr<hw::LinkClient> link_;
  uint64_t linkSessions_ = 0;
  Clock::time_point lastLinkTry_, lastLinkActivity_;
  LinkHealth linkHealth_ = LinkHealth::kDown;
  std::string linkError_;  // empty while the link is up; else why it is not (status)
  // What this rank's modules show (8-bit sRGB); views decode it. No float copy is kept (680 MB on
  // `default`).
  std::vector<std::shared_ptr<const hw::Image>> currentImages_;
  // Per module, the last frame the link failed to deliver (render count and image), so a frame
  // re-sent until it gets through is counted as failed once.
  struct FailedFrame {
    uint64_t displayFrame = 0;
    const hw::Image* image = nullptr;
    bool operator==(const FailedFrame&) const = default;
  };
  std::vector<FailedFrame> lastFailedFrame_;
  bool needsPush_ = false;
  // The swap lock's display frame number: the same on every rank (they push the same frames).
  uint32_t presentedFrame_ = 0;
  // The display's modules that missed the last display frame's deadline (status `lagging`).
  std::vector<int> lagging_;

  LoopStats stats_;
  FrameLossReport lossReport_;
  RenderCounters lastCounters_;
  // Animated scenes: the static geometry's primary hits and shadows, kept between frames.
  FrameCache frameCache_;
  // Animated scenes: which pixels can show the scene, and the bytes of the rest.
  LivePixels livePixels_;
  // An animated scene's previous frame: the next one takes its textures over.
  std::unique_ptr<PhysicalScene> lastScene_;

  std::mutex jobsMutex_;
  std::condition_variable jobsChanged_;
  std::deque<std::shared_ptr<Job>> jobs_;
  bool acceptingJobs_ = true;  // false once run() has ended
  std::atomic<bool> shutdown_{false};
  std::optional<DaemonConfig> restartWith_;
  std::atomic<bool> cancel_{false};  // set by `cancel` and `shutdown`: the calibration stops
  const std::atomic<bool>* stop_ = nullptr;  // run()'s flag (signals): stops every stage too
  bool startingUp_ = true;
  // Rank 0 of a cluster without a calibration, configured to calibrate at start: it does once
  // every rank follows it (calibrateCluster()).
  bool calibrateClusterAtStart_ = false;

  mutable std::mutex publishedMutex_;
  nlohmann::json publishedStatus_, publishedStats_;
  std::string panelUrl_, panelProblem_ = "the control panel is starting";  // publishedMutex_
  std::optional<DaemonConfig> pendingConfig_;                              // guarded by jobsMutex_
  std::optional<std::string> pendingConfigPath_;                           // guarded by jobsMutex_
};

}  // namespace parallax::daemon
