#pragma once
// The report's one timing rule: one untimed warm-up run, then the median of N timed runs, wall
// clock, on every core the process may use. A run may time parts of itself (the rasterizer's
// projection inside its frame); each part's figure is its median over the same runs as the
// whole. Since a part never exceeds its whole within a run (p_i ≤ w_i), the k-th smallest part
// never exceeds the k-th smallest whole, so the medians keep parts ≤ wholes in the table too
// (a best-of-N whole beside a last-run part did not: issue 25).

#include <algorithm>
#include <chrono>
#include <string>
#include <vector>

namespace parallax::report {

struct TimingRule {
  int warmups = 1;
  int runs = 5;

  std::string describe() const;  // "median of 5 runs after 1 warm-up, wall clock"
};

struct MedianTimes {
  double ms = 0.0;              // the whole run
  std::vector<double> partsMs;  // each part, median over the same runs
  int runs = 0;
};

double median(std::vector<double> values);

// `run(std::vector<double>& partsMs)` does the work once and adds what it measured of its parts
// (milliseconds, `parts` of them) into partsMs, which starts at zero every run.
template <typename F>
MedianTimes timeMedian(const TimingRule& rule, int parts, F&& run) {
  std::vector<double> scratch(static_cast<size_t>(parts), 0.0);
  for (int i = 0; i < rule.warmups; ++i) {
    std::fill(scratch.begin(), scratch.end(), 0.0);
    run(scratch);
  }
  std::vector<double> whole;
  std::vector<std::vector<double>> part(static_cast<size_t>(parts));
  for (int i = 0; i < std::max(1, rule.runs); ++i) {
    std::fill(scratch.begin(), scratch.end(), 0.0);
    const auto start = std::chrono::steady_clock::now();
    run(scratch);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    whole.push_back(ms);
    for (size_t p = 0; p < part.size(); ++p) part[p].push_back(scratch[p]);
  }
  MedianTimes out;
  out.ms = median(whole);
  out.runs = static_cast<int>(whole.size());
  for (const std::vector<double>& p : part) out.partsMs.push_back(median(p));
  return out;
}

// The same for a run with no parts: `run()`.
template <typename F>
double timeMedianMs(const TimingRule& rule, F&& run) {
  return timeMedian(rule, 0, [&](std::vector<double>&) { run(); }).ms;
}

}  // namespace parallax::report
