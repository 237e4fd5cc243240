#include "daemon/parallaxd/control_panel.h"

#include <arpa/inet.h>
#include <fmt/format.h>
#include <httplib.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <filesystem>
#include <stdexcept>

#include "common/regular_file.h"
#include "daemon/parallaxd/control_server.h"
#include "daemon/parallaxd/panel_assets.h"
#include "daemon/parallaxd/panel_token.h"

namespace parallax::daemon {
namespace {

constexpr const char* kTokenHeader = "X-Parallax-Token";
constexpr const char* kReportPrefix = "/report/";
// A report is our own static document: no script may run in it, its <style> and the inline
// plots' styles may apply, its pictures come from beside it.
constexpr const char* kReportPolicy =
    "default-src 'none'; style-src 'unsafe-inline'; img-src 'self'; frame-ancestors 'none'; "
    "base-uri 'none'; form-action 'none'";
// The largest PNG a view or frame request may make (8192² RGB, uncompressed, with room).
constexpr size_t kMaxPictureBytes = size_t{256} << 20;

bool isLoopback(const std::string& address) {
  in_addr v4{};
  if (::inet_pton(AF_INET, address.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  return address == "::1";
}

std::string hostPort(const std::string& host, int port) {
  return host.find(':') != std::string::npos ? fmt::format("[{}]:{}", host, port)
                                             : fmt::format("{}:{}", host, port);
}

void refuse(httplib::Response& response, int status, const std::string& why) {
  response.status = status;
  response.set_content(nlohmann::json({{"ok", false}, {"error", why}}).dump() + "\n",
                       "application/json");
}

// A query parameter as a JSON number, as a socket client would write it ("640" an integer, "0.25"
// a float: the request table checks the kinds); nullopt when absent or, with `problem`, bad.
std::optional<nlohmann::json> numberParameter(const httplib::Request& request,
                                              const std::string& name, std::string* problem) {
  if (!request.has_param(name.c_str())) return std::nullopt;
  const std::string text = request.get_param_value(name.c_str());
  const nlohmann::json v = nlohmann::json::parse(text, nullptr, false);
  if (!v.is_number() || !std::isfinite(v.get<double>())) {
    *problem = fmt::format("{}: \"{}\" is not a number", name, text);
    return std::nullopt;
  }
  return v;
}

}  // namespace

ControlPanel::ControlPanel(ControlPanelOptions options, Handler handler)
    : options_(std::move(options)),
      reports_(options_.reports),
      handler_(std::move(handler)),
      server_(std::make_unique<httplib::Server>()),
      loopback_(isLoopback(options_.address)) {
  if (options_.token.size() != kPanelTokenHexChars)
    throw std::runtime_error("the control panel needs its token");
  httplib::Server& s = *server_;
  const int threads = options_.threads;
  s.new_task_queue = [threads] { return new httplib::ThreadPool(static_cast<size_t>(threads)); };
  s.set_payload_max_length(kMaxRequestBytes);
  // Headers and body go out in separate writes: with Nagle's algorithm the body waits for the
  // client's delayed ACK (40 ms a request).
  s.set_tcp_nodelay(true);
  // Short keep-alive: an idle browser connection holds a pool thread only this long.
  s.set_keep_alive_timeout(2);
  s.set_keep_alive_max_count(1000);
  s.set_read_timeout(10);
  s.set_write_timeout(10);
  s.set_default_headers({
      {"Cache-Control", "no-store"},
      {"X-Content-Type-Options", "nosniff"},
      {"X-Frame-Options", "DENY"},
      {"Referrer-Policy", "no-referrer"},
      {"Content-Security-Policy",
       "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' blob:; "
       "connect-src 'self'; frame-ancestors 'none'; base-uri 'none'; form-action 'none'"},
  });
  s.set_pre_routing_handler([this](const httplib::Request& request, httplib::Response& response) {
    return allowed(request, response) ? httplib::Server::HandlerResponse::Unhandled
                                      : httplib::Server::HandlerResponse::Handled;
  });
  s.set_error_handler(httplib::Server::HandlerWithResponse(
      [](const httplib::Request&, httplib::Response& response) {
        // Our own refusals carry their reason; the library's (404, 413, 400) get one here.
        if (!response.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
        const int status = response.status;
        refuse(response, status,
               status == 404   ? "not found"
               : status == 413 ? fmt::format("request too large (over {} bytes)", kMaxRequestBytes)
                               : fmt::format("HTTP {}", status));
        return httplib::Server::HandlerResponse::Handled;
      }));
  s.set_exception_handler(
      [](const httplib::Request&, httplib::Response& response, std::exception_ptr e) {
        try {
          std::rethrow_exception(e);
        } catch (const std::exception& x) {
          refuse(response, 500, x.what());
        } catch (...) {
          refuse(response, 500, "internal error");
        }
      });

  for (const PanelAsset& asset : panelAssets()) {
    const std::string path(asset.path);
    s.Get(path == "/index.html" ? "/" : path,
          [this, path](const httplib::Request&, httplib::Response& response) {
            serveAsset(path, response);
          });
  }
  s.Post("/api/request", [this](const httplib::Request& request, httplib::Response& response) {
    serveRequest(request, response);
  });
  s.Get("/api/view.png", [this](const httplib::Request& request, httplib::Response& response) {
    std::string problem;
    const std::optional<nlohmann::json> x = numberParameter(request, "x", &problem);
    nlohmann::json view = {{"request", "view"}, {"x", x.value_or(0.0)}};
    for (const char* side : {"width", "height"}) {
      if (const std::optional<nlohmann::json> v = numberParameter(request, side, &problem))
        view[side] = *v;
    }
    if (!x && problem.empty()) problem = "x: required (the viewer's x on the observer line, m)";
    if (!problem.empty()) return refuse(response, 400, problem);
    servePicture(view, response);
  });
  s.Get("/api/frame.png", [this](const httplib::Request& request, httplib::Response& response) {
    std::string problem;
    const std::optional<nlohmann::json> module = numberParameter(request, "module", &problem);
    if (!module && problem.empty()) problem = "module: required";
    if (!problem.empty()) return refuse(response, 400, problem);
    servePicture({{"request", "frame"}, {"module", *module}}, response);
  });

  s.Get("/api/report", [this](const httplib::Request&, httplib::Response& response) {
    nlohmann::json reply = {{"ok", true}, {"folder", reports_.folder()}, {"latest", nullptr}};
    if (const std::optional<ReportFolder> latest =
            reports_.folder().empty() ? std::nullopt : reports_.latest()) {
      reply["latest"] = {
          {"name", latest->name},
          {"date", latest->date},
          {"url", fmt::format("report/{}/{}/report.html", options_.token, latest->name)}};
    }
    response.set_content(reply.dump() + "\n", "application/json");
  });
  s.Get(R"(/report/[^/]+/([^/]+)/([^/]*))",
        [this](const httplib::Request& request, httplib::Response& response) {
          serveReportFile(request, response);
        });

  port_ = options_.port == 0
              ? s.bind_to_any_port(options_.address)
              : (s.bind_to_port(options_.address, options_.port) ? options_.port : -1);
  if (port_ <= 0) {
    throw std::runtime_error(fmt::format("the control panel cannot listen on {}",
                                         hostPort(options_.address, options_.port)));
  }
  thread_ = std::thread([this] { server_->listen_after_bind(); });
  if (!loopback_)
    spdlog::warn("panel: listening on {} (not loopback: anyone with the token on that network)",
                 hostPort(options_.address, port_));
}

ControlPanel::~ControlPanel() {
  server_->stop();
  if (thread_.joinable()) thread_.join();
}

std::string ControlPanel::url() const {
  return fmt::format("http://{}/?token={}", hostPort(options_.address, port_), options_.token);
}

bool ControlPanel::allowed(const httplib::Request& request, httplib::Response& response) const {
  // DNS rebinding: a page of evil.example whose name now resolves to 127.0.0.1 talks to us
  // "same-origin", but its requests say Host: evil.example.
  const std::string host = request.get_header_value("Host");
  if (loopback_) {
    const bool loopbackHost =
        host == hostPort("127.0.0.1", port_) || host == hostPort("localhost", port_) ||
        host == hostPort("::1", port_) || host == hostPort(options_.address, port_);
    if (!loopbackHost) {
      refuse(response, 403, fmt::format("host \"{}\" is not this panel's", host));
      return false;
    }
  }
  // Cross-site requests (a page elsewhere posting to us): browsers say where they come from.
  if (request.has_header("Origin") && request.get_header_value("Origin") != "http://" + host) {
    refuse(response, 403,
           fmt::format("origin \"{}\" is not this panel's", request.get_header_value("Origin")));
    return false;
  }
  if (request.get_header_value("Sec-Fetch-Site") == "cross-site") {
    refuse(response, 403, "cross-site request");
    return false;
  }
  std::string token = request.get_header_value(kTokenHeader);
  if (token.empty() && request.has_param("token")) token = request.get_param_value("token");
  if (token.empty() && request.path.rfind(kReportPrefix, 0) == 0) {
    const size_t from = std::char_traits<char>::length(kReportPrefix);
    token = request.path.substr(from, request.path.find('/', from) - from);
  }
  if (token.empty()) {
    refuse(response, 401,
           "the panel's token is required (`parallax ctl panel` prints the URL with it)");
    return false;
  }
  if (!tokensEqual(token, options_.token)) {
    refuse(response, 403, "wrong token");
    return false;
  }
  return true;
}

void ControlPanel::serveAsset(const std::string& path, httplib::Response& response) const {
  const PanelAsset* asset = findPanelAsset(path);
  if (asset == nullptr) return refuse(response, 404, "not found");
  std::string body(asset->body);
  if (path == "/index.html") {
    // The page names its script and style with the token: a browser sends no header of ours
    // for <script src>.
    for (size_t at = body.find("{{token}}"); at != std::string::npos;
         at = body.find("{{token}}", at))
      body.replace(at, 9, options_.token);
  }
  response.set_content(body, std::string(asset->contentType));
}

void ControlPanel::serveRequest(const httplib::Request& request,
                                httplib::Response& response) const {
  const nlohmann::json parsed = nlohmann::json::parse(request.body, nullptr, false);
  if (parsed.is_object()) {
    const std::string name = parsed.value("request", std::string());
    if (name == "shutdown" || name == "panel") {
      return refuse(response, 403,
                    fmt::format("\"{}\" is not available from the panel (use parallax ctl)", name));
    }
    if (parsed.contains("path")) {
      return refuse(response, 403,
                    "path: the panel writes only into its own folder (use parallax ctl)");
    }
  }
  // Exactly what the control socket does with one line: the same parse, checks and handler.
  response.set_content(ControlServer::replyTo(request.body, handler_), "application/json");
}

void ControlPanel::servePicture(const nlohmann::json& controlRequest,
                                httplib::Response& response) const {
  nlohmann::json request = controlRequest;
  const std::string path =
      fmt::format("{}/{}-{}.png", options_.scratch, request["request"].get<std::string>(),
                  pictures_.fetch_add(1));
  request["path"] = path;
  const nlohmann::json reply =
      nlohmann::json::parse(ControlServer::replyTo(request.dump(), handler_), nullptr, false);
  if (!reply.is_object() || !reply.value("ok", false)) {
    response.status = 409;  // the daemon cannot make it now (no frames yet, bad module, ...)
    response.set_content(reply.dump() + "\n", "application/json");
    return;
  }
  std::string png;
  try {
    png = readRegularFile(path, kMaxPictureBytes);
  } catch (const std::exception& e) {
    std::filesystem::remove(path);
    return refuse(response, 500, e.what());
  }
  std::filesystem::remove(path);
  response.set_content(std::move(png), "image/png");
}

void ControlPanel::serveReportFile(const httplib::Request& request,
                                   httplib::Response& response) const {
  // /report/TOKEN/NAME/ is the report itself.
  const std::string report = request.matches[1];
  std::string file = request.matches[2];
  if (file.empty()) file = "report.html";
  std::string problem = "no reports folder";
  const std::optional<ReportFile> found =
      reports_.folder().empty() ? std::nullopt : reports_.read(report, file, &problem);
  if (!found) return refuse(response, 404, problem);
  response.headers.erase("Content-Security-Policy");
  response.set_header("Content-Security-Policy", kReportPolicy);
  response.set_content(found->body, found->contentType);
}

}  // namespace parallax::daemon
