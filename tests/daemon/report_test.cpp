// The report's building blocks (issue 25): the timing rule keeps parts under wholes, plot axes
// tick every decade and count in whole numbers with one number format, plots keep every text
// on the canvas and tell series apart, and the core count follows the affinity mask.

#include "daemon/report/report.h"

#include <OpenImageIO/imagebuf.h>
#include <gtest/gtest.h>
#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <regex>
#include <set>
#include <thread>

#include "daemon/report/plot_axis.h"
#include "daemon/report/png_twin.h"
#include "daemon/report/provenance.h"
#include "daemon/report/report_timing.h"
#include "daemon/report/svg_plot.h"
#include "daemon/report/text_metrics.h"

namespace parallax::report {
namespace {

// Busy for `ms` milliseconds (a sleep could be cut short or stretched; this cannot be shorter).
void spin(double ms) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double, std::milli>(ms);
  while (std::chrono::steady_clock::now() < end) {
  }
}

TEST(ReportTiming, PartMediansNeverExceedTheWholeMedian) {
  // Runs whose part is most of a fast run and little of a slow one: a part taken from another
  // run than its whole (the old best-of-N beside last-run figures) would exceed it.
  std::mt19937 random(25);
  std::uniform_real_distribution<double> ms(0.2, 3.0);
  for (int trial = 0; trial < 5; ++trial) {
    TimingRule rule;
    rule.runs = 5;
    const MedianTimes t = timeMedian(rule, 2, [&](std::vector<double>& parts) {
      const double a = ms(random), b = ms(random);
      auto timed = [](double spinMs) {
        const auto start = std::chrono::steady_clock::now();
        spin(spinMs);
        return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
            .count();
      };
      parts[0] += timed(a);
      parts[1] += timed(b);
      spin(ms(random));
    });
    EXPECT_EQ(t.runs, 5);
    ASSERT_EQ(t.partsMs.size(), 2u);
    EXPECT_LE(t.partsMs[0], t.ms);
    EXPECT_LE(t.partsMs[1], t.ms);
    EXPECT_GT(t.partsMs[0], 0.0);
  }
}

TEST(ReportTiming, MedianOfDominatedSamplesIsDominated) {
  // The argument report_timing.h rests on: p_i ≤ w_i for every i ⇒ median(p) ≤ median(w).
  std::mt19937 random(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 1000; ++trial) {
    const int n = 1 + trial % 8;
    std::vector<double> whole, part;
    for (int i = 0; i < n; ++i) {
      whole.push_back(10 * u(random));
      part.push_back(whole.back() * u(random));
    }
    EXPECT_LE(median(part), median(whole));
  }
  EXPECT_EQ(median({3, 1, 2}), 2);
  EXPECT_EQ(median({4, 1, 2, 3}), 2.5);
  EXPECT_EQ(TimingRule{}.describe().rfind("median of 5 runs after 1 warm-up run", 0), 0u);
}

TEST(PlotAxis, LogAxisHasATickAtEveryDecade) {
  const PlotAxis axis = PlotAxis::fit({3e-7, 0.02, 150.0}, true, false);
  std::set<int> decades;
  for (const PlotAxis::Tick& t : axis.ticks()) {
    if (!t.label.empty() && std::abs(t.at - std::round(t.at)) < 1e-9)
      decades.insert(static_cast<int>(std::round(t.at)));
  }
  for (int e = -7; e <= 3; ++e) EXPECT_TRUE(decades.count(e)) << "no tick at 1e" << e;
  // Within one decade: still two decade ticks, and 2 and 5 between them.
  const PlotAxis narrow = PlotAxis::fit({0.3, 0.45}, true, false);
  std::vector<std::string> labels;
  for (const PlotAxis::Tick& t : narrow.ticks())
    if (!t.label.empty()) labels.push_back(t.label);
  EXPECT_EQ(labels, (std::vector<std::string>{"0.1", "0.2", "0.5", "1"}));
}

TEST(PlotAxis, CountAxesTickOnWholeNumbersOnly) {
  for (const std::vector<double>& counts :
       {std::vector<double>{3, 5}, std::vector<double>{2, 3, 5, 9}, std::vector<double>{0, 47}}) {
    const PlotAxis axis = PlotAxis::fit(counts, false, true);
    const std::vector<PlotAxis::Tick> ticks = axis.ticks();
    EXPECT_GE(ticks.size(), 2u);
    for (const PlotAxis::Tick& t : ticks) {
      EXPECT_EQ(t.at, std::round(t.at)) << t.label;
      EXPECT_EQ(t.label.find('.'), std::string::npos) << t.label;
    }
  }
}

TEST(PlotAxis, OneNumberFormatPerAxis) {
  // The mix: `1e-05` beside `0.0001` on one axis.
  const std::vector<std::string> small = tickLabels({1e-5, 1e-4, 1e-3, 1e-2}, true);
  EXPECT_EQ(small, (std::vector<std::string>{"1e-5", "1e-4", "1e-3", "1e-2"}));
  const std::vector<std::string> plain = tickLabels({0.001, 0.01, 0.1, 1, 10}, true);
  EXPECT_EQ(plain, (std::vector<std::string>{"0.001", "0.01", "0.1", "1", "10"}));
  const std::vector<std::string> linear = tickLabels({0, 0.5, 1, 1.5}, false);
  EXPECT_EQ(linear, (std::vector<std::string>{"0.0", "0.5", "1.0", "1.5"}));
  EXPECT_EQ(general(1.234567e-7), "1.235e-7");
  EXPECT_EQ(general(0.012346), "0.01235");
  EXPECT_EQ(general(1234.6), "1235");
  EXPECT_EQ(general(9.9996e-4), "1.000e-3");
}

SvgPlot crowdedPlot() {
  SvgPlot plot;
  plot.title = "a title long enough to matter: position error against time (module 7 of default)";
  plot.xLabel = "ms / frame";
  plot.yLabel = "RMS position error (mm, physical)";
  plot.logX = plot.logY = true;
  plot.caption = std::string(400, 'x') + " machine: words words words words";
  for (int k = 0; k < 4; ++k) {
    PlotSeries s;
    s.label = k == 3 ? "a legend label far longer than any the report writes, run off the canvas"
                     : "series " + std::to_string(k);
    for (int i = 0; i < 6; ++i) {
      s.x.push_back(std::pow(10.0, 0.3 * i + 0.05 * k));
      s.y.push_back(std::pow(10.0, -0.5 * i));
      s.pointLabels.push_back("L" + std::to_string(i));
    }
    plot.series.push_back(s);
  }
  // Two series on exactly the same points (the tracer and its depth-1 run).
  plot.series.push_back(plot.series[0]);
  plot.series.back().label = "series 0 again";
  return plot;
}

TEST(SvgPlot, EveryTextStaysOnTheCanvas) {
  SvgPlot::Layout layout;
  const std::string svg = crowdedPlot().render(&layout);
  ASSERT_GT(layout.texts.size(), 20u);
  for (const TextBox& b : layout.texts) {
    EXPECT_GE(b.x0, 0.0) << b.text;
    EXPECT_GE(b.y0, 0.0) << b.text;
    EXPECT_LE(b.x1, layout.width) << b.text;
    EXPECT_LE(b.y1, layout.height) << b.text;
  }
  // The long legend went under the frame rather than past the canvas's edge.
  for (const TextBox& b : layout.texts) {
    if (b.text.rfind("a legend label", 0) == 0) {
      EXPECT_GT(b.y0, layout.plotY1);
    }
  }
  EXPECT_NE(svg.find("width=\"" + std::to_string(static_cast<int>(layout.width)) + "\""),
            std::string::npos);
}

TEST(SvgPlot, PointLabelsDoNotCoverEachOther) {
  SvgPlot plot;
  PlotSeries s;
  s.label = "spp";
  for (int n : {1, 4, 9, 16}) {
    s.x.push_back(10.0 * n);
    s.y.push_back(1.0 / n);
    s.pointLabels.push_back(std::to_string(n) + " spp");
  }
  plot.series = {s};
  plot.logX = plot.logY = true;
  SvgPlot::Layout layout;
  plot.render(&layout);
  std::vector<TextBox> labels;
  for (const TextBox& b : layout.texts)
    if (b.text.find(" spp") != std::string::npos) labels.push_back(b);
  ASSERT_EQ(labels.size(), 4u);
  for (size_t i = 0; i < labels.size(); ++i) {
    EXPECT_GE(labels[i].x0, layout.plotX0);
    EXPECT_LE(labels[i].x1, layout.plotX1);
    for (size_t j = i + 1; j < labels.size(); ++j) {
      const bool apart = labels[i].x1 <= labels[j].x0 || labels[j].x1 <= labels[i].x0 ||
                         labels[i].y1 <= labels[j].y0 || labels[j].y1 <= labels[i].y0;
      EXPECT_TRUE(apart) << labels[i].text << " covers " << labels[j].text;
    }
  }
}

TEST(SvgPlot, SeriesDifferInMarkerShapeAndColour) {
  const std::string svg = crowdedPlot().render();
  // Series 0 and its copy (series 4) sit on the same points: different shape and colour.
  const std::regex circle("<circle [^>]*stroke=\"(#[0-9a-f]{6})\"");
  const std::regex polygon("<polygon [^>]*stroke=\"(#[0-9a-f]{6})\"");
  std::smatch a, b;
  ASSERT_TRUE(std::regex_search(svg, a, circle));
  ASSERT_TRUE(std::regex_search(svg, b, polygon));
  EXPECT_NE(a[1].str(), b[1].str());
  EXPECT_TRUE(std::regex_search(svg, std::regex("<rect x=[^>]*fill=\"white\"")));  // squares
}

// The layout is only as good as its widths: each text drawn by the PNG twin's renderer must end
// where the writer measured it to (a caption measured 740 px wide drew 753, past its canvas).
TEST(TextMetrics, WidthsAreWhatThePngTwinDraws) {
  ASSERT_FALSE(plotFontFile().empty()) << "fonts-dejavu-core is not installed";
  const std::filesystem::path folder =
      std::filesystem::temp_directory_path() / ("plx-text-" + std::to_string(::getpid()));
  std::filesystem::create_directories(folder);
  const std::vector<std::pair<std::string, int>> texts = {
      {"machine: Intel(R) Xeon(R) Processor, 2 cores available, Linux 6.18.44-fc-v1045 x86_64, "
       "load average 3.51 at the start; build: parallax 0.1.0 (03e8781),",
       10},
      {"frame cache: memory against display frame rate", 15},
      {"RMS position error (mm, physical) 1e-5 0.0001 L0 L5 16 spp float16", 11},
      {"WWWWWWWWWWWWWWWWWWWWWWWWWWWWWWWW iiiiiiiiiiiiiiiiiiiiiiiiiii", 10}};
  for (size_t i = 0; i < texts.size(); ++i) {
    const auto& [text, size] = texts[i];
    // One line on a canvas wider than it, black on white, starting at x = 10.
    // A file name of its own: OpenImageIO's cache would hand back an earlier line's picture.
    const std::string name = "line" + std::to_string(i);
    const std::string svg = (folder / (name + ".svg")).string(),
                      png = (folder / (name + ".png")).string();
    std::ofstream(svg) << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"1600\" height=\"40\" "
                          "font-family=\"DejaVu Sans, Verdana, sans-serif\"><rect width=\"100%\" "
                          "height=\"100%\" fill=\"white\"/><text x=\"10\" y=\"25\" font-size=\""
                       << size << "\">" << text << "</text></svg>";
    ASSERT_EQ(writePngTwin(svg, png), "") << "rsvg-convert (librsvg2-bin)";
    OIIO::ImageBuf picture(png);
    ASSERT_TRUE(picture.read()) << picture.geterror();
    int right = 0;  // the last column with ink
    for (int y = 0; y < picture.spec().height; ++y)
      for (int x = 0; x < picture.spec().width; ++x)
        if (picture.getchannel(x, y, 0, 0) < 0.5f) right = std::max(right, x + 1);
    const double measured = 10.0 + textWidth(text, size);
    EXPECT_GE(measured, right - 1.5) << size << " px: " << text;
    EXPECT_LE(measured, right + 0.02 * (right - 10) + 2.0) << size << " px: " << text;
  }
  std::filesystem::remove_all(folder);
}

TEST(Provenance, CoresComeFromTheAffinityMask) {
  // What `taskset -c N` does: the thread may run on one CPU (the first it may use now),
  // whatever the machine has.
  int inside = -1;
  std::thread pinned([&] {
    cpu_set_t allowed, one;
    CPU_ZERO(&allowed);
    CPU_ZERO(&one);
    if (sched_getaffinity(0, sizeof allowed, &allowed) != 0) return;
    int first = 0;
    while (first < CPU_SETSIZE && !CPU_ISSET(first, &allowed)) ++first;
    CPU_SET(first, &one);
    if (sched_setaffinity(0, sizeof one, &one) == 0) inside = affinityCoreCount();
  });
  pinned.join();
  EXPECT_EQ(inside, 1);
  const Provenance p = Provenance::collect("parallax report --quick");
  EXPECT_GE(p.cores, 1);
  const std::string line = p.line();
  EXPECT_NE(line.find("machine: "), std::string::npos);
  EXPECT_NE(line.find(" available"), std::string::npos);
  EXPECT_NE(line.find("build: parallax "), std::string::npos);
  EXPECT_NE(line.find("command: `parallax report --quick`"), std::string::npos);
  EXPECT_NE(line.find("UTC"), std::string::npos);
}

}  // namespace
}  // namespace parallax::report
