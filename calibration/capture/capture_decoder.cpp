#include "calibration/capture/capture_decoder.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

#include "calibration/camera/calibration_geometry.h"
#include "calibration/capture/stripe_curve.h"
#include "calibration/capture/stripe_peak.h"
#include "common/check.h"
#include "common/input_error.h"

namespace parallax {

void CaptureDecoderOptions::validate() const {
  patterns.validate();
  if (!(minContrastFraction > 0.0 && minContrastFraction < 1.0)) {
    throw InputError({"", "min_contrast_fraction", 0}, "must be in (0, 1)");
  }
  if (!(lensBlurSigmaPx >= 0.0 && lensBlurSigmaPx <= kMaxLensBlurSigmaPx))
    throw InputError({"", "lens_blur_sigma_px", 0}, "must be 0..5");
  if (pixelStep < 1 || pixelStep > 64) throw InputError({"", "pixel_step", 0}, "must be 1..64");
  if (minStripePixels < 1) throw InputError({"", "min_stripe_pixels", 0}, "must be >= 1");
  if (!(lobeWidthTolerance > 1.0)) throw InputError({"", "lobe_width_tolerance", 0}, "must be > 1");
  if (stripeCurve.degree < 1 || stripeCurve.degree > 5)
    throw InputError({"", "stripe_curve.degree", 0}, "must be 1..5");
  if (stripeCurve.minRows < stripeCurve.degree + 2)
    throw InputError({"", "stripe_curve.min_rows", 0}, "must be at least the degree + 2");
  if (!(stripeCurve.outlierSigmas > 0.0) || !(stripeCurve.minOutlierPx >= 0.0))
    throw InputError({"", "stripe_curve", 0}, "outlier limits must be positive");
  if (!(saturatedLinear > 0.0 && saturatedLinear <= 1.0))
    throw InputError({"", "saturated_linear", 0}, "must be in (0, 1]");
}

namespace {

// Where a phase pattern's decoded position at camera pixel (x, y) really lies when the lens
// blurred it (Gaussian, σ px) after the lobe shaped its brightness I: blurring I·cos(kx)
// gives I·cos(k(x + σ² ∂x ln I)) to first order, so the column code read at x is the one at
// x + σ² ∂x ln I, the row code likewise along y. ∂ ln I comes from the blurred white − black
// reference (the lobe's own width dwarfs σ: its blur changes the slope by σ²/width², second
// order). nullopt where the shift is beyond half a pixel: a cut edge of the lobe, where the
// first-order shift no longer holds.
std::optional<Eigen::Vector2d> blurShift(const std::vector<cv::Mat>& columnFrames,
                                         const std::vector<cv::Mat>& rowFrames, int x, int y,
                                         double sigmaPx) {
  const auto logSlope = [](const std::vector<cv::Mat>& frames, int x0, int y0, int dx,
                           int dy) -> std::optional<double> {
    const cv::Mat& w = frames[0];
    const cv::Mat& b = frames[1];
    const int xa = x0 - dx, ya = y0 - dy, xb = x0 + dx, yb = y0 + dy;
    if (xa < 0 || ya < 0 || xb >= w.cols || yb >= w.rows) return std::nullopt;
    const double ia = w.at<float>(ya, xa) - b.at<float>(ya, xa);
    const double ib = w.at<float>(yb, xb) - b.at<float>(yb, xb);
    if (!(ia > 0.0 && ib > 0.0)) return std::nullopt;
    return 0.5 * (std::log(ib) - std::log(ia));
  };
  const auto gx = logSlope(columnFrames, x, y, 1, 0);
  const auto gy = logSlope(rowFrames, x, y, 0, 1);
  if (!gx || !gy) return std::nullopt;
  const Eigen::Vector2d shift = sigmaPx * sigmaPx * Eigen::Vector2d(*gx, *gy);
  if (!(shift.norm() <= 0.5)) return std::nullopt;
  return shift;
}

}  // namespace

void decodeStation(const std::vector<cv::Mat>& columnFrames, const std::vector<cv::Mat>& rowFrames,
                   const std::vector<int>& group, const DisplayModel& nominal, int station,
                   const CaptureDecoderOptions& options, CalibrationObservations* obs,
                   const CameraPose* decoderPose, const StripeReferences* stripeReferences,
                   std::vector<double>* lobeWidths) {
  options.validate();
  PARALLAX_CHECK(!columnFrames.empty() && !rowFrames.empty());
  PARALLAX_CHECK(station >= 0 && station < static_cast<int>(obs->stations.size()));
  const int width = columnFrames[0].cols, height = columnFrames[0].rows;
  const cv::Mat& white = stripeReferences ? stripeReferences->white : columnFrames[0];
  const cv::Mat& black = stripeReferences ? stripeReferences->black : columnFrames[1];
  const double whiteClipped =
      stripeReferences ? stripeReferences->saturatedLinear : options.saturatedLinear;
  PARALLAX_CHECK(white.size() == columnFrames[0].size() && black.size() == white.size());
  const int mw = nominal.modules[0].width, mh = nominal.modules[0].height;
  const CameraIntrinsics& in = obs->intrinsics;
  // The decoder's idea of the camera: at the tape mark, aimed at the screen centre.
  CameraPose pose;
  pose.centre = obs->stations[static_cast<size_t>(station)].tapeCentre;
  pose.physicalFromCamera = aimCameraAt(pose.centre, Eigen::Vector3d::Zero());
  if (decoderPose) pose = *decoderPose;
  const auto camera = packCamera(pose);

  struct Candidate {
    StripeCentre centre;
    double width;  // the fitted lobe's σ (rad)
  };
  std::vector<Candidate> candidates;
  for (int y = 0; y < height; ++y) {
    // Correspondences and stripe centres on every n-th row: neighbouring rows' stripe centres
    // are nearly the same measurement, and each costs the solver a residual.
    if (y % options.pixelStep != 0) continue;
    // This row's lit pixels with every group module's predicted angle, for the stripe peaks.
    std::vector<StripeRowSample> lit;
    double rowMax = 0.0;
    for (int x = 0; x < width; ++x)
      rowMax = std::max(rowMax, static_cast<double>(white.at<float>(y, x) - black.at<float>(y, x)));
    if (!(rowMax > options.patterns.minContrast)) continue;
    for (int x = 0; x < width; ++x) {
      const double contrast = white.at<float>(y, x) - black.at<float>(y, x);
      if (!(contrast >= options.minContrastFraction * rowMax)) continue;
      const Eigen::Vector2d n = in.normalized({x + 0.5, y + 0.5});
      Vec3<double> s;
      if (!screenPointOfCameraRay(nominal.screen.curvature, camera.data(), n.x(), n.y(), &s))
        continue;
      StripeRowSample sample{x + 0.5, contrast, -1, {}};
      sample.clipped = white.at<float>(y, x) >= whiteClipped;
      double best = 1e9;
      for (size_t g = 0; g < group.size(); ++g) {
        const double angle =
            stripeAngle(nominal.screen, s, nominal.modules[static_cast<size_t>(group[g])].position,
                        pose.centre);
        sample.angles.push_back(angle);
        if (std::abs(angle) < best) {
          best = std::abs(angle);
          sample.owner = static_cast<int>(g);
        }
      }
      if (sample.owner < 0) continue;
      const int label = group[static_cast<size_t>(sample.owner)];
      lit.push_back(std::move(sample));
      if (x % options.pixelStep != 0) continue;
      std::vector<float> ic, ir;
      for (const cv::Mat& f : columnFrames) ic.push_back(f.at<float>(y, x));
      for (const cv::Mat& f : rowFrames) ir.push_back(f.at<float>(y, x));
      const auto clipped = [&](const std::vector<float>& frames) {
        return std::any_of(frames.end() - options.patterns.phaseSteps, frames.end(),
                           [&](float value) { return value >= options.saturatedLinear; });
      };
      if (clipped(ic) || clipped(ir)) continue;
      const auto u = decodePixel(ic, mw, options.patterns);
      const auto v = decodePixel(ir, mh, options.patterns);
      if (!u || !v) continue;
      Eigen::Vector2d at(x + 0.5, y + 0.5);
      if (options.lensBlurSigmaPx > 0.0) {
        const auto shift = blurShift(columnFrames, rowFrames, x, y, options.lensBlurSigmaPx);
        if (!shift) continue;
        at += *shift;
      }
      obs->correspondences.push_back({station, label, at, {*u, *v}});
    }
    std::vector<int> pixels(group.size(), 0);
    for (const StripeRowSample& p : lit) ++pixels[static_cast<size_t>(p.owner)];
    std::vector<double> widths;
    const auto peaks = stripePeaksInRow(lit, static_cast<int>(group.size()), {}, &widths);
    for (size_t g = 0; g < group.size(); ++g) {
      if (pixels[g] >= options.minStripePixels && peaks[g])
        candidates.push_back({{station, group[g], {*peaks[g], y + 0.5}}, widths[g]});
    }
  }
  // Every lobe is the screen's diffusion seen through the same transfer: in angle, one width.
  // A lobe far narrower or wider than the set's median is a fragment (a tail whose peak the
  // module's image edge or the sync band cut away, peaking 10–100 mm from the truth) or two
  // lobes taken as one.
  std::vector<double> all;
  for (const auto& c : candidates)
    if (std::isfinite(c.width)) all.push_back(c.width);
  if (lobeWidths) lobeWidths->insert(lobeWidths->end(), all.begin(), all.end());
  if (all.empty()) return;
  std::nth_element(all.begin(), all.begin() + static_cast<long>(all.size() / 2), all.end());
  const double median = all[all.size() / 2];
  std::map<int, std::vector<Eigen::Vector2d>> stripeOf;  // per module, its centres in row order
  for (const auto& c : candidates) {
    if (c.width >= median / options.lobeWidthTolerance &&
        c.width <= median * options.lobeWidthTolerance)
      stripeOf[c.centre.module].push_back(c.centre.cameraPx);
  }
  for (const auto& [module, centres] : stripeOf) {
    const std::vector<bool> kept = stripeCentresOnCurve(centres, options.stripeCurve);
    for (size_t i = 0; i < centres.size(); ++i)
      if (kept[i]) obs->stripes.push_back({station, module, centres[i]});
  }
}

}  // namespace parallax
