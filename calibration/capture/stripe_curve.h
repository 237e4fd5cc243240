#pragma once
// A module's stripe seen from one station is one smooth curve in the picture: the screen points
// whose light from that module leaves toward the camera (the lobe is flat vertically, so it runs
// the height of the module's image), bent only gently by the screen's curvature and the lens.
// A row's stripe centre far from the curve through the others is a fragment: where the module
// image's top or bottom edge crosses the lobe obliquely and cuts one flank in that row (seen on
// demo's oblique stations: 2–44 mm off on the screen, against 0.1 mm for the rest of the stripe).
// A stripe too short to draw the curve through (a corner of the module's image) cannot be checked
// and is dropped whole.

#include <Eigen/Core>
#include <vector>

namespace parallax {

struct StripeCurveOptions {
  int minRows = 8;             // centres a stripe needs to be checked (and kept)
  int degree = 3;              // of the polynomial x(y)
  double outlierSigmas = 4.0;  // beyond this many robust σ of the curve's residuals...
  double minOutlierPx = 0.15;  // ...and at least this far (camera px): σ of a clean stripe
                               // can be a hundredth of a pixel
};

// For the centres (camera px: x the peak, y the row) of one module's stripe from one station,
// whether each is kept: false for those off the robust curve x(y), and for all of a stripe with
// fewer than minRows centres.
std::vector<bool> stripeCentresOnCurve(const std::vector<Eigen::Vector2d>& centres,
                                       const StripeCurveOptions& options = {});

}  // namespace parallax
