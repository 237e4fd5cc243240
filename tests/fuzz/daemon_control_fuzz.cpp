// parallaxd's two untrusted inputs: the config file (TOML) and control-socket request lines.
// The first byte chooses which; neither may crash — bad input is an InputError or an error
// reply, never anything else.

#include <cstddef>
#include <cstdint>
#include <string>

#include "common/input_error.h"
#include "daemon/parallaxd/control_server.h"
#include "daemon/parallaxd/daemon_config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  if (data[0] & 1) {
    try {
      parallax::daemon::parseDaemonConfig(text, "fuzz.toml");
    } catch (const parallax::InputError&) {
    }
  } else {
    const std::string reply =
        parallax::daemon::ControlServer::replyTo(text, [](const nlohmann::json& r) {
          return nlohmann::json{{"ok", true}, {"echo", r}};
        });
    if (reply.empty() || reply.back() != '\n') __builtin_trap();
  }
  return 0;
}
