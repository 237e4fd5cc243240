#include "daemon/report/report_timing.h"

#include <fmt/format.h>

namespace parallax::report {

std::string TimingRule::describe() const {
  return fmt::format(
      "median of {} runs after {} warm-up run{}, wall clock, on every core the "
      "process may use",
      runs, warmups, warmups == 1 ? "" : "s");
}

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  // Even counts: the mean of the two middle values (still order-preserving: see report_timing.h).
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

}  // namespace parallax::report
