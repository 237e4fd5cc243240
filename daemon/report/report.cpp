#include "daemon/report/report.h"

#include <fmt/format.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <thread>

#include "calibration/display/display_presets.h"
#include "common/atomic_file.h"
#include "common/input_error.h"

namespace parallax::report {
namespace {

std::string cpuModel() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) {
      const size_t colon = line.find(':');
      if (colon != std::string::npos) return line.substr(line.find_first_not_of(' ', colon + 1));
    }
  }
  return "unknown CPU";
}

std::string machine() {
  utsname u{};
  std::string system = "unknown system";
  if (uname(&u) == 0) system = fmt::format("{} {} {}", u.sysname, u.release, u.machine);
  double load[3] = {0, 0, 0};
  const bool haveLoad = getloadavg(load, 3) == 3;
  return fmt::format("{}, {}, {} cores{}", system, cpuModel(), std::thread::hardware_concurrency(),
                     haveLoad ? fmt::format(", load average {:.2f} at the start", load[0]) : "");
}

std::string now() {
  const std::time_t t = std::time(nullptr);
  char text[64];
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M:%S UTC", std::gmtime(&t));
  return text;
}

std::string csvField(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

}  // namespace

void ReportOptions::validate() const {
  if (out.empty()) throw InputError({"", "--out", 0}, "must name a folder");
  if (!(scale == 0.0 || (std::isfinite(scale) && scale >= 0.05 && scale <= 1.0))) {
    throw InputError({"", "--scale", 0}, "must be in [0.05, 1]");
  }
}

DisplayModel scaleDisplayResolution(const DisplayModel& model, double factor) {
  DisplayModel out = model;
  if (factor == 1.0) return out;
  for (OpticalModule& m : out.modules) {
    const int w = std::max(8, static_cast<int>(std::lround(m.width * factor)));
    const int h = std::max(8, static_cast<int>(std::lround(m.height * factor)));
    // Continuous image coordinates scale with the pixel grid (centres at +0.5 on both).
    const double sx = static_cast<double>(w) / m.width, sy = static_cast<double>(h) / m.height;
    m.fx *= sx, m.cx *= sx, m.fy *= sy, m.cy *= sy;
    m.width = w, m.height = h;
  }
  out.validate();
  return out;
}

Report::Report(const ReportOptions& options) : options_(options) {
  options_.validate();
  if (options_.display.empty()) options_.display = options_.quick ? "demo" : "default";
  if (options_.scale == 0.0) options_.scale = options_.quick ? 0.25 : 1.0;
  display_ = scaleDisplayResolution(resolveDisplay(options_.display), options_.scale);
  module_ = static_cast<int>(display_.modules.size() / 2);
  std::filesystem::create_directories(options_.out);
  stamp_ =
      fmt::format("machine: {}; command: `{}`; date: {}", machine(), options_.commandLine, now());
}

std::string Report::path(const std::string& file) const {
  return (std::filesystem::path(options_.out) / file).string();
}

void Report::table(const std::string& name, const Table& table) {
  std::ofstream csv(path(name + ".csv"));
  auto line = [&](const std::vector<std::string>& fields) {
    for (size_t i = 0; i < fields.size(); ++i) csv << (i ? "," : "") << csvField(fields[i]);
    csv << "\n";
  };
  line(table.header);
  for (const auto& row : table.rows) line(row);
  if (!csv) throw InputError({path(name + ".csv"), "", 0}, "cannot write the table");
  markdown_ << "\n|";
  for (const std::string& h : table.header) markdown_ << ' ' << h << " |";
  markdown_ << "\n|";
  for (size_t i = 0; i < table.header.size(); ++i) markdown_ << "---|";
  for (const auto& row : table.rows) {
    markdown_ << "\n|";
    for (const std::string& f : row) markdown_ << ' ' << f << " |";
  }
  markdown_ << fmt::format("\n\n[{0}.csv]({0}.csv) — {1}\n", name, stamp_);
}

void Report::figure(const std::string& name, SvgPlot plot) {
  plot.caption = stamp_;
  plot.write(path(name + ".svg"));
  markdown_ << fmt::format("\n![{0}]({1}.svg)\n", plot.title, name);
}

void Report::image(const std::string& file, const std::string& caption) {
  markdown_ << fmt::format("\n![{0}]({1})\n*{0}* — {2}\n", caption, file, stamp_);
}

void Report::finish() { writeFileAtomically(path("report.md"), markdown_.str()); }

std::string fixed(double value, int decimals) {
  if (!std::isfinite(value)) return value > 0 ? "inf" : (value < 0 ? "-inf" : "nan");
  return fmt::format("{:.{}f}", value, decimals);
}

std::string general(double value) {
  if (!std::isfinite(value)) return value > 0 ? "inf" : (value < 0 ? "-inf" : "nan");
  return fmt::format("{:.4g}", value);
}

std::string writeReport(const ReportOptions& options) {
  Report report(options);
  const DisplayModel& d = report.display();
  report.md() << fmt::format(
      "# Parallax: error against run time\n\n"
      "Display `{}` ({} modules of {}x{}, transfer {}), module {} for the single-module "
      "sections.\n\n{}\n",
      report.options().display, d.modules.size(), d.modules[0].width, d.modules[0].height,
      transferName(d.screen.transfer), report.module(), report.stamp());
  writeFig6Section(report);
  writeErrorVsTimeSection(report);
  writeAntialiasingSection(report);
  writePrecisionSection(report);
  writeTransferSection(report);
  writeCalibrationSection(report);
  writePhotometrySection(report);
  report.finish();
  return report.path("report.md");
}

}  // namespace parallax::report
