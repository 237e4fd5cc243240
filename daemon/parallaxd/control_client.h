#pragma once
// The client side of parallaxd's control socket: one JSON request line out, the reply line back.
// `parallax ctl`, `parallax bench daemon` and the daemon's process tests all talk through it.

#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>

namespace parallax::daemon {

// Nothing listens at the socket path (the daemon is not running yet, or has stopped).
class ControlUnreachable : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Sends `line` (a newline is added) and returns the reply's first line. Throws
// ControlUnreachable when nothing listens, std::runtime_error when the daemon closes the
// connection or does not answer within the timeout or when the socket or its folder belongs to
// another user (checkSocketToConnect), InputError for a path too long.
std::string exchangeControlLine(const std::string& socketPath, const std::string& line,
                                double timeoutSeconds);

// The request as JSON, the reply parsed (a discarded value when the reply is not JSON).
nlohmann::json askDaemon(const std::string& socketPath, const nlohmann::json& request,
                         double timeoutSeconds = 30.0);

// For callers that poll while the daemon starts or stops: nothing when it cannot be reached
// or does not answer, instead of an exception.
std::optional<nlohmann::json> tryAskDaemon(const std::string& socketPath,
                                           const nlohmann::json& request,
                                           double timeoutSeconds = 30.0);

}  // namespace parallax::daemon
