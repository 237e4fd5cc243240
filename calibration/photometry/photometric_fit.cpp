#include "calibration/photometry/photometric_fit.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "calibration/display/colour_difference.h"
#include "common/input_error.h"

namespace parallax {
namespace {

const Eigen::Vector3d kWhite(1.0, 1.0, 1.0);  // D65 in linear sRGB

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  auto mid = v.begin() + static_cast<long>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// The quadratic surface a + b x + c y + d x² + e xy + f y² over the image in [−1, 1]².
using Surface = Eigen::Matrix<double, 6, 1>;
Surface::PlainObject terms(double x, double y) {
  Surface t;
  t << 1.0, x, y, x * x, x * y, y * y;
  return t;
}

struct ModuleFit {
  ModulePhotometricFigures figures;
  Surface surface = Surface::Zero();  // luminance of full white
  double surfaceMax = 1.0;
  std::array<std::array<float, 256>, 3> response{};
  int width = 0, height = 0;

  double falloffAt(double u, double v) const {
    const double s = terms(2.0 * u / width - 1.0, 2.0 * v / height - 1.0).dot(surface) / surfaceMax;
    return std::clamp(s, 1.0 / 16.0, 1.0);
  }
};

// Monotone response table through (0, 0), the measured (level, light) points and (255, 1).
std::array<float, 256> responseTable(const std::vector<int>& levels, std::vector<double> light,
                                     double gamma) {
  // Pool adjacent violators: the least-squares non-decreasing fit to the measured points.
  std::vector<double> value, weight;
  std::vector<int> count;
  for (double l : light) {
    value.push_back(l);
    weight.push_back(1.0);
    count.push_back(1);
    while (value.size() > 1 && value[value.size() - 2] > value.back()) {
      const size_t n = value.size();
      const double w = weight[n - 2] + weight[n - 1];
      value[n - 2] = (value[n - 2] * weight[n - 2] + value[n - 1] * weight[n - 1]) / w;
      weight[n - 2] = w;
      count[n - 2] += count[n - 1];
      value.pop_back();
      weight.pop_back();
      count.pop_back();
    }
  }
  std::vector<double> monotone;
  for (size_t i = 0; i < value.size(); ++i)
    monotone.insert(monotone.end(), static_cast<size_t>(count[i]), value[i]);
  std::array<float, 256> table{};
  const double floor = 1e-7;
  for (int k = 1; k < 255; ++k) {
    double r;
    auto it = std::upper_bound(levels.begin(), levels.end(), k);
    const size_t i = static_cast<size_t>(it - levels.begin());  // levels[i-1] <= k < levels[i]
    if (i == 0) {
      r = std::max(monotone[0], floor) * std::pow(static_cast<double>(k) / levels[0], gamma);
    } else if (i >= levels.size()) {
      r = monotone.back();
    } else {
      const double l0 = levels[i - 1], l1 = levels[i];
      const double r0 = std::max(monotone[i - 1], floor), r1 = std::max(monotone[i], floor);
      r = r0 * std::pow(k / l0, std::log(r1 / r0) / std::log(l1 / l0));
    }
    table[static_cast<size_t>(k)] = static_cast<float>(std::clamp(r, 0.0, 1.0));
  }
  table[0] = 0.0f;
  table[255] = 1.0f;
  for (int k = 1; k < 256; ++k)
    table[static_cast<size_t>(k)] =
        std::max(table[static_cast<size_t>(k)], table[static_cast<size_t>(k) - 1]);
  return table;
}

ModuleFit fitModule(const FlatFieldCaptures& captures, int index,
                    const PhotometricFitOptions& options) {
  ModuleFit fit;
  fit.width = captures.moduleWidth;
  fit.height = captures.moduleHeight;
  ModulePhotometricFigures& f = fit.figures;
  f.module = index;
  const ModuleFlatFields& m = captures.modules[static_cast<size_t>(index)];
  const std::vector<int>& levels = captures.options.levels;
  const int L = static_cast<int>(levels.size());
  const size_t n = m.samples.size();
  f.samples = static_cast<int>(n);
  if (f.samples < options.minSamples) {
    f.excluded = true;
    f.reason = fmt::format("not seen by the camera ({} samples, {} needed)", n, options.minSamples);
    return fit;
  }
  auto shotOf = [&](int c, int l) { return static_cast<size_t>(1 + c * L + l); };
  auto delta = [&](int c, int l, size_t i) {
    return (m.light[shotOf(c, l)][i] - m.light[0][i]).cast<double>();
  };

  // Falloff: the full-white luminance at every sample, a quadratic surface through it (lightly
  // held toward flat where the samples leave a direction unseen).
  Eigen::Matrix<double, 6, 6> normal = Eigen::Matrix<double, 6, 6>::Zero();
  Surface rhs = Surface::Zero();
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d white = delta(0, L - 1, i) + delta(1, L - 1, i) + delta(2, L - 1, i);
    const FlatFieldSample& s = m.samples[i];
    const Surface t = terms(2.0 * s.u / fit.width - 1.0, 2.0 * s.v / fit.height - 1.0);
    normal += t * t.transpose();
    rhs += t * luminance(white);
  }
  for (int k = 1; k < 6; ++k) normal(k, k) += 1e-6 * static_cast<double>(n);
  fit.surface = normal.ldlt().solve(rhs);
  fit.surfaceMax = 0.0;
  double lowest = 1e300;
  for (int j = 0; j <= 48; ++j) {
    for (int i = 0; i <= 64; ++i) {
      const double v = terms(-1.0 + i / 32.0, -1.0 + j / 24.0).dot(fit.surface);
      fit.surfaceMax = std::max(fit.surfaceMax, v);
      lowest = std::min(lowest, v);
    }
  }
  if (!(fit.surfaceMax > 0.0)) fit.surfaceMax = 1.0;
  f.falloff = std::clamp(1.0 - lowest / fit.surfaceMax, 0.0, 1.0);

  // Primaries, black and the response, each sample brought to the brightest point.
  std::vector<double> falloff(n);
  for (size_t i = 0; i < n; ++i) falloff[i] = fit.falloffAt(m.samples[i].u, m.samples[i].v);
  Eigen::Matrix3d primaries = Eigen::Matrix3d::Zero();
  for (int c = 0; c < 3; ++c) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (size_t i = 0; i < n; ++i) sum += delta(c, L - 1, i) / falloff[i];
    primaries.col(c) = sum / static_cast<double>(n);
  }
  Eigen::Vector3d black;
  for (int c = 0; c < 3; ++c) {
    std::vector<double> v(n);
    for (size_t i = 0; i < n; ++i) v[i] = m.black[i][c] / falloff[i];
    black[c] = std::max(median(v), 0.0);
  }
  f.primaries = primaries;
  f.black = black;
  f.whiteLuminance = luminance(primaries * kWhite + black);
  f.blackLuminance = luminance(black);
  for (int c = 0; c < 3; ++c)
    f.primariesXy[static_cast<size_t>(c)] = chromaticity(primaries.col(c));
  for (int c = 0; c < 3; ++c) {
    const Eigen::Vector3d full = primaries.col(c);
    const double norm2 = full.squaredNorm();
    std::vector<double> light(static_cast<size_t>(L));
    for (int l = 0; l < L; ++l) {
      double sum = 0.0;
      for (size_t i = 0; i < n; ++i) sum += delta(c, l, i).dot(full) / falloff[i];
      light[static_cast<size_t>(l)] = norm2 > 0.0 ? sum / static_cast<double>(n) / norm2 : 0.0;
    }
    // The power law through the measured points (log-log least squares, bright enough ones).
    double sxx = 0, sxy = 0;
    for (int l = 0; l + 1 < L; ++l) {
      if (light[static_cast<size_t>(l)] < 0.003) continue;
      const double x = std::log(levels[static_cast<size_t>(l)] / 255.0);
      sxx += x * x;
      sxy += x * std::log(light[static_cast<size_t>(l)]);
    }
    f.gamma[c] = sxx > 0.0 ? std::clamp(sxy / sxx, 0.5, 4.0) : 2.2;
    light.back() = 1.0;  // full drive is the unit
    fit.response[static_cast<size_t>(c)] = responseTable(levels, light, f.gamma[c]);
  }
  return fit;
}

// The smallest move λ of primary direction p toward white such that every module reaches it
// (its drive for it non-negative in every channel).
Eigen::Vector3d reachablePrimary(const Eigen::Vector3d& p,
                                 const std::vector<Eigen::Matrix3d>& inverses) {
  auto reached = [&](const Eigen::Vector3d& t) {
    for (const Eigen::Matrix3d& inv : inverses)
      if ((inv * t).minCoeff() < -1e-12) return false;
    return true;
  };
  if (reached(p)) return p;
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 40; ++i) {
    const double mid = 0.5 * (lo + hi);
    (reached((1.0 - mid) * p + mid * kWhite) ? hi : lo) = mid;
  }
  return (1.0 - hi) * p + hi * kWhite;
}

}  // namespace

void PhotometricFitOptions::validate() const {
  auto check = [](bool ok, const char* field, const std::string& why) {
    if (!ok) throw InputError({"", field, 0}, why);
  };
  check(gainGridWidth >= 2 && gainGridWidth <= 64 && gainGridHeight >= 2 && gainGridHeight <= 64,
        "gain_grid", "must be 2..64 nodes a side");
  check(brightnessQuantile >= 0.0 && brightnessQuantile <= 1.0, "brightness_quantile",
        "must be 0..1");
  check(deadFraction > 0.0 && deadFraction < 1.0, "dead_fraction", "must be in (0, 1)");
  check(gamutOutlierXy > 0.0 && gamutOutlierXy < 0.5, "gamut_outlier_xy", "must be in (0, 0.5)");
  check(minSamples >= 10, "min_samples", "must be >= 10");
}

std::vector<int> PhotometricCalibration::excluded() const {
  std::vector<int> out;
  for (const ModulePhotometricFigures& m : modules)
    if (m.excluded) out.push_back(m.module);
  return out;
}

std::string PhotometricCalibration::describe() const {
  std::string out = fmt::format(
      "target: white {:.3f}, black {:.4f} (luminance, an ideal module's white = 1); primaries "
      "xy R ({:.3f}, {:.3f}) G ({:.3f}, {:.3f}) B ({:.3f}, {:.3f}); brightness shortfall {:.1f}%\n",
      targetWhiteLuminance, targetBlackLuminance, targetPrimariesXy[0].x(),
      targetPrimariesXy[0].y(), targetPrimariesXy[1].x(), targetPrimariesXy[1].y(),
      targetPrimariesXy[2].x(), targetPrimariesXy[2].y(), 100.0 * brightnessShortfall);
  out += "module  samples  gamma R/G/B       white   black   falloff  reach  status\n";
  for (const ModulePhotometricFigures& m : modules) {
    out += fmt::format(
        "{:>6}  {:>7}  {:.2f}/{:.2f}/{:.2f}  {:6.3f}  {:.4f}  {:6.1f}%  {:5.2f}  {}\n", m.module,
        m.samples, m.gamma.x(), m.gamma.y(), m.gamma.z(), m.whiteLuminance, m.blackLuminance,
        100.0 * m.falloff, m.reach, m.excluded ? "excluded: " + m.reason : "ok");
  }
  return out;
}

PhotometricCalibration fitPhotometry(const FlatFieldCaptures& captures,
                                     const PhotometricFitOptions& options) {
  options.validate();
  captures.options.validate();
  const int moduleCount = static_cast<int>(captures.modules.size());
  std::vector<ModuleFit> fits;
  for (int i = 0; i < moduleCount; ++i) fits.push_back(fitModule(captures, i, options));

  // Exclusions, each with its reason: dead, no white, primaries far outside.
  std::vector<double> whites;
  for (const ModuleFit& f : fits)
    if (!f.figures.excluded) whites.push_back(f.figures.whiteLuminance);
  const double medianWhite = median(whites);
  for (ModuleFit& f : fits) {
    ModulePhotometricFigures& m = f.figures;
    if (m.excluded) continue;
    if (!(m.whiteLuminance >= options.deadFraction * medianWhite)) {
      m.excluded = true;
      m.reason =
          fmt::format("dead or black module: its white reaches {:.0f}% of the median module's",
                      100.0 * m.whiteLuminance / std::max(medianWhite, 1e-12));
      continue;
    }
    const Eigen::FullPivLU<Eigen::Matrix3d> lu(m.primaries);
    if (!lu.isInvertible() || (lu.inverse() * kWhite).minCoeff() <= 0.0) {
      m.excluded = true;
      m.reason = "its primaries cannot mix white";
    }
  }
  std::array<Eigen::Vector2d, 3> medianXy{};
  for (int c = 0; c < 3; ++c) {
    std::vector<double> xs, ys;
    for (const ModuleFit& f : fits) {
      if (f.figures.excluded) continue;
      xs.push_back(f.figures.primariesXy[static_cast<size_t>(c)].x());
      ys.push_back(f.figures.primariesXy[static_cast<size_t>(c)].y());
    }
    medianXy[static_cast<size_t>(c)] = Eigen::Vector2d(median(xs), median(ys));
  }
  static const char* kNames[3] = {"red", "green", "blue"};
  for (ModuleFit& f : fits) {
    ModulePhotometricFigures& m = f.figures;
    if (m.excluded) continue;
    for (int c = 0; c < 3 && !m.excluded; ++c) {
      const Eigen::Vector2d& xy = m.primariesXy[static_cast<size_t>(c)];
      const Eigen::Vector2d& mid = medianXy[static_cast<size_t>(c)];
      if ((xy - mid).norm() > options.gamutOutlierXy) {
        m.excluded = true;
        m.reason = fmt::format(
            "gamut far outside the others: its {} at xy ({:.3f}, {:.3f}), the median module's at "
            "({:.3f}, {:.3f}); it would shrink every module's colours",
            kNames[c], xy.x(), xy.y(), mid.x(), mid.y());
      }
    }
  }
  std::vector<const ModuleFit*> included;
  std::vector<Eigen::Matrix3d> inverses;
  for (const ModuleFit& f : fits) {
    if (f.figures.excluded) continue;
    included.push_back(&f);
    inverses.push_back(f.figures.primaries.inverse());
  }
  if (included.empty()) {
    std::string why;
    for (const ModuleFit& f : fits)
      why += fmt::format("; module {}: {}", f.figures.module, f.figures.reason);
    throw PhotometricCaptureError("photometric calibration: no module can be calibrated" + why);
  }

  // The target gamut: each primary of the included modules' mean chromaticity (at unit
  // luminance), moved toward white until all of them reach it; white scaled to D65.
  Eigen::Matrix3d directions;
  for (int c = 0; c < 3; ++c) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const ModuleFit* f : included) {
      const Eigen::Vector3d p = f->figures.primaries.col(c);
      mean += p / luminance(p);
    }
    directions.col(c) = reachablePrimary(mean / static_cast<double>(included.size()), inverses);
  }
  const Eigen::Vector3d mix = directions.inverse() * kWhite;  // target white = directions · mix
  // The black every module reaches: the target black β · white must need non-negative drive
  // after each module's own black.
  double beta = 0.0;
  for (size_t k = 0; k < included.size(); ++k) {
    const Eigen::Vector3d need = inverses[k] * included[k]->figures.black,
                          unit = inverses[k] * kWhite;
    for (int c = 0; c < 3; ++c) beta = std::max(beta, need[c] / unit[c]);
  }
  // Each module's reach: the largest white Y at which its darkest corner still has drive ≤ 1.
  auto reachOf = [&](const ModuleFit& f, const Eigen::Matrix3d& inverse) {
    double darkest = 1.0;
    for (int j = 0; j <= 24; ++j)
      for (int i = 0; i <= 32; ++i)
        darkest = std::min(darkest, f.falloffAt((i / 32.0) * f.width, (j / 24.0) * f.height));
    const Eigen::Vector3d unit = inverse * kWhite, own = inverse * f.figures.black;
    double y = 1e300;
    for (int c = 0; c < 3; ++c) y = std::min(y, (1.0 + own[c]) * darkest / unit[c]);
    return std::max(y - beta, 0.0);
  };
  std::vector<double> reach;
  for (size_t k = 0; k < included.size(); ++k) reach.push_back(reachOf(*included[k], inverses[k]));
  std::vector<double> sorted = reach;
  std::sort(sorted.begin(), sorted.end());
  const double target =
      sorted[static_cast<size_t>(std::lround(options.brightnessQuantile * (sorted.size() - 1)))];

  PhotometricCalibration out;
  out.correction.target.primaries = target * directions * mix.asDiagonal();
  out.correction.target.black = beta * kWhite;
  out.targetWhiteLuminance =
      luminance(out.correction.target.primaries * kWhite + out.correction.target.black);
  out.targetBlackLuminance = luminance(out.correction.target.black);
  for (int c = 0; c < 3; ++c)
    out.targetPrimariesXy[static_cast<size_t>(c)] = chromaticity(directions.col(c));

  // Per module: drive = (P⁻¹ T f · content + P⁻¹ B) · gain − P⁻¹ b, gain = 1 / falloff.
  for (ModuleFit& f : fits) {
    ModulePhotometricFigures& m = f.figures;
    ModuleColourCorrection c = ModuleColourCorrection::srgbIdentity();
    const bool dead =
        m.excluded && (m.samples < options.minSamples || m.reason.rfind("dead", 0) == 0 ||
                       m.reason.rfind("its primaries", 0) == 0);
    if (!dead) {
      const Eigen::Matrix3d inverse = m.primaries.inverse();
      const double own = reachOf(f, inverse);
      m.reach = std::min(1.0, own / std::max(target, 1e-12));
      c.driveFromContent = (inverse * out.correction.target.primaries * m.reach).cast<float>();
      c.lift = (inverse * out.correction.target.black).cast<float>();
      c.blackDrive = (inverse * m.black).cast<float>();
      c.gainWidth = options.gainGridWidth;
      c.gainHeight = options.gainGridHeight;
      c.gain.clear();
      for (int j = 0; j < c.gainHeight; ++j) {
        for (int i = 0; i < c.gainWidth; ++i) {
          const double u = 0.5 + i * (f.width - 1.0) / (c.gainWidth - 1);
          const double v = 0.5 + j * (f.height - 1.0) / (c.gainHeight - 1);
          c.gain.push_back(static_cast<float>(std::clamp(1.0 / f.falloffAt(u, v), 1.0, 16.0)));
        }
      }
      c.response = f.response;
    } else {
      m.reach = 0.0;
    }
    if (!m.excluded) out.brightnessShortfall = std::max(out.brightnessShortfall, 1.0 - m.reach);
    c.validate();
    out.correction.modules.push_back(std::move(c));
    out.modules.push_back(m);
  }
  return out;
}

}  // namespace parallax
