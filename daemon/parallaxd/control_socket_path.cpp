#include "daemon/parallaxd/control_socket_path.h"

#include <fmt/format.h>
#include <unistd.h>

#include <cstdlib>

namespace parallax::daemon {

std::string defaultControlSocketPath() {
  if (const char* runtime = std::getenv("XDG_RUNTIME_DIR"); runtime && *runtime) {
    return std::string(runtime) + "/parallax/parallaxd.sock";
  }
  return fmt::format("/tmp/parallax-{}/parallaxd.sock", ::getuid());
}

}  // namespace parallax::daemon
