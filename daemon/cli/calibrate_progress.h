#pragma once
// What `parallax calibrate` shows on stderr while it runs: its stages numbered and in order,
// each with a time left that does not lie.
//   calibrate [1/3] capture: 96 pictures   a bar, time left at the rate so far
//   calibrate [2/3] decode: 8 picture sets   a bar, the same (the sets cost alike)
//   calibrate [3/3] fit, 9 steps             a line a step with its time and solver iterations
// The fit's first transfer cannot say how long it will take (each solve runs until it
// converges); the second fits the same observations under the other transfer, so its steps
// say how much is left from the first's time. Steps with no count of their own (loading the
// pictures, the camera's checkerboard calibration) get a line with their time (StageLog).
// Silent under --quiet, as the bars are.

#include <chrono>
#include <optional>
#include <string>

#include "common/progress_bar.h"
#include "daemon/parallaxd/calibration_pipeline.h"

namespace parallax::cli {

class CalibrateProgress {
 public:
  explicit CalibrateProgress(int stages) : stages_(stages) {}
  ~CalibrateProgress() { end(); }
  CalibrateProgress(const CalibrateProgress&) = delete;
  CalibrateProgress& operator=(const CalibrateProgress&) = delete;

  // A stage without counts: its line, ended with its time when the next one starts.
  void plain(const std::string& what);
  // The pipeline's hooks for each counted stage; each starts its stage at its first report.
  daemon::PipelineProgress capture();
  daemon::PipelineProgress decode();
  daemon::PipelineProgress fit();
  // Ends the open stage (its time, or its bar at 100%).
  void end();

 private:
  using Clock = std::chrono::steady_clock;
  std::string next(const std::string& what);  // "calibrate [2/3] what"
  void bar(const std::string& what, int done, int total);
  void fitStep(const FitStep& step);

  int stages_;
  int stage_ = 0;
  std::optional<ProgressBar> bar_;
  int barDone_ = 0;        // what bar_ has counted (a count may be reported twice)
  bool lineOpen_ = false;  // a plain stage or a fit step waits for its time
  Clock::time_point lineStart_;
  int iterations_ = 0;  // of the open fit step's solve, if it has one
  // The fit: when it and its second transfer started, and the first transfer's name.
  Clock::time_point fitStart_, secondStart_;
  std::string firstTransfer_;
  bool inSecond_ = false;
};

}  // namespace parallax::cli
