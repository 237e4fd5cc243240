#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <cmath>

#include "common/process_cpu_time.h"
#include "daemon/parallaxd/conductor.h"
#include "daemon/parallaxd/installer_patterns.h"
#include "daemon/parallaxd/module_renderer.h"
#include "daemon/parallaxd/render_while_sending.h"

// The conductor's render loop: frame pacing, rendering, pushing to the modules, keeping the
// link alive and knowing whether it works.

namespace parallax::daemon {

std::chrono::milliseconds Conductor::timeToNextTurn() const {
  using std::chrono::milliseconds;
  const auto idle = milliseconds(std::min(250, options_.keepAliveMs));
  if (state_.state() != DaemonState::kPlaying || !script_ || !script_->script().animated())
    return idle;
  const auto left = std::chrono::duration_cast<milliseconds>(nextFrameDue_ - Clock::now());
  return std::clamp(left, milliseconds(0), idle);
}

void Conductor::turn() {
  // Rank 0 decides (the script changed on disk, an animation period came, a frame is due) and
  // every rank plays the same turn.
  nlohmann::json plan = {{"step", "turn"}};
  if (state_.state() == DaemonState::kPlaying && script_ && overlay_.empty()) {
    const ScriptedScene::Reload reload = script_->reloadIfChanged();
    if (reload != ScriptedScene::Reload::kUnchanged) plan["reload"] = true;
    if (reload == ScriptedScene::Reload::kFailed) {
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
      plan["time"] = sceneTime_;
      due = true;
    }
    if (due && textures_.size() == owned_.size() &&
        (script_->version() != renderedSceneVersion_ ||
         texturesVersion_ != renderedTexturesVersion_)) {
      plan["render"] = true;
    }
  }
  const auto told = Clock::now();
  tellOthers(plan);
  const double tellMs = std::chrono::duration<double, std::milli>(Clock::now() - told).count();
  if (plan.contains("render") && clustered()) tellTiming_.add(tellMs);
  const double reportMs = playTurn(plan);
  if (!plan.contains("render") && clustered()) idleSyncTiming_.add(tellMs + reportMs);
  if (plan.contains("render") && clustered()) {
    double slowestWork = 0.0;
    for (const nlohmann::json& r : rankReports_)
      slowestWork = std::max(slowestWork, r.value("work_ms", 0.0));
    const double turnMs = std::chrono::duration<double, std::milli>(Clock::now() - told).count();
    overheadTiming_.add(std::max(0.0, turnMs - slowestWork));
  }
}

double Conductor::playTurn(const nlohmann::json& plan) {
  // A rank's work on a frame starts here: the other ranks time the animation here too.
  const auto workStarted = Clock::now();
  if (!link_ && Clock::now() - lastLinkTry_ > std::chrono::seconds(2)) connectLink(0);
  if (!cluster_->isConductor() && script_) {
    // Rank 0 has reloaded and timed its copy of the script already.
    if (plan.contains("reload") && script_->reload() == ScriptedScene::Reload::kFailed)
      sceneError_ = script_->lastError();
    if (plan.contains("time")) {
      sceneTime_ = plan["time"].get<double>();
      if (!script_->setTime(sceneTime_)) sceneError_ = script_->lastError();
    }
  }
  // A reloaded scene's footprint starts from its own bounds, not around the old scene's too.
  if (plan.contains("reload")) livePixels_.clear();
  if (plan.contains("render")) renderAndPush(workStarted);
  keepLinkAlive();
  if (needsPush_ && link_ && !currentImages_.empty()) {
    ++stats_.resendsAfterReconnect;
    push(currentImages_, 0);  // this rank's modules only, shown at once: the frame already played
  }
  // The reports also hold rank 0 until every rank has sent its Present: were rank 0 to start
  // the next frame's render at once, on cores the ranks share it would take them from the
  // ranks still to send theirs (the swap lock's skew p95 went from 2-3 to 10-16 ms on demo,
  // 3 ranks, when the reports came with the Present's agreement instead).
  const auto reported = Clock::now();
  gatherRankReports(options_.config.cluster.timeoutMs);
  const double reportMs =
      std::chrono::duration<double, std::milli>(Clock::now() - reported).count();
  if (plan.contains("render") && clustered()) reportTiming_.add(reportMs);
  return reportMs;
}

void Conductor::renderAndPush(Clock::time_point workStarted) {
  const auto started = Clock::now();
  DisplayFrame frame;
  SentAhead sent;
  std::string failure;
  try {
    if (!script_)
      throw std::runtime_error("no scene loaded on " + ownership_.describe(cluster_->rank()));
    if (textures_.size() != owned_.size())
      throw std::runtime_error("no ray textures on " + ownership_.describe(cluster_->rank()));
    // The frame cache pays only when frames follow frames: an animated scene.
    const Scene& scene = script_->scene();
    const bool useCache = options_.config.scene.frameCache && script_->script().animated();
    if (!useCache) frameCache_.clear();
    // The previous frame's scene hands its textures over (not read and filtered again).
    auto built = std::make_unique<PhysicalScene>(
        scene, calibration_.displayableBox,
        useCache ? &frameCache_.dynamicInstances(scene) : nullptr, lastScene_.get());
    PhysicalScene& physical = *built;
    const double buildMs =
        std::chrono::duration<double, std::milli>(Clock::now() - started).count();
    const auto prepareStart = Clock::now();
    const bool cached =
        useCache && frameCache_.prepare(physical, textures_, texturesVersion_, options_.render);
    // The pixels outside the scene's footprint are the same in every frame of an animated scene.
    const bool useFootprint = options_.config.scene.footprint && script_->script().animated();
    if (useFootprint) {
      livePixels_.prepare(physical, textures_, texturesVersion_, encoders_, encodersVersion_);
    } else {
      livePixels_.clear();
    }
    const double prepareMs =
        std::chrono::duration<double, std::milli>(Clock::now() - prepareStart).count();
    const double cpuStart = processCpuMs();
    const auto render = [&](const ModuleDone* done) {
      return renderDisplayFrame(physical, textures_, options_.render, encoders_,
                                cached ? &frameCache_ : nullptr,
                                useFootprint ? &livePixels_ : nullptr, done);
    };
    if (link_) {
      // Each module's image goes to the link as soon as it is done, numbered as pushAndPresent
      // will present it; the modules hold it until then (a frame that fails is not presented).
      const uint32_t displayFrame = presentedFrame_ + 1;
      frame = renderWhileSending([&](const ModuleDone& done) { return render(&done); },
                                 [&](size_t module, std::shared_ptr<const hw::Image> image) {
                                   link_->submit(static_cast<int>(module), std::move(image),
                                                 displayFrame);
                                 },
                                 &sent.error);
      sent.already = true;
    } else {
      frame = render(nullptr);
    }
    if (cached) frameCache_.count(frame.counters);
    // The cache's trial compares frames through it with full re-traces by their CPU time, which
    // hardly moves with what else the machine runs.
    if (useCache) frameCache_.reportFrameCost(processCpuMs() - cpuStart);
    if (script_->script().animated()) {
      lastScene_ = std::move(built);
    } else {
      lastScene_.reset();
    }
    // Building the scene (its BVH) and the cache are part of the frame that needed them.
    frame.renderMs += buildMs + prepareMs;
  } catch (const std::exception& e) {
    failure = e.what();
  }
  // Nothing of a failed frame reaches the modules: they keep the last complete one. In a
  // cluster that holds for the display: no rank pushes unless every rank rendered its part.
  const auto rendered = Clock::now();
  const double renderPartMs =
      std::chrono::duration<double, std::milli>(rendered - workStarted).count();
  const bool everyRankRendered = cluster_->all(failure.empty(), options_.config.cluster.timeoutMs);
  if (clustered())
    agreeTiming_.add(std::chrono::duration<double, std::milli>(Clock::now() - rendered).count());
  if (failure.empty() && !everyRankRendered) failure = "another rank's part of the frame failed";
  if (script_) renderedSceneVersion_ = script_->version();
  if (!failure.empty()) {
    ++stats_.renderFailures;
    sceneError_ = failure;
    spdlog::error("render failed, the modules keep the previous frame: {}", failure);
    return;
  }
  stats_.render.add(frame.renderMs);
  stats_.encode.add(frame.encodeMs);
  ++stats_.displayFrames;
  lastCounters_ = frame.counters;
  currentImages_ = std::move(frame.images);
  renderedTexturesVersion_ = texturesVersion_;
  pushAndPresent(currentImages_, sent);
  // This rank's own part of the frame: its render and its push (not the waits for the others).
  work_.add(renderPartMs + (link_ ? stats_.push.lastMs : 0.0));
  if (link_)
    stats_.latency.add(std::chrono::duration<double, std::milli>(Clock::now() - started).count());
}

void Conductor::pushAndPresent(const std::vector<std::shared_ptr<const hw::Image>>& images,
                               const SentAhead& sent) {
  const uint32_t n = ++presentedFrame_;
  if (link_) {
    push(images, n, sent);
  } else {
    needsPush_ = true;
  }
  // Every rank's modules hold the frame, or were given up on at the deadline: present it on
  // every rank at once. Every rank takes part, with or without a link, so that none waits alone.
  const auto agreeing = Clock::now();
  cluster_->all(true, options_.config.cluster.timeoutMs);
  if (link_ && !link_->present(n))
    noteLinkHealth(LinkHealth::kStalled,
                   "the Present of display frame " + std::to_string(n) + " could not be sent");
  stats_.present.add(std::chrono::duration<double, std::milli>(Clock::now() - agreeing).count());
}

void Conductor::push(const std::vector<std::shared_ptr<const hw::Image>>& images,
                     uint32_t displayFrame, const SentAhead& sent) {
  const auto started = Clock::now();
  needsPush_ = false;
  try {
    if (sent.error) std::rethrow_exception(sent.error);
    if (!sent.already) {
      for (size_t i = 0; i < images.size(); ++i)
        link_->submit(static_cast<int>(i), images[i], displayFrame);
    }
    if (displayFrame == 0) {
      link_->flush();
    } else {
      const std::vector<int> late = link_->awaitDisplayFrame(
          displayFrame,
          Clock::now() + std::chrono::milliseconds(options_.config.hardware.presentDeadlineMs));
      std::vector<int> lagging;
      for (int i : late) lagging.push_back(owned_[static_cast<size_t>(i)]);
      stats_.moduleFramesLate += lagging.size();
      if (lagging != lagging_ && !lagging.empty())
        spdlog::warn(
            "swap lock: module(s) {} not complete {} ms after the push of display frame "
            "{}: presented without them (they keep their frame one display frame, then "
            "go dark)",
            fmt::join(lagging, ", "), options_.config.hardware.presentDeadlineMs, displayFrame);
      if (lagging != lagging_ && lagging.empty()) spdlog::info("swap lock: every module in step");
      lagging_ = std::move(lagging);
    }
  } catch (const std::exception& e) {
    spdlog::error("push failed: {}", e.what());
    needsPush_ = true;
  }
  std::string failure;
  bool delivered = false;
  for (const hw::FrameOutcome& o : link_->takeOutcomes()) {
    if (o.status == hw::FrameStatus::kFailed && failure.empty())
      failure = fmt::format("module {}: {}", o.module, o.reason);
    if (o.status == hw::FrameStatus::kDelivered || o.status == hw::FrameStatus::kSkippedUnchanged)
      delivered = true;
    switch (o.status) {
      case hw::FrameStatus::kDelivered:
        ++stats_.moduleFramesSent;
        break;
      case hw::FrameStatus::kSkippedUnchanged:
        ++stats_.moduleFramesUnchanged;
        break;
      case hw::FrameStatus::kFailed:
        countFailedModuleFrame(o.module, images);
        needsPush_ = true;  // try again on the next turn (the link may be back by then)
        break;
      default:
        break;
    }
  }
  stats_.push.add(std::chrono::duration<double, std::milli>(Clock::now() - started).count());
  lastLinkActivity_ = Clock::now();
  if (!failure.empty()) {
    noteLinkHealth(LinkHealth::kStalled, "frames fail: " + failure);
  } else if (delivered) {
    noteLinkHealth(LinkHealth::kUp, "");
  }
  if (link_->sessions() != linkSessions_) {
    // The link reconnected during the push: LinkClient resent what was in flight, but a
    // module that restarted may have lost frames delivered before; send them all again.
    linkSessions_ = link_->sessions();
    needsPush_ = true;
  }
}

void Conductor::countFailedModuleFrame(
    int module, const std::vector<std::shared_ptr<const hw::Image>>& images) {
  // A failed frame is re-sent on every turn until the link takes it: count the frame once, and
  // each further failure of the same frame as a failed resend.
  if (module < 0 || static_cast<size_t>(module) >= images.size()) return;
  if (lastFailedFrame_.size() != images.size()) lastFailedFrame_.assign(images.size(), {});
  const FailedFrame frame{stats_.displayFrames, images[static_cast<size_t>(module)].get()};
  FailedFrame& last = lastFailedFrame_[static_cast<size_t>(module)];
  if (last == frame) {
    ++stats_.failedResends;
  } else {
    last = frame;
    ++stats_.moduleFramesFailed;
  }
}

void Conductor::keepLinkAlive() {
  if (!link_) return;
  if (Clock::now() - lastLinkActivity_ >= std::chrono::milliseconds(options_.keepAliveMs)) {
    // Reconnects by itself when the link dropped; false when no module answers even then.
    if (link_->ping()) {
      if (!needsPush_) noteLinkHealth(LinkHealth::kUp, "");
    } else {
      noteLinkHealth(LinkHealth::kDown, "the modules do not answer the keep-alive");
    }
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
  images.resize(owned_.size());
  for (size_t i = 0; i < owned_.size(); ++i) {
    const int index = owned_[i];
    const OpticalModule& m = nominal_.modules[static_cast<size_t>(index)];
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
  pushAndPresent(currentImages_);
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

void Conductor::noteLinkHealth(LinkHealth health, const std::string& problem) {
  // Transitions only: a link that stays stalled is counted in the minute's frame-loss line.
  if (health != linkHealth_) {
    if (health == LinkHealth::kUp) {
      spdlog::info("link: up (was {})", linkHealthName(linkHealth_));
    } else {
      spdlog::warn("link: {} (was {}): {}", linkHealthName(health), linkHealthName(linkHealth_),
                   problem);
    }
  }
  linkHealth_ = health;
  linkError_ = problem;
}

}  // namespace parallax::daemon
