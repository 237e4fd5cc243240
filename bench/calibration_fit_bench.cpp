// Calibration error against run time (issue 6): ray error of the fitted display against the
// ground truth, against solver iterations, the number of camera stations (capture time), the
// sampling density of the decoded patterns, and the camera noise. Prints markdown tables;
// never passes or fails on time (timings on a shared machine are noisy: the load average is
// printed, and the fit's CPU time beside its wall time). "fit" is the solves; "diag" the
// residual statistics, covariance and conditioning that follow them.
//
//   calibration_fit_bench [default|demo] [--quick] [--experiment] [--seeds N [--first-seed S]]
//                         [--rows PX]
//   calibration_fit_bench [--display NAME|FILE] --pictures N [--true-intrinsics]
//   calibration_fit_bench [--display NAME|FILE] --decoder-error SEED [--true-intrinsics]
//   calibration_fit_bench --setup NAME|all [--seeds N] [--first-seed S] [--threads T] [--verbose]
//                        [--allow-partial]
//   calibration_fit_bench --setup NAME --decoder-error SEED [--true-intrinsics]
//   (--decoder-error also takes --blur PX: the camera's lens blur, σ in px, 0.6 by default;
//    --decoder-error and --pictures take --blur-not-stated: camera.json does not state the
//    blur, so the decoder leaves the shift it gives the phase patterns, capture_decoder.h;
//    --decoder-error takes --white-noise PX: the correspondences replaced by the truth plus
//    independent noise of that σ, module px)
//                         [--module-px-residual]
//   calibration_fit_bench --noise-map
// --experiment: only the errors-in-variables comparison (where the correspondences' noise sits:
// on the camera pixel, as a camera gives it, or on the module pixel; the residual: two-stage
// camera px, FitOptions' default, or module px only), at two sampling densities.
// --display: the nominal of the picture modes (a built-in name or a display JSON; demo).
// --pictures N: the picture path's seed sweep (issue 17): N seeds, each rendered
// (checkerboard intrinsics, patterns from five stations over 4 m), decoded and fitted; per seed
// the gate's verdict, the true worst error against the predicted 3σ worst, and over the sweep
// the coverage (true worst within 3σ, per module) and the ratio of true to predicted RMS.
// --setup: the picture path over the synthetic sweep's setups (picture_sessions.h), by name
// ("2 stations", "observer line 10 m", ...; "all": every one), N seeds each (20) from S (1000);
// the table per setup and the count of installed modules beyond the gate's limits (exit 1 when
// there are any). --noise-map: how the synthetic camera noise maps to the sensor's.
// --decoder-error SEED: one such session, the decoder's stripe centres and correspondences
// measured against the truth (bias and outliers), and the fit's error against its σ per module.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <map>
#include <optional>
#include <random>
#include <string>

#include "bench/picture_sessions.h"
#include "calibration/camera/calibration_geometry.h"
#include "calibration/display/display_presets.h"
#include "calibration/display/ray_error.h"
#include "calibration/fit/display_fit.h"
#include "calibration/fit/prediction_coverage.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/synthetic_observations.h"

namespace {

using namespace parallax;

struct Row {
  double simSeconds, fitSeconds, diagnosticsSeconds, fitCpuSeconds;
  int iterations;
  size_t correspondences;
  RayErrorStats rays;
  bool passes;
};

Row runOnce(const DisplayModel& nominal, const DisplayModel& truth, const SyntheticOptions& sim,
            const FitOptions& fit) {
  Row row;
  const auto t0 = std::chrono::steady_clock::now();
  const SyntheticCalibration data = simulateObservations(truth, sim);
  const auto t1 = std::chrono::steady_clock::now();
  const std::clock_t c0 = std::clock();
  const FitResult result = fitDisplay(nominal, data.observations, fit);
  row.fitCpuSeconds = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  row.simSeconds = std::chrono::duration<double>(t1 - t0).count();
  row.fitSeconds = result.solveSeconds;
  row.diagnosticsSeconds = result.diagnosticsSeconds;
  row.iterations = result.iterations;
  row.correspondences = data.observations.correspondences.size();
  row.rays = totalRayError(compareRays(truth, result.model, {8}));
  row.passes = result.passesQualityChecks();
  return row;
}

void header(const char* axis) {
  std::printf(
      "\n| %s | correspondences | fit wall s | diag wall s | fit+diag CPU s | iterations | ray px "
      "RMS | ray px max | screen mm RMS | observer mm RMS | gate |\n",
      axis);
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
}

void print(const std::string& value, const Row& r) {
  std::printf("| %s | %zu | %.2f | %.2f | %.2f | %d | %.4f | %.3f | %.3f | %.2f | %s |\n",
              value.c_str(), r.correspondences, r.fitSeconds, r.diagnosticsSeconds, r.fitCpuSeconds,
              r.iterations, r.rays.rmsPx, r.rays.maxPx, r.rays.rmsScreenMm, r.rays.rmsObserverMm,
              r.passes ? "pass" : "refused");
  std::fflush(stdout);
}

// The decoder's own error, measured against the truth (true display, camera poses and
// intrinsics), then the fit's true error against its predicted σ per module: where the picture
// path's error comes from (issue 17). Outliers (stripes > 1 mm, correspondences > 0.5 px at the
// truth) are counted apart; the means of the rest are the decoder's biases.
int decoderError(const DisplayModel& nominal, const std::string& display,
                 const PictureSessionOptions& options, std::uint64_t seed, bool residualInModulePx,
                 std::optional<double> whiteNoisePx) {
  const bool trueIntrinsics = options.trueIntrinsics;
  const PictureSession session = renderPictureSession(nominal, seed, options);
  const CalibrationObservations& obs = session.obs;
  const CameraIntrinsics& ti = session.camera.intrinsics;
  const double k = session.truth.screen.curvature;
  const auto screenPoint = [&](int camera, const Eigen::Vector2d& px, Eigen::Vector3d* s) {
    const auto block = packCamera(session.camera.poses[static_cast<size_t>(camera)]);
    const Eigen::Vector2d n = ti.normalized(px);
    return screenPointOfCameraRay(k, block.data(), n.x(), n.y(), s);
  };
  // The module pixel that truly lights the screen point a correspondence's camera pixel sees.
  const auto trueModulePx = [&](const Correspondence& c, double uv[2]) {
    Eigen::Vector3d sp;
    const OpticalModule& tm = session.truth.modules[static_cast<size_t>(c.module)];
    const auto mb = packModule(tm);
    return screenPoint(c.camera, c.cameraPx, &sp) &&
           projectIntoModule(mb.data(), tm.width, tm.mirror ? -1.0 : 1.0, sp, uv);
  };
  std::printf(
      "# decoder error at the truth: %s seed %llu, %s intrinsics (f %.2f, k1 %.4f; "
      "true f %.2f, k1 %.4f)\n",
      display.c_str(), static_cast<unsigned long long>(seed),
      trueIntrinsics ? "true" : "checkerboard", session.intrinsicsUsed.fx,
      session.intrinsicsUsed.k1, ti.fx, ti.k1);
  if (session.checkerboard)
    std::printf("%s\n", formatCheckerboardCalibration(*session.checkerboard, &ti).c_str());
  const size_t stations = obs.stations.size();
  std::vector<double> sum(stations, 0.0), sumSq(stations, 0.0);
  std::vector<int> count(stations, 0), outliers(stations, 0);
  double sideSum[6] = {};
  int sideCount[6] = {};
  std::map<std::pair<int, int>, std::pair<double, int>> lobes;  // (module, station): sum, count
  for (const StripeCentre& st : obs.stripes) {
    Eigen::Vector3d sp;
    if (!screenPoint(st.camera, st.cameraPx, &sp)) continue;
    const double r =
        1e3 * stripeMismatch<double>(session.truth.screen.transfer, k, sp,
                                     session.truth.modules[static_cast<size_t>(st.module)].position,
                                     session.camera.poses[static_cast<size_t>(st.camera)].centre);
    const auto c = static_cast<size_t>(st.camera);
    if (std::abs(r) > 1.0) {
      ++outliers[c];
      continue;
    }
    {
      // A module's stripes at one station, averaged: one lobe's centres err together.
      auto& g = lobes[{st.module, st.camera}];
      g.first += r;
      ++g.second;
    }
    {
      // The stripe's error by where it crosses the screen beside its module (x from the
      // module, 6 bins of 10 cm): a lobe peak pulled outward on both sides reads as depth.
      const double dx = sp.x() - session.truth.modules[static_cast<size_t>(st.module)].position.x();
      const int bin = std::clamp(static_cast<int>(std::floor(dx / 0.1)) + 3, 0, 5);
      sideSum[bin] += r;
      ++sideCount[bin];
    }
    sum[c] += r;
    sumSq[c] += r * r;
    ++count[c];
  }
  {
    double sq = 0.0, worst = 0.0;
    for (const auto& [key, g] : lobes) {
      const double mean = g.first / g.second;
      sq += mean * mean;
      worst = std::max(worst, std::abs(mean));
    }
    std::printf("stripes averaged per module and station (%zu lobes): RMS %.3f mm, worst %.3f mm\n",
                lobes.size(), lobes.empty() ? 0.0 : std::sqrt(sq / lobes.size()), worst);
  }
  for (int b = 0; b < 6; ++b) {
    if (sideCount[b])
      std::printf("stripes %+.1f..%+.1f m beside their module: %d, mean %+.3f mm\n", (b - 3) * 0.1,
                  (b - 2) * 0.1, sideCount[b], sideSum[b] / sideCount[b]);
  }
  for (size_t c = 0; c < stations; ++c) {
    std::printf("stripes, station %zu: %d within 1 mm: mean %+.3f mm, RMS %.3f mm; %d beyond\n", c,
                count[c], count[c] ? sum[c] / count[c] : 0.0,
                count[c] ? std::sqrt(sumSq[c] / count[c]) : 0.0, outliers[c]);
  }
  // The fiducial sightings against their true projections: a bias here places every camera.
  for (size_t st = 0; st < stations; ++st) {
    double sx = 0, sy = 0, sr = 0;
    int n = 0;
    for (const FiducialSighting& f : obs.fiducialSightings) {
      if (static_cast<size_t>(f.camera) != st) continue;
      const Eigen::Vector2d& xy = obs.fiducials[static_cast<size_t>(f.fiducial)];
      const Eigen::Vector3d p = session.truth.screen.pointAt(xy.x(), xy.y());
      Eigen::Vector2d px;
      if (!projectPhysical(ti, session.camera.poses[st], p, &px)) continue;
      const Eigen::Vector2d d = f.cameraPx - px;
      const Eigen::Vector2d out = (px - Eigen::Vector2d(ti.cx, ti.cy)).normalized();
      sx += d.x();
      sy += d.y();
      sr += d.dot(out);
      ++n;
    }
    if (n)
      std::printf("fiducials, station %zu: %d, mean dx %+.3f dy %+.3f, radial %+.3f px\n", st, n,
                  sx / n, sy / n, sr / n);
  }
  // The correspondences against the module pixel the truth gives for their camera pixel: all,
  // by the module pixel's distance to its image's nearest edge (module px), by station, and
  // per module (in the fit's table below: a module whose decode errs together shows there).
  struct ModuleDecode {
    int n = 0, beyond = 0;
    double su = 0, sv = 0, sq = 0;
    void add(const ModuleDecode& o) {
      n += o.n;
      beyond += o.beyond;
      su += o.su;
      sv += o.sv;
      sq += o.sq;
    }
  };
  std::map<std::pair<int, int>, ModuleDecode> perDecode;  // (station, module)
  {
    const double edges[] = {0, 4, 8, 16, 32, 64, 1e9};
    std::vector<double> su(stations), sv(stations), mu(stations), mv(stations);
    std::vector<int> sn(stations), ou(stations), ov(stations);
    constexpr int kBins = 6;
    double bu[kBins] = {}, bv[kBins] = {}, bsq[kBins] = {};
    int bn[kBins] = {}, bout[kBins] = {};
    double cSum = 0.0, cSq = 0.0;
    double scale[6] = {};
    int cCount = 0, cOut = 0;
    for (const Correspondence& c : obs.correspondences) {
      const OpticalModule& tm = session.truth.modules[static_cast<size_t>(c.module)];
      double uv[2];
      if (!trueModulePx(c, uv)) continue;
      const double edge = std::min(
          {c.modulePx.x(), tm.width - c.modulePx.x(), c.modulePx.y(), tm.height - c.modulePx.y()});
      int b = 0;
      while (b + 1 < kBins && edge >= edges[b + 1]) ++b;
      const double du = c.modulePx.x() - uv[0], dv = c.modulePx.y() - uv[1];
      const auto st = static_cast<size_t>(c.camera);
      const bool gross = std::hypot(du, dv) > 0.5;
      ModuleDecode& md = perDecode[{c.camera, c.module}];
      if (gross) {
        ++md.beyond;
      } else {
        ++md.n;
        md.su += du;
        md.sv += dv;
        md.sq += du * du + dv * dv;
      }
      ou[st] += std::abs(du) > 0.5;
      ov[st] += std::abs(dv) > 0.5;
      if (gross) {
        ++cOut;
        ++bout[b];
        continue;
      }
      cSum += du + dv;
      cSq += du * du + dv * dv;
      ++cCount;
      {
        // A scale about the image centre cancels in the mean: its slope, per axis.
        const double xu = uv[0] - 0.5 * tm.width, xv = uv[1] - 0.5 * tm.height;
        scale[0] += du * xu;
        scale[1] += xu * xu;
        scale[2] += dv * xv;
        scale[3] += xv * xv;
        scale[4] += du;
        scale[5] += dv;
      }
      mu[st] += du;
      mv[st] += dv;
      su[st] += du * du;
      sv[st] += dv * dv;
      ++sn[st];
      bu[b] += du;
      bv[b] += dv;
      bsq[b] += du * du + dv * dv;
      ++bn[b];
    }
    std::printf(
        "correspondences: %d within 0.5 px: mean %+.4f px, RMS %.3f px per axis; %d beyond\n",
        cCount, cCount ? cSum / (2 * cCount) : 0.0, cCount ? std::sqrt(cSq / (2 * cCount)) : 0.0,
        cOut);
    if (cCount) {
      std::printf(
          "  against the module pixel from its image's centre: du %.6f px a px (%+.3f px at the "
          "edge), dv %.6f px a px (%+.3f px at the edge)\n",
          scale[0] / scale[1], scale[0] / scale[1] * 0.5 * session.truth.modules[0].width,
          scale[2] / scale[3], scale[2] / scale[3] * 0.5 * session.truth.modules[0].height);
    }
    for (int b = 0; b < kBins; ++b) {
      std::printf(
          "  %3.0f-%3.0f px from the edge: %6d, mean du %+.4f dv %+.4f, RMS %.3f; %d beyond\n",
          edges[b], std::min(edges[b + 1], 999.0), bn[b], bn[b] ? bu[b] / bn[b] : 0.0,
          bn[b] ? bv[b] / bn[b] : 0.0, bn[b] ? std::sqrt(bsq[b] / (2 * bn[b])) : 0.0, bout[b]);
    }
    {
      // The decodes by their share of gross errors (beyond 0.5 px): how far their inliers'
      // mean is off, against what their noise alone gives (FitOptions::unreliableDecodeTail).
      const double shares[] = {0.0, 0.02, 0.05, 0.1, 0.2, 1.01};
      for (int b = 0; b + 1 < static_cast<int>(std::size(shares)); ++b) {
        int groups = 0;
        double meanSq = 0.0, noiseSq = 0.0;
        for (const auto& [key, d] : perDecode) {
          const double share = static_cast<double>(d.beyond) / (d.n + d.beyond);
          if (d.n < 10 || share < shares[b] || share >= shares[b + 1]) continue;
          const double meanU = d.su / d.n, meanV = d.sv / d.n;
          ++groups;
          meanSq += meanU * meanU + meanV * meanV;
          noiseSq += (d.sq / d.n - meanU * meanU - meanV * meanV) / d.n;
        }
        if (groups)
          std::printf(
              "  decodes with %2.0f-%3.0f%% gross errors: %3d, their inliers' mean off %.4f px "
              "RMS, noise alone %.4f\n",
              100 * shares[b], std::min(100.0, 100 * shares[b + 1]), groups,
              std::sqrt(meanSq / groups), std::sqrt(noiseSq / groups));
      }
    }
    for (size_t st = 0; st < stations; ++st) {
      if (sn[st] == 0) continue;
      std::printf(
          "  station %zu: mean du %+.4f dv %+.4f, RMS du %.3f dv %.3f; beyond 0.5 px in u %d, in v "
          "%d\n",
          st, mu[st] / sn[st], mv[st] / sn[st], std::sqrt(su[st] / sn[st]),
          std::sqrt(sv[st] / sn[st]), ou[st], ov[st]);
    }
  }

  FitOptions fit;
  fit.threads = 2;
  // A decoded correspondence's noise is on its module pixel (the camera pixel is a grid point):
  // --module-px-residual fits it where it sits (FitOptions::residualInCameraPx false).
  fit.residualInCameraPx = !residualInModulePx;
  // --white-noise: the decoded correspondences replaced by the truth plus independent noise,
  // which the σ must describe whatever the decoder does (it showed the fixed fiducial σ).
  CalibrationObservations kept = obs;
  if (whiteNoisePx) {
    std::mt19937 rng(static_cast<unsigned>(seed));
    std::normal_distribution<double> nd(0.0, *whiteNoisePx);
    kept.correspondences.clear();
    for (const Correspondence& c : obs.correspondences) {
      double uv[2];
      if (!trueModulePx(c, uv)) continue;
      Correspondence e = c;
      e.modulePx = {uv[0] + nd(rng), uv[1] + nd(rng)};
      kept.correspondences.push_back(e);
    }
  }
  const FitResult result = fitDisplay(nominal, kept, fit);
  const std::vector<RayErrorStats> rays = compareRays(session.truth, result.model);
  std::printf("fit (%s residual): k", residualInModulePx ? "module px" : "camera px (two-stage)");
  std::printf(
      " %.5f (true %.5f, σ %.5f); σ correspondences %.3f px, stripes %.3f mm; fiducials %.4f "
      "camera px RMS\n",
      result.model.screen.curvature, k, result.curvatureStdDev, result.correspondenceSigmaPx,
      result.stripeSigmaMm, result.fiducialRmsPx);
  for (const std::string& note : result.notes) std::printf("note: %s\n", note.c_str());
  for (const UnreliableDecode& d : result.unreliableDecodes) {
    std::printf("decode left out: station %d module %d, %d of %d gross errors (typical %.1f%%)\n",
                d.station, d.module, d.grossErrors, d.correspondences, 100.0 * d.typicalShare);
  }
  const auto& se = result.sharedErrors;
  std::printf(
      "rows within a (station, module) group, in σ: u %.2f v %.2f stripes %.2f; their "
      "common part: u %.2f v %.2f stripes %.2f\n",
      se[0], se[1], se[2], se[3], se[4], se[5]);
  for (const CameraFit& cf : result.cameras) {
    const CameraPose& t = session.camera.poses[static_cast<size_t>(cf.camera)];
    const Eigen::Vector3d d = (cf.pose.centre - t.centre) * 1e3;
    std::printf("camera %d: centre %+.2f %+.2f %+.2f mm (σ %.2f %.2f %.2f), rotation %.4f°\n",
                cf.camera, d.x(), d.y(), d.z(), cf.stdDev[3], cf.stdDev[4], cf.stdDev[5],
                cf.pose.physicalFromCamera.angularDistance(t.physicalFromCamera) * 180.0 / M_PI);
  }
  std::vector<ModuleDecode> perModule(session.truth.modules.size());
  for (const auto& [key, d] : perDecode) perModule[static_cast<size_t>(key.second)].add(d);
  std::printf(
      "| module | Δx, Δy, Δz mm (σ) | Δfx px (σ) | true RMS px / observer mm | predicted | true "
      "worst px / mm | 3σ worst | decoded: within 0.5 px, mean du dv, RMS px; beyond "
      "|\n|---|---|---|---|---|---|---|---|\n");
  for (const ModuleGate& g : result.gate.modules) {
    const auto m = static_cast<size_t>(g.module);
    const OpticalModule &t = session.truth.modules[m], &f = result.model.modules[m];
    const Eigen::Vector3d d = (f.position - t.position) * 1e3;
    const auto& sd = result.modules[m].stdDev;
    std::printf(
        "| %zu | %+.2f (%.2f), %+.2f (%.2f), %+.2f (%.2f) | %+.2f (%.2f) | %.3f / %.2f | "
        "%.3f / %.2f | %.3f / %.2f | %.3f / %.2f%s | %d, %+.4f %+.4f, %.3f; %d |\n",
        m, d.x(), sd[3], d.y(), sd[4], d.z(), sd[5], f.fx - t.fx, sd[6], rays[m].rmsPx,
        rays[m].rmsObserverMm, g.predicted.rmsPx, g.predicted.rmsObserverMm, rays[m].maxPx,
        rays[m].maxObserverMm, g.boundPx, g.boundObserverMm, g.passes ? "" : " (fails)",
        perModule[m].n, perModule[m].n ? perModule[m].su / perModule[m].n : 0.0,
        perModule[m].n ? perModule[m].sv / perModule[m].n : 0.0,
        perModule[m].n ? std::sqrt(perModule[m].sq / (2 * perModule[m].n)) : 0.0,
        perModule[m].beyond);
  }
  return 0;
}

// The picture path on `seeds` seeds of a display (issue 17's benchmark half of the sweep).
int pictureSweep(const std::string& display, int seeds, const PictureSessionOptions& options) {
  const bool trueIntrinsics = options.trueIntrinsics;
  const DisplayModel nominal = resolveDisplay(display);
  std::printf(
      "# picture path sweep: %s, %s intrinsics, lens blur %s, 5 stations over 4 m, pixel step "
      "6\n"
      "| seed | gate | true worst px / mm | predicted 3σ worst px / mm | modules within 3σ | "
      "true/pred RMS px, mm | σ module px | first refusal |\n|---|---|---|---|---|---|---|---|\n",
      display.c_str(), trueIntrinsics ? "true" : "checkerboard",
      options.lensBlurStated ? "stated" : "not stated");
  int accepted = 0, violations = 0;
  PredictionCoverage all;
  for (int i = 0; i < seeds; ++i) {
    const std::uint64_t seed = 3000 + static_cast<std::uint64_t>(i);
    const PictureSession session = renderPictureSession(nominal, seed, options);
    const DisplayModel& truth = session.truth;
    const CalibrationObservations& obs = session.obs;
    FitOptions fit;
    fit.threads = 2;
    const FitResult result = fitDisplay(nominal, obs, fit);
    const std::vector<RayErrorStats> rays = compareRays(truth, result.model);
    const bool passes = result.passesQualityChecks();
    accepted += passes;
    double worstPx = 0, worstMm = 0, boundPx = 0, boundMm = 0;
    PredictionCoverage run;
    for (const ModuleGate& g : result.gate.modules) {
      const RayErrorStats& e = rays[static_cast<size_t>(g.module)];
      if (!g.predicted.bounded || g.predicted.samples == 0 || e.samples == 0) continue;
      worstPx = std::max(worstPx, e.maxPx);
      worstMm = std::max(worstMm, e.maxObserverMm);
      boundPx = std::max(boundPx, g.boundPx);
      boundMm = std::max(boundMm, g.boundObserverMm);
      if (passes && (e.maxPx > fit.gate.worstPx || e.maxObserverMm > fit.gate.worstObserverMm))
        ++violations;
      if (!result.gate.reasons.empty()) continue;
      run.add(PredictionCoverage::ofModule(g, e, fit.gate.sigmas));
    }
    all.add(run);
    const std::vector<std::string> why = result.gate.describe();
    std::printf("| %llu | %s | %.3f / %.2f | %.3f / %.2f | %d/%d | %.2f, %.2f | %.3f | %s |\n",
                static_cast<unsigned long long>(seed), passes ? "accepted" : "refused", worstPx,
                worstMm, boundPx, boundMm, run.covered, run.modules, run.ratioPx(), run.ratioMm(),
                result.correspondenceSigmaPx, why.empty() ? "" : why.front().c_str());
    std::fflush(stdout);
  }
  std::printf(
      "\nall: %d/%d accepted, %d installed modules beyond the gate's limits; coverage %.1f%% of "
      "%d modules within 3σ; true/predicted RMS %.2f px, %.2f mm\n",
      accepted, seeds, violations, all.modules ? 100.0 * all.coverage() : 0.0, all.modules,
      all.ratioPx(), all.ratioMm());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string preset = "default", pictureDisplay = "demo";
  bool quick = false, experiment = false, baseSeeds = false;
  int baseRows = 10;  // --rows: the synthetic base's module rows, every this many px
  PictureSweepOptions sweep;
  bool setupSweep = false;
  for (int i = 1; i < argc; ++i) {
    const bool hasValue = i + 1 < argc;
    if (std::strcmp(argv[i], "--setup") == 0 && hasValue) {
      sweep.setup = argv[++i];
      setupSweep = true;
      continue;
    }
    if (std::strcmp(argv[i], "--setups") == 0 && hasValue) {
      sweep.setup = argv[++i];  // "all"
      setupSweep = true;
      continue;
    }
    if (std::strcmp(argv[i], "--seeds") == 0 && hasValue) {
      sweep.seeds = std::max(1, std::atoi(argv[++i]));
      baseSeeds = true;
      continue;
    }
    if (std::strcmp(argv[i], "--rows") == 0 && hasValue) {
      baseRows = std::clamp(std::atoi(argv[++i]), 1, 64);
      continue;
    }
    if (std::strcmp(argv[i], "--first-seed") == 0 && hasValue) {
      sweep.firstSeed = std::atoi(argv[++i]);
      continue;
    }
    if (std::strcmp(argv[i], "--threads") == 0 && hasValue) {
      sweep.threads = std::max(1, std::atoi(argv[++i]));
      continue;
    }
    if (std::strcmp(argv[i], "--verbose") == 0) {
      sweep.verbose = true;
      continue;
    }
    if (std::strcmp(argv[i], "--allow-partial") == 0) {
      sweep.allowPartial = true;
      continue;
    }
    if (std::strcmp(argv[i], "--noise-map") == 0) {
      pictureNoiseMap(sweep.threads);
      return 0;
    }
    if (std::strcmp(argv[i], "--display") == 0 && i + 1 < argc) {
      pictureDisplay = argv[++i];
      continue;
    }
    if (std::strcmp(argv[i], "--quick") == 0)
      quick = true;
    else if (std::strcmp(argv[i], "--experiment") == 0)
      experiment = true;
    else if (std::strcmp(argv[i], "--decoder-error") == 0 && i + 1 < argc) {
      const auto seed = static_cast<std::uint64_t>(std::atoll(argv[++i]));
      PictureSessionOptions options;
      bool modulePx = false;
      std::optional<double> whiteNoise;
      for (int j = i + 1; j < argc; ++j) {
        if (std::strcmp(argv[j], "--white-noise") == 0 && j + 1 < argc)
          whiteNoise = std::atof(argv[j + 1]);
        options.trueIntrinsics |= std::strcmp(argv[j], "--true-intrinsics") == 0;
        if (std::strcmp(argv[j], "--blur-not-stated") == 0) options.lensBlurStated = false;
        modulePx |= std::strcmp(argv[j], "--module-px-residual") == 0;
        if (std::strcmp(argv[j], "--blur") == 0 && j + 1 < argc)
          options.blurSigmaPx = std::atof(argv[j + 1]);
      }
      if (!setupSweep)
        return decoderError(resolveDisplay(pictureDisplay), pictureDisplay, options, seed, modulePx,
                            whiteNoise);
      DisplayModel nominal;
      if (!pictureSetupByName(sweep.setup, &nominal, &options)) {
        std::fprintf(stderr, "unknown setup \"%s\"\n", sweep.setup.c_str());
        return 2;
      }
      return decoderError(nominal, sweep.setup, options, seed, modulePx, whiteNoise);
    } else if (std::strcmp(argv[i], "--pictures") == 0 && i + 1 < argc) {
      const int seeds = std::max(1, std::atoi(argv[++i]));
      PictureSessionOptions options;
      for (int j = i + 1; j < argc; ++j) {
        options.trueIntrinsics |= std::strcmp(argv[j], "--true-intrinsics") == 0;
        if (std::strcmp(argv[j], "--blur-not-stated") == 0) options.lensBlurStated = false;
      }
      return pictureSweep(pictureDisplay, seeds, options);
    } else
      preset = argv[i];
  }
  if (setupSweep) {
    const int beyond = pictureSetupSweep(sweep);
    return beyond < 0 ? 2 : beyond > 0 ? 1 : 0;
  }
  NominalDisplayOptions nominalOptions;
  nominalOptions.preset = preset;
  const DisplayModel nominal = makeNominalDisplay(nominalOptions);
  GroundTruthOptions truthOptions;
  truthOptions.seed = 2026;
  const DisplayModel truth = makeGroundTruth(nominal, truthOptions);
  SyntheticOptions base;
  base.seed = 7;
  base.rig.spanM = 3.2;
  base.noisePx = 0.3;
  // Rows every 10 module px, 11 samples across each stripe: ~160k correspondences on default,
  // still sparser than the decoder gives at pixelStep 6 with the 1920×1080 camera (a module
  // row every ~4 px, ~7 samples across). Rows every 16 px / 5 across (the base until the
  // camera-px residual) left the fit noise-limited at 0.06–0.08 px over three seeds.
  // --rows: another density (4 is the decoder's on default).
  base.rowStepPx = baseRows;
  base.samplesAcrossStripe = 11;
  FitOptions fit;
  fit.threads = 2;
  std::printf("# calibration error vs run time: display \"%s\" (%zu modules of %dx%d), seed 2026\n",
              preset.c_str(), nominal.modules.size(), nominal.modules[0].width,
              nominal.modules[0].height);
  double load[1] = {0.0};
  if (getloadavg(load, 1) < 1) load[0] = -1.0;
  std::printf(
      "fit wall time includes waiting for the CPU on a shared machine (load average %.2f at the "
      "start); "
      "CPU time is the process's (2 solver threads)\n",
      load[0]);
  std::printf(
      "base: 5 stations over 3.2 m, 0.3 px camera noise, rows every %d px, %d samples across each "
      "stripe\n",
      static_cast<int>(base.rowStepPx), base.samplesAcrossStripe);

  if (baseSeeds && !setupSweep) {
    // The base setup on other truths: the error a seed does not choose (issue 17's 72-module
    // target, ≤ 0.05 px RMS on any seed, was met on seed 2026 alone).
    header("truth seed (base setup, noise seed = truth seed)");
    for (int i = 0; i < sweep.seeds; ++i) {
      GroundTruthOptions t;
      t.seed = static_cast<std::uint64_t>(sweep.firstSeed + i);
      SyntheticOptions s = base;
      s.seed = t.seed;
      print(std::to_string(t.seed), runOnce(nominal, makeGroundTruth(nominal, t), s, fit));
    }
    return 0;
  }
  if (experiment) {
    header("noise (px) on / residual / sampling");
    struct Case {
      double noise;
      bool onModule, cameraResidual;
    };
    for (const Case& c : std::vector<Case>{{0.3, false, true},
                                           {0.3, false, false},
                                           {0.3, true, false},
                                           {0.0, false, true},
                                           {0.0, false, false}}) {
      for (auto [rows, across] : std::vector<std::pair<double, int>>{{16, 5}, {10, 11}}) {
        SyntheticOptions s = base;
        s.noisePx = c.noise;
        s.noiseOnModulePx = c.onModule;
        s.rowStepPx = rows;
        s.samplesAcrossStripe = across;
        FitOptions f = fit;
        f.residualInCameraPx = c.cameraResidual;
        char label[128];
        std::snprintf(label, sizeof label, "%.1f on %s / residual in %s / rows %d, %d across",
                      c.noise, c.onModule ? "module px" : "camera px",
                      c.cameraResidual ? "camera px (two-stage)" : "module px",
                      static_cast<int>(rows), across);
        print(label, runOnce(nominal, truth, s, f));
      }
    }
    return 0;
  }
  header("max iterations per solve");
  for (int iterations : quick ? std::vector<int>{2, 100} : std::vector<int>{1, 2, 3, 5, 10, 100}) {
    FitOptions f = fit;
    f.maxIterations = iterations;
    print(std::to_string(iterations), runOnce(nominal, truth, base, f));
  }
  header("camera stations");
  for (int stations : quick ? std::vector<int>{3, 9} : std::vector<int>{2, 3, 5, 9, 15}) {
    SyntheticOptions s = base;
    s.rig.stations = stations;
    print(std::to_string(stations), runOnce(nominal, truth, s, fit));
  }
  header("sampled rows / samples across a stripe");
  for (auto [rows, across] : quick ? std::vector<std::pair<double, int>>{{16, 5}, {10, 11}}
                                   : std::vector<std::pair<double, int>>{
                                         {32, 3}, {16, 5}, {16, 9}, {12, 11}, {10, 11}, {8, 9}}) {
    SyntheticOptions s = base;
    s.rowStepPx = rows;
    s.samplesAcrossStripe = across;
    print("every " + std::to_string(static_cast<int>(rows)) + " px / " + std::to_string(across),
          runOnce(nominal, truth, s, fit));
  }
  header("camera noise (px)");
  for (double noise :
       quick ? std::vector<double>{0.3} : std::vector<double>{0.1, 0.3, 0.5, 1.0, 2.0}) {
    SyntheticOptions s = base;
    s.noisePx = noise;
    char label[16];
    std::snprintf(label, sizeof label, "%.1f", noise);
    print(label, runOnce(nominal, truth, s, fit));
  }
  return 0;
}
