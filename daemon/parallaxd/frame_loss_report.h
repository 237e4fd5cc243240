#pragma once
// What the display lost, for the operator's log: at most one line a period (a minute) saying how
// many animation frames were dropped, module frames failed on the link and renders failed in
// it — never a line per frame, and nothing for a period that lost nothing.

#include <chrono>
#include <optional>
#include <string>

#include "daemon/parallaxd/loop_stats.h"

namespace parallax::daemon {

class FrameLossReport {
 public:
  using Clock = std::chrono::steady_clock;
  explicit FrameLossReport(Clock::duration period = std::chrono::minutes(1));

  // Called every loop turn with the running totals. Once a period has passed since the last
  // report: the line for what was lost since then (nullopt when nothing was), and a new period
  // starts. Before that: nullopt.
  std::optional<std::string> take(const LoopStats& stats, Clock::time_point now);

 private:
  Clock::duration period_;
  std::optional<Clock::time_point> since_;
  LoopStats atStart_;
};

}  // namespace parallax::daemon
