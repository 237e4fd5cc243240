#include "daemon/parallaxd/daemon_config.h"

#include <arpa/inet.h>
#include <fmt/format.h>
#include <toml++/toml.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <span>
#include <vector>

#include "calibration/display/display_model_json.h"
#include "calibration/display/display_presets.h"
#include "common/regular_file.h"
#include "hw/camera/camera_name.h"

namespace parallax::daemon {
namespace {

// Reads one table's keys, each checked for type, and refuses keys it does not know (a typo
// must not silently fall back to a default). Every error names file, key and line.
class TableReader {
 public:
  TableReader(const toml::table& table, std::string file, std::string prefix)
      : table_(table), file_(std::move(file)), prefix_(std::move(prefix)) {}

  [[noreturn]] void fail(const toml::node& node, const std::string& key,
                         const std::string& why) const {
    throw InputError({file_, prefix_ + key, static_cast<int>(node.source().begin.line)}, why);
  }
  const toml::node* find(const std::string& key) {
    known_.insert(key);
    return table_.get(key);
  }
  void readString(const std::string& key, std::string* out) {
    if (const toml::node* n = find(key)) {
      if (!n->is_string()) fail(*n, key, "must be a string");
      *out = n->as_string()->get();
    }
  }
  void readBool(const std::string& key, bool* out) {
    if (const toml::node* n = find(key)) {
      if (!n->is_boolean()) fail(*n, key, "must be true or false");
      *out = n->as_boolean()->get();
    }
  }
  template <typename Int>
  void readInt(const std::string& key, Int* out, long long lo, long long hi) {
    if (const toml::node* n = find(key)) {
      if (!n->is_integer()) fail(*n, key, "must be an integer");
      const long long v = n->as_integer()->get();
      if (v < lo || v > hi) fail(*n, key, fmt::format("must be in {}..{}, got {}", lo, hi, v));
      *out = static_cast<Int>(v);
    }
  }
  void readNumber(const std::string& key, double* out, double lo, double hi) {
    if (const toml::node* n = find(key)) {
      double v = 0.0;
      if (n->is_integer()) {
        v = static_cast<double>(n->as_integer()->get());
      } else if (n->is_floating_point()) {
        v = n->as_floating_point()->get();
      } else {
        fail(*n, key, "must be a number");
      }
      if (!std::isfinite(v) || v < lo || v > hi)
        fail(*n, key, fmt::format("must be in {}..{}, got {}", lo, hi, v));
      *out = v;
    }
  }
  const toml::table* subTable(const std::string& key) {
    const toml::node* n = find(key);
    if (n && !n->is_table()) fail(*n, key, "must be a table");
    return n ? n->as_table() : nullptr;
  }
  void refuseUnknownKeys() const {
    for (const auto& [key, node] : table_) {
      const std::string name(key.str());
      if (!known_.count(name)) fail(node, name, "unknown key");
    }
  }
  const std::string& file() const { return file_; }

 private:
  const toml::table& table_;
  std::string file_;
  std::string prefix_;
  std::set<std::string> known_;
};

void readDisplay(TableReader& r, DisplayConfig* d) {
  const bool hasPreset = r.find("preset") != nullptr;
  r.readString("preset", &d->preset);
  r.readString("file", &d->file);
  if (const toml::node* n = r.find("file"); n && hasPreset)
    r.fail(*n, "file", "give either preset or file, not both");
  if (d->file.empty() && !isBuiltInDisplay(d->preset)) {
    r.fail(*r.find("preset"), "preset",
           fmt::format("no built-in display \"{}\" (default, demo)", d->preset));
  }
  int modules = 0;
  if (const toml::node* n = r.find("modules")) {
    r.readInt("modules", &modules, 1, 1024);
    if (!d->file.empty()) r.fail(*n, "modules", "overrides a preset only, not a display file");
    d->modules = modules;
  }
  if (const toml::node* n = r.find("resolution")) {
    const toml::array* a = n->as_array();
    if (!a || a->size() != 2 || !(*a)[0].is_integer() || !(*a)[1].is_integer()) {
      r.fail(*n, "resolution", "must be [width, height] in pixels");
    }
    const long long w = (*a)[0].as_integer()->get(), h = (*a)[1].as_integer()->get();
    if (w < 8 || h < 8 || w > 8192 || h > 8192)
      r.fail(*n, "resolution", "each side must be in 8..8192");
    if (!d->file.empty()) r.fail(*n, "resolution", "overrides a preset only, not a display file");
    d->width = static_cast<int>(w);
    d->height = static_cast<int>(h);
  }
  r.refuseUnknownKeys();
}

void readHardware(TableReader& r, HardwareConfig* h) {
  r.readString("kind", &h->kind);
  if (h->kind != "sim" && h->kind != "usb")
    r.fail(*r.find("kind"), "kind", "must be \"sim\" or \"usb\"");
  r.readString("socket", &h->socket);
  r.readInt("seed", &h->seed, 0, 2147483647);
  r.readString("dump", &h->dump);
  r.readInt("present_deadline_ms", &h->presentDeadlineMs, 1, 60000);
  r.readBool("photometric_variation", &h->photometricVariation);
  if (const toml::node* n = r.find("faults")) {
    const toml::array* a = n->as_array();
    if (!a) r.fail(*n, "faults", "must be an array of strings such as \"2:disconnect\"");
    for (const toml::node& f : *a) {
      if (!f.is_string())
        r.fail(f, "faults", "must be an array of strings such as \"2:disconnect\"");
      h->faults.push_back(f.as_string()->get());
    }
  }
  r.readInt("vid", &h->vid, 0, 0xffff);
  r.readInt("pid", &h->pid, 0, 0xffff);
  if (const toml::table* modules = r.subTable("modules")) {
    for (const auto& [key, node] : *modules) {
      if (!node.is_integer() || node.as_integer()->get() < 0 || node.as_integer()->get() > 1023) {
        r.fail(node, fmt::format("modules.\"{}\"", key.str()), "must be a module index in 0..1023");
      }
      const int module = static_cast<int>(node.as_integer()->get());
      for (const auto& [serial, other] : h->serialToModule) {
        if (other == module) {
          r.fail(node, fmt::format("modules.\"{}\"", key.str()),
                 fmt::format("module {} is already the device with serial \"{}\"", module, serial));
        }
      }
      h->serialToModule[std::string(key.str())] = module;
      h->serialLine[std::string(key.str())] = static_cast<int>(node.source().begin.line);
    }
    h->file = r.file();
  }
  const char* usbOnly[] = {"vid", "pid", "modules"};
  const char* simOnly[] = {"socket", "seed", "faults", "dump", "photometric_variation"};
  for (const char* key : h->kind == "sim" ? std::span<const char* const>(usbOnly)
                                          : std::span<const char* const>(simOnly)) {
    if (const toml::node* n = r.find(key))
      r.fail(*n, key, fmt::format("does not apply to kind = \"{}\"", h->kind));
  }
  if (h->kind == "usb") {
    for (const char* key : {"vid", "pid"}) {
      if (!r.find(key)) r.fail(*r.find("kind"), key, "is required for kind = \"usb\"");
    }
  }
  r.refuseUnknownKeys();
}

void readCalibration(TableReader& r, CalibrationConfig* c) {
  r.readString("file", &c->file);
  r.readString("camera", &c->cameraName);
  r.readString("camera_metadata", &c->cameraMetadata);
  if (const toml::node* n = r.find("camera"); n && !hw::isCameraName(c->cameraName)) {
    // The old form named the camera's metadata here; it still means that.
    const bool metadataFile = c->cameraName.size() > 5 && c->cameraName.ends_with(".json");
    if (!metadataFile || r.find("camera_metadata")) {
      r.fail(
          *n, "camera",
          fmt::format("unknown camera \"{}\": give link, opencv:SPEC or folder:DIR (the camera's "
                      "metadata goes in camera_metadata)",
                      c->cameraName));
    }
    c->cameraMetadata = c->cameraName;
    c->cameraName = "link";
  }
  int pixelStep = 0;
  if (r.find("pixel_step")) {
    r.readInt("pixel_step", &pixelStep, 1, 64);
    c->pixelStep = pixelStep;
  }
  r.readBool("allow_auto_exposure", &c->allowAutoExposure);
  r.readString("station_command", &c->stationCommand);
  r.readBool("auto", &c->autoCalibrate);
  // Above a module's own size, or a metre on the observer line, a limit no longer gates.
  r.readNumber("max_error_px", &c->maxErrorPx, 0.01, 100.0);
  r.readNumber("max_observer_mm", &c->maxObserverMm, 0.1, 1000.0);
  r.readBool("allow_partial", &c->allowPartial);
  r.readString("photometric", &c->photometric);
  if (const toml::node* n = r.find("photometric");
      n && c->photometric != "auto" && c->photometric != "on" && c->photometric != "off") {
    r.fail(*n, "photometric",
           fmt::format("must be \"auto\", \"on\" or \"off\", got \"{}\"", c->photometric));
  }
  r.refuseUnknownKeys();
}

void readScene(TableReader& r, SceneConfig* s) {
  r.readString("script", &s->script);
  if (const toml::node* n = r.find("script"); n && s->script.empty())
    r.fail(*n, "script", "must not be empty");
  r.readNumber("fps", &s->fps, 0.1, 240.0);
  r.readBool("frame_cache", &s->frameCache);
  r.readBool("footprint", &s->footprint);
  if (const toml::table* p = r.subTable("parameters")) {
    TableReader params(*p, r.file(), "scene.parameters.");
    for (const auto& [key, node] : *p) {
      double v = 0.0;
      params.readNumber(std::string(key.str()), &v, -1e9, 1e9);
      s->parameters[std::string(key.str())] = v;
    }
  }
  r.refuseUnknownKeys();
}

void readDaemon(TableReader& r, DaemonConfig* c) {
  r.readString("socket", &c->controlSocket);
  r.readString("cache_dir", &c->cacheDir);
  r.readString("log_level", &c->logLevel);
  static const std::set<std::string> kLevels = {"trace", "debug",    "info", "warn",
                                                "error", "critical", "off"};
  if (!kLevels.count(c->logLevel)) {
    r.fail(*r.find("log_level"), "log_level",
           "must be trace, debug, info, warn, error, critical or off");
  }
  if (c->controlSocket.size() > 100) {
    r.fail(*r.find("socket"), "socket", "a Unix socket path must be shorter than 100 bytes");
  }
  r.refuseUnknownKeys();
}

bool isAddressLiteral(const std::string& address) {
  unsigned char bytes[16];
  return ::inet_pton(AF_INET, address.c_str(), bytes) == 1 ||
         ::inet_pton(AF_INET6, address.c_str(), bytes) == 1;
}

void readPanel(TableReader& r, PanelConfig* p) {
  r.readBool("enabled", &p->enabled);
  r.readString("address", &p->address);
  if (const toml::node* n = r.find("address"); n && !isAddressLiteral(p->address)) {
    r.fail(*n, "address",
           fmt::format("must be an IP address such as \"127.0.0.1\" or \"::1\", got \"{}\"",
                       p->address));
  }
  r.readInt("port", &p->port, 0, 65535);
  r.readString("reports", &p->reports);
  r.refuseUnknownKeys();
}

void readCluster(TableReader& r, ClusterConfig* c) {
  if (const toml::node* n = r.find("modules")) {
    const std::string shape =
        "must be an array with, per rank, an array of module indices: [[0, 1], [2, 3]]";
    const toml::array* ranks = n->as_array();
    if (!ranks || ranks->empty()) r.fail(*n, "modules", shape);
    for (const toml::node& rank : *ranks) {
      const toml::array* modules = rank.as_array();
      if (!modules) r.fail(rank, "modules", shape);
      std::vector<int>& owned = c->modules.emplace_back();
      for (const toml::node& m : *modules) {
        if (!m.is_integer() || m.as_integer()->get() < 0 || m.as_integer()->get() > 1023)
          r.fail(m, "modules", "module indices must be integers in 0..1023");
        owned.push_back(static_cast<int>(m.as_integer()->get()));
      }
    }
    c->file = r.file();
    c->line = static_cast<int>(n->source().begin.line);
  }
  r.readInt("timeout_ms", &c->timeoutMs, 100, 3600000);
  r.refuseUnknownKeys();
}

// The link's timeouts and patch frames ([link]): each key in its range here, with its line; what
// spans keys
// (link_down_retry_max_ms below link_down_retry_ms) is LinkOptions::validate's, named the same.
void readLink(TableReader& r, hw::LinkOptions* l) {
  r.readInt("ack_timeout_ms", &l->ackTimeoutMs, 1, 600000);
  r.readInt("capture_timeout_ms", &l->captureTimeoutMs, 1, 3600000);
  r.readInt("max_retries", &l->maxRetries, 0, 100);
  r.readInt("stall_limit_ms", &l->stallLimitMs, 1, 3600000);
  r.readInt("reconnect_attempts", &l->reconnectAttempts, 0, 100);
  r.readInt("reconnect_delay_ms", &l->reconnectDelayMs, 0, 60000);
  r.readInt("connect_timeout_ms", &l->connectTimeoutMs, 1, 600000);
  r.readInt("link_down_retry_ms", &l->linkDownRetryMs, 0, 3600000);
  r.readInt("link_down_retry_max_ms", &l->linkDownRetryMaxMs, 0, 3600000);
  r.readInt("down_retry_budget_ms", &l->downRetryBudgetMs, 1, 3600000);
  r.readBool("patch_frames", &l->patchFrames);
  r.refuseUnknownKeys();
  try {
    l->validate();
  } catch (const InputError& e) {
    // At its line when the file sets the key; a default at fault is named by
    // DaemonConfig::validate ("link.KEY").
    const std::string& key = e.location().field;
    if (const toml::node* n = r.find(key)) r.fail(*n, key, e.reason());
  }
}

}  // namespace

void DaemonConfig::validate() const {
  auto require = [](bool ok, const char* key, const std::string& why) {
    if (!ok) throw InputError({"", key, 0}, why);
  };
  require(!display.file.empty() || isBuiltInDisplay(display.preset), "display.preset",
          "must be default or demo");
  require(hardware.kind == "sim" || hardware.kind == "usb", "hardware.kind", "must be sim or usb");
  require(hardware.kind != "usb" || (hardware.vid > 0 && hardware.pid > 0), "hardware.vid",
          "usb needs vid and pid");
  require(scene.fps > 0.0 && scene.fps <= 240.0, "scene.fps", "must be in (0, 240]");
  require(!scene.script.empty(), "scene.script", "must not be empty");
  require(isAddressLiteral(panel.address), "panel.address", "must be an IP address literal");
  require(panel.port >= 0 && panel.port <= 65535, "panel.port", "must be in 0..65535");
  try {
    link.validate();
  } catch (const InputError& e) {
    throw InputError({"", "link." + e.location().field, 0}, e.reason());
  }
  require(controlSocketPath().size() < 100, "daemon.socket",
          "a Unix socket path must be shorter than 100 bytes");
  // A preset's size is checked here, before anything of that size exists (a display file's
  // when nominalDisplayOf reads it).
  if (display.file.empty()) nominalDisplayOf(display);
}

std::string DaemonConfig::controlSocketPath() const {
  return controlSocket.empty() ? defaultControlSocketPath() : controlSocket;
}
std::string DaemonConfig::cacheDirPath() const {
  return cacheDir.empty() ? defaultCacheDir() : cacheDir;
}
std::string DaemonConfig::calibrationFilePath() const {
  return calibration.file.empty() ? cacheDirPath() + "/calibration.json" : calibration.file;
}
std::string DaemonConfig::calibrationFileOfRank(int rank) const {
  std::string path = calibrationFilePath();
  const std::string placeholder = "{rank}";
  for (size_t at = path.find(placeholder); at != std::string::npos; at = path.find(placeholder))
    path.replace(at, placeholder.size(), std::to_string(rank));
  return path;
}
std::string DaemonConfig::stateDirPath() const {
  const std::string folder =
      std::filesystem::absolute(calibrationFilePath()).parent_path().string();
  return folder.empty() ? "." : folder;
}
std::string DaemonConfig::reportsDirPath() const {
  return panel.reports.empty() ? stateDirPath() + "/reports" : panel.reports;
}

DaemonConfig parseDaemonConfig(const std::string& text, const std::string& name) {
  toml::table root;
  try {
    root = toml::parse(text, name);
  } catch (const toml::parse_error& e) {
    throw InputError({name, "", static_cast<int>(e.source().begin.line)},
                     std::string(e.description()));
  }
  DaemonConfig config;
  config.sourceFile = name;
  TableReader top(root, name, "");
  using Section = void (*)(TableReader&, DaemonConfig*);
  const std::pair<const char*, Section> sections[] = {
      {"display", [](TableReader& r, DaemonConfig* c) { readDisplay(r, &c->display); }},
      {"hardware", [](TableReader& r, DaemonConfig* c) { readHardware(r, &c->hardware); }},
      {"calibration", [](TableReader& r, DaemonConfig* c) { readCalibration(r, &c->calibration); }},
      {"scene", [](TableReader& r, DaemonConfig* c) { readScene(r, &c->scene); }},
      {"daemon", [](TableReader& r, DaemonConfig* c) { readDaemon(r, c); }},
      {"panel", [](TableReader& r, DaemonConfig* c) { readPanel(r, &c->panel); }},
      {"cluster", [](TableReader& r, DaemonConfig* c) { readCluster(r, &c->cluster); }},
      {"link", [](TableReader& r, DaemonConfig* c) { readLink(r, &c->link); }},
  };
  for (const auto& [section, read] : sections) {
    if (const toml::table* t = top.subTable(section)) {
      TableReader reader(*t, name, std::string(section) + ".");
      read(reader, &config);
    }
  }
  top.refuseUnknownKeys();
  try {
    config.validate();
  } catch (const InputError& e) {
    if (e.location().file.empty()) throw e.inFile(name);
    throw;
  }
  return config;
}

DaemonConfig loadDaemonConfig(const std::string& path) {
  // Only a regular file: a FIFO would block the daemon (and a reload) for ever.
  return parseDaemonConfig(readRegularFile(path, size_t{1} << 20), path);
}

namespace {

// A preset's size is known before its model is made; a file's once its model is read (a
// model is a few hundred bytes a module: the pixels come later, from its size).
void checkDisplaySize(const DisplayModel& model, const DisplayConfig& d) {
  const std::string where = d.file.empty() ? "" : d.file;
  const auto refuse = [&](const char* key, const std::string& why) {
    throw InputError({where, d.file.empty() ? key : "modules", 0}, why);
  };
  if (model.modules.size() > static_cast<size_t>(kMaxDisplayModules)) {
    refuse("display.modules",
           fmt::format("{} modules: at most {}", model.modules.size(), kMaxDisplayModules));
  }
  long long pixels = 0;
  for (const OpticalModule& m : model.modules) {
    if (m.width < 1 || m.height < 1 || m.width > 8192 || m.height > 8192)
      refuse("display.resolution",
             fmt::format("{}x{}: each side must be in 1..8192", m.width, m.height));
    pixels += static_cast<long long>(m.width) * m.height;
  }
  if (pixels > kMaxDisplayPixels) {
    refuse(d.file.empty() ? (d.modules ? "display.modules" : "display.resolution") : "display.file",
           fmt::format("{} modules with {} pixels in all: more than the {} a display may have "
                       "(modules × resolution)",
                       model.modules.size(), pixels, kMaxDisplayPixels));
  }
}

// The in-place list (daemon_config.h): copied from `from` onto `to`.
void copyInPlaceFields(const DaemonConfig& from, DaemonConfig* to) {
  to->sourceFile = from.sourceFile;
  to->scene = from.scene;
  to->calibration.cameraName = from.calibration.cameraName;
  to->calibration.cameraMetadata = from.calibration.cameraMetadata;
  to->calibration.pixelStep = from.calibration.pixelStep;
  to->calibration.allowAutoExposure = from.calibration.allowAutoExposure;
  to->calibration.stationCommand = from.calibration.stationCommand;
  to->calibration.autoCalibrate = from.calibration.autoCalibrate;
  to->calibration.photometric = from.calibration.photometric;
  to->calibration.maxErrorPx = from.calibration.maxErrorPx;
  to->calibration.maxObserverMm = from.calibration.maxObserverMm;
  to->calibration.allowPartial = from.calibration.allowPartial;
  to->logLevel = from.logLevel;
}

// Defaults made explicit, so an omitted key and its default value compare equal.
DaemonConfig resolvedPaths(DaemonConfig c) {
  c.calibration.file = c.calibrationFilePath();
  c.controlSocket = c.controlSocketPath();
  c.cacheDir = c.cacheDirPath();
  return c;
}

}  // namespace

std::vector<std::string> sectionsNeedingRestart(const DaemonConfig& running,
                                                const DaemonConfig& next) {
  DaemonConfig a = resolvedPaths(running), b = resolvedPaths(next);
  copyInPlaceFields(a, &b);  // b now differs from a only where a restart is needed
  std::vector<std::string> sections;
  if (!(a.display == b.display)) sections.push_back("display");
  if (!(a.hardware == b.hardware)) sections.push_back("hardware");
  if (!(a.calibration == b.calibration)) sections.push_back("calibration");
  if (!(a.panel == b.panel)) sections.push_back("panel");
  if (!(a.link == b.link)) sections.push_back("link");
  // Whatever is left ([daemon] and any top-level field) is compared as a whole too.
  b.display = a.display;
  b.hardware = a.hardware;
  b.calibration = a.calibration;
  b.panel = a.panel;
  b.link = a.link;
  if (!(a == b)) sections.push_back("daemon");
  return sections;
}

DaemonConfig withInPlaceChanges(const DaemonConfig& running, const DaemonConfig& next) {
  DaemonConfig applied = running;
  copyInPlaceFields(next, &applied);
  applied.sourceFile = running.sourceFile;
  return applied;
}

DisplayModel nominalDisplayOf(const DisplayConfig& d) {
  if (!d.file.empty()) {
    DisplayModel model = loadDisplayModel(d.file);
    checkDisplaySize(model, d);
    return model;
  }
  NominalDisplayOptions o;
  o.preset = d.preset;
  o.modules = d.modules;
  o.width = d.width;
  o.height = d.height;
  DisplayModel model = makeNominalDisplay(o);
  checkDisplaySize(model, d);
  return model;
}

std::string linkSpecOf(const HardwareConfig& hardware, int modules) {
  if (hardware.kind == "sim") return hardware.socket.empty() ? "" : "simhw:" + hardware.socket;
  std::string spec = fmt::format("usb:{:04x}:{:04x}", hardware.vid, hardware.pid);
  if (hardware.serialToModule.empty()) return spec;  // every matching device, in bus order
  const auto where = [&](const std::string& serial) -> InputLocation {
    const auto line = hardware.serialLine.find(serial);
    return {hardware.file, fmt::format("hardware.modules.\"{}\"", serial),
            line == hardware.serialLine.end() ? 0 : line->second};
  };
  std::vector<std::string> serials(static_cast<size_t>(modules));
  for (const auto& [serial, module] : hardware.serialToModule) {
    if (module >= modules) {
      throw InputError(where(serial), fmt::format("module {} does not exist: the display has {} "
                                                  "(0..{})",
                                                  module, modules, modules - 1));
    }
    if (!serials[static_cast<size_t>(module)].empty()) {
      throw InputError(where(serial),
                       fmt::format("module {} is already the device with serial \"{}\"", module,
                                   serials[static_cast<size_t>(module)]));
    }
    serials[static_cast<size_t>(module)] = serial;
  }
  for (int m = 0; m < modules; ++m) {
    if (serials[static_cast<size_t>(m)].empty()) {
      throw InputError({hardware.file, "hardware.modules", 0},
                       fmt::format("no device serial is mapped to module {}", m));
    }
    spec += (m == 0 ? ":" : ",") + serials[static_cast<size_t>(m)];
  }
  return spec;
}

std::string defaultCacheDir() {
  if (const char* cache = std::getenv("XDG_CACHE_HOME"); cache && *cache)
    return std::string(cache) + "/parallax";
  if (const char* home = std::getenv("HOME"); home && *home)
    return std::string(home) + "/.cache/parallax";
  return fmt::format("/tmp/parallax-{}/cache", ::getuid());
}

}  // namespace parallax::daemon
