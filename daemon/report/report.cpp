#include "daemon/report/report.h"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "calibration/display/display_presets.h"
#include "common/atomic_file.h"
#include "common/input_error.h"
#include "daemon/report/png_twin.h"

namespace parallax::report {
namespace {

std::string csvField(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string escapeHtml(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '&')
      out += "&amp;";
    else if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '"')
      out += "&quot;";
    else
      out += c;
  }
  return out;
}

// Markdown's inline subset the sections write (`code`, [text](link), *emphasis*) as HTML.
std::string inlineHtml(const std::string& text) {
  std::string out;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '`') {
      const size_t end = text.find('`', i + 1);
      if (end != std::string::npos) {
        out += "<code>" + escapeHtml(text.substr(i + 1, end - i - 1)) + "</code>";
        i = end;
        continue;
      }
    } else if (c == '[') {
      const size_t mid = text.find("](", i + 1), end = text.find(')', mid + 2);
      if (mid != std::string::npos && end != std::string::npos) {
        out += fmt::format("<a href=\"{}\">{}</a>", escapeHtml(text.substr(mid + 2, end - mid - 2)),
                           inlineHtml(text.substr(i + 1, mid - i - 1)));
        i = end;
        continue;
      }
    } else if (c == '*' && i + 1 < text.size() && text[i + 1] != ' ') {
      const size_t end = text.find('*', i + 1);
      if (end != std::string::npos) {
        out += "<em>" + inlineHtml(text.substr(i + 1, end - i - 1)) + "</em>";
        i = end;
        continue;
      }
    }
    out += escapeHtml(std::string(1, c));
  }
  return out;
}

const char* const kStyle =
    "body{font-family:'DejaVu Sans',Verdana,sans-serif;max-width:70em;margin:1em auto;"
    "padding:0 1em;line-height:1.4}table{border-collapse:collapse;margin:0.5em 0;font-size:90%}"
    "th,td{border:1px solid #ccc;padding:2px 6px;text-align:right}th{background:#f3f3f3}"
    "td:first-child,th:first-child{text-align:left}figure{margin:1em 0}svg{max-width:100%;"
    "height:auto}.provenance{color:#555;font-size:85%}.rule{font-style:italic}"
    ".pictures{display:flex;flex-wrap:wrap;gap:1em}.pictures img{max-width:100%}";

// A markdown table cell: a `|` would end it.
std::string mdCell(const std::string& text) {
  std::string out;
  for (char c : text) out += c == '|' ? std::string("\\|") : std::string(1, c);
  return out;
}

}  // namespace

void ReportOptions::validate() const {
  if (out.empty()) throw InputError({"", "--out", 0}, "must name a folder");
  if (!(scale == 0.0 || (std::isfinite(scale) && scale >= 0.05 && scale <= 1.0))) {
    throw InputError({"", "--scale", 0}, "must be in [0.05, 1]");
  }
}

std::string partOf(const std::string& part, const std::string& whole) {
  return fmt::format("{} (part of {})", part, whole);
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
  provenance_ = Provenance::collect(options_.commandLine);
  timing_.runs = options_.quick ? 3 : 5;
}

std::string Report::path(const std::string& file) const {
  return (std::filesystem::path(options_.out) / file).string();
}

void Report::heading(const std::string& title) {
  markdown_ << "\n## " << title << "\n";
  html_ << "<h2>" << inlineHtml(title) << "</h2>\n";
}

void Report::text(const std::string& paragraph) {
  markdown_ << "\n" << paragraph << "\n";
  html_ << "<p>" << inlineHtml(paragraph) << "</p>\n";
}

void Report::bullet(const std::string& line) {
  markdown_ << "- " << line << "\n";
  html_ << "<ul><li>" << inlineHtml(line) << "</li></ul>\n";
}

void Report::absent(const std::string& title, const std::string& why) {
  heading(title);
  text(why);
}

void Report::table(const std::string& name, const Table& table) {
  const std::string file = path(name + ".csv");
  std::ofstream csv(file);
  csv << "# " << provenance_.line() << "\n";
  if (!table.rule.empty()) csv << "# times: " << table.rule << "\n";
  auto line = [&](const std::vector<std::string>& fields) {
    for (size_t i = 0; i < fields.size(); ++i) csv << (i ? "," : "") << csvField(fields[i]);
    csv << "\n";
  };
  line(table.header);
  for (const auto& row : table.rows) line(row);
  if (!csv) throw InputError({file, "", 0}, "cannot write the table");

  if (!table.rule.empty()) markdown_ << "\nTimes: " << table.rule << ".\n";
  markdown_ << "\n|";
  for (const std::string& h : table.header) markdown_ << ' ' << mdCell(h) << " |";
  markdown_ << "\n|";
  for (size_t i = 0; i < table.header.size(); ++i) markdown_ << "---|";
  for (const auto& row : table.rows) {
    markdown_ << "\n|";
    for (const std::string& f : row) markdown_ << ' ' << mdCell(f) << " |";
  }
  markdown_ << fmt::format("\n\n[{0}.csv]({0}.csv)\n", name);

  if (!table.rule.empty())
    html_ << "<p class=\"rule\">Times: " << inlineHtml(table.rule) << ".</p>\n";
  html_ << "<table>\n<thead><tr>";
  for (const std::string& h : table.header) html_ << "<th>" << inlineHtml(h) << "</th>";
  html_ << "</tr></thead>\n<tbody>\n";
  for (const auto& row : table.rows) {
    html_ << "<tr>";
    for (const std::string& f : row) html_ << "<td>" << escapeHtml(f) << "</td>";
    html_ << "</tr>\n";
  }
  html_ << fmt::format("</tbody>\n</table>\n<p><a href=\"{0}.csv\">{0}.csv</a></p>\n", name);
}

void Report::figure(const std::string& name, SvgPlot plot) {
  // The HTML states the provenance once at its top; the SVG file carries it as its caption.
  const std::string inlineSvg = plot.render();
  plot.caption = provenance_.line();
  plot.write(path(name + ".svg"));
  const std::string problem = writePngTwin(path(name + ".svg"), path(name + ".png"));
  if (!problem.empty() && pngProblem_.empty()) pngProblem_ = problem;
  markdown_ << fmt::format("\n![{0}]({1}.svg)\n\n[{1}.svg]({1}.svg) · [{1}.png]({1}.png)\n",
                           plot.title, name);
  html_ << fmt::format(
      "<figure>\n{0}<figcaption><a href=\"{1}.svg\">{1}.svg</a> · <a href=\"{1}.png\">{1}.png</a>"
      "</figcaption>\n</figure>\n",
      inlineSvg, name);
}

void Report::images(const std::vector<std::pair<std::string, std::string>>& pictures) {
  markdown_ << "\n|";
  for (const auto& p : pictures) markdown_ << ' ' << p.second << " |";
  markdown_ << "\n|";
  for (size_t i = 0; i < pictures.size(); ++i) markdown_ << "---|";
  markdown_ << "\n|";
  for (const auto& p : pictures) markdown_ << " ![](" << p.first << ") |";
  markdown_ << "\n";
  html_ << "<div class=\"pictures\">\n";
  for (const auto& p : pictures) {
    html_ << fmt::format(
        "<figure><img src=\"{0}\" alt=\"{1}\"/><figcaption>{2}</figcaption></figure>\n",
        escapeHtml(p.first), escapeHtml(p.second), inlineHtml(p.second));
  }
  html_ << "</div>\n";
}

void Report::finish() {
  const std::string title = "Parallax: error against run time";
  const std::string intro = fmt::format("Provenance of every figure here: {}", provenance_.line());
  std::string md = "# " + title + "\n\n" + intro + "\n" + markdown_.str();
  std::string html = fmt::format(
      "<!DOCTYPE html>\n<html xmlns=\"http://www.w3.org/1999/xhtml\" lang=\"en\">\n<head>\n"
      "<meta charset=\"utf-8\"/>\n<title>{}</title>\n<style>{}</style>\n</head>\n<body>\n"
      "<h1>{}</h1>\n<p class=\"provenance\">{}</p>\n",
      escapeHtml(title), kStyle, escapeHtml(title), inlineHtml(intro));
  if (!pngProblem_.empty()) {
    md += "\nPNG twins of the plots were not written: " + pngProblem_ + ".\n";
    html += "<p>PNG twins of the plots were not written: " + escapeHtml(pngProblem_) + ".</p>\n";
  }
  html += html_.str() + "</body>\n</html>\n";
  writeFileAtomically(path("report.md"), md);
  writeFileAtomically(path("report.html"), html);
}

std::string fixed(double value, int decimals) {
  if (!std::isfinite(value)) return value > 0 ? "inf" : (value < 0 ? "-inf" : "nan");
  return fmt::format("{:.{}f}", value, decimals);
}

// Four significant digits, plain from 0.001 to below a million and `1.234e-7` beyond, as the
// plots' tick labels.
std::string general(double value) {
  if (!std::isfinite(value)) return value > 0 ? "inf" : (value < 0 ? "-inf" : "nan");
  const double a = std::abs(value);
  if (a == 0.0) return "0";
  const int exponent = static_cast<int>(std::floor(std::log10(a)));
  if (a < 1e-3 || a >= 1e6) {
    double mantissa = value / std::pow(10.0, exponent);
    int e = exponent;
    if (std::abs(std::stod(fmt::format("{:.3f}", mantissa))) >= 10.0) mantissa /= 10.0, ++e;
    return fmt::format("{:.3f}e{}", mantissa, e);
  }
  return fmt::format("{:.{}f}", value, std::max(0, 3 - exponent));
}

std::string writeReport(const ReportOptions& options) {
  Report report(options);
  const DisplayModel& d = report.display();
  report.text(fmt::format(
      "Display `{}` ({} modules of {}x{}, transfer {}), module {} for the single-module sections. "
      "Tables that time repeated runs state their rule above them; the rule is the same "
      "everywhere ({}), so parts never exceed their wholes.",
      report.options().display, d.modules.size(), d.modules[0].width, d.modules[0].height,
      transferName(d.screen.transfer), report.module(), report.timing().describe()));
  writeFig6Section(report);
  writeErrorVsTimeSection(report);
  writeAntialiasingSection(report);
  writePrecisionSection(report);
  writeTransferSection(report);
  writeTracerOverheadSection(report);
  writeCalibrationSection(report);
  writeCaptureSection(report);
  writePhotometrySection(report);
  writeFrameCacheSection(report);
  writeClusterSection(report);
  report.finish();
  return report.path("report.md");
}

}  // namespace parallax::report
