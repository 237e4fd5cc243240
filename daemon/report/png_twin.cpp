#include "daemon/report/png_twin.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <spawn.h>
#include <sys/wait.h>

#include <cerrno>
#include <cstring>
#include <vector>

extern char** environ;

namespace parallax::report {

std::string writePngTwin(const std::string& svg, const std::string& png) {
  std::vector<std::string> args = {"rsvg-convert", "--format", "png", "--output", png, svg};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  // Its diagnostics go to our stderr; nothing is read from stdin.
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  pid_t pid = 0;
  const int error = posix_spawnp(&pid, "rsvg-convert", &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (error != 0) {
    return error == ENOENT ? "rsvg-convert is not installed (Debian package librsvg2-bin)"
                           : fmt::format("cannot run rsvg-convert: {}", std::strerror(error));
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    return fmt::format("rsvg-convert failed on {}", svg);
  return "";
}

}  // namespace parallax::report
