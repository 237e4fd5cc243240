#include "calibration/fit/fit_statistics.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "calibration/fit/decode_resolution.h"

namespace parallax::fit {
namespace {

void fillModel(const FitInputs& in, const FitState& state, DisplayModel* model) {
  *model = in.nominal;
  model->name = in.nominal.name + "-calibrated";
  model->screen.curvature = state.k;
  model->screen.transfer = in.transfer;
  for (size_t m = 0; m < state.modules.size(); ++m) {
    if (in.observed[m]) unpackModule(state.modules[m].data(), &model->modules[m]);
  }
}

}  // namespace

void summarizeResiduals(const FitInputs& in, const FitState& state, const CorrespondenceForm& form,
                        const NoiseLevels& sigmas, FitResult* result) {
  const CalibrationObservations& obs = in.obs;
  const size_t modules = in.nominal.modules.size(), cameras = obs.stations.size();
  fillModel(in, state, &result->model);

  // ---- correspondences: outliers, RMS of the inliers per module and camera ----
  result->modules.assign(modules, {});
  result->cameras.assign(cameras, {});
  std::vector<double> sumSqModule(modules, 0.0), sumSqCamera(cameras, 0.0);
  std::vector<int> inliersModule(modules, 0), inliersCamera(cameras, 0);
  std::vector<int> inliersModuleCamera(modules * cameras, 0);
  for (size_t m = 0; m < modules; ++m) {
    result->modules[m].module = static_cast<int>(m);
    result->modules[m].observed = in.observed[m];
  }
  for (size_t c = 0; c < cameras; ++c) {
    result->cameras[c].camera = static_cast<int>(c);
    result->cameras[c].pose = unpackCamera(state.cameras[c].data());
  }
  for (size_t i = 0; i < obs.correspondences.size(); ++i) {
    const Correspondence& c = obs.correspondences[i];
    ModuleFit& mf = result->modules[static_cast<size_t>(c.module)];
    CameraFit& cf = result->cameras[static_cast<size_t>(c.camera)];
    ++mf.correspondences;
    ++cf.correspondences;
    Eigen::Vector2d r;
    if (!correspondenceResidual(in, state, form, i, &r) ||
        r.norm() > kOutlierSigmas * sigmas.correspondencePx) {
      ++mf.outliers;
      ++result->outliers;
      continue;
    }
    sumSqModule[static_cast<size_t>(c.module)] += r.squaredNorm();
    sumSqCamera[static_cast<size_t>(c.camera)] += r.squaredNorm();
    ++inliersModule[static_cast<size_t>(c.module)];
    ++inliersCamera[static_cast<size_t>(c.camera)];
    if (form.uses(i))  // not in a decode left out whole
      ++inliersModuleCamera[static_cast<size_t>(c.module) * cameras +
                            static_cast<size_t>(c.camera)];
  }
  for (size_t m = 0; m < modules; ++m) {
    for (size_t c = 0; c < cameras; ++c) {
      const int n = inliersModuleCamera[m * cameras + c];
      if (n > 0 && n >= kMinViewShare * inliersModule[m]) ++result->modules[m].stationsSeeing;
    }
  }
  // RMS per axis (so it compares with σ directly).
  for (size_t m = 0; m < modules; ++m) {
    if (inliersModule[m])
      result->modules[m].rmsPx = std::sqrt(sumSqModule[m] / (2.0 * inliersModule[m]));
  }
  for (size_t c = 0; c < cameras; ++c) {
    if (inliersCamera[c])
      result->cameras[c].rmsPx = std::sqrt(sumSqCamera[c] / (2.0 * inliersCamera[c]));
  }

  // ---- stripes (mm on the screen) ----
  std::vector<double> stripeAbs, stripeSumSq(modules, 0.0);
  double stripeTotal = 0.0;
  for (size_t i = 0; i < obs.stripes.size(); ++i) {
    const StripeCentre& s = obs.stripes[i];
    if (!in.observed[static_cast<size_t>(s.module)]) continue;
    double r;
    if (!stripeResidualMm(in, state, i, &r)) continue;
    ++result->modules[static_cast<size_t>(s.module)].stripes;
    result->stripeResidualsMm.push_back(r);
    stripeSumSq[static_cast<size_t>(s.module)] += r * r;
    stripeTotal += r * r;
    stripeAbs.push_back(std::abs(r));
  }
  for (size_t m = 0; m < modules; ++m) {
    ModuleFit& mf = result->modules[m];
    if (mf.stripes) mf.stripeRmsMm = std::sqrt(stripeSumSq[m] / mf.stripes);
  }
  if (!stripeAbs.empty())
    result->stripeRmsMm = std::sqrt(stripeTotal / static_cast<double>(stripeAbs.size()));

  // ---- fiducials (camera px) ----
  double fidSumSq = 0.0;
  int fidCount = 0;
  std::vector<double> camFidSumSq(cameras, 0.0);
  for (size_t i = 0; i < obs.fiducialSightings.size(); ++i) {
    const FiducialSighting& f = obs.fiducialSightings[i];
    Eigen::Vector2d r;
    if (!fiducialResidualPx(in, state, i, &r)) continue;
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
  result->correspondenceSigmaPx = sigmas.correspondencePx;
  result->stripeSigmaMm = sigmas.stripeMm;
  result->correspondenceSigmaMm = sigmas.correspondencePx * mmPerModulePx(in, state);

  // ---- decodes left out whole (FitOptions::unreliableDecodeTail) ----
  result->unreliableDecodes = form.unreliable;
  for (const UnreliableDecode& d : form.unreliable)
    ++result->modules[static_cast<size_t>(d.module)].decodesLeftOut;
  if (!form.unreliable.empty()) {
    constexpr size_t kListed = 12;
    std::string list;
    for (size_t i = 0; i < std::min(kListed, form.unreliable.size()); ++i) {
      const UnreliableDecode& d = form.unreliable[i];
      list += fmt::format("{}station {} module {} ({:.0f}%)", i ? ", " : "", d.station, d.module,
                          100.0 * d.grossErrors / std::max(1, d.correspondences));
    }
    if (form.unreliable.size() > kListed) list += ", …";
    result->notes.push_back(fmt::format(
        "{} (station, module) decodes left out: far more of their correspondences were gross "
        "errors than the typical decode's {:.1f}%, and what made them biases the rest together "
        "(as a module seen at a steep angle gives); the modules keep their other stations' "
        "decodes: {}",
        form.unreliable.size(), 100.0 * form.unreliable.front().typicalShare, list));
  }

  // ---- what the decoder found of the camera's response, when it decoded pictures ----
  if (obs.cameraResponse && (obs.cameraResponse->disagrees || !obs.cameraResponse->measured))
    result->notes.push_back(describeCameraResponse(*obs.cameraResponse));
  if (obs.cameraResponse && obs.cameraResponse->undecided()) {
    result->cameraResponseUndecided = true;
    result->notes.push_back(fmt::format(
        "camera response: neither the camera's response nor the modules' alone gives lobes of the "
        "screen's width ({:.2f}× the nominal's as recorded, {:.2f}× re-linearized): both may "
        "bend, so the patterns' linearization is a guess; state response_gamma in camera.json "
        "(1 for a linear or raw camera, 2.2 for an sRGB one)",
        obs.cameraResponse->lobeWidthRecorded, obs.cameraResponse->lobeWidthRelinearized));
  }

  // ---- the lens blur's shift of the decoded patterns (capture_decoder.h) ----
  result->lensBlurSigmaPx = obs.lensBlurSigmaPx;
  if (obs.cameraResponse && !obs.lensBlurSigmaPx)
    result->notes.push_back(
        "the camera's lens blur is not stated (lens_blur_sigma_px in camera.json): inside each "
        "module's lobe it shifts the decoded patterns toward the lobe's peak, which the fit reads "
        "as cameras nearer the screen (by several mm for a 0.6 px blur) "
        "and its σ do not count");

  // ---- stations that see the modules too coarsely for their patterns (decode_resolution.h) ----
  {
    std::string stations;
    double least = 0.0, most = 0.0;
    for (const StationResolution& r : decodeResolution(obs.correspondences)) {
      if (!(r.modulePxACameraPx > kCoarseModulePxACameraPx)) continue;
      least = stations.empty() ? r.modulePxACameraPx : std::min(least, r.modulePxACameraPx);
      most = std::max(most, r.modulePxACameraPx);
      stations += fmt::format("{}{}", stations.empty() ? "" : ", ", r.station);
    }
    if (!stations.empty())
      result->notes.push_back(fmt::format(
          "station(s) {} see the modules coarsely: a camera pixel spans {:.1f}-{:.1f} module "
          "pixels (the default 16-px phase period, under {:.0f} camera pixels), so their decodes "
          "are noisy and biased beyond what the σ count; nearer stations or a longer lens give "
          "finer ones",
          stations, least, most, 16.0 / kCoarseModulePxACameraPx));
  }

  // ---- the transfer check: stripes that the assumed transfer cannot explain ----
  const double stripeSigma = robustSigma(stripeAbs);
  if (!stripeAbs.empty() && stripeSigma > in.options.transferMismatchRatio *
                                              std::max(result->correspondenceSigmaMm, 0.1)) {
    result->transferMismatch = true;
    result->notes.push_back(fmt::format(
        "the stripe centres disagree with the assumed {} transfer: their residuals are {:.2f} mm "
        "(robust σ) against {:.3f} mm for the correspondences; the screen does not follow the {} "
        "model",
        transferName(in.transfer), stripeSigma, result->correspondenceSigmaMm,
        transferName(in.transfer)));
  }
  // A heavy tail (most stripe centres fit, some far off) leaves the robust σ small while the
  // fit cannot account for where those modules' light leaves the screen: the observer-line σ,
  // which rests on the stripes, then understates the error. Flagged, never silent.
  if (!stripeAbs.empty() && result->stripeRmsMm > 5.0 * std::max(stripeSigma, 0.1)) {
    result->notes.push_back(fmt::format(
        "stripe centres: {:.2f} mm RMS against a robust σ of {:.3f} mm ({:.0f}×): some stripes "
        "disagree with the model, so the observer-line figures (predicted σ) may understate the "
        "error there",
        result->stripeRmsMm, stripeSigma, result->stripeRmsMm / std::max(stripeSigma, 0.1)));
  }
}

void noteModulesNotEstimated(const FitInputs& in, FitResult* result) {
  for (size_t m = 0; m < result->modules.size(); ++m) {
    if (!in.observed[m]) {
      result->notes.push_back(fmt::format(
          "module {} was not seen by any camera: its rays are unknown (held nominal only under "
          "--allow-partial)",
          m));
    }
  }
  int held = 0;
  for (size_t m = 0; m < in.held.size(); ++m) held += in.held[m] ? 1 : 0;
  if (held > 0)
    result->notes.push_back(fmt::format("{} module(s) held at their starting calibration", held));
}

}  // namespace parallax::fit
