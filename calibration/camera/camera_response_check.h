#pragma once
// What the decoder found of the calibration camera's response (measured from the phase
// pictures: calibration/capture/camera_response.h) against what camera.json said.

#include <fmt/format.h>

#include <string>

namespace parallax {

struct CameraResponseCheck {
  double assumedGamma = 1.0;  // camera.json's response_gamma (1 when it gives none)
  bool stated = false;        // camera.json gave it
  bool measured = false;      // false: too few usable pixels, or fewer than 4 phase steps
  double measuredGamma = 1.0;
  double sigma = 0.0;  // of measuredGamma
  int pixels = 0;      // phase pixels the measurement used
  // The measured γ differs from the assumed one by more than the tolerance (3σ, and at least 2%).
  bool disagrees = false;
  // ... and camera.json gave none, so the pictures were re-linearized with the measured γ. A
  // stated γ is kept (and the disagreement noted): the phase pictures show the whole chain from
  // pattern code to recorded value, which is the camera's own response only when the modules
  // are driven linearly; a display whose modules have a response curve of their own shows less
  // (a γ 2.2 camera over γ 2.2 modules measures about 1), while the lobes need the camera's.
  bool corrected = false;

  // The γ every decoded quantity used.
  double usedGamma() const { return corrected ? measuredGamma : assumedGamma; }
};

// "camera response: γ 2.200 ± 0.0040 measured from 18000 phase pixels; camera.json gives none:
// the pictures were re-linearized with the measured γ" (one line, no newline).
inline std::string describeCameraResponse(const CameraResponseCheck& check) {
  if (!check.measured)
    return fmt::format(
        "camera response: not measured ({} usable phase pixels; 4 or more phase steps needed); "
        "γ {:.2f} from camera.json taken on trust",
        check.pixels, check.assumedGamma);
  if (!check.stated)
    return fmt::format(
        "camera response: γ {:.3f} ± {:.4f} measured from {} phase pixels; camera.json gives "
        "none{}",
        check.measuredGamma, check.sigma, check.pixels,
        check.corrected ? ": the pictures were re-linearized with the measured γ"
                        : " and the pictures are linear: used as they are");
  return fmt::format(
      "camera response: γ {:.3f} ± {:.4f} measured from {} phase pixels; camera.json states "
      "{:.2f}{}",
      check.measuredGamma, check.sigma, check.pixels, check.assumedGamma,
      check.disagrees ? ": they disagree (modules with a response curve of their own, or a wrong "
                        "camera.json?); the stated γ is used"
                      : ": consistent");
}

}  // namespace parallax
