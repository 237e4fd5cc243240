// A stripe's centres lie on one smooth curve (stripe_curve.h): fragments off it are dropped,
// a stripe too short to check is dropped whole, a clean one is kept whole.

#include "calibration/capture/stripe_curve.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "calibration/simulation/seeded_random.h"

namespace parallax {
namespace {

// A gently bent stripe (camera px), rows every 4 px, with 0.03 px of noise.
std::vector<Eigen::Vector2d> bentStripe(int rows, std::uint64_t seed) {
  SeededRandom random(seed);
  std::vector<Eigen::Vector2d> out;
  for (int r = 0; r < rows; ++r) {
    const double y = 40.5 + 4.0 * r;
    out.push_back(
        {280.0 + 0.02 * (y - 160.0) + 4e-5 * (y - 160.0) * (y - 160.0) + 0.03 * random.normal(),
         y});
  }
  return out;
}

TEST(StripeCurve, KeepsACleanStripeWhole) {
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    const auto kept = stripeCentresOnCurve(bentStripe(60, seed));
    EXPECT_EQ(std::count(kept.begin(), kept.end(), true), 60) << "seed " << seed;
  }
}

TEST(StripeCurve, DropsTheFragmentsAtTheEndsAndOnlyThem) {
  auto centres = bentStripe(60, 7);
  // Where the module image's top and bottom edges cut the lobe: 9, 3 and 0.5 px off.
  centres[0].x() += 9.0;
  centres[1].x() -= 3.0;
  centres[59].x() += 0.5;
  const auto kept = stripeCentresOnCurve(centres);
  EXPECT_FALSE(kept[0]);
  EXPECT_FALSE(kept[1]);
  EXPECT_FALSE(kept[59]);
  EXPECT_EQ(std::count(kept.begin(), kept.end(), true), 57);
}

TEST(StripeCurve, AStripeTooShortToCheckIsDropped) {
  const auto kept = stripeCentresOnCurve(bentStripe(5, 3));
  EXPECT_EQ(std::count(kept.begin(), kept.end(), true), 0);
  EXPECT_TRUE(stripeCentresOnCurve({}).empty());
}

}  // namespace
}  // namespace parallax
