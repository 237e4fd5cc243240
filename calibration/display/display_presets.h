#pragma once
// The nominal displays built in, with their layouts written down in one place:
//
//  default: 72 modules of 1024×768 behind a 1.6 m × 0.9 m screen.
//  demo:    16 modules of 512×384 behind the same screen.
//
// Both: a straight row of modules 1.0 m behind the screen at its centre's height, evenly
// spaced over x ∈ ±(W/2)(1 + D/Z) (D the modules' distance behind the screen, Z the observer
// line's in front): just wide enough that a viewer at the centre of the observer line sees the
// whole screen lit — the screen's edge reaches that viewer only through a module that far out.
// (A row ±35° wide as seen from the screen centre, the 70° of a HoloVizio 722RC, left that
// viewer the middle 58% of the screen; a row giving every screen point ±35° would coarsen the
// angular pitch 2.1× and need camera stations far beyond the observer line's centre to see the
// outermost modules.) Each module is yawed to aim at the screen centre, upright and mirrored
// (rear projection), with
// the largest focal length whose image still covers the whole screen with a 2% margin. The
// observer line is 2 m in front at the screen centre's height; the diffusion width is 1.5× the
// angular pitch between neighbouring modules seen from the screen centre; B_P is the screen's
// rectangle, 0.5 m deep, centred on it.

#include <optional>
#include <string>

#include "calibration/display/display_model.h"

namespace parallax {

struct NominalDisplayOptions {
  std::string preset = "default";  // "default" or "demo"
  std::optional<int> modules;      // overrides the preset's count
  std::optional<int> width, height;
  std::optional<double> curvature;
  std::optional<ScreenTransfer> transfer;

  // Throws InputError naming the option.
  void validate() const;
};

DisplayModel makeNominalDisplay(const NominalDisplayOptions& options);

bool isBuiltInDisplay(const std::string& name);

// A `--display` argument: a built-in name ("default", "demo") or a JSON file.
DisplayModel resolveDisplay(const std::string& fileOrName);

// Mean angle (degrees) between neighbouring modules as seen from the screen centre.
double angularPitchDeg(const DisplayModel& model);

}  // namespace parallax
