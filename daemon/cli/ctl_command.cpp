// parallax ctl [--socket PATH] REQUEST [ARGS]
// The control client of parallaxd: turns the words into one JSON request line, sends it over
// the daemon's Unix socket and prints the reply (exit 1 when the reply says ok: false).
// Without --socket it finds the daemon that `parallaxd` with no config started
// ($XDG_RUNTIME_DIR/parallax/parallaxd.sock, else /tmp/parallax-$UID/parallaxd.sock).
//
//   parallax ctl status | stats | play | pause | reload | shutdown | testcard | rollback
//   parallax ctl load cornell            parallax ctl set radius=0.2   (or: set radius 0.2)
//   parallax ctl frame 3 [--path f.png]  parallax ctl view 0.5 [--path v.png]
//   parallax ctl identify [3]            parallax ctl calibrate [--module 3]
//   parallax ctl --json '{"request": "status"}'

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <iostream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "common/input_error.h"
#include "daemon/cli/commands.h"
#include "daemon/parallaxd/daemon_config.h"

namespace parallax::cli {
namespace {

struct CtlArgs {
  std::string socket;
  std::string json;
  double timeoutSeconds = 600.0;  // a calibration takes minutes
};

nlohmann::json valueOf(const std::string& text) {
  nlohmann::json number = nlohmann::json::parse(text, nullptr, false);
  if (!number.is_discarded() && (number.is_number() || number.is_boolean())) return number;
  return text;
}

// The first positional argument after the request, by request.
const char* positionalKey(const std::string& request) {
  if (request == "load") return "scene";
  if (request == "view") return "x";
  if (request == "frame" || request == "identify" || request == "calibrate") return "module";
  return nullptr;
}

nlohmann::json requestFromWords(const std::vector<std::string>& words) {
  if (words.empty()) throw InputError({"", "REQUEST", 0}, "name a request: status, stats, load, play, pause, set, frame, view, calibrate, reload, shutdown, identify, testcard, rollback");
  nlohmann::json request = {{"request", words[0]}};
  bool positionalUsed = false;
  for (size_t i = 1; i < words.size(); ++i) {
    const std::string& w = words[i];
    if (w.rfind("--", 0) == 0) {
      if (i + 1 >= words.size()) throw InputError({"", w, 0}, "needs a value");
      request[w.substr(2)] = valueOf(words[++i]);
    } else if (const size_t eq = w.find('='); eq != std::string::npos && words[0] == "set") {
      request["name"] = w.substr(0, eq);
      request["value"] = valueOf(w.substr(eq + 1));
    } else if (words[0] == "set" && !request.contains("name")) {
      request["name"] = w;
    } else if (words[0] == "set" && !request.contains("value")) {
      request["value"] = valueOf(w);
    } else if (const char* key = positionalKey(words[0]); key && !positionalUsed) {
      request[key] = key == std::string("scene") ? nlohmann::json(w) : valueOf(w);
      positionalUsed = true;
    } else {
      throw InputError({"", w, 0}, fmt::format("unexpected argument for \"{}\"", words[0]));
    }
  }
  return request;
}

std::string exchange(const std::string& path, const std::string& line, double timeoutSeconds) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error(std::string("socket: ") + std::strerror(errno));
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.size() >= sizeof addr.sun_path) throw InputError({"", "--socket", 0}, "path too long");
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd);
    throw std::runtime_error(fmt::format("no daemon at {} ({}): is parallaxd running?", path, why));
  }
  const std::string out = line + "\n";
  if (::send(fd, out.data(), out.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(out.size())) {
    ::close(fd);
    throw std::runtime_error("the daemon closed the connection");
  }
  std::string reply;
  char buffer[4096];
  while (reply.find('\n') == std::string::npos) {
    pollfd p{fd, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(timeoutSeconds * 1000.0));
    if (ready == 0) {
      ::close(fd);
      throw std::runtime_error(fmt::format("no reply within {} s", timeoutSeconds));
    }
    const ssize_t n = ::recv(fd, buffer, sizeof buffer, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    reply.append(buffer, static_cast<size_t>(n));
  }
  ::close(fd);
  if (reply.empty()) throw std::runtime_error("the daemon closed the connection without a reply");
  return reply.substr(0, reply.find('\n'));
}

int runCtl(const CtlArgs& args, const std::vector<std::string>& words) {
  nlohmann::json request;
  if (!args.json.empty()) {
    request = nlohmann::json::parse(args.json, nullptr, false);
    if (request.is_discarded()) throw InputError({"", "--json", 0}, "not valid JSON");
  } else {
    request = requestFromWords(words);
  }
  const std::string path = args.socket.empty() ? daemon::defaultControlSocketPath() : args.socket;
  const std::string line = exchange(path, request.dump(), args.timeoutSeconds);
  const nlohmann::json reply = nlohmann::json::parse(line, nullptr, false);
  if (reply.is_discarded()) {
    std::cout << line << "\n";
    return 1;
  }
  std::cout << reply.dump(2) << "\n";
  return reply.value("ok", false) ? 0 : 1;
}

}  // namespace

void addCtlCommand(CLI::App& app) {
  auto args = std::make_shared<CtlArgs>();
  CLI::App* command = app.add_subcommand("ctl", "talk to a running parallaxd (status, load, play, view, ...)");
  command->prefix_command();  // everything after the request is the request's own
  command->add_option("--socket", args->socket, "control socket (default: where parallaxd with no config listens)");
  command->add_option("--json", args->json, "send this JSON request as it is");
  command->add_option("--timeout", args->timeoutSeconds, "seconds to wait for the reply");
  command->callback([args, command] {
    const int code = runCtl(*args, command->remaining());
    if (code != 0) throw CLI::RuntimeError(code);
  });
}

}  // namespace parallax::cli
