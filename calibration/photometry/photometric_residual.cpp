#include "calibration/photometry/photometric_residual.h"

#include <algorithm>

#include "calibration/display/colour_difference.h"

namespace parallax {

PhotometricSummary measurePhotometricResidual(const FlatFieldCaptures& captures,
                                              const PhotometricCalibration& calibration,
                                              const PhotometricResidualOptions& options) {
  const DisplayColourCorrection& correction = calibration.correction;
  const ColourTarget& target = correction.target;
  const Eigen::Vector3d white = target.black + target.primaries * Eigen::Vector3d::Ones();
  const Eigen::Vector3d grey =
      target.black + target.primaries * Eigen::Vector3d::Constant(options.grey);
  const Eigen::Vector3d greyLab = labFromLinearSrgb(grey, white);
  const int levels = static_cast<int>(captures.options.levels.size());
  const int w = captures.moduleWidth, h = captures.moduleHeight;
  const int cells = options.cellsX * options.cellsY;

  PhotometricSummary out;
  std::vector<double> luminances;
  double sumDeltaE = 0.0;
  int counted = 0;
  for (size_t i = 0; i < captures.modules.size(); ++i) {
    const ModuleFlatFields& m = captures.modules[i];
    const ModulePhotometricFigures& figures = calibration.modules[i];
    const ModuleColourCorrection& c = correction.modules[i];
    ModulePhotometricSummary s;
    s.excluded = figures.excluded;
    s.reason = figures.reason;
    s.scale = figures.whiteLuminance > 0.0
                  ? calibration.targetWhiteLuminance / figures.whiteLuminance
                  : 0.0;
    s.gainMax = *std::max_element(c.gain.begin(), c.gain.end());
    // A dead module or one nobody saw has nothing to measure.
    const bool measurable = figures.samples >= 1 && figures.whiteLuminance > 0.0;
    std::vector<Eigen::Vector3d> sum(static_cast<size_t>(cells), Eigen::Vector3d::Zero());
    std::vector<int> count(static_cast<size_t>(cells), 0);
    const Eigen::Vector3f content = Eigen::Vector3f::Constant(static_cast<float>(options.grey));
    for (size_t k = 0; measurable && k < m.samples.size(); ++k) {
      const FlatFieldSample& sample = m.samples[k];
      const float gain = c.gainAt(sample.u, sample.v, w, h);
      const Eigen::Vector3f drive = ((c.driveFromContent * content + c.lift) * gain - c.blackDrive)
                                        .cwiseMax(0.0f)
                                        .cwiseMin(1.0f);
      Eigen::Vector3d light = m.black[k].cast<double>();
      for (int ch = 0; ch < 3; ++ch) {
        const size_t full = static_cast<size_t>(1 + ch * levels + levels - 1);
        light += static_cast<double>(drive[ch]) * (m.light[full][k] - m.light[0][k]).cast<double>();
      }
      const int cx =
          std::clamp(static_cast<int>(sample.u / w * options.cellsX), 0, options.cellsX - 1);
      const int cy =
          std::clamp(static_cast<int>(sample.v / h * options.cellsY), 0, options.cellsY - 1);
      sum[static_cast<size_t>(cy * options.cellsX + cx)] += light;
      ++count[static_cast<size_t>(cy * options.cellsX + cx)];
    }
    double moduleSum = 0.0;
    int moduleCells = 0;
    for (int cell = 0; cell < cells; ++cell) {
      if (count[static_cast<size_t>(cell)] < options.minSamplesPerCell) continue;
      const Eigen::Vector3d light =
          sum[static_cast<size_t>(cell)] / count[static_cast<size_t>(cell)];
      const double de = ciede2000(labFromLinearSrgb(light, white), greyLab);
      moduleSum += de;
      ++moduleCells;
      s.deltaEWorst = std::max(s.deltaEWorst, de);
      if (figures.excluded) continue;
      sumDeltaE += de;
      ++counted;
      out.deltaEWorst = std::max(out.deltaEWorst, de);
      luminances.push_back(luminance(light));
    }
    if (moduleCells > 0) s.deltaEMean = moduleSum / moduleCells;
    out.modules.push_back(std::move(s));
  }
  if (counted > 0) {
    out.deltaEMean = sumDeltaE / counted;
    double mean = 0.0;
    for (double y : luminances) mean += y;
    mean /= static_cast<double>(luminances.size());
    const auto [lo, hi] = std::minmax_element(luminances.begin(), luminances.end());
    out.nonUniformity = mean > 0.0 ? (*hi - *lo) / mean : 0.0;
  }
  return out;
}

}  // namespace parallax
