#pragma once
// `parallax report`: the error-against-run-time report (issues 7, 25). Report holds what every
// section shares: the output folder, the document being written — as report.md and, with the
// same content and the plots inline, report.html, which opens in a browser with no server —
// the provenance every file states once, and the timing rule (report_timing.h).

#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "calibration/display/display_model.h"
#include "daemon/report/provenance.h"
#include "daemon/report/report_timing.h"
#include "daemon/report/svg_plot.h"

namespace parallax::report {

struct ReportOptions {
  std::string out = "parallax-report";
  std::string display;  // empty: `default`, or `demo` with --quick
  double scale = 0.0;   // module resolution factor; 0: 1, or 0.25 with --quick
  bool quick = false;   // CI: demo display, small resolution, fewer levels: seconds
  std::string commandLine;

  void validate() const;  // throws InputError naming the option
};

// A column whose header ends in " (part of WHOLE)" is a part of the column named WHOLE, row by
// row; the report's test checks that no part exceeds its whole.
std::string partOf(const std::string& part, const std::string& whole);

struct Table {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  std::string rule = {};  // how its times were taken, stated above it; "" when it holds none
};

class Report {
 public:
  explicit Report(const ReportOptions& options);

  const ReportOptions& options() const { return options_; }
  const DisplayModel& display() const { return display_; }
  int module() const { return module_; }            // the module the single-module sections use
  std::string path(const std::string& file) const;  // inside the output folder
  const Provenance& provenance() const { return provenance_; }
  const TimingRule& timing() const { return timing_; }  // for every table that repeats runs

  // Text is markdown's inline subset: `code`, [text](link), *emphasis*.
  void heading(const std::string& title);
  void text(const std::string& paragraph);
  void bullet(const std::string& line);
  // A trade-off section whose feature this build does not have: its heading and one line.
  void absent(const std::string& title, const std::string& why);
  // NAME.csv (provenance on its first line, after `# `) and the table in the document.
  void table(const std::string& name, const Table& table);
  // NAME.svg (provenance as its caption) and NAME.png; inline in the HTML.
  void figure(const std::string& name, SvgPlot plot);
  // Pictures side by side: (file in the output folder, caption).
  void images(const std::vector<std::pair<std::string, std::string>>& pictures);
  void finish();  // writes report.md and report.html

 private:
  ReportOptions options_;
  DisplayModel display_;
  int module_ = 0;
  Provenance provenance_;
  TimingRule timing_;
  std::string pngProblem_;  // why PNG twins are missing, said once
  std::ostringstream markdown_, html_;
};

// The sections, one file each (report_*.cpp).
void writeFig6Section(Report& report);
void writeErrorVsTimeSection(Report& report);
void writeAntialiasingSection(Report& report);
void writePrecisionSection(Report& report);
void writeTransferSection(Report& report);
void writeTracerOverheadSection(Report& report);
void writeCalibrationSection(Report& report);
void writeCaptureSection(Report& report);
void writePhotometrySection(Report& report);
void writeFrameCacheSection(Report& report);
void writeClusterSection(Report& report);

// Runs every section; returns report.md's path.
std::string writeReport(const ReportOptions& options);

// A display with every module's resolution and intrinsics scaled by `factor` (same rays at the
// same continuous image positions, fewer pixels).
DisplayModel scaleDisplayResolution(const DisplayModel& model, double factor);

// Shared formatting.
std::string fixed(double value, int decimals);
std::string general(double value);

}  // namespace parallax::report
