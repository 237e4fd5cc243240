#pragma once
// The timing helper of report.h (a template, so it lives in a header).

#include <algorithm>
#include <chrono>
#include <limits>

namespace parallax::report {

template <typename F>
double timeMs(F&& run, double budgetMs, int maxRuns) {
  double best = std::numeric_limits<double>::infinity(), spent = 0.0;
  // At least 3 runs unless one takes over a second: a single run on a shared machine can be
  // several times slower than the code.
  for (int i = 0; i < maxRuns && (i == 0 || spent < budgetMs || (i < 3 && best < 1000.0)); ++i) {
    const auto start = std::chrono::steady_clock::now();
    run();
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    best = std::min(best, ms);
    spent += ms;
  }
  return best;
}

}  // namespace parallax::report
