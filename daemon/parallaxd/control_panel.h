#pragma once
// The browser control panel (issue 24): parallaxd serves one page (daemon/parallaxd/panel/:
// plain HTML, JS and CSS, compiled into the program) and a small HTTP API over cpp-httplib.
// Every action is a control request handed to the SAME handler as the control socket's
// (ControlServer::replyTo): the panel has no request logic of its own.
//
//   GET  /?token=T              the page (its script and style with the token in their URLs)
//   GET  /panel.js, /panel.css  the page's script and style
//   POST /api/request           one control request as JSON → its reply, as on the socket
//   GET  /api/view.png?x=X[&width=W&height=H]   `view` into the panel's scratch folder, served
//   GET  /api/frame.png?module=N                `frame` likewise
//   GET  /api/report            the reports folder and its latest report (name, date, URL)
//   GET  /report/T/NAME/FILE    a file of report NAME (panel_reports.h: only report files, only
//                               in the reports folder); the token is in the path so that the
//                               report's relative links (its CSVs, SVGs, PNGs) carry it too
//
// Security, checked before any route: the token (header X-Parallax-Token or query `token`,
// compared in constant time) on every request; an Origin header must be the page's own and a
// browser's Sec-Fetch-Site must not be cross-site (cross-site requests from other pages); on a
// loopback address the Host must be a loopback name (DNS rebinding); bodies over
// kMaxRequestBytes are refused (413). The page's files are served from memory; the only path
// that reaches the file system is a report's, checked by PanelReports. A report is served with
// a policy of its own: no script at all, its inline styles allowed. From the panel the requests
// that write where the client says
// (`path`), stop the daemon (`shutdown`) or reveal the token (`panel`) are refused.

#include <atomic>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "daemon/parallaxd/panel_reports.h"

namespace httplib {
class Server;
struct Request;
struct Response;
}  // namespace httplib

namespace parallax::daemon {

struct ControlPanelOptions {
  std::string address = "127.0.0.1";
  int port = 8470;      // 0: any free port
  std::string token;    // panel_token.h
  std::string scratch;  // a private folder (0700) for the PNGs of view and frame requests
  std::string reports;  // the `parallax report` folders served (panel_reports.h); "": none
  int threads = 8;      // requests served at once (a `calibrate` holds one for minutes)
};

class ControlPanel {
 public:
  static constexpr size_t kMaxRequestBytes = 64 * 1024;  // as the control socket's lines
  using Handler = std::function<nlohmann::json(const nlohmann::json&)>;

  // Binds and starts serving; throws std::runtime_error naming the address when it cannot bind.
  ControlPanel(ControlPanelOptions options, Handler handler);
  ~ControlPanel();  // stops serving, waits for the requests in flight
  ControlPanel(const ControlPanel&) = delete;
  ControlPanel& operator=(const ControlPanel&) = delete;

  int port() const { return port_; }
  // http://ADDRESS:PORT/?token=T (IPv6 addresses in brackets).
  std::string url() const;

 private:
  bool allowed(const httplib::Request& request, httplib::Response& response) const;
  void serveAsset(const std::string& path, httplib::Response& response) const;
  void serveRequest(const httplib::Request& request, httplib::Response& response) const;
  void servePicture(const nlohmann::json& controlRequest, httplib::Response& response) const;
  void serveReportFile(const httplib::Request& request, httplib::Response& response) const;

  ControlPanelOptions options_;
  PanelReports reports_;
  Handler handler_;
  std::unique_ptr<httplib::Server> server_;
  int port_ = 0;
  bool loopback_ = true;
  mutable std::atomic<uint64_t> pictures_{0};
  std::thread thread_;
};

}  // namespace parallax::daemon
