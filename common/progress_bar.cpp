#include "common/progress_bar.h"

#include <fmt/format.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>

namespace parallax {
namespace {

std::atomic<bool> quiet{false};

}  // namespace

void ProgressBar::setQuiet(bool on) { quiet = on; }

std::string ProgressBar::timeLeft(double fraction, double seconds) {
  if (seconds < 1.0 || fraction <= 0.0 || fraction >= 1.0) return "";
  const auto left = static_cast<long>(std::lround(seconds * (1.0 - fraction) / fraction));
  if (left >= 60) return fmt::format("~{}m{:02}s left", left / 60, left % 60);
  return fmt::format("~{}s left", left);
}

ProgressBar::ProgressBar(std::string label, std::int64_t total, bool enabled)
    : label_(std::move(label)),
      total_(total > 0 ? total : 1),
      enabled_(enabled && !quiet.load()),
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
    const std::string left = final ? "" : timeLeft(fraction, seconds);
    // Padded: a shorter line must cover the longer one it redraws.
    std::fprintf(stderr, "\r%s [%s] %5.1f%% %6.1fs %-16s%s", label_.c_str(), bar.c_str(),
                 100.0 * fraction, seconds, left.c_str(), final ? "\n" : "");
  } else {
    const int decile = static_cast<int>(fraction * 10);
    if (decile == lastDecile_) return;  // a line per 10%, the last one included
    lastDecile_ = decile;
    const std::string left = timeLeft(fraction, seconds);
    std::fprintf(stderr, "%s: %3d%% (%.1fs%s%s)\n", label_.c_str(), decile * 10, seconds,
                 left.empty() ? "" : ", ", left.c_str());
  }
  std::fflush(stderr);
}

}  // namespace parallax
