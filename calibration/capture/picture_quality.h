#pragma once
// Is a calibration picture fit to decode, apart from showing the right frame (sync_code.h)?
// Two faults a picture taken by hand has and a streaming camera rarely does:
//  - over-exposed: the lit screen at the sensor's full scale, where a stripe's peak and its
//    flanks read alike (the stripe centres go flat-topped, the Gray-code threshold between
//    white and black moves);
//  - blurred: the camera shook or its focus slipped, so neighbouring stripes run into each
//    other. Measured on the sync code's cells, whose size the code's layout fixes: the contrast
//    between a pair's lit and unlit cell (SyncReading::contrast).
// Each returns why the picture is refused, or nullopt when it is fine.

#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "calibration/capture/sync_code.h"

namespace parallax {

struct PictureQualityLimits {
  // Share of the lit pixels (linear light above 0.1) allowed at full scale (0.995 and more:
  // 255 in 8 bits, whatever the response). The simulated camera clips its lobes' peaks in up to
  // 9% of the lit pixels (the decoder leaves clipped pixels out); six times that exposure clips
  // 31%.
  double maxClippedShare = 0.2;
  // The sync code cells' contrast below which a picture is called blurred: 0.77–0.88 in sharp
  // pictures of the simulated display (240x136 camera, cells of about 2 camera px); a Gaussian
  // blur of 1.5 camera px brings it to 0.56, of 2 px to 0.35.
  double minCodeContrast = 0.6;
};

// Over-exposure, from a picture in linear light (CV_32F, full scale 1).
std::optional<std::string> overExposure(const cv::Mat& linear, const PictureQualityLimits& limits);

// Blur, from the picture's sync code reading (a coded frame): nullopt too when the code's cells
// are not lit at all (a picture of a reference frame: that is the sync code's to name).
std::optional<std::string> blur(const SyncReading& reading, const PictureQualityLimits& limits);

}  // namespace parallax
