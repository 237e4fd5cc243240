#include "common/progress_bar.h"

#include <unistd.h>

#include <cstdio>

namespace parallax {

ProgressBar::ProgressBar(std::string label, std::int64_t total, bool enabled)
    : label_(std::move(label)),
      total_(total > 0 ? total : 1),
      enabled_(enabled),
      interactive_(isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()) {}

// Left without finish() (an error or an interruption unwound past it): the last line says how
// far it got, not 100%.
ProgressBar::~ProgressBar() { end(done_.load()); }

void ProgressBar::advance(std::int64_t steps) {
  const std::int64_t done = done_.fetch_add(steps) + steps;
  if (!enabled_) return;
  // Only one thread draws; the others never wait for the terminal.
  std::unique_lock lock(drawMutex_, std::try_to_lock);
  if (lock.owns_lock()) draw(done, false);
}

void ProgressBar::finish() { end(total_); }

void ProgressBar::end(std::int64_t done) {
  std::lock_guard lock(drawMutex_);
  if (finished_ || !enabled_) {
    finished_ = true;
    return;
  }
  finished_ = true;
  draw(done, true);
}

void ProgressBar::draw(std::int64_t done, bool final) {
  if (done > total_) done = total_;
  const double fraction = static_cast<double>(done) / static_cast<double>(total_);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  if (interactive_) {
    const int permille = static_cast<int>(fraction * 1000);
    if (permille == lastPermille_ && !final) return;
    lastPermille_ = permille;
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(fraction * kWidth);
    std::string bar(static_cast<size_t>(filled), '#');
    bar.resize(kWidth, '.');
    std::fprintf(stderr, "\r%s [%s] %5.1f%% %6.1fs%s", label_.c_str(), bar.c_str(),
                 100.0 * fraction, seconds, final ? "\n" : "");
  } else {
    const int decile = static_cast<int>(fraction * 10);
    if (decile == lastDecile_) return;  // a line per 10%, the last one included
    lastDecile_ = decile;
    std::fprintf(stderr, "%s: %3d%% (%.1fs)\n", label_.c_str(), decile * 10, seconds);
  }
  std::fflush(stderr);
}

}  // namespace parallax
