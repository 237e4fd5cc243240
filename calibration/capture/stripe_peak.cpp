#include "calibration/capture/stripe_peak.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

namespace parallax {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// A lobe as a function of its module's angle: amplitude·exp(−(angle − mean)² / (2·width²)).
struct Lobe {
  double amplitude = 0.0, mean = 0.0, width = 0.0;

  double at(double angle) const {
    const double u = (angle - mean) / width;
    return amplitude * std::exp(-0.5 * u * u);
  }
};

// The Gaussian through one module's pixels (contrast with the neighbours' lobes removed), by
// weighted least squares of log contrast = a + b·t + c·t², t the angle about the brightest
// pixel's in units of the run's angular extent (keeps the normal equations well scaled).
// Weights contrast²: the log's noise falls as 1/contrast.
// A bright end is a cut (the module's image or the screen ended there) unless the stripe runs
// on into a neighbour's pixels: that is a valley between two lobes, whose overlap the rounds
// remove.
std::optional<Lobe> fitLobe(const std::vector<double>& x, const std::vector<double>& angle,
                            const std::vector<double>& contrast, const std::vector<bool>& clipped,
                            bool frontIsValley, bool backIsValley,
                            const StripePeakOptions& options) {
  const size_t n = angle.size();
  if (n < 3) return std::nullopt;
  size_t top = 0;
  for (size_t i = 1; i < n; ++i) {
    if (contrast[i] > contrast[top]) top = i;
  }
  const double peak = contrast[top];
  if (!(peak > 0.0) || !std::isfinite(peak)) return std::nullopt;
  if (!frontIsValley && contrast.front() > options.cutFraction * peak) return std::nullopt;
  if (!backIsValley && contrast.back() > options.cutFraction * peak) return std::nullopt;
  double spread = 0.0;
  for (double a : angle) spread = std::max(spread, std::abs(a - angle[top]));
  if (!(spread > 0.0) || !std::isfinite(spread)) return std::nullopt;
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  int used = 0;
  double tMin = 0.0, tMax = 0.0;
  // Next to a cut the lens blurred the edge with the dark beyond it: those pixels are darker
  // than the lobe, and would pull the vertex away from the cut.
  const double frontGuard = frontIsValley ? -kInf : x.front() + options.cutGuardPx;
  const double backGuard = backIsValley ? kInf : x.back() - options.cutGuardPx;
  for (size_t i = 0; i < n; ++i) {
    if (!(contrast[i] >= options.fitFraction * peak) || clipped[i]) continue;
    if (x[i] < frontGuard || x[i] > backGuard) continue;
    const double t = (angle[i] - angle[top]) / spread;
    if (!std::isfinite(t)) return std::nullopt;
    const Eigen::Vector3d row(1.0, t, t * t);
    const double w = contrast[i] * contrast[i];
    normal += w * row * row.transpose();
    rhs += w * row * std::log(contrast[i]);
    tMin = std::min(tMin, t);
    tMax = std::max(tMax, t);
    ++used;
  }
  if (used < options.minFitSamples) return std::nullopt;
  const Eigen::Vector3d c = normal.ldlt().solve(rhs);
  if (!c.allFinite() || !(c[2] < 0.0)) return std::nullopt;
  const double tPeak = -c[1] / (2.0 * c[2]);
  if (!(tPeak >= tMin && tPeak <= tMax)) return std::nullopt;
  Lobe lobe;
  lobe.mean = angle[top] + tPeak * spread;
  lobe.width = spread * std::sqrt(-0.5 / c[2]);
  lobe.amplitude = std::exp(c[0] - c[1] * c[1] / (4.0 * c[2]));
  if (!std::isfinite(lobe.width) || !std::isfinite(lobe.amplitude)) return std::nullopt;
  return lobe;
}

// The camera x where the angle passes through `target`, between the two samples that bracket it.
std::optional<double> cameraXAtAngle(const std::vector<double>& x, const std::vector<double>& angle,
                                     double target) {
  for (size_t i = 0; i + 1 < x.size(); ++i) {
    const double a0 = angle[i] - target, a1 = angle[i + 1] - target;
    if (a0 == 0.0) return x[i];
    if ((a0 < 0.0) != (a1 < 0.0)) return x[i] + a0 / (a0 - a1) * (x[i + 1] - x[i]);
  }
  if (!angle.empty() && angle.back() == target) return x.back();
  return std::nullopt;
}

// Whether the pixel next to row[i] (one camera pixel to the side) is lit and given to another
// module.
bool bordersNeighbour(const std::vector<StripeRowSample>& row, size_t i, int side) {
  const auto j = static_cast<std::ptrdiff_t>(i) + side;
  if (j < 0 || j >= static_cast<std::ptrdiff_t>(row.size())) return false;
  const StripeRowSample& next = row[static_cast<size_t>(j)];
  return next.owner != row[i].owner && std::abs(next.x - row[i].x - side) < 0.5;
}

}  // namespace

std::vector<std::optional<double>> stripePeaksInRow(const std::vector<StripeRowSample>& row,
                                                    int groupSize, const StripePeakOptions& options,
                                                    std::vector<double>* widths) {
  const auto modules = static_cast<size_t>(std::max(groupSize, 0));
  std::vector<std::optional<Lobe>> lobes(modules);
  std::vector<std::vector<size_t>> owned(modules);
  for (size_t i = 0; i < row.size(); ++i) {
    if (row[i].owner >= 0 && static_cast<size_t>(row[i].owner) < modules &&
        row[i].angles.size() == modules) {
      owned[static_cast<size_t>(row[i].owner)].push_back(i);
    }
  }
  std::vector<std::optional<double>> peaks(modules);
  std::vector<double> x, angle, contrast;
  std::vector<bool> clipped;
  // Module m's pixels with the fitted neighbours' lobes taken out.
  const auto ownSamples = [&](size_t m) {
    x.clear();
    angle.clear();
    contrast.clear();
    clipped.clear();
    for (size_t i : owned[m]) {
      double own = row[i].contrast;
      for (size_t other = 0; other < modules; ++other) {
        if (other != m && lobes[other]) own -= lobes[other]->at(row[i].angles[other]);
      }
      x.push_back(row[i].x);
      angle.push_back(row[i].angles[m]);
      contrast.push_back(own);
      clipped.push_back(row[i].clipped);
    }
  };
  const auto fitOwn = [&](size_t m) {
    const bool frontIsValley = !owned[m].empty() && bordersNeighbour(row, owned[m].front(), -1);
    const bool backIsValley = !owned[m].empty() && bordersNeighbour(row, owned[m].back(), +1);
    return fitLobe(x, angle, contrast, clipped, frontIsValley, backIsValley, options);
  };
  for (int round = 0; round <= options.rounds; ++round) {
    for (size_t m = 0; m < modules; ++m) {
      ownSamples(m);
      // In place (Gauss–Seidel): the next module already sees this one's refined lobe.
      lobes[m] = fitOwn(m);
      if (round == options.rounds && lobes[m]) peaks[m] = cameraXAtAngle(x, angle, lobes[m]->mean);
    }
  }
  // A neighbour whose lobe could not be fitted (its peak cut by its image's or the screen's
  // edge, or never on this row) still lights this stripe's flank where its angle is small, and
  // nothing subtracted it: the peak is pulled toward it. With wide lobes it need not even own a
  // pixel of the row (a 4-module display's 42° lobes from an end station: 5 mm on the observer
  // line). Its light is predicted as a lobe of this one's width and amplitude centred where its
  // angle is zero, taken out, and the stripe refitted: if that moves the peak by more than
  // maxNeighbourBias, the centre is not known, so none is given.
  for (size_t m = 0; m < modules; ++m) {
    if (!peaks[m]) continue;
    ownSamples(m);
    const Lobe guess{lobes[m]->amplitude, 0.0, lobes[m]->width};
    bool unfitted = false;
    for (size_t other = 0; other < modules; ++other) {
      if (other == m || lobes[other]) continue;
      unfitted = true;
      for (size_t k = 0; k < owned[m].size(); ++k)
        contrast[k] -= guess.at(row[owned[m][k]].angles[other]);
    }
    if (!unfitted) continue;
    const std::optional<Lobe> cleaned = fitOwn(m);
    if (!cleaned || !(std::abs(cleaned->mean - lobes[m]->mean) <= options.maxNeighbourBias))
      peaks[m].reset();
  }
  if (widths) {
    widths->assign(modules, std::numeric_limits<double>::quiet_NaN());
    for (size_t m = 0; m < modules; ++m)
      if (peaks[m] && lobes[m]) (*widths)[m] = lobes[m]->width;
  }
  return peaks;
}

}  // namespace parallax
