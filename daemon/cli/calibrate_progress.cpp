#include "daemon/cli/calibrate_progress.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "daemon/cli/command_line.h"

namespace parallax::cli {
namespace {

// As the bars say it ("~12s left", "~3m05s left").
std::string secondsLeft(double seconds) {
  const auto left = static_cast<long>(std::lround(std::max(seconds, 1.0)));
  if (left >= 60) return fmt::format("~{}m{:02}s left", left / 60, left % 60);
  return fmt::format("~{}s left", left);
}

// "conical" of "conical: final solve"; empty for a step of no transfer (the gate).
std::string transferOf(const std::string& what) {
  const size_t colon = what.find(':');
  return colon == std::string::npos ? std::string() : what.substr(0, colon);
}

}  // namespace

std::string CalibrateProgress::next(const std::string& what) {
  end();
  ++stage_;
  return fmt::format("calibrate [{}/{}] {}", stage_, stages_, what);
}

void CalibrateProgress::plain(const std::string& what) {
  const std::string line = next(what);
  lineOpen_ = true;
  lineStart_ = Clock::now();
  iterations_ = 0;
  if (quiet()) return;
  std::fprintf(stderr, "%s ...", line.c_str());
  std::fflush(stderr);
}

void CalibrateProgress::end() {
  bar_.reset();  // its last line: 100% after finish(), else how far it got
  if (!lineOpen_) return;
  lineOpen_ = false;
  if (quiet()) return;
  const double s = std::chrono::duration<double>(Clock::now() - lineStart_).count();
  if (iterations_ > 0) {
    std::fprintf(stderr, " %.1f s, %d solver iteration%s\n", s, iterations_,
                 iterations_ == 1 ? "" : "s");
  } else {
    std::fprintf(stderr, " %.1f s\n", s);
  }
}

void CalibrateProgress::bar(const std::string& what, int done, int total) {
  if (!bar_) {
    bar_.emplace(next(what), total);
    barDone_ = 0;
  }
  if (done > barDone_) bar_->advance(done - barDone_);
  barDone_ = std::max(barDone_, done);
  if (done >= total) {
    bar_->finish();
    bar_.reset();
  }
}

daemon::PipelineProgress CalibrateProgress::capture() {
  daemon::PipelineProgress progress;
  progress.pictures = [this](int done, int total) {
    bar(fmt::format("capture: {} pictures", total), done, total);
  };
  return progress;
}

daemon::PipelineProgress CalibrateProgress::decode() {
  daemon::PipelineProgress progress;
  progress.decoded = [this](int done, int total) {
    bar(fmt::format("decode: {} picture sets", total), done, total);
  };
  return progress;
}

daemon::PipelineProgress CalibrateProgress::fit() {
  daemon::PipelineProgress progress;
  progress.fitStep = [this](const FitStep& step) { fitStep(step); };
  progress.iteration = [this](int) { ++iterations_; };
  return progress;
}

void CalibrateProgress::fitStep(const FitStep& step) {
  const Clock::time_point now = Clock::now();
  std::string what = step.what;
  if (step.index == 1) {
    const std::string line = next(fmt::format("fit, {} steps", step.total));
    fitStart_ = now;
    firstTransfer_ = transferOf(step.what);
    inSecond_ = false;
    if (!quiet()) std::fprintf(stderr, "%s\n", line.c_str());
  } else {
    end();
  }
  // The second transfer fits the same observations: about as long as the first took.
  const std::string transfer = transferOf(step.what);
  if (!inSecond_ && !transfer.empty() && transfer != firstTransfer_) {
    inSecond_ = true;
    secondStart_ = now;
  }
  if (inSecond_) {
    const double first = std::chrono::duration<double>(secondStart_ - fitStart_).count();
    const double left = first - std::chrono::duration<double>(now - secondStart_).count();
    what += left > 0.0 ? fmt::format(" ({}: the {} fit took {:.0f}s)", secondsLeft(left),
                                     firstTransfer_, first)
                       : fmt::format(" (longer than the {} fit took)", firstTransfer_);
  }
  lineOpen_ = true;
  lineStart_ = now;
  iterations_ = 0;
  if (quiet()) return;
  std::fprintf(stderr, "  fit [%d/%d] %s ...", step.index, step.total, what.c_str());
  std::fflush(stderr);
}

}  // namespace parallax::cli
