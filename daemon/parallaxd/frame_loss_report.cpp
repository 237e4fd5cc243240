#include "daemon/parallaxd/frame_loss_report.h"

#include <fmt/format.h>

namespace parallax::daemon {

FrameLossReport::FrameLossReport(Clock::duration period) : period_(period) {}

std::optional<std::string> FrameLossReport::take(const LoopStats& stats, Clock::time_point now) {
  if (!since_) {
    since_ = now;
    atStart_ = stats;
    return std::nullopt;
  }
  if (now - *since_ < period_) return std::nullopt;
  const uint64_t dropped = stats.droppedFrames - atStart_.droppedFrames;
  const uint64_t failed = stats.moduleFramesFailed - atStart_.moduleFramesFailed;
  const uint64_t renderFailures = stats.renderFailures - atStart_.renderFailures;
  const uint64_t shown = stats.displayFrames - atStart_.displayFrames;
  const double seconds = std::chrono::duration<double>(now - *since_).count();
  since_ = now;
  atStart_ = stats;
  if (dropped == 0 && failed == 0 && renderFailures == 0) return std::nullopt;
  // A long stage (a calibration) can hold the loop past the period: say how long it was.
  return fmt::format(
      "frames lost in the last {:.0f} s: {} dropped (the render fell behind the fps), {} module "
      "frames failed on the link, {} renders failed; {} frames rendered",
      seconds, dropped, failed, renderFailures, shown);
}

}  // namespace parallax::daemon
