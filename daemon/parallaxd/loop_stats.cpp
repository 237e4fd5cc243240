#include "daemon/parallaxd/loop_stats.h"

#include <fmt/format.h>

#include <algorithm>

namespace parallax::daemon {

void StageTiming::add(double ms) {
  lastMs = ms;
  totalMs += ms;
  maxMs = std::max(maxMs, ms);
  ++count;
}

nlohmann::json StageTiming::toJson() const {
  return {{"last_ms", lastMs}, {"mean_ms", meanMs()}, {"max_ms", maxMs}, {"count", count}};
}

nlohmann::json LoopStats::toJson() const {
  return {{"display_frames", displayFrames},
          {"module_frames_sent", moduleFramesSent},
          {"module_frames_unchanged_not_sent", moduleFramesUnchanged},
          {"module_frames_failed", moduleFramesFailed},
          {"failed_resends", failedResends},
          {"dropped_frames", droppedFrames},
          {"resends_after_reconnect", resendsAfterReconnect},
          {"render_failures", renderFailures},
          {"module_frames_late", moduleFramesLate},
          {"timings",
           {{"render", render.toJson()},
            {"encode", encode.toJson()},
            {"push", push.toJson()},
            {"present", present.toJson()},
            {"end_to_end", latency.toJson()}}}};
}

std::string LoopStats::summary() const {
  return fmt::format(
      "{} display frames; module frames: {} sent, {} unchanged (not re-sent), {} failed; {} "
      "dropped; "
      "mean ms: render {:.1f}, encode {:.1f}, push {:.1f}, end to end {:.1f}",
      displayFrames, moduleFramesSent, moduleFramesUnchanged, moduleFramesFailed, droppedFrames,
      render.meanMs(), encode.meanMs(), push.meanMs(), latency.meanMs());
}

}  // namespace parallax::daemon
