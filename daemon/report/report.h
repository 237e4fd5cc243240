#pragma once
// `parallax report`: the markdown report with its CSV tables and SVG plots (issue 7). Report
// holds what every section shares: the output folder, the markdown being written, and the
// stamp every table and figure carries (machine, command line, date).

#include <sstream>
#include <string>
#include <vector>

#include "calibration/display/display_model.h"
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

struct Table {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
};

class Report {
 public:
  Report(const ReportOptions& options);

  const ReportOptions& options() const { return options_; }
  const DisplayModel& display() const { return display_; }
  int module() const { return module_; }            // the module the single-module sections use
  std::string path(const std::string& file) const;  // inside the output folder

  std::ostringstream& md() { return markdown_; }
  // "machine: ..., command: ..., date: ..." for captions and under every table.
  const std::string& stamp() const { return stamp_; }
  // Writes the table as NAME.csv and into the markdown, followed by the stamp.
  void table(const std::string& name, const Table& table);
  // Writes the plot as NAME.svg (with the stamp as caption) and links it from the markdown.
  void figure(const std::string& name, SvgPlot plot);
  void image(const std::string& file, const std::string& caption);
  void finish();  // writes report.md

 private:
  ReportOptions options_;
  DisplayModel display_;
  int module_ = 0;
  std::string stamp_;
  std::ostringstream markdown_;
};

// The sections, one file each (report_*.cpp).
void writeFig6Section(Report& report);
void writeErrorVsTimeSection(Report& report);
void writeAntialiasingSection(Report& report);
void writePrecisionSection(Report& report);
void writeTransferSection(Report& report);
void writeCalibrationSection(Report& report);
void writePhotometrySection(Report& report);

// Runs every section; returns report.md's path.
std::string writeReport(const ReportOptions& options);

// A display with every module's resolution and intrinsics scaled by `factor` (same rays at the
// same continuous image positions, fewer pixels).
DisplayModel scaleDisplayResolution(const DisplayModel& model, double factor);

// Shared formatting.
std::string fixed(double value, int decimals);
std::string general(double value);
// Wall-clock ms of `run`, the minimum over repetitions until ~`budgetMs` is spent (at least 3
// unless a run takes over a second, at most `maxRuns`): the least disturbed run on a shared
// machine.
template <typename F>
double timeMs(F&& run, double budgetMs = 300.0, int maxRuns = 5);

}  // namespace parallax::report

#include "daemon/report/report_timing.h"
