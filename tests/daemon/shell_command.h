#pragma once
// Runs a command line through the shell for the process tests: its exit status (-1 when it did
// not exit normally) and everything it printed (stdout and stderr together).

#include <sys/wait.h>

#include <cstdio>
#include <string>
#include <utility>

namespace parallax::testing {

inline std::pair<int, std::string> runShellCommand(const std::string& command) {
  std::string out;
  FILE* p = ::popen((command + " 2>&1").c_str(), "r");
  if (p == nullptr) return {-1, "popen failed"};
  char buffer[4096];
  size_t n = 0;
  while ((n = std::fread(buffer, 1, sizeof buffer, p)) > 0) out.append(buffer, n);
  const int status = ::pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

}  // namespace parallax::testing
