// The photometric correction in the calibration store (issue 21): stored beside the geometric
// calibration and versioned with it — installed together, `.previous` kept, rolled back
// together; carried over by a geometric recalibration; a damaged or mismatched file (wrong
// module count, a number that is not one, another calibration's) refused with the file and the
// field named, the geometry still used and nothing else changed.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "calibration/display/display_model_json.h"
#include "calibration/display/display_presets.h"
#include "common/input_error.h"
#include "daemon/parallaxd/calibration_store.h"
#include "tests/daemon/test_folder.h"

namespace parallax::daemon {
namespace {

namespace fs = std::filesystem;
using test_support::bytesOf;

DisplayModel display(double shift) {
  NominalDisplayOptions o;
  o.preset = "demo";
  o.modules = 4;
  o.width = 64;
  o.height = 48;
  DisplayModel model = makeNominalDisplay(o);
  for (OpticalModule& m : model.modules) m.cx += shift;
  return model;
}

// A correction told apart by `lift`: its modules' black lift.
DisplayColourCorrection correction(float lift, size_t modules = 4) {
  DisplayColourCorrection c;
  for (size_t i = 0; i < modules; ++i) {
    ModuleColourCorrection m = ModuleColourCorrection::srgbIdentity();
    m.lift = Eigen::Vector3f::Constant(lift);
    c.modules.push_back(m);
    ModulePhotometricSummary s;
    s.deltaEMean = 0.5;
    c.summary.modules.push_back(s);
  }
  c.summary.deltaEMean = 0.5;
  c.summary.nonUniformity = 0.02;
  return c;
}

float liftOf(const std::optional<DisplayColourCorrection>& c) {
  return c ? c->modules.front().lift.x() : -1.0f;
}

bool sameModel(const DisplayModel& a, const DisplayModel& b) {
  return displayModelToJson(a) == displayModelToJson(b);
}

class CalibrationStorePhotometry : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = test_support::freshTestFolder("plx-store-photo");
    path_ = (folder_ / "calibration.json").string();
  }
  void TearDown() override { fs::remove_all(folder_); }

  fs::path folder_;
  std::string path_;
};

using Photometry = CalibrationStore::Photometry;

TEST_F(CalibrationStorePhotometry, InstalledBesideTheGeometryAndLoadedWithIt) {
  const CalibrationStore store(path_);
  EXPECT_EQ(store.photometryPath(), (folder_ / "calibration.photometry.json").string());
  const StoredCalibration installed =
      store.install(display(1.0), Photometry::kReplace, correction(0.01f));
  EXPECT_FLOAT_EQ(liftOf(installed.photometry), 0.01f);
  const std::optional<StoredCalibration> loaded = store.loadFor(display(0.0));
  ASSERT_TRUE(loaded);
  EXPECT_TRUE(sameModel(loaded->model, display(1.0)));
  EXPECT_FLOAT_EQ(liftOf(loaded->photometry), 0.01f);
  EXPECT_EQ(loaded->photometrySource, store.photometryPath());
  EXPECT_TRUE(loaded->photometryRefused.empty()) << loaded->photometryRefused;
  EXPECT_DOUBLE_EQ(loaded->photometry->summary.nonUniformity, 0.02);
}

TEST_F(CalibrationStorePhotometry, RollbackRestoresGeometryAndPhotometryTogether) {
  const CalibrationStore store(path_);
  store.install(display(1.0), Photometry::kReplace, correction(0.01f));
  store.install(display(2.0), Photometry::kReplace, correction(0.02f));
  StoredCalibration back = store.rollback(display(0.0));
  EXPECT_TRUE(sameModel(back.model, display(1.0)));
  EXPECT_FLOAT_EQ(liftOf(back.photometry), 0.01f);
  EXPECT_FLOAT_EQ(liftOf(store.loadFor(display(0.0))->photometry), 0.01f);
  // And forward again: the rolled-back version is the previous one now.
  back = store.rollback(display(0.0));
  EXPECT_TRUE(sameModel(back.model, display(2.0)));
  EXPECT_FLOAT_EQ(liftOf(back.photometry), 0.02f);
}

TEST_F(CalibrationStorePhotometry, RollbackToAVersionWithoutPhotometryRemovesIt) {
  const CalibrationStore store(path_);
  store.install(display(1.0));
  store.install(display(2.0), Photometry::kReplace, correction(0.02f));
  const StoredCalibration back = store.rollback(display(0.0));
  EXPECT_TRUE(sameModel(back.model, display(1.0)));
  EXPECT_FALSE(back.photometry);
  EXPECT_FALSE(fs::exists(store.photometryPath()));
  EXPECT_FALSE(store.loadFor(display(0.0))->photometry);
  EXPECT_FLOAT_EQ(liftOf(store.rollback(display(0.0)).photometry), 0.02f);
}

TEST_F(CalibrationStorePhotometry, AGeometricRecalibrationCarriesThePhotometryOver) {
  const CalibrationStore store(path_);
  store.install(display(1.0), Photometry::kReplace, correction(0.01f));
  const StoredCalibration next = store.install(display(2.0));
  EXPECT_FLOAT_EQ(liftOf(next.photometry), 0.01f);
  EXPECT_FLOAT_EQ(liftOf(store.loadFor(display(0.0))->photometry), 0.01f);
  // Explicitly none: the colours are no longer corrected.
  EXPECT_FALSE(store.install(display(3.0), Photometry::kReplace, std::nullopt).photometry);
  EXPECT_FALSE(fs::exists(store.photometryPath()));
}

// Each bad file: refused at load naming the file and the field; the geometry still loads.
void expectRefusedAtLoad(const CalibrationStore& store, const std::string& field) {
  const std::optional<StoredCalibration> loaded = store.loadFor(display(0.0));
  ASSERT_TRUE(loaded);
  EXPECT_TRUE(sameModel(loaded->model, display(1.0)));
  EXPECT_FALSE(loaded->photometry);
  EXPECT_NE(loaded->photometryRefused.find(store.photometryPath()), std::string::npos)
      << loaded->photometryRefused;
  EXPECT_NE(loaded->photometryRefused.find(field), std::string::npos) << loaded->photometryRefused;
}

// The file with `from` replaced by `to` once, the checksum removed (as a hand edit would be).
void edit(const std::string& path, const std::string& from, const std::string& to) {
  std::string text = bytesOf(path);
  const size_t at = text.find(from);
  ASSERT_NE(at, std::string::npos) << from;
  text.replace(at, from.size(), to);
  // Keys are written sorted: "checksum" first, `"checksum":"fnv1a64:…",`.
  const size_t checksum = text.find("\"checksum\":\"");
  ASSERT_NE(checksum, std::string::npos);
  const size_t end = text.find('"', checksum + 12);
  text.erase(checksum, end + 2 - checksum);
  std::ofstream(path, std::ios::trunc) << text;
}

TEST_F(CalibrationStorePhotometry, ADamagedFileIsRefusedByItsChecksum) {
  const CalibrationStore store(path_);
  store.install(display(1.0), Photometry::kReplace, correction(0.01f));
  std::string text = bytesOf(store.photometryPath());
  const size_t at = text.find("\"non_uniformity\":0.02");
  ASSERT_NE(at, std::string::npos);
  text[at + 20] = '3';  // 0.02 → 0.03: still a valid file, only the checksum can tell
  std::ofstream(store.photometryPath(), std::ios::trunc) << text;
  expectRefusedAtLoad(store, "checksum");
}

TEST_F(CalibrationStorePhotometry, ANumberThatIsNotOneIsRefusedNamingTheField) {
  const CalibrationStore store(path_);
  store.install(display(1.0), Photometry::kReplace, correction(0.01f));
  // JSON has no NaN: a writer that had one gives null.
  edit(store.photometryPath(), "\"lift\":[", "\"lift\":[null,");
  expectRefusedAtLoad(store, "modules[0].lift");
}

TEST_F(CalibrationStorePhotometry, AFileForAnotherModuleCountIsRefused) {
  const CalibrationStore store(path_);
  store.install(display(1.0), Photometry::kReplace, correction(0.01f));
  DisplayColourCorrection three = correction(0.01f, 3);
  three.geometry = loadColourCorrection(store.photometryPath()).geometry;
  saveColourCorrection(three, store.photometryPath());
  expectRefusedAtLoad(store, "modules");
  // And an install of one is refused before anything is written.
  const std::string before = bytesOf(path_);
  EXPECT_THROW(store.install(display(2.0), Photometry::kReplace, correction(0.01f, 3)), InputError);
  EXPECT_EQ(bytesOf(path_), before);
}

TEST_F(CalibrationStorePhotometry, APhotometryOfAnotherGeometryIsRefused) {
  const CalibrationStore store(path_);
  store.install(display(1.0), Photometry::kReplace, correction(0.01f));
  DisplayColourCorrection other = correction(0.01f);
  other.geometry = "0123456789abcdef";  // a torn install, a file copied from elsewhere
  saveColourCorrection(other, store.photometryPath());
  expectRefusedAtLoad(store, "geometry");
}

TEST_F(CalibrationStorePhotometry, RollbackToABadPreviousPhotometryChangesNothing) {
  const CalibrationStore store(path_);
  store.install(display(1.0), Photometry::kReplace, correction(0.01f));
  store.install(display(2.0), Photometry::kReplace, correction(0.02f));
  edit(store.previousPhotometryPath(), "\"gain\":[", "\"gain\":[0.5,");
  const std::string current = bytesOf(path_), currentPhotometry = bytesOf(store.photometryPath());
  try {
    store.rollback(display(0.0));
    FAIL() << "rolled back to a bad photometry";
  } catch (const InputError& e) {
    EXPECT_EQ(e.location().file, store.previousPhotometryPath()) << e.what();
    EXPECT_NE(std::string(e.what()).find("gain"), std::string::npos) << e.what();
  }
  EXPECT_EQ(bytesOf(path_), current);
  EXPECT_EQ(bytesOf(store.photometryPath()), currentPhotometry);
}

}  // namespace
}  // namespace parallax::daemon
