#pragma once
// Stripe centres along one camera row: where each module's lobe peaks.
//
// The screen's horizontal lobe is symmetric in the exit angle, not in camera pixels: an oblique
// station or a wide lobe (demo's is ~10°) maps equal angles to unequal pixel runs, so the
// contrast-weighted centroid of a stripe lands millimetres off the peak on the observer line.
// The peak survives any monotone change of variable, so it is found in the predicted angle:
// a Gaussian (a parabola in log contrast) is fitted against each pixel's angle as the nominal
// model predicts it, and the peak angle is carried back to the camera x between the samples
// that bracket it. (The nominal's angle differs from the truth's by a near-constant offset
// across one stripe, which moves the parabola without bending it.)
//
// The modules of a group lie about three lobe widths (σ) apart, so each stripe's flanks carry
// its neighbours' tails — more on the side where an oblique camera squeezes them together.
// The fit therefore runs a few rounds, each stripe refitted after the others' fitted lobes
// are subtracted from the row. (On demo from the outer stations, the neighbours' tails alone
// moved the peaks by about a camera pixel, ~2 mm on the screen.)
//
// Pixels the sensor clipped stay in their module's run (they are lit, and bound its extent) but
// not in its fit: the flat top of a clipped lobe would pull the parabola's vertex toward the
// flank with more unclipped samples (on demo, ±0.4 mm at the oblique stations).

#include <optional>
#include <vector>

namespace parallax {

// One camera pixel of a row, lit by the modules of the group.
struct StripeRowSample {
  double x = 0.0;         // camera px (pixel centre), increasing along the row
  double contrast = 0.0;  // white − black, linear light
  int owner = -1;         // the group module the pixel was given to (index into angles)
  std::vector<double>
      angles;  // per group module: predicted signed angle between its exit ray and the camera (rad)
  bool clipped = false;  // the sensor clipped it: its contrast is only a lower bound
};

struct StripePeakOptions {
  double fitFraction = 0.3;  // samples at or above this fraction of the peak enter the fit
  double cutFraction = 0.5;  // a stripe whose first or last pixel is this bright was cut off
  // Pixels this close (camera px) to an end that is not a valley between two lobes stay out of
  // the fit: the lens blurs a cut lobe's edge (and a lobe's own dim end) with the dark beyond.
  double cutGuardPx = 2.0;
  int minFitSamples = 4;
  int rounds = 6;  // neighbour-subtraction rounds after the first fit (Gauss–Seidel)
  // Largest pull (rad) a neighbour whose lobe could not be fitted may be predicted to put on a
  // peak (stripe_peak.cpp): 5e-5 rad is 0.1 mm at 2 m, a third of a good stripe's noise.
  double maxNeighbourBias = 5e-5;
};

// Per group module: the camera x of its lobe's peak in this row, or nothing when its stripe was
// cut, is too short, or does not peak inside its own pixels (no finite answer is made up).
// `widths`, when given, receives each found lobe's fitted width (its Gaussian σ, rad; NaN where
// there is no peak): every lobe is the screen's own, so one far from the others' width is a
// fragment (capture_decoder.cpp compares them over a picture set).
std::vector<std::optional<double>> stripePeaksInRow(const std::vector<StripeRowSample>& row,
                                                    int groupSize,
                                                    const StripePeakOptions& options = {},
                                                    std::vector<double>* widths = nullptr);

}  // namespace parallax
