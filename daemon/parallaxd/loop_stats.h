#pragma once
// What the render loop counts and times, for `stats`, `--explain`-style logs and the bench.

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

namespace parallax::daemon {

// Last, mean and worst of one stage's duration (ms).
struct StageTiming {
  double lastMs = 0.0, totalMs = 0.0, maxMs = 0.0;
  uint64_t count = 0;
  void add(double ms);
  double meanMs() const { return count ? totalMs / static_cast<double>(count) : 0.0; }
  nlohmann::json toJson() const;
};

struct LoopStats {
  uint64_t displayFrames = 0;          // display frames rendered (all modules)
  uint64_t moduleFramesSent = 0;       // module frames that went over the link and were shown
  uint64_t moduleFramesUnchanged = 0;  // not re-sent: the module already shows these bytes
  // Module frames (each rendered frame of each module once) the link failed to deliver; a frame
  // that fails again when it is re-sent is not counted twice.
  uint64_t moduleFramesFailed = 0;
  uint64_t failedResends = 0;  // re-sends of an already failed module frame that failed again
  uint64_t droppedFrames = 0;  // animation periods that passed without a frame
  uint64_t resendsAfterReconnect = 0;  // pushes of the current frames to a reconnected link
  uint64_t renderFailures = 0;         // frames not shown because rendering threw
  // Module frames presented without (the module had not acknowledged its frame by the deadline).
  uint64_t moduleFramesLate = 0;
  // latency: frame due → presented. present: every rank agreeing to present, then the Present.
  StageTiming render, encode, push, present, latency;
  nlohmann::json toJson() const;
  // One line, for the log (what `--explain` prints for `parallax render`).
  std::string summary() const;
};

}  // namespace parallax::daemon
