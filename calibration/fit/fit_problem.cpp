#include "calibration/fit/fit_problem.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include "calibration/fit/fit_residuals.h"

namespace parallax::fit {
namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(mid), v.end());
  return v[mid];
}

double mirrorSignOf(const OpticalModule& m) { return m.mirror ? -1.0 : 1.0; }

// The cameras, k and the fiducial and tape residuals: stage 0's whole problem, the start of
// the others'.
void addCameraTerms(const FitInputs& in, const NoiseLevels& sigmas,
                    const std::vector<bool>* fiducialOutliers, FitState* state, FitProblem* built) {
  ceres::Problem& problem = *built->problem;
  for (auto& cam : state->cameras) {
    problem.AddParameterBlock(
        cam.data(), kCameraBlockSize,
        new ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>());
  }
  // Bounds on k: the screen's edges stay within the cylinder's radius (|x| < R = 1/|k|, where
  // its sag is defined), with 2% to spare.
  const double kLimit = 0.98 / (0.5 * in.nominal.screen.width);
  problem.AddParameterBlock(&state->k, 1);
  problem.SetParameterLowerBound(&state->k, 0, -kLimit);
  problem.SetParameterUpperBound(&state->k, 0, kLimit);
  if (!in.options.fitCurvature) problem.SetParameterBlockConstant(&state->k);

  // Fiducials: robust while the cameras are placed by them alone (stage 0), which finds the
  // misdetected ones; with the modules, the others enter without a loss. They are the
  // gauge (the cylinder does not change along y: beyond the tape's 5 cm only they hold the
  // height of everything):
  // under a robust loss, a start far off at high noise let the correspondences (99.9% of
  // the residuals) push them into the loss's flat tail, and the whole fit drifted (2 px
  // noise, 160k correspondences on default: rays off by 10^27 px).
  for (size_t i = 0; i < in.obs.fiducialSightings.size(); ++i) {
    if (fiducialOutliers && (*fiducialOutliers)[i]) continue;
    const FiducialSighting& f = in.obs.fiducialSightings[i];
    built->add(problem.AddResidualBlock(
        FiducialCost::Create(&in.obs.intrinsics, in.obs.fiducials[static_cast<size_t>(f.fiducial)],
                             f.cameraPx, 1.0 / sigmas.fiducialPx),
        built->withModules ? nullptr : built->loss.get(),
        state->cameras[static_cast<size_t>(f.camera)].data(), &state->k));
  }
  for (size_t c = 0; c < in.obs.stations.size(); ++c) {
    built->add(problem.AddResidualBlock(
        TapeCost::Create(in.obs.stations[c].tapeCentre, 1.0 / in.options.tapeSigmaM), nullptr,
        state->cameras[c].data()));
  }
}

FitProblem emptyProblem(const FitInputs& in, bool withModules) {
  FitProblem built;
  built.withModules = withModules;
  // One loss object shared by all robust blocks.
  built.loss = std::make_unique<ceres::CauchyLoss>(in.options.robustScale);
  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  built.problem = std::make_unique<ceres::Problem>(po);
  return built;
}

// Module px of camera pixel `n` (normalized) of correspondence i through the current state.
bool modulePixelOf(const FitInputs& in, const FitState& state, size_t i, const Eigen::Vector2d& n,
                   Eigen::Vector2d* uv) {
  const Correspondence& c = in.obs.correspondences[i];
  const OpticalModule& m = in.nominal.modules[static_cast<size_t>(c.module)];
  const ModulePxCorrespondenceCost cost(n, Eigen::Vector2d::Zero(), static_cast<double>(m.width),
                                        mirrorSignOf(m), 1.0);
  double out[2];
  if (!cost(state.modules[static_cast<size_t>(c.module)].data(),
            state.cameras[static_cast<size_t>(c.camera)].data(), &state.k, out)) {
    return false;
  }
  *uv = {out[0], out[1]};
  return uv->allFinite();
}

}  // namespace

FitInputs::FitInputs(const DisplayModel& nominalModel, const CalibrationObservations& observations,
                     const FitOptions& fitOptions, ScreenTransfer assumedTransfer)
    : nominal(nominalModel), obs(observations), options(fitOptions), transfer(assumedTransfer) {
  observed.assign(nominal.modules.size(), false);
  for (const Correspondence& c : obs.correspondences)
    observed[static_cast<size_t>(c.module)] = true;
  held.assign(nominal.modules.size(), false);
  for (int m : options.heldModules) held[static_cast<size_t>(m)] = true;
  for (const Correspondence& c : obs.correspondences)
    correspondenceN.push_back(obs.intrinsics.normalized(c.cameraPx));
  for (const StripeCentre& s : obs.stripes)
    stripeN.push_back(obs.intrinsics.normalized(s.cameraPx));
}

FitState startingState(const FitInputs& in) {
  FitState state;
  for (const OpticalModule& m : in.nominal.modules) state.modules.push_back(packModule(m));
  for (const CameraStation& st : in.obs.stations) {
    CameraPose pose;
    pose.centre = st.tapeCentre;
    pose.physicalFromCamera = aimCameraAt(st.tapeCentre, Eigen::Vector3d::Zero());
    state.cameras.push_back(packCamera(pose));
  }
  state.k = in.nominal.screen.curvature;
  return state;
}

FitProblem buildProblem(const FitInputs& in, const NoiseLevels& sigmas, const CameraPlacementStage&,
                        FitState* state) {
  FitProblem built = emptyProblem(in, /*withModules=*/false);
  addCameraTerms(in, sigmas, /*fiducialOutliers=*/nullptr, state, &built);
  return built;
}

FitProblem buildProblem(const FitInputs& in, const NoiseLevels& sigmas, const ModuleStage& stage,
                        FitState* state) {
  FitProblem built = emptyProblem(in, /*withModules=*/true);
  addCameraTerms(in, sigmas, stage.fiducialOutliers, state, &built);
  ceres::Problem& problem = *built.problem;
  ceres::LossFunction* loss = built.loss.get();
  const CorrespondenceForm& form = *stage.form;

  for (size_t m = 0; m < state->modules.size(); ++m) {
    if (!in.observed[m]) continue;
    problem.AddParameterBlock(
        state->modules[m].data(), kModuleBlockSize,
        new ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<9>>());
    if (in.held[m]) problem.SetParameterBlockConstant(state->modules[m].data());
  }
  for (size_t i = 0; i < in.obs.correspondences.size(); ++i) {
    if (i % stage.stride != 0 || !form.uses(i)) continue;
    // A residual Ceres cannot evaluate at the start stops the solve before its first step;
    // such a correspondence (a module pixel whose starting ray misses the screen, at the
    // rim of a strongly curved one) is left out of this solve.
    Eigen::Vector2d startResidual;
    if (!correspondenceResidual(in, *state, form, i, &startResidual)) continue;
    const Correspondence& c = in.obs.correspondences[i];
    const OpticalModule& m = in.nominal.modules[static_cast<size_t>(c.module)];
    const double width = static_cast<double>(m.width);
    ceres::CostFunction* cost =
        form.kind == CorrespondenceForm::kCameraPx
            ? CameraPxCorrespondenceCost::Create(&in.obs.intrinsics, c.modulePx, c.cameraPx, width,
                                                 mirrorSignOf(m),
                                                 form.cameraScale[i] / sigmas.correspondencePx)
            : ModulePxCorrespondenceCost::Create(in.correspondenceN[i], c.modulePx, width,
                                                 mirrorSignOf(m), 1.0 / sigmas.correspondencePx);
    built.add(
        problem.AddResidualBlock(cost, loss, state->modules[static_cast<size_t>(c.module)].data(),
                                 state->cameras[static_cast<size_t>(c.camera)].data(), &state->k),
        decodedGroup(c.camera, c.module, DecodedKind::kCorrespondence));
  }
  for (size_t i = 0; i < in.obs.stripes.size(); ++i) {
    const StripeCentre& s = in.obs.stripes[i];
    if (!in.observed[static_cast<size_t>(s.module)]) continue;
    built.add(problem.AddResidualBlock(
                  StripeCost::Create(in.stripeN[i], in.transfer, 1.0 / (1e-3 * sigmas.stripeMm)),
                  loss, state->modules[static_cast<size_t>(s.module)].data(),
                  state->cameras[static_cast<size_t>(s.camera)].data(), &state->k),
              decodedGroup(s.camera, s.module, DecodedKind::kStripe));
  }
  return built;
}

bool correspondenceResidual(const FitInputs& in, const FitState& state,
                            const CorrespondenceForm& form, size_t i, Eigen::Vector2d* r) {
  const Correspondence& c = in.obs.correspondences[i];
  if (form.kind == CorrespondenceForm::kCameraPx) {
    const OpticalModule& m = in.nominal.modules[static_cast<size_t>(c.module)];
    const CameraPxCorrespondenceCost cost(&in.obs.intrinsics, c.modulePx, c.cameraPx,
                                          static_cast<double>(m.width), mirrorSignOf(m),
                                          form.cameraScale[i]);
    double out[2];
    if (!cost(state.modules[static_cast<size_t>(c.module)].data(),
              state.cameras[static_cast<size_t>(c.camera)].data(), &state.k, out)) {
      return false;
    }
    *r = {out[0], out[1]};
    return r->allFinite();
  }
  Eigen::Vector2d uv;
  if (!modulePixelOf(in, state, i, in.correspondenceN[i], &uv)) return false;
  *r = uv - c.modulePx;
  return true;
}

bool stripeResidualMm(const FitInputs& in, const FitState& state, size_t i, double* r) {
  const StripeCentre& s = in.obs.stripes[i];
  const StripeCost cost(in.stripeN[i], in.transfer, 1e3);
  double out;
  if (!cost(state.modules[static_cast<size_t>(s.module)].data(),
            state.cameras[static_cast<size_t>(s.camera)].data(), &state.k, &out)) {
    return false;
  }
  *r = out;
  return std::isfinite(out);
}

bool fiducialResidualPx(const FitInputs& in, const FitState& state, size_t i, Eigen::Vector2d* r) {
  const FiducialSighting& f = in.obs.fiducialSightings[i];
  const FiducialCost cost(&in.obs.intrinsics, in.obs.fiducials[static_cast<size_t>(f.fiducial)],
                          f.cameraPx, 1.0);
  double out[2];
  if (!cost(state.cameras[static_cast<size_t>(f.camera)].data(), &state.k, out)) return false;
  *r = {out[0], out[1]};
  return true;
}

std::vector<bool> findFiducialOutliers(const FitInputs& in, const FitState& state,
                                       const NoiseLevels& sigmas) {
  std::vector<bool> outlier(in.obs.fiducialSightings.size(), false);
  for (size_t i = 0; i < outlier.size(); ++i) {
    Eigen::Vector2d r;
    outlier[i] = !fiducialResidualPx(in, state, i, &r) ||
                 std::hypot(r.x(), r.y()) > kOutlierSigmas * sigmas.fiducialPx;
  }
  return outlier;
}

CorrespondenceForm cameraPxForm(const FitInputs& in, const FitState& state,
                                const NoiseLevels& sigmas) {
  const size_t n = in.obs.correspondences.size();
  CorrespondenceForm form;
  form.kind = CorrespondenceForm::kCameraPx;
  // Module px per camera px at every correspondence, √|det| of the local 2 × 2 map, from the
  // current state (after the cameras found the screen). Where it cannot be evaluated, the
  // median of the others.
  form.cameraScale.assign(n, 0.0);
  std::vector<double> good;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& px = in.obs.correspondences[i].cameraPx;
    Eigen::Vector2d a, b, c;
    if (!modulePixelOf(in, state, i, in.correspondenceN[i], &a) ||
        !modulePixelOf(in, state, i, in.obs.intrinsics.normalized(px + Eigen::Vector2d(1.0, 0.0)),
                       &b) ||
        !modulePixelOf(in, state, i, in.obs.intrinsics.normalized(px + Eigen::Vector2d(0.0, 1.0)),
                       &c)) {
      continue;
    }
    Eigen::Matrix2d j;
    j << b - a, c - a;
    const double scale = std::sqrt(std::abs(j.determinant()));
    if (std::isfinite(scale) && scale > 0.0) {
      form.cameraScale[i] = scale;
      good.push_back(scale);
    }
  }
  const double fallback = good.empty() ? 1.0 : median(good);
  for (double& s : form.cameraScale) {
    if (!(s > 0.0)) s = fallback;
  }
  // Correspondences more than kOutlierSigmas σ off in the module-px answer: gross decoding
  // errors (a wrong module pixel can light a point the camera never saw, where the camera-px
  // residual is not defined and would stall the solver). The report still counts them.
  const CorrespondenceForm modulePx;
  form.excluded.assign(n, false);
  for (size_t i = 0; i < n; ++i) {
    Eigen::Vector2d r;
    form.excluded[i] = !correspondenceResidual(in, state, modulePx, i, &r) ||
                       r.norm() > kOutlierSigmas * sigmas.correspondencePx;
  }
  // Each (station, module) decode's gross errors against the typical decode's share; those
  // far above it go whole.
  struct Decode {
    UnreliableDecode counts;
    bool unreliable = false;
  };
  std::map<std::pair<int, int>, Decode> decodes;
  for (size_t i = 0; i < n; ++i) {
    const Correspondence& c = in.obs.correspondences[i];
    UnreliableDecode& d = decodes[{c.camera, c.module}].counts;
    d.station = c.camera;
    d.module = c.module;
    ++d.correspondences;
    d.grossErrors += form.excluded[i] ? 1 : 0;
  }
  if (in.options.unreliableDecodeTail <= 0.0 || decodes.empty()) return form;
  std::vector<double> shares;
  for (const auto& [key, d] : decodes)
    shares.push_back(static_cast<double>(d.counts.grossErrors) / d.counts.correspondences);
  const double typical = std::max(median(shares), kTypicalGrossErrorShare);
  for (auto& [key, d] : decodes) {
    d.counts.typicalShare = typical;
    d.unreliable = binomialUpperTail(d.counts.correspondences, d.counts.grossErrors, typical) <
                   in.options.unreliableDecodeTail;
    if (d.unreliable) form.unreliable.push_back(d.counts);
  }
  if (form.unreliable.empty()) return form;
  for (size_t i = 0; i < n; ++i) {
    const Correspondence& c = in.obs.correspondences[i];
    if (decodes[{c.camera, c.module}].unreliable) form.excluded[i] = true;
  }
  return form;
}

double mmPerModulePx(const FitInputs& in, const FitState& state) {
  std::vector<double> v;
  for (size_t m = 0; m < state.modules.size(); ++m) {
    if (!in.observed[m]) continue;
    const auto& b = state.modules[m];
    const double distance = Eigen::Vector3d(b[4], b[5], b[6]).norm();
    v.push_back(1e3 * distance / (b[7] * in.nominal.modules[m].width));
  }
  return v.empty() ? 1.0 : median(v);
}

NoiseLevels reestimateNoise(const FitInputs& in, const FitState& state,
                            const CorrespondenceForm& form, const NoiseLevels& sigmas,
                            bool fiducials) {
  std::vector<double> corr, stripe;
  for (size_t i = 0; i < in.obs.correspondences.size(); ++i) {
    Eigen::Vector2d r;
    if (correspondenceResidual(in, state, form, i, &r)) {
      corr.push_back(std::abs(r.x()));
      corr.push_back(std::abs(r.y()));
    }
  }
  for (size_t i = 0; i < in.obs.stripes.size(); ++i) {
    double r;
    if (in.observed[static_cast<size_t>(in.obs.stripes[i].module)] &&
        stripeResidualMm(in, state, i, &r))
      stripe.push_back(std::abs(r));
  }
  // Floors: exact synthetic data would give σ = 0 and an information matrix of infinities.
  NoiseLevels out = sigmas;
  if (!corr.empty()) out.correspondencePx = std::max(robustSigma(corr), 1e-3);
  const double corrMm = out.correspondencePx * mmPerModulePx(in, state);
  if (!stripe.empty()) out.stripeMm = std::max(robustSigma(stripe), std::max(0.5 * corrMm, 1e-3));
  if (fiducials) {
    std::vector<double> fid;
    for (size_t i = 0; i < in.obs.fiducialSightings.size(); ++i) {
      Eigen::Vector2d r;
      if (fiducialResidualPx(in, state, i, &r)) {
        fid.push_back(std::abs(r.x()));
        fid.push_back(std::abs(r.y()));
      }
    }
    // A handful of sightings says little of their spread: the a-priori σ stays.
    constexpr size_t kMinFiducialResiduals = 16;
    // Below a hundredth of a pixel a marker's centre is not measured, whatever the residuals.
    constexpr double kFiducialFloorPx = 0.01;
    if (fid.size() >= kMinFiducialResiduals)
      out.fiducialPx = std::max(robustSigma(fid), kFiducialFloorPx);
  }
  return out;
}

double binomialUpperTail(int n, int k, double p) {
  if (k <= 0) return 1.0;
  if (k > n) return 0.0;
  if (p <= 0.0) return 0.0;
  if (p >= 1.0) return 1.0;
  double tail = 0.0;
  const double logP = std::log(p), logQ = std::log1p(-p), logNFactorial = std::lgamma(n + 1.0);
  for (int j = k; j <= n; ++j) {
    tail += std::exp(logNFactorial - std::lgamma(j + 1.0) - std::lgamma(n - j + 1.0) + j * logP +
                     (n - j) * logQ);
  }
  return std::min(1.0, tail);
}

double robustSigma(const std::vector<double>& absResiduals) {
  return 1.4826 * median(absResiduals);
}

}  // namespace parallax::fit
