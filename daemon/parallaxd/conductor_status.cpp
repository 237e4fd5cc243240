#include <fmt/format.h>

#include "common/process_cpu_time.h"
#include "daemon/parallaxd/conductor.h"

// What `status` and `stats` answer: built on the conductor thread after every turn and
// request, published for the socket's threads.

namespace parallax::daemon {

std::string_view linkHealthName(LinkHealth health) {
  switch (health) {
    case LinkHealth::kUp:
      return "up";
    case LinkHealth::kStalled:
      return "stalled";
    case LinkHealth::kDown:
      return "down";
  }
  return "unknown";
}

nlohmann::json Conductor::statusJson() const {
  const StateSnapshot s = state_.snapshot();
  nlohmann::json j = {
      {"ok", true},
      {"state", daemonStateName(s.state)},
      {"stage", s.stage},
      {"seconds_in_state", s.secondsInState},
      {"display",
       {{"name", nominal_.name},
        {"modules", nominal_.modules.size()},
        {"screen_width", nominal_.screen.width},
        {"observer", {{"y", nominal_.observer.y}, {"z", nominal_.observer.z}}}}},
      {"calibration", {{"source", calibrationSource_}, {"hash", hashHex(texturesHash_)}}},
      {"photometry", photometryJson()},
      {"ray_textures", {{"from_cache", cacheStats_.loaded}, {"generated", cacheStats_.generated}}},
      {"link",
       {{"up", link_ != nullptr && linkHealth_ == LinkHealth::kUp},
        {"health", linkHealthName(link_ ? linkHealth_ : LinkHealth::kDown)},
        {"sessions", linkSessions_},
        {"lagging", laggingModules()},
        {"present_deadline_ms", options_.config.hardware.presentDeadlineMs},
        {"error", link_ || !linkError_.empty() ? linkError_ : "not connected"}}},
      {"fps", options_.config.scene.fps}};
  if (!options_.simulatorFolder.empty()) j["simulated_display"] = options_.simulatorFolder;
  if (clustered()) {
    j["cluster"] = clusterJson();
    // The display's link is up only when every rank's is: name the ranks whose link is not.
    nlohmann::json down = nlohmann::json::array();
    for (const nlohmann::json& r : rankReports_) {
      const std::string health = r.at("link").at("health").get<std::string>();
      if (health == linkHealthName(LinkHealth::kUp)) continue;
      down.push_back(fmt::format("{}: link {} ({})", ownership_.describe(r.at("rank").get<int>()),
                                 health, r.at("link").value("error", std::string())));
    }
    if (!down.empty()) j["link"]["up"] = false;
    j["link"]["ranks_down"] = down;
  }
  if (!s.lastError.empty()) j["last_error"] = {{"stage", s.lastErrorStage}, {"error", s.lastError}};
  if (script_) {
    j["scene"] = {{"name", sceneArgument_},
                  {"animated", script_->script().animated()},
                  {"time", sceneTime_},
                  {"reloads", script_->reloads()},
                  {"failed_reloads", script_->failedReloads()}};
    nlohmann::json params = nlohmann::json::object(), ranges = nlohmann::json::object();
    for (const ScriptParameter& p : script_->script().parameters()) {
      params[p.name] = p.value;
      // What px.param declared: the panel's sliders are made from it.
      ranges[p.name] = {{"min", p.min},
                        {"max", p.max},
                        {"default", p.defaultValue},
                        {"description", p.description}};
    }
    j["scene"]["parameters"] = params;
    j["scene"]["parameter_ranges"] = ranges;
  }
  if (!sceneError_.empty()) j["scene_error"] = sceneError_;
  if (!overlay_.empty()) j["showing"] = overlay_;
  return j;
}

nlohmann::json Conductor::statsJson() const {
  nlohmann::json j = stats_.toJson();
  j["ok"] = true;
  j["summary"] = stats_.summary();
  j["cpu_ms"] = processCpuMs();  // this process (rank 0): CPU a frame for `parallax bench`
  j["render_counters"] = lastCounters_.lines();
  const FrameCacheStats& cache = frameCache_.stats();
  j["frame_cache"] = {{"enabled", options_.config.scene.frameCache},
                      {"builds", cache.builds},
                      {"last_build_ms", cache.lastBuildMs},
                      {"build_ms", cache.buildMs},
                      {"frames_cached", cache.framesCached},
                      {"frames_bypassed", cache.framesBypassed},
                      {"last_rebuild", cache.lastRebuild},
                      {"payoff", cache.payoff},
                      {"declined", cache.declined},
                      {"frames_measured", cache.framesMeasured},
                      {"bytes_freed", cache.bytesFreed},
                      {"bytes", cache.bytes},
                      {"pixels", cache.pixels},
                      {"bytes_per_pixel", cache.bytesPerPixel()},
                      {"static_objects", cache.staticInstances},
                      {"dynamic_objects", cache.dynamicInstances},
                      {"static_lights", cache.cachedLights},
                      {"pixels_reused", cache.saved.pixelsReused},
                      {"shadow_rays_not_traced", cache.saved.shadowAnswered},
                      {"shadow_rays_dynamic_only", cache.saved.shadowDynamicOnly},
                      {"shadow_rays_past_dynamic_bounds", cache.saved.shadowPassedDynamic},
                      {"lines", cache.lines()}};
  const LivePixelsStats live = livePixels_.stats();
  j["live_pixels"] = {{"enabled", options_.config.scene.footprint},
                      {"builds", live.builds},
                      {"last_build_ms", live.lastBuildMs},
                      {"live_pixels", live.livePixels},
                      {"pixels", live.pixels},
                      {"backdrop_bytes", live.backdropBytes},
                      {"recycled_images", live.recycledImages},
                      {"new_images", live.newImages},
                      {"line", live.line()}};
  if (link_) {
    const hw::LinkStats& l = link_->stats();
    j["link"] = {{"submitted", l.submitted},
                 {"delivered", l.delivered},
                 {"skipped_unchanged", l.skipped},
                 {"failed", l.failed},
                 {"retries", l.retries},
                 {"reconnects", l.reconnects},
                 {"hangs", l.hangs},
                 {"bytes_sent", l.payloadBytesSent},
                 {"patches", l.patches},
                 {"patches_refused", l.patchesRefused},
                 {"patch_bytes_saved", l.patchBytesSaved},
                 {"sessions", link_->sessions()}};
  }
  return j;
}

nlohmann::json Conductor::photometryJson() const {
  if (!photometry_) {
    nlohmann::json none = "none";
    if (!photometryRefused_.empty()) none = {{"state", "none"}, {"refused", photometryRefused_}};
    return none;
  }
  const PhotometricSummary& s = photometry_->summary;
  nlohmann::json modules = nlohmann::json::array();
  for (size_t i = 0; i < s.modules.size(); ++i) {
    const ModulePhotometricSummary& m = s.modules[i];
    nlohmann::json j = {{"module", i},
                        {"scale", m.scale},
                        {"gain_max", m.gainMax},
                        {"delta_e_mean", m.deltaEMean},
                        {"delta_e_worst", m.deltaEWorst}};
    if (m.excluded) j["excluded"] = m.reason;
    modules.push_back(std::move(j));
  }
  return {{"source", photometrySource_},
          {"delta_e_mean", s.deltaEMean},
          {"delta_e_worst", s.deltaEWorst},
          {"non_uniformity", s.nonUniformity},
          {"modules", modules}};
}

void Conductor::publish() {
  nlohmann::json status = statusJson(), stats = statsJson();
  std::lock_guard lock(publishedMutex_);
  publishedStatus_ = std::move(status);
  publishedStats_ = std::move(stats);
}

}  // namespace parallax::daemon
