#include "calibration/fit/display_fit.h"

#include <ceres/ceres.h>
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>

#include "calibration/camera/calibration_geometry.h"
#include "common/input_error.h"

namespace parallax {
namespace {

constexpr double kRadToDeg = 180.0 / std::numbers::pi;
// A correspondence this many σ off is counted as an outlier in the report (the Cauchy loss has
// already down-weighted it in the fit).
constexpr double kOutlierSigmas = 5.0;

// ---- residuals ----

// r = (π_module(s(k, camera, n)) − (u, v)) / σ, module px / σ.
//   module[0..12] (fit_geometry.h), camera[0..6], k[0].
struct CorrespondenceCost {
  double nx, ny, u, v, width, mirrorSign, invSigma;

  template <typename T>
  bool operator()(const T* module, const T* camera, const T* k, T* r) const {
    Vec3<T> s;
    if (!screenPointOfCameraRay(k[0], camera, nx, ny, &s)) return false;
    T uv[2];
    if (!projectIntoModule(module, width, mirrorSign, s, uv)) return false;
    r[0] = (uv[0] - T(u)) * T(invSigma);
    r[1] = (uv[1] - T(v)) * T(invSigma);
    return true;
  }
};

// r = (π_camera(s(module, k, u, v)) − observed camera px) · scale / σ. The noise sits on the
// camera pixel (the decoder locates the pattern in the picture; the module pixel is the code it
// read, exact), so the camera pixel is predicted from the module pixel and stays on the
// measured side: back-projecting the noisy camera pixel instead (CorrespondenceCost) puts the
// noise inside the model, which biases least squares (errors in variables). `scale`, module px
// per camera px at this correspondence fixed at the start, keeps the residual in module px like
// the other form, so σ, outliers and reports keep their units.
struct CameraCorrespondenceCost {
  const CameraIntrinsics* intrinsics;
  double u, v, cameraU, cameraV, width, mirrorSign, scaleOverSigma;

  template <typename T>
  bool operator()(const T* module, const T* camera, const T* k, T* r) const {
    Vec3<T> s;
    if (!screenPointOfModulePixel(module, width, mirrorSign, k[0], u, v, &s)) return false;
    T px[2];
    if (!projectIntoCamera(*intrinsics, camera, s, px)) return false;
    r[0] = (px[0] - T(cameraU)) * T(scaleOverSigma);
    r[1] = (px[1] - T(cameraV)) * T(scaleOverSigma);
    return true;
  }
};

// r = stripeMismatch(s(k, camera, n), p, c) / σ, mm / σ.
struct StripeCost {
  double nx, ny, invSigmaM;
  ScreenTransfer transfer;

  template <typename T>
  bool operator()(const T* module, const T* camera, const T* k, T* r) const {
    Vec3<T> s;
    if (!screenPointOfCameraRay(k[0], camera, nx, ny, &s)) return false;
    const Vec3<T> p(module[4], module[5], module[6]);
    const Vec3<T> c(camera[4], camera[5], camera[6]);
    r[0] = stripeMismatch(transfer, k[0], s, p, c) * T(invSigmaM);
    return true;
  }
};

// r = (π_camera(x, y, sag(k, x)) − observed) / σ, camera px / σ.
struct FiducialCost {
  const CameraIntrinsics* intrinsics;
  double x, y, px, py, invSigma;

  template <typename T>
  bool operator()(const T* camera, const T* k, T* r) const {
    const Vec3<T> point(T(x), T(y), screenSag(k[0], T(x)));
    T pixel[2];
    if (!projectIntoCamera(*intrinsics, camera, point, pixel)) return false;
    r[0] = (pixel[0] - T(px)) * T(invSigma);
    r[1] = (pixel[1] - T(py)) * T(invSigma);
    return true;
  }
};

// r = (centre − tape) / σ_tape.
struct TapeCost {
  Eigen::Vector3d tape;
  double invSigma;

  template <typename T>
  bool operator()(const T* camera, T* r) const {
    for (int i = 0; i < 3; ++i) r[i] = (camera[4 + i] - T(tape[i])) * T(invSigma);
    return true;
  }
};

struct Sigmas {
  double correspondencePx, stripeMm, fiducialPx;
};

struct State {
  std::vector<std::array<double, kModuleBlockSize>> modules;
  std::vector<std::array<double, kCameraBlockSize>> cameras;
  double k = 0.0;
};

// Observations with their normalized camera coordinates precomputed (camera intrinsics are
// fixed: undistortion happens once, here, never inside the solver).
struct Prepared {
  std::vector<Eigen::Vector2d> corrN, stripeN;
};

class ProgressCallback : public ceres::IterationCallback {
 public:
  explicit ProgressCallback(const std::function<void(int, double)>& f) : f_(f) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    if (f_) f_(s.iteration, s.cost);
    return ceres::SOLVER_CONTINUE;
  }

 private:
  const std::function<void(int, double)>& f_;
};

// Ends a solve when the caller asks (FitOptions::stopRequested).
class StopCallback : public ceres::IterationCallback {
 public:
  explicit StopCallback(const std::function<bool()>& stopRequested)
      : stopRequested_(stopRequested) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return stopRequested_() ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
  }

 private:
  const std::function<bool()>& stopRequested_;
};

// Stops a solve once a successful step lowers the cost by less than `tolerance`. The cost is
// ½ Σ (r/σ)², so near the minimum a step that lowers it by ΔC moved the parameters by
// √(2 ΔC) standard deviations (Mahalanobis): 0.01 is 0.14 σ, and the steps still to come
// (each ~10× smaller here) would not change the rays. Ceres' relative tolerance cannot say
// this: the cost grows with the number of observations (1e-10 of it took 2–3 more Jacobians).
class CostChangeTolerance : public ceres::IterationCallback {
 public:
  explicit CostChangeTolerance(double tolerance) : tolerance_(tolerance) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    if (s.iteration > 0 && s.step_is_successful && s.cost_change < tolerance_) {
      return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
    }
    return ceres::SOLVER_CONTINUE;
  }

 private:
  double tolerance_;
};

// Cost-change tolerances: a first solve only has to bring a start close enough for the
// camera-px residual and the outlier test (within a σ or so); the final one to 0.14 σ.
constexpr double kStartCostTolerance = 1.0;
constexpr double kFinalCostTolerance = 0.01;
// Correspondences in the first solve (more cost time, not a better start); the final one uses all.
constexpr size_t kStartCorrespondences = 40000;

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(mid), v.end());
  return v[mid];
}

// Robust σ: 1.4826 × median |r| is σ for Gaussian noise and ignores up to half outliers.
double robustSigma(const std::vector<double>& absResiduals) {
  return 1.4826 * median(absResiduals);
}

class DisplayFitter {
 public:
  DisplayFitter(const DisplayModel& nominal, const CalibrationObservations& obs,
                const FitOptions& options, ScreenTransfer transfer)
      : nominal_(nominal), obs_(obs), options_(options), transfer_(transfer) {
    observed_.assign(nominal.modules.size(), false);
    for (const Correspondence& c : obs.correspondences)
      observed_[static_cast<size_t>(c.module)] = true;
    held_.assign(nominal.modules.size(), false);
    for (int m : options.heldModules) held_[static_cast<size_t>(m)] = true;
    for (const Correspondence& c : obs.correspondences)
      prepared_.corrN.push_back(obs.intrinsics.normalized(c.cameraPx));
    for (const StripeCentre& s : obs.stripes)
      prepared_.stripeN.push_back(obs.intrinsics.normalized(s.cameraPx));
    // Start: nominal modules, cameras at the tape marks aimed at the screen centre.
    for (const OpticalModule& m : nominal.modules) state_.modules.push_back(packModule(m));
    for (const CameraStation& st : obs.stations) {
      CameraPose pose;
      pose.centre = st.tapeCentre;
      pose.physicalFromCamera = aimCameraAt(st.tapeCentre, Eigen::Vector3d::Zero());
      state_.cameras.push_back(packCamera(pose));
    }
    state_.k = nominal.screen.curvature;
    sigmas_ = {options.correspondenceSigmaPx, options.stripeSigmaMm, options.fiducialSigmaPx};
  }

  FitResult run() {
    const auto start = std::chrono::steady_clock::now();
    FitResult result;
    // Stage 0: camera poses (and k) from fiducials and tape alone, so the full problem starts
    // with cameras that see the screen where it is.
    solve(/*withModules=*/false, /*costTolerance=*/0.0, &result);
    if (result.stopped) return result;
    findFiducialOutliers();
    // Stage 1: the module-px residual. It is defined wherever a camera ray meets the screen,
    // so a bad start or a gross decoding error cannot stop the solve; its answer is biased
    // (the camera noise sits inside the model) but close, and it finds the outliers and σ.
    // When a final solve follows, this is a start: it needs no more than
    // kStartCorrespondences, beyond that one in `stride_` (observations come in scan order,
    // so every module and station keeps its share).
    const bool finalSolveFollows = options_.residualInCameraPx || options_.reestimateNoise;
    stride_ = finalSolveFollows
                  ? std::max<size_t>(1, obs_.correspondences.size() / kStartCorrespondences)
                  : 1;
    solve(true, finalSolveFollows ? kStartCostTolerance : kFinalCostTolerance, &result);
    stride_ = 1;
    if (result.stopped) return result;
    if (options_.reestimateNoise) reestimateSigmas();
    if (options_.residualInCameraPx) {
      // Stage 2: the camera-px residual from that start, without the gross outliers (a wrong
      // module pixel can light a point the camera never saw, where this residual is not
      // defined and would stall the solver).
      fixCameraScales();
      excludeOutliers();
      cameraResidual_ = true;
      solve(true, kFinalCostTolerance, &result);
      if (result.stopped) return result;
      if (options_.reestimateNoise) {
        reestimateSigmas();
        problem_ = build(true);  // the covariance is read with the final σ
      }
    } else if (options_.reestimateNoise) {
      solve(true, kFinalCostTolerance, &result);
    }
    result.solveSeconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const auto diagnosticsStart = std::chrono::steady_clock::now();
    report(&result);
    result.diagnosticsSeconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - diagnosticsStart).count();
    return result;
  }

 private:
  double kHalfLimit() const { return 0.98 / (0.5 * nominal_.screen.width); }

  std::unique_ptr<ceres::Problem> build(bool withModules) {
    // One loss object shared by all robust blocks, owned here rather than by the problem.
    ceres::Problem::Options po;
    po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    auto problem = std::make_unique<ceres::Problem>(po);
    lossOwner_ = std::make_unique<ceres::CauchyLoss>(options_.robustScale);
    ceres::LossFunction* loss = lossOwner_.get();
    for (auto& cam : state_.cameras) {
      problem->AddParameterBlock(cam.data(), kCameraBlockSize,
                                 new ceres::ProductManifold<ceres::EigenQuaternionManifold,
                                                            ceres::EuclideanManifold<3>>());
    }
    problem->AddParameterBlock(&state_.k, 1);
    problem->SetParameterLowerBound(&state_.k, 0, -kHalfLimit());
    problem->SetParameterUpperBound(&state_.k, 0, kHalfLimit());
    if (!options_.fitCurvature) problem->SetParameterBlockConstant(&state_.k);

    // Fiducials: robust while the cameras are placed by them alone (stage 0), which finds the
    // misdetected ones; with the modules, the others enter without a loss. They are the
    // gauge (the cylinder does not change along y: beyond the tape's 5 cm only they hold the
    // height of everything):
    // under a robust loss, a start far off at high noise let the correspondences (99.9% of
    // the residuals) push them into the loss's flat tail, and the whole fit drifted (2 px
    // noise, 160k correspondences on default: rays off by 10^27 px).
    for (size_t i = 0; i < obs_.fiducialSightings.size(); ++i) {
      if (withModules && fiducialOutlier_[i]) continue;
      const FiducialSighting& f = obs_.fiducialSightings[i];
      const Eigen::Vector2d& xy = obs_.fiducials[static_cast<size_t>(f.fiducial)];
      auto* cost = new ceres::AutoDiffCostFunction<FiducialCost, 2, kCameraBlockSize, 1>(
          new FiducialCost{&obs_.intrinsics, xy.x(), xy.y(), f.cameraPx.x(), f.cameraPx.y(),
                           1.0 / sigmas_.fiducialPx});
      problem->AddResidualBlock(cost, withModules ? nullptr : loss,
                                state_.cameras[static_cast<size_t>(f.camera)].data(), &state_.k);
    }
    for (size_t c = 0; c < obs_.stations.size(); ++c) {
      auto* cost = new ceres::AutoDiffCostFunction<TapeCost, 3, kCameraBlockSize>(
          new TapeCost{obs_.stations[c].tapeCentre, 1.0 / options_.tapeSigmaM});
      problem->AddResidualBlock(cost, nullptr, state_.cameras[c].data());
    }
    if (!withModules) return problem;

    for (size_t m = 0; m < state_.modules.size(); ++m) {
      if (!observed_[m]) continue;
      problem->AddParameterBlock(state_.modules[m].data(), kModuleBlockSize,
                                 new ceres::ProductManifold<ceres::EigenQuaternionManifold,
                                                            ceres::EuclideanManifold<9>>());
      if (held_[m]) problem->SetParameterBlockConstant(state_.modules[m].data());
    }
    for (size_t i = 0; i < obs_.correspondences.size(); ++i) {
      if (i % stride_ != 0 || (cameraResidual_ && excluded_[i])) continue;
      const Correspondence& c = obs_.correspondences[i];
      const OpticalModule& m = nominal_.modules[static_cast<size_t>(c.module)];
      ceres::CostFunction* cost;
      Eigen::Vector2d startResidual;
      // A residual Ceres cannot evaluate at the start stops the solve before its first step;
      // such a correspondence (a module pixel whose starting ray misses the screen, at the
      // rim of a strongly curved one) is left out of this solve.
      if (!correspondenceResidual(i, &startResidual)) continue;
      if (cameraResidual_) {
        cost = new ceres::AutoDiffCostFunction<CameraCorrespondenceCost, 2, kModuleBlockSize,
                                               kCameraBlockSize, 1>(new CameraCorrespondenceCost{
            &obs_.intrinsics, c.modulePx.x(), c.modulePx.y(), c.cameraPx.x(), c.cameraPx.y(),
            static_cast<double>(m.width), m.mirror ? -1.0 : 1.0,
            cameraScale_[i] / sigmas_.correspondencePx});
      } else {
        cost = new ceres::AutoDiffCostFunction<CorrespondenceCost, 2, kModuleBlockSize,
                                               kCameraBlockSize, 1>(new CorrespondenceCost{
            prepared_.corrN[i].x(), prepared_.corrN[i].y(), c.modulePx.x(), c.modulePx.y(),
            static_cast<double>(m.width), m.mirror ? -1.0 : 1.0, 1.0 / sigmas_.correspondencePx});
      }
      problem->AddResidualBlock(cost, loss, state_.modules[static_cast<size_t>(c.module)].data(),
                                state_.cameras[static_cast<size_t>(c.camera)].data(), &state_.k);
    }
    for (size_t i = 0; i < obs_.stripes.size(); ++i) {
      const StripeCentre& s = obs_.stripes[i];
      if (!observed_[static_cast<size_t>(s.module)]) continue;
      auto* cost =
          new ceres::AutoDiffCostFunction<StripeCost, 1, kModuleBlockSize, kCameraBlockSize, 1>(
              new StripeCost{prepared_.stripeN[i].x(), prepared_.stripeN[i].y(),
                             1.0 / (1e-3 * sigmas_.stripeMm), transfer_});
      problem->AddResidualBlock(cost, loss, state_.modules[static_cast<size_t>(s.module)].data(),
                                state_.cameras[static_cast<size_t>(s.camera)].data(), &state_.k);
    }
    return problem;
  }

  void solve(bool withModules, double costTolerance, FitResult* result) {
    problem_.reset();
    problem_ = build(withModules);
    ceres::Solver::Options so;
    so.max_num_iterations = options_.maxIterations;
    so.num_threads = options_.threads;
    so.function_tolerance = 1e-10;
    so.parameter_tolerance = 1e-10;
    so.gradient_tolerance = 1e-14;
    so.logging_type = ceres::SILENT;
    if (withModules) {
      // Modules never share a residual, so they are eliminated first (bundle adjustment's
      // points); the reduced system over cameras and k is tiny and dense.
      so.linear_solver_type = ceres::DENSE_SCHUR;
      auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
      for (size_t m = 0; m < state_.modules.size(); ++m) {
        if (observed_[m]) ordering->AddElementToGroup(state_.modules[m].data(), 0);
      }
      for (auto& cam : state_.cameras) ordering->AddElementToGroup(cam.data(), 1);
      ordering->AddElementToGroup(&state_.k, 1);
      so.linear_solver_ordering = ordering;
    } else {
      so.linear_solver_type = ceres::DENSE_QR;
    }
    ProgressCallback callback(options_.onIteration);
    if (options_.onIteration) so.callbacks.push_back(&callback);
    CostChangeTolerance tolerance(costTolerance);
    so.callbacks.push_back(&tolerance);
    StopCallback stop(options_.stopRequested);
    if (options_.stopRequested) so.callbacks.push_back(&stop);
    ceres::Solver::Summary summary;
    // The bounds on k make Ceres follow every trust-region step with a projected line search
    // that evaluates the full Jacobian a second time (half the solve time). The bounds are
    // still kept: Ceres clamps each step into them.
    so.max_num_line_search_step_size_iterations = 0;
    ceres::Solve(so, problem_.get(), &summary);
    result->iterations += static_cast<int>(summary.iterations.size());
    // Only StopCallback aborts (USER_FAILURE); the others continue or end successfully.
    if (summary.termination_type == ceres::USER_FAILURE && options_.stopRequested)
      result->stopped = true;
    if (withModules) {
      result->converged = summary.termination_type == ceres::CONVERGENCE ||
                          summary.termination_type == ceres::USER_SUCCESS;
    }
  }

  // Unrobustified residuals, in their natural units.
  // Module px of camera pixel `n` (normalized) of correspondence i through the current state.
  bool modulePixelOf(size_t i, const Eigen::Vector2d& n, Eigen::Vector2d* uv) const {
    const Correspondence& c = obs_.correspondences[i];
    const OpticalModule& m = nominal_.modules[static_cast<size_t>(c.module)];
    const CorrespondenceCost cost{
        n.x(), n.y(), 0.0, 0.0, static_cast<double>(m.width), m.mirror ? -1.0 : 1.0, 1.0};
    double out[2];
    if (!cost(state_.modules[static_cast<size_t>(c.module)].data(),
              state_.cameras[static_cast<size_t>(c.camera)].data(), &state_.k, out)) {
      return false;
    }
    *uv = {out[0], out[1]};
    return uv->allFinite();
  }

  // Fiducial sightings more than kOutlierSigmas σ off once the cameras are placed.
  void findFiducialOutliers() {
    fiducialOutlier_.assign(obs_.fiducialSightings.size(), false);
    for (size_t i = 0; i < obs_.fiducialSightings.size(); ++i) {
      const FiducialSighting& f = obs_.fiducialSightings[i];
      const Eigen::Vector2d& xy = obs_.fiducials[static_cast<size_t>(f.fiducial)];
      const FiducialCost cost{&obs_.intrinsics, xy.x(),         xy.y(),
                              f.cameraPx.x(),   f.cameraPx.y(), 1.0};
      double r[2];
      fiducialOutlier_[i] =
          !cost(state_.cameras[static_cast<size_t>(f.camera)].data(), &state_.k, r) ||
          std::hypot(r[0], r[1]) > kOutlierSigmas * sigmas_.fiducialPx;
    }
  }

  // Correspondences more than kOutlierSigmas σ off after the module-px stage: gross decoding
  // errors, left out of the camera-px stage (the report still counts them as outliers).
  void excludeOutliers() {
    excluded_.assign(obs_.correspondences.size(), false);
    for (size_t i = 0; i < obs_.correspondences.size(); ++i) {
      Eigen::Vector2d r;
      excluded_[i] =
          !correspondenceResidual(i, &r) || r.norm() > kOutlierSigmas * sigmas_.correspondencePx;
    }
  }

  // Module px per camera px at every correspondence, √|det| of the local 2 × 2 map, from the
  // current state (called once, after the cameras found the screen). Where it cannot be
  // evaluated, the median of the others.
  void fixCameraScales() {
    cameraScale_.assign(obs_.correspondences.size(), 0.0);
    std::vector<double> good;
    for (size_t i = 0; i < obs_.correspondences.size(); ++i) {
      const Eigen::Vector2d& px = obs_.correspondences[i].cameraPx;
      Eigen::Vector2d a, b, c;
      if (!modulePixelOf(i, prepared_.corrN[i], &a) ||
          !modulePixelOf(i, obs_.intrinsics.normalized(px + Eigen::Vector2d(1.0, 0.0)), &b) ||
          !modulePixelOf(i, obs_.intrinsics.normalized(px + Eigen::Vector2d(0.0, 1.0)), &c)) {
        continue;
      }
      Eigen::Matrix2d j;
      j << b - a, c - a;
      const double scale = std::sqrt(std::abs(j.determinant()));
      if (std::isfinite(scale) && scale > 0.0) {
        cameraScale_[i] = scale;
        good.push_back(scale);
      }
    }
    const double fallback = good.empty() ? 1.0 : median(good);
    for (double& s : cameraScale_) {
      if (!(s > 0.0)) s = fallback;
    }
  }

  bool correspondenceResidual(size_t i, Eigen::Vector2d* r) const {
    const Correspondence& c = obs_.correspondences[i];
    if (cameraResidual_) {
      const OpticalModule& m = nominal_.modules[static_cast<size_t>(c.module)];
      const CameraCorrespondenceCost cost{&obs_.intrinsics,      c.modulePx.x(),
                                          c.modulePx.y(),        c.cameraPx.x(),
                                          c.cameraPx.y(),        static_cast<double>(m.width),
                                          m.mirror ? -1.0 : 1.0, cameraScale_[i]};
      double out[2];
      if (!cost(state_.modules[static_cast<size_t>(c.module)].data(),
                state_.cameras[static_cast<size_t>(c.camera)].data(), &state_.k, out)) {
        return false;
      }
      *r = {out[0], out[1]};
      return r->allFinite();
    }
    Eigen::Vector2d uv;
    if (!modulePixelOf(i, prepared_.corrN[i], &uv)) return false;
    *r = uv - c.modulePx;
    return true;
  }
  bool stripeResidualMm(size_t i, double* r) const {
    const StripeCentre& s = obs_.stripes[i];
    const StripeCost cost{prepared_.stripeN[i].x(), prepared_.stripeN[i].y(), 1e3, transfer_};
    double out;
    if (!cost(state_.modules[static_cast<size_t>(s.module)].data(),
              state_.cameras[static_cast<size_t>(s.camera)].data(), &state_.k, &out)) {
      return false;
    }
    *r = out;
    return std::isfinite(out);
  }
  // Size of a module pixel on the screen (mm), for expressing module-px noise on the screen.
  double mmPerModulePx() const {
    std::vector<double> v;
    for (size_t m = 0; m < state_.modules.size(); ++m) {
      if (!observed_[m]) continue;
      const auto& b = state_.modules[m];
      const double distance = Eigen::Vector3d(b[4], b[5], b[6]).norm();
      v.push_back(1e3 * distance / (b[7] * nominal_.modules[m].width));
    }
    return v.empty() ? 1.0 : median(v);
  }

  void reestimateSigmas() {
    std::vector<double> corr, stripe;
    for (size_t i = 0; i < obs_.correspondences.size(); ++i) {
      Eigen::Vector2d r;
      if (correspondenceResidual(i, &r)) {
        corr.push_back(std::abs(r.x()));
        corr.push_back(std::abs(r.y()));
      }
    }
    for (size_t i = 0; i < obs_.stripes.size(); ++i) {
      double r;
      if (observed_[static_cast<size_t>(obs_.stripes[i].module)] && stripeResidualMm(i, &r))
        stripe.push_back(std::abs(r));
    }
    // Floors: exact synthetic data would give σ = 0 and an information matrix of infinities.
    if (!corr.empty()) sigmas_.correspondencePx = std::max(robustSigma(corr), 1e-3);
    const double corrMm = sigmas_.correspondencePx * mmPerModulePx();
    if (!stripe.empty())
      sigmas_.stripeMm = std::max(robustSigma(stripe), std::max(0.5 * corrMm, 1e-3));
  }

  void report(FitResult* result) {
    // ---- the model ----
    result->model = nominal_;
    result->model.name = nominal_.name + "-calibrated";
    result->model.screen.curvature = state_.k;
    result->model.screen.transfer = transfer_;
    for (size_t m = 0; m < state_.modules.size(); ++m) {
      if (observed_[m]) unpackModule(state_.modules[m].data(), &result->model.modules[m]);
    }

    // ---- residual statistics ----
    result->modules.assign(nominal_.modules.size(), {});
    result->cameras.assign(obs_.stations.size(), {});
    std::vector<double> sumSqModule(nominal_.modules.size(), 0.0),
        sumSqCamera(obs_.stations.size(), 0.0);
    std::vector<int> inliersModule(nominal_.modules.size(), 0),
        inliersCamera(obs_.stations.size(), 0);
    for (size_t m = 0; m < nominal_.modules.size(); ++m) {
      result->modules[m].module = static_cast<int>(m);
      result->modules[m].observed = observed_[m];
    }
    for (size_t c = 0; c < obs_.stations.size(); ++c) {
      result->cameras[c].camera = static_cast<int>(c);
      result->cameras[c].pose = unpackCamera(state_.cameras[c].data());
    }
    for (size_t i = 0; i < obs_.correspondences.size(); ++i) {
      const Correspondence& c = obs_.correspondences[i];
      ModuleFit& mf = result->modules[static_cast<size_t>(c.module)];
      CameraFit& cf = result->cameras[static_cast<size_t>(c.camera)];
      ++mf.correspondences;
      ++cf.correspondences;
      Eigen::Vector2d r;
      if (!correspondenceResidual(i, &r) || r.norm() > kOutlierSigmas * sigmas_.correspondencePx) {
        ++mf.outliers;
        ++result->outliers;
        continue;
      }
      sumSqModule[static_cast<size_t>(c.module)] += r.squaredNorm();
      sumSqCamera[static_cast<size_t>(c.camera)] += r.squaredNorm();
      ++inliersModule[static_cast<size_t>(c.module)];
      ++inliersCamera[static_cast<size_t>(c.camera)];
    }
    // RMS per axis (so it compares with σ directly).
    for (size_t m = 0; m < result->modules.size(); ++m) {
      if (inliersModule[m])
        result->modules[m].rmsPx = std::sqrt(sumSqModule[m] / (2.0 * inliersModule[m]));
    }
    for (size_t c = 0; c < result->cameras.size(); ++c) {
      if (inliersCamera[c])
        result->cameras[c].rmsPx = std::sqrt(sumSqCamera[c] / (2.0 * inliersCamera[c]));
    }
    std::vector<double> stripeAbs, stripeSumSq(nominal_.modules.size(), 0.0);
    double stripeTotal = 0.0;
    for (size_t i = 0; i < obs_.stripes.size(); ++i) {
      const StripeCentre& s = obs_.stripes[i];
      if (!observed_[static_cast<size_t>(s.module)]) continue;
      double r;
      if (!stripeResidualMm(i, &r)) continue;
      ++result->modules[static_cast<size_t>(s.module)].stripes;
      result->stripeResidualsMm.push_back(r);
      stripeSumSq[static_cast<size_t>(s.module)] += r * r;
      stripeTotal += r * r;
      stripeAbs.push_back(std::abs(r));
    }
    for (size_t m = 0; m < result->modules.size(); ++m) {
      ModuleFit& mf = result->modules[m];
      if (mf.stripes) mf.stripeRmsMm = std::sqrt(stripeSumSq[m] / mf.stripes);
    }
    if (!stripeAbs.empty())
      result->stripeRmsMm = std::sqrt(stripeTotal / static_cast<double>(stripeAbs.size()));
    double fidSumSq = 0.0;
    int fidCount = 0;
    std::vector<double> camFidSumSq(obs_.stations.size(), 0.0);
    for (const FiducialSighting& f : obs_.fiducialSightings) {
      const Eigen::Vector2d& xy = obs_.fiducials[static_cast<size_t>(f.fiducial)];
      const FiducialCost cost{&obs_.intrinsics, xy.x(),         xy.y(),
                              f.cameraPx.x(),   f.cameraPx.y(), 1.0};
      double r[2];
      if (!cost(state_.cameras[static_cast<size_t>(f.camera)].data(), &state_.k, r)) continue;
      const double sq = r[0] * r[0] + r[1] * r[1];
      fidSumSq += sq;
      ++fidCount;
      camFidSumSq[static_cast<size_t>(f.camera)] += sq;
      ++result->cameras[static_cast<size_t>(f.camera)].fiducials;
    }
    if (fidCount) result->fiducialRmsPx = std::sqrt(fidSumSq / (2.0 * fidCount));
    for (CameraFit& cf : result->cameras) {
      if (cf.fiducials)
        cf.fiducialRmsPx =
            std::sqrt(camFidSumSq[static_cast<size_t>(cf.camera)] / (2.0 * cf.fiducials));
    }
    result->correspondenceSigmaPx = sigmas_.correspondencePx;
    result->stripeSigmaMm = sigmas_.stripeMm;
    result->correspondenceSigmaMm = sigmas_.correspondencePx * mmPerModulePx();

    // ---- the transfer check: stripes that the assumed transfer cannot explain ----
    const double stripeSigma = robustSigma(stripeAbs);
    if (!stripeAbs.empty() && stripeSigma > options_.transferMismatchRatio *
                                                std::max(result->correspondenceSigmaMm, 0.1)) {
      result->transferMismatch = true;
      result->notes.push_back(fmt::format(
          "the stripe centres disagree with the assumed {} transfer: their residuals are {:.2f} mm "
          "(robust σ) against {:.3f} mm for the correspondences; the screen does not follow the {} "
          "model",
          transferName(transfer_), stripeSigma, result->correspondenceSigmaMm,
          transferName(transfer_)));
    }

    diagnoseJacobian(result);

    for (size_t m = 0; m < result->modules.size(); ++m) {
      if (!observed_[m]) {
        result->notes.push_back(fmt::format(
            "module {} was not seen by any camera: kept at its nominal pose and intrinsics", m));
      }
    }
    int held = 0;
    for (size_t m = 0; m < held_.size(); ++m) held += held_[m] ? 1 : 0;
    if (held > 0)
      result->notes.push_back(fmt::format("{} module(s) held at their starting calibration", held));
  }

  void diagnoseJacobian(FitResult* result) {
    std::vector<double*> blocks;
    std::vector<size_t> moduleOf;
    for (size_t m = 0; m < state_.modules.size(); ++m) {
      if (observed_[m] && !held_[m]) {  // held modules are not estimated: no covariance
        blocks.push_back(state_.modules[m].data());
        moduleOf.push_back(m);
      }
    }
    for (auto& cam : state_.cameras) blocks.push_back(cam.data());
    if (options_.fitCurvature) blocks.push_back(&state_.k);
    ceres::Problem::EvaluateOptions eo;
    eo.parameter_blocks = blocks;
    eo.apply_loss_function = true;
    eo.num_threads = options_.threads;
    ceres::CRSMatrix jacobian;
    double cost = 0.0;
    const int sharedSize = kCameraTangentSize * static_cast<int>(state_.cameras.size()) +
                           (options_.fitCurvature ? 1 : 0);
    if (!problem_->Evaluate(eo, &cost, nullptr, nullptr, &jacobian)) {
      result->notes.push_back("the Jacobian could not be evaluated at the solution");
      result->converged = false;
      return;
    }
    const InformationBlocks info = informationFromJacobian(
        jacobian.num_rows, jacobian.num_cols, jacobian.rows, jacobian.cols, jacobian.values,
        static_cast<int>(moduleOf.size()), kModuleTangentSize, sharedSize);
    const Diagnostics d = diagnose(info, options_.conditioning);

    for (size_t j = 0; j < moduleOf.size(); ++j) {
      ModuleFit& mf = result->modules[moduleOf[j]];
      mf.conditioning = d.modules[j];
      const double width = nominal_.modules[moduleOf[j]].width;
      for (int p = 0; p < kModuleTangentSize; ++p) {
        double sd = d.moduleStdDev[j][p];
        if (p < 3)
          sd *= kRadToDeg;
        else if (p < 6)
          sd *= 1e3;
        else if (p < 10)
          sd *= width;
        mf.stdDev[static_cast<size_t>(p)] = sd;
      }
      // The module's covariance joined with k's, for the gate (ray_uncertainty.h).
      Eigen::MatrixXd& cov = mf.rayCovariance;
      cov = Eigen::MatrixXd::Zero(kModuleTangentSize + 1, kModuleTangentSize + 1);
      cov.topLeftCorner(kModuleTangentSize, kModuleTangentSize) = d.moduleCovariance[j];
      if (options_.fitCurvature) {
        const Eigen::VectorXd cross = d.moduleSharedCovariance[j].col(sharedSize - 1);
        cov.block(0, kModuleTangentSize, kModuleTangentSize, 1) = cross;
        cov.block(kModuleTangentSize, 0, 1, kModuleTangentSize) = cross.transpose();
        cov(kModuleTangentSize, kModuleTangentSize) =
            d.sharedCovariance(sharedSize - 1, sharedSize - 1);
      }
      for (int p = 0; p < kModuleTangentSize; ++p) {
        if (!std::isfinite(d.moduleStdDev[j][p]))
          cov(p, p) = std::numeric_limits<double>::infinity();
      }
      if (d.modules[j].state != Conditioning::kGood) {
        Deficiency def;
        def.module = static_cast<int>(moduleOf[j]);
        def.state = d.modules[j].state;
        def.reciprocalCondition = d.modules[j].reciprocalCondition;
        for (int p : d.modules[j].nullDirection) def.parameters.push_back(moduleParameterName(p));
        result->deficiencies.push_back(def);
      }
    }
    for (size_t c = 0; c < state_.cameras.size(); ++c) {
      for (int p = 0; p < kCameraTangentSize; ++p) {
        double sd = d.sharedStdDev[static_cast<long>(c) * kCameraTangentSize + p];
        sd *= p < 3 ? kRadToDeg : 1e3;
        result->cameras[c].stdDev[static_cast<size_t>(p)] = sd;
      }
    }
    result->curvatureStdDev = options_.fitCurvature ? d.sharedStdDev[sharedSize - 1] : 0.0;
    if (d.shared.state != Conditioning::kGood) {
      Deficiency def;
      def.module = -1;
      def.state = d.shared.state;
      def.reciprocalCondition = d.shared.reciprocalCondition;
      for (int p : d.shared.nullDirection) {
        if (options_.fitCurvature && p == sharedSize - 1) {
          def.parameters.push_back("screen curvature k");
        } else {
          def.parameters.push_back(fmt::format("camera {} {}", p / kCameraTangentSize,
                                               cameraParameterName(p % kCameraTangentSize)));
        }
      }
      result->deficiencies.push_back(def);
    }
  }

  const DisplayModel& nominal_;
  const CalibrationObservations& obs_;
  const FitOptions& options_;
  ScreenTransfer transfer_;
  std::vector<bool> observed_;
  std::vector<bool> held_;
  Prepared prepared_;
  State state_;
  Sigmas sigmas_;
  size_t stride_ = 1;                  // every stride_-th correspondence in the solve
  bool cameraResidual_ = false;        // the stage: correspondence residual in camera px
  std::vector<double> cameraScale_;    // per correspondence, for the camera-px stage
  std::vector<bool> excluded_;         // per correspondence, left out of the camera-px stage
  std::vector<bool> fiducialOutlier_;  // per sighting, left out once the modules are in
  std::unique_ptr<ceres::LossFunction> lossOwner_;
  std::unique_ptr<ceres::Problem> problem_;
};

void validateObservations(const DisplayModel& nominal, const CalibrationObservations& obs) {
  const int modules = static_cast<int>(nominal.modules.size());
  const int cameras = static_cast<int>(obs.stations.size());
  const int fiducials = static_cast<int>(obs.fiducials.size());
  auto finite2 = [](const Eigen::Vector2d& v) {
    return std::isfinite(v.x()) && std::isfinite(v.y());
  };
  if (cameras == 0) throw InputError({"", "stations", 0}, "no camera stations");
  for (int c = 0; c < cameras; ++c) {
    if (!obs.stations[static_cast<size_t>(c)].tapeCentre.allFinite()) {
      throw InputError({"", fmt::format("stations[{}].tape_centre", c), 0}, "not finite");
    }
  }
  for (size_t i = 0; i < obs.correspondences.size(); ++i) {
    const Correspondence& c = obs.correspondences[i];
    if (c.module < 0 || c.module >= modules || c.camera < 0 || c.camera >= cameras ||
        !finite2(c.cameraPx) || !finite2(c.modulePx)) {
      throw InputError({"", fmt::format("correspondences[{}]", i), 0},
                       "refers to a module or camera that does not exist, or is not finite");
    }
  }
  for (size_t i = 0; i < obs.stripes.size(); ++i) {
    const StripeCentre& s = obs.stripes[i];
    if (s.module < 0 || s.module >= modules || s.camera < 0 || s.camera >= cameras ||
        !finite2(s.cameraPx)) {
      throw InputError({"", fmt::format("stripes[{}]", i), 0},
                       "refers to a module or camera that does not exist, or is not finite");
    }
  }
  for (size_t i = 0; i < obs.fiducialSightings.size(); ++i) {
    const FiducialSighting& f = obs.fiducialSightings[i];
    if (f.fiducial < 0 || f.fiducial >= fiducials || f.camera < 0 || f.camera >= cameras ||
        !finite2(f.cameraPx)) {
      throw InputError({"", fmt::format("fiducial_sightings[{}]", i), 0},
                       "refers to a fiducial or camera that does not exist, or is not finite");
    }
  }
}

}  // namespace

void FitOptions::validate() const {
  auto positive = [](double v, const char* name) {
    if (!(std::isfinite(v) && v > 0.0))
      throw InputError({"", name, 0}, fmt::format("must be > 0, got {}", v));
  };
  positive(correspondenceSigmaPx, "correspondence_sigma_px");
  positive(stripeSigmaMm, "stripe_sigma_mm");
  positive(fiducialSigmaPx, "fiducial_sigma_px");
  positive(tapeSigmaM, "tape_sigma_m");
  positive(robustScale, "robust_scale");
  positive(transferMismatchRatio, "transfer_mismatch_ratio");
  gate.validate();
  rayGrid.validate();
  if (maxIterations < 1 || maxIterations > 10000)
    throw InputError({"", "max_iterations", 0}, "must be 1..10000");
  if (threads < 1 || threads > 256) throw InputError({"", "threads", 0}, "must be 1..256");
  conditioning.validate();
}

std::string Deficiency::describe() const {
  std::string who = module < 0 ? "shared parameters" : fmt::format("module {}", module);
  std::string params;
  for (size_t i = 0; i < parameters.size(); ++i) params += (i ? ", " : "") + parameters[i];
  return fmt::format("{}: {} (reciprocal condition {:.2e}); the data cannot separate: {}", who,
                     conditioningName(state), reciprocalCondition, params);
}

bool FitResult::passesQualityChecks() const { return !stopped && gate.passes; }

FitResult fitDisplay(const DisplayModel& nominal, const CalibrationObservations& observations,
                     const FitOptions& options) {
  options.validate();
  nominal.validate();
  validateObservations(nominal, observations);
  for (int m : options.heldModules) {
    if (m < 0 || m >= static_cast<int>(nominal.modules.size())) {
      throw InputError({"", "held_modules", 0},
                       fmt::format("no module {} (the display has {})", m, nominal.modules.size()));
    }
  }
  const ScreenTransfer transfer = options.transfer.value_or(nominal.screen.transfer);
  FitResult result = DisplayFitter(nominal, observations, options, transfer).run();
  if (options.tryOtherTransfer && !result.stopped) {
    FitOptions other = options;
    other.tryOtherTransfer = false;
    other.transfer =
        transfer == ScreenTransfer::kConical ? ScreenTransfer::kLinear : ScreenTransfer::kConical;
    FitResult alt = DisplayFitter(nominal, observations, other, *other.transfer).run();
    if (alt.stopped) return alt;
    result = selectTransfer(std::move(result), std::move(alt), options.gate);
  }
  result.heldModules = options.heldModules;
  if (!result.stopped) applyGate(nominal, options.gate, options.rayGrid, &result);
  return result;
}

}  // namespace parallax
