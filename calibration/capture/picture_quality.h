#pragma once
// Is a calibration picture fit to decode, apart from showing the right frame (sync_code.h)?
// Two faults a picture taken by hand has and a streaming camera rarely does:
//  - over-exposed: the lit screen at the sensor's full scale, where a stripe's peak and its
//    flanks read alike (the stripe centres go flat-topped, the Gray-code threshold between
//    white and black moves);
//  - blurred: the camera shook or its focus slipped, so neighbouring stripes run into each
//    other. Measured on the sync code's cells: the contrast between a pair's lit and unlit cell
//    (SyncReading::contrast). How sharp a sharp picture's cells look depends on how many camera
//    pixels they cover (0.77–0.88 with a 240x136 camera on six small modules, 0.50–0.67 with
//    640x360 on the demo display), so a picture is judged against the session's own pictures.
// Each says why the picture is refused, or nullopt when it is fine.

#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace parallax {

struct PictureQualityLimits {
  // Share of the lit pixels (linear light above 0.1) allowed at full scale (0.995 and more:
  // 255 in 8 bits, whatever the response). The simulated camera clips its lobes' peaks in up to
  // 9% of the lit pixels (the decoder leaves clipped pixels out); six times that exposure clips
  // 31%.
  double maxClippedShare = 0.2;
  // A picture whose code contrast is under this share of the session's median is blurred:
  // sharp pictures stay above 0.85 of it; a Gaussian blur of 1.5 camera px (240x136 camera)
  // brings a picture to 0.68, of 2 px to 0.43.
  double minContrastRatio = 0.75;
  int minPicturesForBlur = 4;  // before that many, a picture has nothing to be judged against
};

// Over-exposure, from a picture in linear light (CV_32F, full scale 1).
std::optional<std::string> overExposure(const cv::Mat& linear, const PictureQualityLimits& limits);

// The sync code contrasts of a session's coded pictures, and which of them are blurred.
class BlurCheck {
 public:
  explicit BlurCheck(PictureQualityLimits limits = {}) : limits_(limits) {}
  // Why a picture of this contrast is blurred next to the pictures counted so far (once there
  // are enough); nullopt when it is not, or when its cells are not lit at all (contrast 0: a
  // picture of a reference frame, for the sync code to name).
  std::optional<std::string> judge(double contrast) const;
  // Counts an accepted picture.
  void add(double contrast) { contrasts_.push_back(contrast); }
  // At the end, against the whole session's median: the first counted picture that is blurred
  // (its index in the order added, and why), which the pictures before it could not tell.
  std::optional<std::pair<size_t, std::string>> firstBlurred() const;

 private:
  std::optional<std::string> against(double contrast, double median) const;

  PictureQualityLimits limits_;
  std::vector<double> contrasts_;
};

}  // namespace parallax
