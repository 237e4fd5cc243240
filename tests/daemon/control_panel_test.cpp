// The browser control panel as a browser (or an attacker's page) sees it: the page and the API
// with the token; without it, with a wrong one, from a foreign origin or host, oversized, or
// asking for files outside the page: refused, and the request handler never called. Requests
// reach the handler exactly as on the control socket.

#include "daemon/parallaxd/control_panel.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <tuple>
#include <vector>

#include "daemon/parallaxd/control_request.h"
#include "daemon/parallaxd/panel_token.h"

namespace parallax::daemon {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Sends `bytes` as they are to 127.0.0.1:port and returns all the server answers: requests a
// well-behaved client library would never send (raw paths, huge headers).
std::string rawExchange(int port, const std::string& bytes) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return "";
  }
  const timeval timeout{10, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  size_t sent = 0;
  while (sent < bytes.size()) {
    const ssize_t n = ::send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) break;  // the server may refuse before reading everything
    sent += static_cast<size_t>(n);
  }
  // Until the reply is complete (its Content-Length) or the server closes: a refused request's
  // connection may stay open until the keep-alive timeout.
  std::string reply;
  char chunk[4096];
  ssize_t n = 0;
  while ((n = ::recv(fd, chunk, sizeof chunk, 0)) > 0) {
    reply.append(chunk, static_cast<size_t>(n));
    const size_t end = reply.find("\r\n\r\n");
    const size_t length = reply.find("Content-Length: ");
    if (end != std::string::npos && length != std::string::npos && length < end &&
        reply.size() >= end + 4 + std::stoul(reply.substr(length + 16)))
      break;
  }
  ::close(fd);
  return reply;
}

int statusOf(const std::string& rawReply) {
  // "HTTP/1.1 404 Not Found"
  return rawReply.size() > 12 ? std::atoi(rawReply.c_str() + 9) : 0;
}

class ControlPanelTest : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = fs::temp_directory_path() /
              ("plx-panel-" + std::to_string(::getpid()) + "-" +
               ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(folder_);
    fs::create_directories(folder_ / "scratch");
    token_ = newPanelToken();
    ControlPanelOptions options;
    options.port = 0;
    options.token = token_;
    options.scratch = (folder_ / "scratch").string();
    options.reports = (folder_ / "reports").string();
    panel_ = std::make_unique<ControlPanel>(options, [this](const json& request) {
      std::lock_guard lock(mutex_);
      received_.push_back(request);
      const std::string name = request["request"];
      // Checked against the request table as the conductor checks it (kinds, ranges, keys).
      parseRequestArgs(*findControlRequest(name), request, 4);
      if (name == "view" || name == "frame") {
        std::ofstream(request["path"].get<std::string>(), std::ios::binary)
            << "picture of " << name;
        return json{{"ok", true}, {"path", request["path"]}};
      }
      if (name == "set") return json{{"ok", false}, {"error", "no scene loaded"}};
      return json{{"ok", true}, {"state", "playing"}};
    });
    client_ = std::make_unique<httplib::Client>("127.0.0.1", panel_->port());
  }
  void TearDown() override {
    client_.reset();
    panel_.reset();
    fs::remove_all(folder_);
  }
  httplib::Headers withToken(httplib::Headers h = {}) const {
    h.emplace("X-Parallax-Token", token_);
    return h;
  }
  size_t handled() {
    std::lock_guard lock(mutex_);
    return received_.size();
  }
  std::string origin() const { return "http://127.0.0.1:" + std::to_string(panel_->port()); }

  fs::path folder_;
  std::string token_;
  std::unique_ptr<ControlPanel> panel_;
  std::unique_ptr<httplib::Client> client_;
  std::mutex mutex_;
  std::vector<json> received_;
};

TEST_F(ControlPanelTest, ServesThePageAndHandsRequestsToTheHandlerAsTheSocketDoes) {
  EXPECT_EQ(panel_->url(),
            "http://127.0.0.1:" + std::to_string(panel_->port()) + "/?token=" + token_);
  auto page = client_->Get("/?token=" + token_);
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_NE(page->body.find("panel.js?token=" + token_), std::string::npos);
  EXPECT_EQ(page->get_header_value("X-Frame-Options"), "DENY");
  EXPECT_NE(page->get_header_value("Content-Security-Policy").find("default-src 'none'"),
            std::string::npos);
  for (const char* asset : {"/panel.js", "/panel.css"}) {
    auto r = client_->Get(asset, withToken());
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 200) << asset;
    EXPECT_GT(r->body.size(), 100u) << asset;
  }
  auto reply = client_->Post("/api/request", withToken({{"Origin", origin()}}),
                             R"({"request": "status"})", "application/json");
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status, 200);
  EXPECT_EQ(json::parse(reply->body), json({{"ok", true}, {"state", "playing"}}));
  ASSERT_EQ(handled(), 1u);
  EXPECT_EQ(received_[0], json({{"request", "status"}}));
  // A refusal by the handler is a reply, as on the socket; malformed JSON the socket's error.
  reply = client_->Post("/api/request", withToken(),
                        R"({"request": "set", "name": "a", "value": 1})", "application/json");
  ASSERT_TRUE(reply);
  EXPECT_EQ(json::parse(reply->body)["error"], "no scene loaded");
  reply = client_->Post("/api/request", withToken(), "{not json", "application/json");
  ASSERT_TRUE(reply);
  EXPECT_NE(json::parse(reply->body)["error"].get<std::string>().find("malformed request"),
            std::string::npos);
}

TEST_F(ControlPanelTest, RefusesEveryRequestWithoutTheToken) {
  for (const char* path : {"/", "/panel.js", "/panel.css", "/api/view.png?x=0"}) {
    auto r = client_->Get(path);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 401) << path;
    EXPECT_EQ(r->body.find("function"), std::string::npos) << path;
  }
  auto r = client_->Post("/api/request", R"({"request": "pause"})", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 401);
  // A wrong token, one of another length, the right one in capitals: refused.
  std::string upper = token_;
  for (char& c : upper) c = static_cast<char>(std::toupper(c));
  for (const std::string& wrong : {newPanelToken(), token_.substr(1), upper, token_ + "0"}) {
    r = client_->Post("/api/request", {{"X-Parallax-Token", wrong}}, R"({"request": "pause"})",
                      "application/json");
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 403) << wrong;
    r = client_->Get("/?token=" + wrong);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 403) << wrong;
  }
  EXPECT_EQ(handled(), 0u);
}

TEST_F(ControlPanelTest, RefusesForeignOriginsAndHosts) {
  const std::string pause = R"({"request": "pause"})";
  for (const std::string& foreign : {std::string("http://evil.example"), std::string("null"),
                                     "https://127.0.0.1:" + std::to_string(panel_->port()),
                                     "http://127.0.0.1:" + std::to_string(panel_->port() + 1)}) {
    auto r =
        client_->Post("/api/request", withToken({{"Origin", foreign}}), pause, "application/json");
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 403) << foreign;
  }
  auto r = client_->Post("/api/request", withToken({{"Sec-Fetch-Site", "cross-site"}}), pause,
                         "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 403);
  // DNS rebinding: the attacker's name resolved to us; the browser sends its Host (and its
  // Origin matches that Host, so only the Host check stops it).
  const std::string rebound = "evil.example:" + std::to_string(panel_->port());
  const std::string raw =
      "POST /api/request HTTP/1.1\r\nHost: " + rebound + "\r\nOrigin: http://" + rebound +
      "\r\nX-Parallax-Token: " + token_ +
      "\r\nContent-Type: application/json\r\nContent-Length: " + std::to_string(pause.size()) +
      "\r\nConnection: close\r\n\r\n" + pause;
  EXPECT_EQ(statusOf(rawExchange(panel_->port(), raw)), 403);
  EXPECT_EQ(handled(), 0u);
  // The page's own origin, and localhost for it, are accepted.
  r = client_->Post("/api/request",
                    withToken({{"Origin", origin()}, {"Sec-Fetch-Site", "same-origin"}}), pause,
                    "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(handled(), 1u);
}

TEST_F(ControlPanelTest, RefusesOversizedRequests) {
  // A body one byte over the socket's line limit.
  const std::string big =
      R"({"request": "status", "x": ")" + std::string(ControlPanel::kMaxRequestBytes, 'a') + "\"}";
  auto r = client_->Post("/api/request", withToken(), big, "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 413);
  // Headers and a URL past the library's limits (8 KiB): refused, never handled.
  const std::string hugeHeader =
      "GET /?token=" + token_ + " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(panel_->port()) +
      "\r\nX-Filler: " + std::string(20000, 'b') + "\r\nConnection: close\r\n\r\n";
  EXPECT_EQ(statusOf(rawExchange(panel_->port(), hugeHeader)), 400);
  const std::string hugeUrl = "GET /?token=" + token_ + "&q=" + std::string(20000, 'c') +
                              " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(panel_->port()) +
                              "\r\nConnection: close\r\n\r\n";
  EXPECT_EQ(statusOf(rawExchange(panel_->port(), hugeUrl)), 414);
  EXPECT_EQ(handled(), 0u);
}

TEST_F(ControlPanelTest, NeverServesFilesOutsideItsOwn) {
  std::ofstream(folder_ / "secret.txt") << "root:x:0:0";
  const std::string host = "127.0.0.1:" + std::to_string(panel_->port());
  for (const std::string& path :
       {std::string("/../../../../etc/passwd"), std::string("/%2e%2e/%2e%2e/%2e%2e/etc/passwd"),
        std::string("/..%2f..%2f..%2fetc%2fpasswd"), std::string("/panel.js/../../../etc/passwd"),
        std::string("//etc/passwd"), std::string("/api/../../etc/passwd"),
        std::string("/index.html/../panel.token"), "/" + (folder_ / "secret.txt").string(),
        std::string("/../scratch"), std::string("/panel.token")}) {
    const std::string raw = "GET " + path + "?token=" + token_ + " HTTP/1.1\r\nHost: " + host +
                            "\r\nX-Parallax-Token: " + token_ + "\r\nConnection: close\r\n\r\n";
    const std::string reply = rawExchange(panel_->port(), raw);
    const int status = statusOf(reply);
    EXPECT_TRUE(status == 404 || status == 400) << path << ": " << status;
    EXPECT_EQ(reply.find("root:"), std::string::npos) << path;
  }
}

TEST_F(ControlPanelTest, WritesOnlyIntoItsOwnFolderAndCannotStopTheDaemon) {
  for (const std::string& body :
       {std::string(R"({"request": "view", "x": 0, "path": "/tmp/elsewhere.png"})"),
        std::string(R"({"request": "frame", "module": 0, "path": "/etc/cron.d/x"})"),
        std::string(R"({"request": "shutdown"})"), std::string(R"({"request": "panel"})")}) {
    auto r = client_->Post("/api/request", withToken(), body, "application/json");
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 403) << body;
  }
  EXPECT_EQ(handled(), 0u);
}

TEST_F(ControlPanelTest, PicturesComeFromTheViewAndFrameRequests) {
  auto r = client_->Get("/api/view.png?x=0.25&width=64&height=36", withToken());
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->get_header_value("Content-Type"), "image/png");
  EXPECT_EQ(r->body, "picture of view");
  r = client_->Get("/api/frame.png?module=3", withToken());
  ASSERT_TRUE(r);
  EXPECT_EQ(r->body, "picture of frame");
  ASSERT_EQ(handled(), 2u);
  EXPECT_EQ(received_[0]["request"], "view");
  EXPECT_EQ(received_[0]["x"], 0.25);
  EXPECT_TRUE(received_[0]["width"].is_number_integer()) << "the table wants an integer";
  EXPECT_EQ(received_[0]["width"], 64);
  EXPECT_EQ(received_[1]["module"], 3);
  for (const json& request : received_) {
    const fs::path path = request["path"].get<std::string>();
    EXPECT_EQ(path.parent_path(), folder_ / "scratch");
    EXPECT_FALSE(fs::exists(path)) << "the scratch picture is removed once served";
  }
  // Arguments that are not numbers never reach the handler.
  for (const char* bad : {"/api/view.png", "/api/view.png?x=left", "/api/view.png?x=1e999",
                          "/api/frame.png?module=two"}) {
    r = client_->Get(bad, withToken());
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 400) << bad;
  }
  EXPECT_EQ(handled(), 2u);
}

// A report folder as `parallax report --out` leaves it, written `age` seconds ago.
void writeReport(const fs::path& folder, const std::string& title, int age) {
  fs::create_directories(folder);
  std::ofstream(folder / "report.html") << "<html><body>" << title << "<img src=\"plot.png\"/>";
  std::ofstream(folder / "plot.png") << "png of " << title;
  std::ofstream(folder / "table.csv") << "# machine: x\na,b\n1,2\n";
  fs::last_write_time(folder / "report.html",
                      fs::file_time_type::clock::now() - std::chrono::seconds(age));
}

TEST_F(ControlPanelTest, LinksTheLatestReportAndServesItsFiles) {
  auto r = client_->Get("/api/report", withToken());
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  EXPECT_EQ(json::parse(r->body)["latest"], nullptr) << "no reports folder yet";
  EXPECT_EQ(json::parse(r->body)["folder"], (folder_ / "reports").string());

  writeReport(folder_ / "reports" / "2026-12-01", "older", 3600);
  writeReport(folder_ / "reports" / "2026-12-03", "newest", 60);
  fs::create_directories(folder_ / "reports" / "no-report-here");  // a folder without report.html
  // A newer report reached through a symlink is not one of the folder's own.
  writeReport(folder_ / "outside", "outside", 0);
  fs::create_directory_symlink(folder_ / "outside", folder_ / "reports" / "zz-link");
  r = client_->Get("/api/report", withToken());
  ASSERT_TRUE(r);
  const json latest = json::parse(r->body)["latest"];
  ASSERT_TRUE(latest.is_object()) << r->body;
  EXPECT_EQ(latest["name"], "2026-12-03");
  EXPECT_EQ(latest["url"], "report/" + token_ + "/2026-12-03/report.html");
  EXPECT_EQ(latest["date"].get<std::string>().size(), std::string("2026-12-03 06:55 UTC").size());

  // The report and the files it links, by relative URLs that carry the token in their path.
  r = client_->Get("/" + latest["url"].get<std::string>());
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_NE(r->body.find("newest"), std::string::npos);
  EXPECT_EQ(r->get_header_value("Content-Type"), "text/html; charset=utf-8");
  ASSERT_EQ(r->get_header_value_count("Content-Security-Policy"), 1u);
  EXPECT_NE(r->get_header_value("Content-Security-Policy").find("default-src 'none'"),
            std::string::npos);
  EXPECT_EQ(r->get_header_value("Content-Security-Policy").find("script"), std::string::npos);
  const std::string base = "/report/" + token_ + "/";
  for (const auto& [path, type, body] :
       std::vector<std::tuple<std::string, std::string, std::string>>{
           {"2026-12-03/plot.png", "image/png", "png of newest"},
           {"2026-12-01/plot.png", "image/png", "png of older"},
           {"2026-12-01/", "text/html; charset=utf-8", ""}}) {
    r = client_->Get(base + path);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 200) << path;
    EXPECT_EQ(r->get_header_value("Content-Type"), type) << path;
    if (!body.empty()) {
      EXPECT_EQ(r->body, body) << path;
    }
  }
  // Without the token, or with a wrong one, nothing.
  for (const std::string& wrong : {newPanelToken(), std::string()}) {
    r = client_->Get("/report/" + wrong + "/2026-12-03/report.html");
    ASSERT_TRUE(r);
    EXPECT_TRUE(r->status == 401 || r->status == 403) << wrong << ": " << r->status;
    EXPECT_EQ(r->body.find("newest"), std::string::npos);
  }
  r = client_->Get("/api/report");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 401);
  EXPECT_EQ(handled(), 0u) << "reports are the panel's, not control requests";
}

TEST_F(ControlPanelTest, ServesNoFileOutsideTheReportsFolder) {
  writeReport(folder_ / "reports" / "r1", "one", 0);
  writeReport(folder_ / "outside", "outside", 0);
  std::ofstream(folder_ / "secret.csv") << "root:x:0:0";
  std::ofstream(folder_ / "reports" / "r1" / "notes.txt") << "root:x:0:0";  // not a report kind
  std::ofstream(folder_ / "reports" / "r1" / ".hidden.csv") << "root:x:0:0";
  fs::create_symlink(folder_ / "secret.csv", folder_ / "reports" / "r1" / "escape.csv");
  fs::create_directory_symlink(folder_ / "outside", folder_ / "reports" / "linked");
  ASSERT_EQ(::mkfifo((folder_ / "reports" / "r1" / "fifo.csv").c_str(), 0600), 0);
  const std::string host = "127.0.0.1:" + std::to_string(panel_->port());
  const std::string base = "/report/" + token_;
  for (const std::string& path :
       {base + "/../../secret.csv", base + "/r1/../../secret.csv",
        base + "/r1/..%2f..%2fsecret.csv", base + "/%2e%2e/secret.csv", base + "/r1/%2e%2e",
        base + "/..", base + "/r1/escape.csv", base + "/r1/fifo.csv", base + "/r1/notes.txt",
        base + "/r1/.hidden.csv", base + "/linked/report.html", base + "/linked/plot.png",
        base + "/r1/sub/table.csv", base + "/" + (folder_ / "secret.csv").string(),
        base + "//secret.csv", base + "/r1%2f..%2f..%2fsecret.csv/x",
        base + "/r1/table.csv%00.png"}) {
    const std::string raw =
        "GET " + path + " HTTP/1.1\r\nHost: " + host + "\r\nConnection: close\r\n\r\n";
    const std::string reply = rawExchange(panel_->port(), raw);
    const int status = statusOf(reply);
    EXPECT_TRUE(status == 404 || status == 400) << path << ": " << status;
    EXPECT_EQ(reply.find("root:"), std::string::npos) << path;
    EXPECT_EQ(reply.find("outside"), std::string::npos) << path;
  }
  // The same report's own files are served (the refusals above are not a server that serves none).
  auto r = client_->Get(base + "/r1/table.csv");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->get_header_value("Content-Type"), "text/csv; charset=utf-8");
}

TEST(PanelToken, IsPrivateKeptAndReplacedWhenOthersCouldReadIt) {
  const fs::path folder =
      fs::temp_directory_path() / ("plx-token-" + std::to_string(::getpid())) / "state";
  fs::remove_all(folder.parent_path());
  const std::string token = loadOrCreatePanelToken(folder.string());
  const fs::path file = folder / "panel.token";
  EXPECT_EQ(token.size(), kPanelTokenHexChars);
  EXPECT_EQ(token.find_first_not_of("0123456789abcdef"), std::string::npos);
  struct stat st {};
  ASSERT_EQ(::stat(file.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  EXPECT_EQ(loadOrCreatePanelToken(folder.string()), token) << "kept across restarts";
  EXPECT_NE(newPanelToken(), newPanelToken());
  // Readable by the group: no longer a secret, so a new one (0600 again).
  ::chmod(file.c_str(), 0640);
  const std::string second = loadOrCreatePanelToken(folder.string());
  EXPECT_NE(second, token);
  ASSERT_EQ(::stat(file.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  // Not a token, or a symlink to someone's file: replaced, the target untouched.
  std::ofstream(file) << "short\n";
  ::chmod(file.c_str(), 0600);
  EXPECT_NE(loadOrCreatePanelToken(folder.string()), second);
  std::ofstream(folder.parent_path() / "target") << "keep me";
  fs::remove(file);
  fs::create_symlink(folder.parent_path() / "target", file);
  EXPECT_EQ(loadOrCreatePanelToken(folder.string()).size(), kPanelTokenHexChars);
  EXPECT_FALSE(fs::is_symlink(file));
  std::ifstream target(folder.parent_path() / "target");
  EXPECT_EQ(std::string((std::istreambuf_iterator<char>(target)), {}), "keep me");
  fs::remove_all(folder.parent_path());
}

}  // namespace
}  // namespace parallax::daemon
