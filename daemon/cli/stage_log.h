#pragma once
// For commands whose long steps cannot report their own progress (`simulate`'s checkerboard
// pictures and writing): one line on stderr as each step starts and how long it took, so no
// step looks hung — "simulate [2/3] 12 checkerboard pictures ... 5.2 s".
// Silent under --quiet.

#include <chrono>
#include <cstdio>
#include <string>

#include "daemon/cli/command_line.h"

namespace parallax::cli {

class StageLog {
 public:
  StageLog(std::string command, int stages) : command_(std::move(command)), stages_(stages) {}
  ~StageLog() { end(); }
  StageLog(const StageLog&) = delete;
  StageLog& operator=(const StageLog&) = delete;

  // Ends the step before it (with its time) and starts the next one.
  void begin(const std::string& what) {
    end();
    ++stage_;
    open_ = true;
    start_ = std::chrono::steady_clock::now();
    if (quiet()) return;
    std::fprintf(stderr, "%s [%d/%d] %s ...", command_.c_str(), stage_, stages_, what.c_str());
    std::fflush(stderr);
  }
  // A step shown otherwise (a progress bar of its own): counted, not printed.
  void skip() {
    end();
    ++stage_;
  }
  void end() {
    if (!open_) return;
    open_ = false;
    if (quiet()) return;
    const double s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    std::fprintf(stderr, " %.1f s\n", s);
  }

 private:
  std::string command_;
  int stages_;
  int stage_ = 0;
  bool open_ = false;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace parallax::cli
