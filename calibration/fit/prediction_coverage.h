#pragma once
// How well a fit's predicted ray errors describe the true ones, against a known truth, summed
// over modules (issue 17's sweeps, synthetic and from pictures): how many modules' true worst
// error is within `sigmas` × their predicted worst σ, in module px and on the observer line
// both, and the ratio of true to predicted RMS (1 when σ are right).

#include <cmath>

#include "calibration/display/ray_error.h"
#include "calibration/fit/calibration_gate.h"

namespace parallax {

struct PredictionCoverage {
  int modules = 0, covered = 0;
  double trueSumSqPx = 0.0, predictedSumSqPx = 0.0;
  double trueSumSqMm = 0.0, predictedSumSqMm = 0.0;

  // One module: its gate entry (the prediction) and its true error.
  static PredictionCoverage ofModule(const ModuleGate& gate, const RayErrorStats& truth,
                                     double sigmas) {
    const RayUncertainty& p = gate.predicted;
    PredictionCoverage one;
    one.modules = 1;
    one.covered =
        truth.maxPx <= sigmas * p.worstPx && truth.maxObserverMm <= sigmas * p.worstObserverMm;
    one.trueSumSqPx = truth.rmsPx * truth.rmsPx;
    one.predictedSumSqPx = p.rmsPx * p.rmsPx;
    one.trueSumSqMm = truth.rmsObserverMm * truth.rmsObserverMm;
    one.predictedSumSqMm = p.rmsObserverMm * p.rmsObserverMm;
    return one;
  }

  void add(const PredictionCoverage& o) {
    modules += o.modules;
    covered += o.covered;
    trueSumSqPx += o.trueSumSqPx;
    predictedSumSqPx += o.predictedSumSqPx;
    trueSumSqMm += o.trueSumSqMm;
    predictedSumSqMm += o.predictedSumSqMm;
  }
  // The share of modules covered (1 when there are none).
  double coverage() const { return modules ? static_cast<double>(covered) / modules : 1.0; }
  double ratioPx() const {
    return predictedSumSqPx > 0 ? std::sqrt(trueSumSqPx / predictedSumSqPx) : 0.0;
  }
  double ratioMm() const {
    return predictedSumSqMm > 0 ? std::sqrt(trueSumSqMm / predictedSumSqMm) : 0.0;
  }
};

}  // namespace parallax
