#pragma once
// What the decoder found of the calibration camera's response (measured from the phase
// pictures: calibration/capture/camera_response.h) against what camera.json said.

#include <fmt/format.h>

#include <cmath>
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
  // When corrected: which end of the chain bends the light, told by the lobes (the screen's
  // diffusion, a Gaussian in angle whose width the nominal states; a power response scales a
  // Gaussian's width by 1/√exponent): the median fitted lobe σ over the nominal's, in the
  // pictures as recorded and re-linearized. When the recorded lobes are the nearer, the camera
  // is linear under the assumed γ and the modules' own response bends the patterns: only the
  // patterns are linearized with the measured γ; lobes and fiducials are used as recorded.
  bool modulesBend = false;
  double lobeWidthRecorded = 0.0, lobeWidthRelinearized = 0.0;  // ratios to the nominal's
  // When corrected: the exponent that makes the phase samples less the black reference
  // sinusoidal (0 when not measured). When the modules bend, their response shapes only the
  // light above their black (the black level and the room's light add after it), so the
  // patterns are linearized above the black reference with it: raised whole with the chain's
  // exponent, a dim lobe flank, where the black is a larger share, bent otherwise than the
  // centre, and the phase moved with the brightness (a photometric demo: 70 mm worst on the
  // observer line).
  double aboveBlackExponent = 0.0;
  // When corrected and the lobes were compared: the lobes of the end found to bend are not the
  // nominal's width either (beyond `tolerance`, a ratio): neither the camera's response nor the
  // modules' alone explains the pictures (both bend, or the nominal's diffusion is far from the
  // screen's), so the decoder cannot know what it linearized. Observed: a γ 2.2 camera over
  // modules of a response of their own measured 1.23× and 1.34×, and installed 70 mm off on the
  // observer line; sound decisions land within 4% (0.96×, 0.98×).
  bool undecided(double tolerance = 1.15) const {
    if (!corrected || !(lobeWidthRecorded > 0.0) || !(lobeWidthRelinearized > 0.0)) return false;
    const double chosen = modulesBend ? lobeWidthRecorded : lobeWidthRelinearized;
    return std::abs(std::log(chosen)) > std::log(tolerance);
  }
  // The modules' own response γ (light ∝ code^γ) when they bend, else 0.
  double modulesGamma() const {
    return corrected && modulesBend && aboveBlackExponent > 0.0 ? 1.0 / aboveBlackExponent : 0.0;
  }

  // The γ the patterns were decoded with (the whole chain's).
  double usedGamma() const { return corrected ? measuredGamma : assumedGamma; }
  // The γ the lobes and fiducials were found with (the camera's).
  double cameraGamma() const { return corrected && !modulesBend ? measuredGamma : assumedGamma; }
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
        !check.corrected                   ? " and the pictures are linear: used as they are"
        : !(check.lobeWidthRecorded > 0.0) ? ": the pictures were re-linearized with the measured γ"
        : check.modulesBend
            ? fmt::format(
                  ": the lobes are the screen's width as recorded (median σ {:.2f}× the "
                  "nominal's; {:.2f}× re-linearized), so the modules' own response bends the "
                  "patterns{}: the patterns were linearized above their black with it, the lobes "
                  "used as recorded",
                  check.lobeWidthRecorded, check.lobeWidthRelinearized,
                  check.modulesGamma() > 0.0
                      ? fmt::format(" (γ {:.2f} above their black)", check.modulesGamma())
                      : std::string())
            : fmt::format(
                  ": the pictures were re-linearized with the measured γ (the lobes then are "
                  "{:.2f}× the nominal's width, {:.2f}× as recorded)",
                  check.lobeWidthRelinearized, check.lobeWidthRecorded));
  return fmt::format(
      "camera response: γ {:.3f} ± {:.4f} measured from {} phase pixels; camera.json states "
      "{:.2f}{}",
      check.measuredGamma, check.sigma, check.pixels, check.assumedGamma,
      check.disagrees ? ": they disagree (modules with a response curve of their own, or a wrong "
                        "camera.json?); the stated γ is used"
                      : ": consistent");
}

}  // namespace parallax
