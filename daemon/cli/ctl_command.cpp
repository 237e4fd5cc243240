// parallax ctl [--socket PATH] REQUEST [ARGS]
// The control client of parallaxd (linked into the light `parallax` front, parallax_main.cpp):
// turns the words into one JSON request line, sends it over the daemon's Unix socket and prints the
// reply (exit 1 when the reply says ok: false). Without --socket it finds the daemon that
// `parallaxd` with no config started
// ($XDG_RUNTIME_DIR/parallax/parallaxd.sock, else /tmp/parallax-$UID/parallaxd.sock).
//
//   parallax ctl status | stats | play | pause | reload | shutdown | testcard | rollback | cancel
//   parallax ctl load cornell            parallax ctl set radius=0.2   (or: set radius 0.2)
//   parallax ctl frame 3 [--path f.png]  parallax ctl view 0.5 [--path v.png]
//   parallax ctl identify [3]            parallax ctl calibrate [--module 3]
//   parallax ctl panel                   (prints the browser panel's URL with its token)
//   parallax ctl --json '{"request": "status"}'

#include <fmt/format.h>

#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "common/input_error.h"
#include "daemon/cli/command_line.h"
#include "daemon/cli/commands.h"
#include "daemon/parallaxd/control_client.h"
#include "daemon/parallaxd/control_request.h"
#include "daemon/parallaxd/control_socket_path.h"

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
  if (words.empty())
    throw InputError({"", "REQUEST", 0}, "name a request:\n" + daemon::controlRequestHelp());
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
  // The daemon writes only to absolute paths (its working folder is not the user's): a
  // relative --path is the caller's, resolved here.
  if (request.contains("path") && request["path"].is_string()) {
    const std::string path = request["path"];
    if (!path.empty())
      request["path"] = std::filesystem::absolute(path).lexically_normal().string();
  }
  return request;
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
  const std::string line = daemon::exchangeControlLine(path, request.dump(), args.timeoutSeconds);
  const nlohmann::json reply = nlohmann::json::parse(line, nullptr, false);
  if (reply.is_discarded()) {
    std::cout << line << "\n";
    return 1;
  }
  const bool ok = reply.value("ok", false);
  if (ok && request.value("request", "") == "panel" && reply.contains("url")) {
    std::cout << reply["url"].get<std::string>() << "\n";  // to open, or to pipe to a browser
  } else if (!quiet()) {
    std::cout << reply.dump(2) << "\n";
  } else if (!ok) {
    std::cerr << "parallax ctl: " << reply.value("error", reply.dump()) << "\n";
  }
  return ok ? 0 : 1;
}

}  // namespace

void addCtlCommand(CLI::App& app) {
  auto args = std::make_shared<CtlArgs>();
  CLI::App* command =
      app.add_subcommand("ctl", "talk to a running parallaxd (status, load, play, view, ...)");
  command->prefix_command();    // everything after the request is the request's own
  command->fallthrough(false);  // ... even under an app whose options fall through (--quiet)
  command->footer("Requests (arguments as --key value, or the first one positional):\n" +
                  daemon::controlRequestHelp());
  command->add_option("--socket", args->socket,
                      "control socket (default: where parallaxd with no config listens)");
  command->add_option("--json", args->json, "send this JSON request as it is");
  command->add_option("--timeout", args->timeoutSeconds, "seconds to wait for the reply");
  addQuietFlag(*command);  // print nothing on success: the exit code says it
  command->callback([args, command] {
    const int code = runCtl(*args, command->remaining());
    if (code != 0) throw CLI::RuntimeError(code);
  });
}

}  // namespace parallax::cli
