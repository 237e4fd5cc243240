#include "calibration/simulation/synthetic_observations.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "calibration/camera/calibration_geometry.h"
#include "calibration/display/conventions.h"
#include "calibration/simulation/seeded_random.h"
#include "common/input_error.h"

namespace parallax {
namespace {

// Screen point lit by module pixel (u, v) in the truth, or false.
bool screenPointOf(const Screen& screen, const ModuleOptics& optics, double u, double v,
                   Eigen::Vector3d* s) {
  Eigen::Vector3d d;
  if (!optics.rayDirection(u, v, &d)) return false;
  double t;
  return screen.intersect(optics.position(), d, &t, s);
}

}  // namespace

void CameraRigOptions::validate() const {
  if (stations < 1 || stations > 64) throw InputError({"", "stations", 0}, "must be 1..64");
  if (!(spanM >= 0.0 && spanM < 20.0)) throw InputError({"", "span_m", 0}, "must be 0..20 m");
  if (!(tapeErrorM >= 0.0 && tapeErrorM < 1.0)) {
    throw InputError({"", "tape_error_m", 0}, "must be 0..1 m");
  }
  if (!(aimErrorDeg >= 0.0 && aimErrorDeg < 10.0)) {
    throw InputError({"", "aim_error_deg", 0}, "must be 0..10");
  }
  if (intrinsics.width < 16 || intrinsics.height < 16 || !(intrinsics.fx > 0.0) ||
      !(intrinsics.fy > 0.0)) {
    throw InputError({"", "intrinsics", 0},
                     "needs a size of at least 16 px and positive focal lengths");
  }
}

void SyntheticOptions::validate() const {
  rig.validate();
  auto check = [](bool ok, const char* field, const char* why) {
    if (!ok) throw InputError({"", field, 0}, why);
  };
  check(noisePx >= 0.0 && noisePx < 100.0, "noise_px", "must be 0..100");
  check(fiducialNoisePx >= 0.0 && fiducialNoisePx < 100.0, "fiducial_noise_px", "must be 0..100");
  check(rowStepPx >= 1.0, "row_step_px", "must be >= 1");
  check(samplesAcrossStripe >= 1 && samplesAcrossStripe <= 64, "samples_across_stripe",
        "must be 1..64");
  check(fullScreenStepPx >= 1.0, "full_screen_step_px", "must be >= 1");
  check(outlierFraction >= 0.0 && outlierFraction <= 0.5, "outlier_fraction", "must be 0..0.5");
}

std::vector<CameraStation> cameraStations(const DisplayModel& model, const CameraRigOptions& rig) {
  rig.validate();
  std::vector<CameraStation> stations;
  for (int i = 0; i < rig.stations; ++i) {
    const double x =
        rig.stations == 1 ? 0.0 : rig.spanM * (-0.5 + static_cast<double>(i) / (rig.stations - 1));
    stations.push_back({model.observer.pointAt(x)});
  }
  return stations;
}

SyntheticCalibration simulateObservations(const DisplayModel& truth,
                                          const SyntheticOptions& options) {
  options.validate();
  truth.validate();
  SyntheticCalibration out;
  CalibrationObservations& obs = out.observations;
  obs.intrinsics = options.rig.intrinsics;
  obs.stations = cameraStations(truth, options.rig);
  obs.fiducials = screenFiducials(truth.screen);
  SeededRandom random(options.seed);

  // True poses: the tape is off by up to tapeErrorM (each axis within ±tapeErrorM/√3), the aim
  // by up to aimErrorDeg about each axis.
  for (const CameraStation& station : obs.stations) {
    SeededRandom r = random.split();
    const double e = options.rig.tapeErrorM / std::sqrt(3.0);
    CameraPose pose;
    pose.centre =
        station.tapeCentre + Eigen::Vector3d(r.uniform(-e, e), r.uniform(-e, e), r.uniform(-e, e));
    const double a = radians(options.rig.aimErrorDeg);
    pose.physicalFromCamera = aimCameraAt(pose.centre, Eigen::Vector3d::Zero()) *
                              Eigen::AngleAxisd(r.uniform(-a, a), Eigen::Vector3d::UnitX()) *
                              Eigen::AngleAxisd(r.uniform(-a, a), Eigen::Vector3d::UnitY()) *
                              Eigen::AngleAxisd(r.uniform(-a, a), Eigen::Vector3d::UnitZ());
    out.truePoses.push_back(pose);
  }

  // Fiducials.
  SeededRandom fiducialRandom = random.split();
  for (size_t c = 0; c < out.truePoses.size(); ++c) {
    for (size_t f = 0; f < obs.fiducials.size(); ++f) {
      const Eigen::Vector3d point =
          truth.screen.pointAt(obs.fiducials[f].x(), obs.fiducials[f].y());
      Eigen::Vector2d px;
      if (!projectPhysical(obs.intrinsics, out.truePoses[c], point, &px)) continue;
      px += Eigen::Vector2d(fiducialRandom.normal(options.fiducialNoisePx),
                            fiducialRandom.normal(options.fiducialNoisePx));
      if (!obs.intrinsics.contains(px)) continue;
      obs.fiducialSightings.push_back({static_cast<int>(c), static_cast<int>(f), px});
    }
  }

  const double halfLobe = 0.5 * radians(truth.screen.diffusionDeg);
  for (size_t m = 0; m < truth.modules.size(); ++m) {
    SeededRandom r = random.split();  // per module, so hiding one leaves the others' draws alone
    if (std::find(options.hiddenModules.begin(), options.hiddenModules.end(),
                  static_cast<int>(m)) != options.hiddenModules.end()) {
      continue;
    }
    const OpticalModule& module = truth.modules[m];
    const ModuleOptics optics(module);
    auto addCorrespondence = [&](int camera, double u, double v, const Eigen::Vector3d& s) {
      Eigen::Vector2d px;
      if (!projectPhysical(obs.intrinsics, out.truePoses[static_cast<size_t>(camera)], s, &px))
        return;
      const Eigen::Vector2d noise(r.normal(options.noisePx), r.normal(options.noisePx));
      Eigen::Vector2d modulePx(u, v);
      if (options.noiseOnModulePx) {
        modulePx += noise;
      } else {
        px += noise;
      }
      if (!obs.intrinsics.contains(px)) return;
      if (r.uniform() < options.outlierFraction) {
        // A gross decoding error: some other pixel of the module entirely.
        modulePx = {r.uniform(0.0, module.width), r.uniform(0.0, module.height)};
      }
      obs.correspondences.push_back({camera, static_cast<int>(m), px, modulePx});
    };

    if (!options.lobeVisibility) {
      for (double v = 0.5 * options.fullScreenStepPx; v < module.height;
           v += options.fullScreenStepPx) {
        for (double u = 0.5 * options.fullScreenStepPx; u < module.width;
             u += options.fullScreenStepPx) {
          Eigen::Vector3d s;
          if (!screenPointOf(truth.screen, optics, u, v, &s)) continue;
          for (size_t c = 0; c < out.truePoses.size(); ++c)
            addCorrespondence(static_cast<int>(c), u, v, s);
        }
      }
      continue;
    }

    for (size_t c = 0; c < out.truePoses.size(); ++c) {
      const Eigen::Vector3d centre = out.truePoses[c].centre;
      auto angleAt = [&](double u, double v, double* angle, Eigen::Vector3d* s) {
        if (!screenPointOf(truth.screen, optics, u, v, s)) return false;
        *angle = stripeAngle(truth.screen, *s, module.position, centre);
        return std::isfinite(*angle);
      };
      for (double v = 0.5 * options.rowStepPx; v < module.height; v += options.rowStepPx) {
        // The stripe centre in this row: a sign change of the angle between coarse samples
        // along the row, then bisection. The angle falls monotonically across a module's
        // image, so there is at most one.
        constexpr int kCoarse = 32;
        double uLo = -1.0, uHi = -1.0, aLo = 0.0;
        double prevU = 0.0, prevA = 0.0;
        bool havePrev = false;
        for (int i = 0; i <= kCoarse; ++i) {
          const double u = 0.5 + (module.width - 1.0) * i / kCoarse;
          double a;
          Eigen::Vector3d s;
          if (!angleAt(u, v, &a, &s)) {
            havePrev = false;
            continue;
          }
          if (havePrev && (prevA <= 0.0) != (a <= 0.0)) {
            uLo = prevU;
            uHi = u;
            aLo = prevA;
            break;
          }
          prevU = u;
          prevA = a;
          havePrev = true;
        }
        if (uLo < 0.0) continue;
        for (int iter = 0; iter < 50 && uHi - uLo > 1e-6; ++iter) {
          const double mid = 0.5 * (uLo + uHi);
          double a;
          Eigen::Vector3d s;
          if (!angleAt(mid, v, &a, &s)) break;
          if ((a <= 0.0) == (aLo <= 0.0)) {
            uLo = mid;
            aLo = a;
          } else {
            uHi = mid;
          }
        }
        const double u0 = 0.5 * (uLo + uHi);
        Eigen::Vector3d s0;
        double a0;
        if (!angleAt(u0, v, &a0, &s0)) continue;
        // Width of the half lobe in module pixels from the local slope of the angle.
        double a1;
        Eigen::Vector3d s1;
        if (!angleAt(u0 + 1.0, v, &a1, &s1) || a1 == a0) continue;
        const double halfWidthPx = halfLobe / std::abs(a1 - a0);
        const int n = options.samplesAcrossStripe;
        for (int k = 0; k < n; ++k) {
          const double u = n == 1 ? u0 : u0 + halfWidthPx * (-1.0 + 2.0 * (k + 0.5) / n);
          Eigen::Vector3d s;
          if (u < 0.0 || u > module.width || !screenPointOf(truth.screen, optics, u, v, &s))
            continue;
          addCorrespondence(static_cast<int>(c), u, v, s);
        }
        if (options.stripes) {
          Eigen::Vector2d px;
          if (!projectPhysical(obs.intrinsics, out.truePoses[c], s0, &px)) continue;
          px += Eigen::Vector2d(r.normal(options.noisePx), r.normal(options.noisePx));
          if (!obs.intrinsics.contains(px)) continue;
          obs.stripes.push_back({static_cast<int>(c), static_cast<int>(m), px});
        }
      }
    }
  }
  return out;
}

}  // namespace parallax
