// Stripe centres along a camera row (stripe_peak.h): the lobe's peak, not the pixels' centroid,
// with the neighbours' overlapping lobes taken out.

#include "calibration/capture/stripe_peak.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <vector>

namespace parallax {
namespace {

// A row seen obliquely: module m's angle at camera x bends (quadratic term), the way an oblique
// station maps equal angles to unequal pixel runs. Lobes: Gaussian in the true angle.
struct SyntheticRow {
  std::vector<double> peakX;      // where each module's angle is zero (the truth)
  double sigma = 0.072;           // rad (demo's ~10° FWHM)
  double slope = 0.0075;          // rad per camera px
  double bend = 2.0e-5;           // rad per px²
  double predictionOffset = 0.0;  // the nominal's angle error (rad), constant over the row

  double angle(int m, double x) const {
    const double u = x - peakX[static_cast<size_t>(m)];
    return -(slope * u + bend * u * u);
  }

  std::vector<StripeRowSample> samples(double threshold = 0.2) const {
    std::vector<StripeRowSample> row;
    for (int px = 0; px < 640; ++px) {
      const double x = px + 0.5;
      StripeRowSample s{x, 0.0, -1, {}};
      double best = 1e9;
      for (int m = 0; m < static_cast<int>(peakX.size()); ++m) {
        const double a = angle(m, x);
        s.contrast += std::exp(-0.5 * (a / sigma) * (a / sigma));
        s.angles.push_back(a + predictionOffset);
        if (std::abs(a) < best) {
          best = std::abs(a);
          s.owner = m;
        }
      }
      if (s.contrast >= threshold) row.push_back(s);
    }
    return row;
  }
};

double centroid(const std::vector<StripeRowSample>& row, int module) {
  double sw = 0.0, swx = 0.0;
  for (const StripeRowSample& s : row) {
    if (s.owner != module) continue;
    sw += s.contrast;
    swx += s.contrast * s.x;
  }
  return swx / sw;
}

// The decoder keeps a stripe centre only when its lobe is as wide as the set's others
// (capture_decoder.cpp): the width given back is the lobe's own σ, neighbours taken out.
TEST(StripePeak, GivesEachLobesOwnWidth) {
  SyntheticRow truth;
  truth.peakX = {200.0, 330.0, 460.0};
  std::vector<double> widths;
  const auto peaks = stripePeaksInRow(truth.samples(), 3, {}, &widths);
  ASSERT_EQ(widths.size(), 3u);
  for (int m = 0; m < 3; ++m) {
    ASSERT_TRUE(peaks[static_cast<size_t>(m)].has_value());
    EXPECT_NEAR(widths[static_cast<size_t>(m)], truth.sigma, 0.05 * truth.sigma);
  }
}

TEST(StripePeak, AnIsolatedLobeSeenObliquelyPeaksWhereItsAngleIsZeroNotAtItsCentroid) {
  SyntheticRow truth;
  truth.peakX = {300.25};
  const auto row = truth.samples();
  const auto peaks = stripePeaksInRow(row, 1);
  ASSERT_TRUE(peaks[0].has_value());
  EXPECT_NEAR(*peaks[0], 300.25, 0.02);
  // The centroid is what the decoder used before: pixels off on this bend.
  EXPECT_GT(std::abs(centroid(row, 0) - 300.25), 0.5);
}

// A sensor that clips the lobes' tops flattens them; those pixels are a lower bound only. With
// neighbours overlapping, the clipped run is lopsided, and left in the fits it pulls the peaks
// (and the neighbour subtraction) off; marked clipped, the flanks alone give the peaks.
TEST(StripePeak, ClippedPixelsAtTheLobesTopsAreLeftOutOfTheirFits) {
  SyntheticRow truth;
  truth.peakX = {200.0, 228.0, 262.0};
  std::vector<StripeRowSample> row = truth.samples();
  constexpr double kClip = 0.85;
  for (StripeRowSample& s : row) s.contrast = std::min(s.contrast, kClip);
  const auto worstError = [&](const std::vector<std::optional<double>>& peaks) {
    double worst = 0.0;
    for (size_t m = 0; m < peaks.size(); ++m)
      worst = std::max(worst, peaks[m] ? std::abs(*peaks[m] - truth.peakX[m]) : 1e9);
    return worst;
  };
  const double unmarked = worstError(stripePeaksInRow(row, 3));
  for (StripeRowSample& s : row) s.clipped = s.contrast >= kClip;
  EXPECT_LT(worstError(stripePeaksInRow(row, 3)), 0.05);
  EXPECT_GT(unmarked, 0.1);  // what the decoder did before
}

TEST(StripePeak, OverlappingNeighboursAreTakenOutOfEachOthersFlanks) {
  SyntheticRow truth;
  truth.peakX = {200.0, 228.0, 262.0};  // ~3 lobe widths apart, the valleys above half of the
                                        // threshold the decoder lights pixels at
  truth.predictionOffset = 0.01;        // the nominal model's angles are off by ~0.6°
  const auto row = truth.samples();
  const auto peaks = stripePeaksInRow(row, 3);
  for (int m = 0; m < 3; ++m) {
    ASSERT_TRUE(peaks[static_cast<size_t>(m)].has_value()) << m;
    EXPECT_NEAR(*peaks[static_cast<size_t>(m)], truth.peakX[static_cast<size_t>(m)], 0.05) << m;
  }
  // Without the rounds, the middle lobe's flanks carry its neighbours' tails.
  StripePeakOptions single;
  single.rounds = 0;
  const auto biased = stripePeaksInRow(row, 3, single);
  double worst = 0.0;
  for (int m = 0; m < 3; ++m) {
    if (biased[static_cast<size_t>(m)])
      worst = std::max(
          worst, std::abs(*biased[static_cast<size_t>(m)] - truth.peakX[static_cast<size_t>(m)]));
  }
  EXPECT_GT(worst, 0.2);
}

TEST(StripePeak, ALobeCutByTheImageEdgeGivesNoCentre) {
  SyntheticRow truth;
  truth.peakX = {5.0};  // its left half falls off the camera's row
  const auto peaks = stripePeaksInRow(truth.samples(), 1);
  EXPECT_FALSE(peaks[0].has_value());
}

// A lobe whose module image (or the screen) ends on its flank, seen through the lens: the edge
// is blurred with the dark beyond it (σ 0.6 px, the simulated sensor's), so its last pixels are
// darker than the lobe. Fitted, they pulled the peak away from the edge; on demo such stripes
// were off together, one module at one station by up to 0.28 mm on the screen (the picture
// path's shared stripe error). The pixels next to such an end stay out of the fit.
TEST(StripePeak, TheBlurredPixelsAtACutEndDoNotPullThePeak) {
  SyntheticRow truth;
  truth.peakX = {300.25};
  const double lobePx = truth.sigma / truth.slope;
  const double edge = truth.peakX[0] + 1.25 * lobePx;  // the lobe is at 46% there: not "cut off"
  constexpr double kBlurPx = 0.6;
  std::vector<StripeRowSample> row;
  for (StripeRowSample s : truth.samples()) {
    s.contrast *= 0.5 * std::erfc((s.x - edge) / (std::sqrt(2.0) * kBlurPx));
    if (s.contrast >= 0.2) row.push_back(s);
  }
  StripePeakOptions unguarded;
  unguarded.cutGuardPx = 0.0;
  const auto guarded = stripePeaksInRow(row, 1);
  const auto pulled = stripePeaksInRow(row, 1, unguarded);
  ASSERT_TRUE(guarded[0].has_value() && pulled[0].has_value());
  std::printf("    peak error: %.3f px with the guard, %.3f px without\n",
              *guarded[0] - truth.peakX[0], *pulled[0] - truth.peakX[0]);
  EXPECT_NEAR(*guarded[0], truth.peakX[0], 0.02);
  EXPECT_GT(std::abs(*pulled[0] - truth.peakX[0]), 0.03);
}

// A neighbour cut by the row's end leaves its light on the next stripe's flank with nothing to
// subtract it: that stripe's peak would be pulled toward it (a camera pixel and more at demo's
// oblique stations), so it gives no centre either. The same pair away from the edge gives both.
TEST(StripePeak, AStripeBesideACutNeighbourGivesNoCentre) {
  SyntheticRow cut;
  cut.peakX = {5.0, 34.0};
  const auto beside = stripePeaksInRow(cut.samples(), 2);
  EXPECT_FALSE(beside[0].has_value());
  EXPECT_FALSE(beside[1].has_value());

  SyntheticRow whole;
  whole.peakX = {105.0, 134.0};
  const auto both = stripePeaksInRow(whole.samples(), 2);
  ASSERT_TRUE(both[0].has_value() && both[1].has_value());
  EXPECT_NEAR(*both[1], 134.0, 0.2);
}

// With wide lobes (a few modules behind a wide screen: 42° FWHM) a neighbour whose peak is off
// the row need not own a single pixel of it and still light this stripe's flank: nothing can
// subtract it, so the stripe gives no centre (from a 4-module display's end stations its peak
// was 5 mm off on the observer line). The same stripe with the neighbour far away gives its
// centre.
TEST(StripePeak, AStripeLitByANeighbourOffTheRowGivesNoCentre) {
  SyntheticRow wide;
  wide.sigma = 0.3;
  wide.bend = 0.0;
  const auto fromScreenEdge = [](std::vector<StripeRowSample> row) {
    std::erase_if(row, [](const StripeRowSample& s) { return s.x < 100.0; });
    return row;
  };
  wide.peakX = {164.0, 30.0};  // the neighbour peaks 70 px before the row starts
  const auto row = fromScreenEdge(wide.samples());
  ASSERT_FALSE(row.empty());
  ASSERT_TRUE(std::all_of(row.begin(), row.end(), [](const auto& s) { return s.owner == 0; }));
  EXPECT_FALSE(stripePeaksInRow(row, 2)[0].has_value());

  wide.peakX = {164.0, -400.0};
  const auto alone = stripePeaksInRow(fromScreenEdge(wide.samples()), 2);
  ASSERT_TRUE(alone[0].has_value());
  EXPECT_NEAR(*alone[0], 164.0, 0.2);
}

TEST(StripePeak, FlatNoisyOrEmptyRowsGiveNoCentreAndNoNan) {
  std::vector<StripeRowSample> flat;
  for (int x = 0; x < 50; ++x) flat.push_back({x + 0.5, 0.5, 0, {0.001 * (x - 25)}});
  EXPECT_FALSE(stripePeaksInRow(flat, 1)[0].has_value());  // no peak inside: cut at both ends
  EXPECT_TRUE(stripePeaksInRow({}, 2).size() == 2);
  std::vector<StripeRowSample> hostile = {{0.5, NAN, 0, {0.0}},
                                          {1.5, 1.0, 0, {INFINITY}},
                                          {2.5, -1.0, 0, {0.0}},
                                          {3.5, 0.1, 7, {0.0}},
                                          {4.5, 0.1, 0, {}}};
  for (const auto& p : stripePeaksInRow(hostile, 1)) {
    if (p) EXPECT_TRUE(std::isfinite(*p));
  }
}

}  // namespace
}  // namespace parallax
