#pragma once
// From one camera station's recorded frames to CalibrationObservations: every camera pixel
// decodes to a module pixel (structured_light.h), is given to a module, and each module's
// stripe centre is found in every camera row.
//
// Which module lit a pixel: the modules of one group show their patterns at once, and from one
// station each appears only in its own stripe. The decoder predicts, from the nominal display
// and the tape-measured station, the horizontal angle at which each group module's light
// leaves the screen point the pixel sees, and gives the pixel to the module whose predicted
// angle to the camera is smallest. Stripe position depends only on module position (not on
// its orientation or intrinsics), and groups are spaced several diffusion widths apart, so
// the nominal layout is enough to tell them apart.
// Stripe centre: the peak of the module's lobe along a camera row (white − black contrast),
// found in the predicted exit angle (stripe_peak.h), not the pixels' centroid.

#include <functional>
#include <opencv2/core.hpp>
#include <vector>

#include "calibration/camera/calibration_observations.h"
#include "calibration/capture/stripe_curve.h"
#include "calibration/capture/structured_light.h"
#include "calibration/display/display_model.h"

namespace parallax {

inline constexpr double kMaxLensBlurSigmaPx = 5.0;

struct CaptureDecoderOptions {
  StructuredLightOptions patterns;
  double minContrastFraction = 0.25;  // of the row's brightest contrast, for a correspondence
  int pixelStep = 2;                  // decode every n-th camera pixel in x and y (and
                                      // find stripe centres on every n-th row)
  int minStripePixels = 3;            // per row, for a stripe centre
  // The camera lens's blur (σ of its Gaussian spread, camera px; 0 = none). The lens blurs
  // the pattern after the screen's lobe has shaped its brightness I, which moves a phase
  // pattern's apparent position by σ² ∂ln I toward the brighter side: inside a lobe the
  // decoded module coordinates are compressed about the lobe's peak, and the fit reads that
  // as a camera nearer the screen. The decoder moves each correspondence's camera pixel back.
  double lensBlurSigmaPx = 0.0;  // 0..kMaxLensBlurSigmaPx
  // A stripe centre is kept when its lobe's fitted width is within this factor of the picture
  // set's median lobe width.
  double lobeWidthTolerance = 1.5;
  // Each stripe's centres are checked against the smooth curve through them (stripe_curve.h).
  StripeCurveOptions stripeCurve;
  // Linear picture values at or above this were clipped by the sensor (decodeCaptures sets it
  // from the camera's response: the top 8-bit code). A clipped pixel says only "at least this
  // bright": it is left out of the stripe-peak fits (a flattened lobe top pulls the peak toward
  // its longer unclipped flank) and out of the correspondences when a phase frame clipped (the
  // phase of a clipped sinusoid is biased).
  double saturatedLinear = 1.0;
  // decodeCaptures calls it after each picture set (a station's group) is decoded, optional:
  // the sets cost alike, so the count is an honest measure of the work left.
  std::function<void(int done, int total)> onPictureSet;

  void validate() const;
};

// frames: per axis (columns, rows), the station's recorded frames already converted to linear
// light, in makePatternFrames' order. group: the modules that showed the patterns.
// The camera pose the decoder predicts stripes from: the tape mark aimed at the screen
// centre, or (decodeCaptures) the pose the fiducials give, which is far closer — the tape's
// 5 cm shift the predicted stripes by about a degree, near the spacing of a group's stripes.
//
// stripeReferences: the white and black references the stripe centres are found in, when they
// are not the column frames' first two: with modules whose own response bends the patterns,
// the patterns are decoded linearized for the whole chain, the lobes in the camera's light
// (decodeCaptures). lobeWidths, when given, receives every stripe centre candidate's fitted lobe
// width (its Gaussian σ, rad).
struct StripeReferences {
  cv::Mat white, black;
  double saturatedLinear = 1.0;  // as CaptureDecoderOptions::saturatedLinear, for these
};
void decodeStation(const std::vector<cv::Mat>& columnFrames, const std::vector<cv::Mat>& rowFrames,
                   const std::vector<int>& group, const DisplayModel& nominal, int station,
                   const CaptureDecoderOptions& options, CalibrationObservations* observations,
                   const CameraPose* decoderPose = nullptr,
                   const StripeReferences* stripeReferences = nullptr,
                   std::vector<double>* lobeWidths = nullptr);

}  // namespace parallax
