// The simulator's photometric truth (calibration/simulation/photometric_truth.h) and the
// correction file (calibration/display/colour_correction.h): seeded, in the issue's ranges, a
// weak and a tinted module, files that round-trip and refuse bad fields by name.

#include "calibration/simulation/photometric_truth.h"

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "calibration/display/colour_correction.h"
#include "common/input_error.h"

namespace parallax {
namespace {

TEST(PhotometricTruth, SeededInTheIssuesRangesWithAWeakAndATintedModule) {
  const PhotometricTruth a = makePhotometricTruth(16, {}), b = makePhotometricTruth(16, {});
  ASSERT_EQ(a.modules.size(), 16u);
  int weak = 0, tinted = 0;
  for (size_t i = 0; i < a.modules.size(); ++i) {
    const ModulePhotometricTruth& m = a.modules[i];
    EXPECT_EQ(m.primaries, b.modules[i].primaries);  // same seed, same truth
    for (int c = 0; c < 3; ++c) {
      EXPECT_GE(m.gamma[c], 1.8);
      EXPECT_LE(m.gamma[c], 2.6);
    }
    EXPECT_GE(m.vignetting, 0.1);
    EXPECT_LE(m.vignetting, 0.3);
    // The falloff: 1 at its centre, 1 − vignetting at the farthest corner, never below.
    const double cx = (1.0 + m.vignettingCentre.x()) * 256.0,
                 cy = (1.0 + m.vignettingCentre.y()) * 192.0;
    EXPECT_NEAR(m.falloff(cx, cy, 512, 384), 1.0, 1e-12);
    double lowest = 1.0;
    for (double u : {0.0, 512.0})
      for (double v : {0.0, 384.0}) lowest = std::min(lowest, m.falloff(u, v, 512, 384));
    EXPECT_NEAR(lowest, 1.0 - m.vignetting, 1e-12);
    const Eigen::Vector3d gains = m.primaries.colwise().sum();
    weak += gains.maxCoeff() < 0.75;
    tinted += gains.maxCoeff() > 0.8 && gains.minCoeff() < 0.75;
  }
  EXPECT_EQ(weak, 1);
  EXPECT_EQ(tinted, 1);
  PhotometricTruthOptions other;
  other.seed = 2;
  EXPECT_NE(makePhotometricTruth(16, other).modules[0].primaries, a.modules[0].primaries);
}

TEST(PhotometricTruth, FileRoundTripsAndNamesBadFields) {
  const PhotometricTruth truth = makePhotometricTruth(4, {});
  const std::string path = ::testing::TempDir() + "photometric_truth.json";
  savePhotometricTruth(truth, path);
  const PhotometricTruth back = loadPhotometricTruth(path);
  ASSERT_EQ(back.modules.size(), 4u);
  EXPECT_TRUE(back.modules[2].primaries.isApprox(truth.modules[2].primaries, 1e-12));
  std::ofstream(path) << R"({"format": "parallax-photometric-truth", "version": 1, "seed": 1,
    "modules": [{"gamma": [2, 2, 9], "primaries": [1,0,0,0,1,0,0,0,1], "black": [0,0,0],
                 "vignetting": 0.1, "vignetting_centre": [0, 0]}]})";
  try {
    loadPhotometricTruth(path);
    FAIL() << "a gamma of 9 was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.location().field, "modules[0].gamma");
    EXPECT_EQ(e.location().file, path);
  }
}

TEST(ColourCorrectionFile, NamesTheBadField) {
  DisplayColourCorrection c;
  c.modules.push_back(ModuleColourCorrection::srgbIdentity());
  c.modules.push_back(ModuleColourCorrection::srgbIdentity());
  const std::string path = ::testing::TempDir() + "photometry.json";
  saveColourCorrection(c, path);
  EXPECT_EQ(loadColourCorrection(path).modules.size(), 2u);
  nlohmann::json j = nlohmann::json::parse(std::ifstream(path));
  j["modules"][1]["gain"] = {0.2};
  std::ofstream(path) << j.dump();
  try {
    loadColourCorrection(path);
    FAIL() << "an edited file was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.location().field, "checksum") << e.what();
  }
  // A hand edit is accepted without its checksum, and then checked field by field.
  j.erase("checksum");
  std::ofstream(path, std::ios::trunc) << j.dump();
  try {
    loadColourCorrection(path);
    FAIL() << "a gain below 1 was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.location().field, "modules[1].gain");
    EXPECT_EQ(e.location().file, path);
  }
}

}  // namespace
}  // namespace parallax
