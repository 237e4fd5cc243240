// The calibration store keeps an installer's calibration safe (issue 18, defects 3 and 4):
// a damaged calibration file is recognised by its checksum and never used; at start-up a
// damaged current file with a good .previous gives the previous one and says so; .previous
// only ever receives a file that verified; an install on a full disk (here a file-size limit
// in a child process) fails loudly and leaves the old files exactly as they were, with no
// partial or empty .previous.

#include "daemon/parallaxd/calibration_store.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "calibration/display/display_model_json.h"
#include "calibration/display/display_presets.h"
#include "common/input_error.h"
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
  for (OpticalModule& m : model.modules) m.cx += shift;  // a different calibration, same display
  return model;
}

void writeBytes(const fs::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

// Changes one digit of the first module's principal point: still valid JSON, still a valid
// model, only the checksum can tell.
void damageOneNumber(const fs::path& path) {
  std::string text = bytesOf(path);
  const size_t at = text.find("\"principal_px\"");
  ASSERT_NE(at, std::string::npos);
  const size_t digit = text.find_first_of("123456789", at);
  text[digit] = text[digit] == '9' ? '8' : static_cast<char>(text[digit] + 1);
  writeBytes(path, text);
}

bool sameModel(const DisplayModel& a, const DisplayModel& b) {
  return displayModelToJson(a) == displayModelToJson(b);
}

class CalibrationStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = test_support::freshTestFolder("plx-store");
    path_ = (folder_ / "calibration.json").string();
  }
  void TearDown() override { fs::remove_all(folder_); }

  fs::path folder_;
  std::string path_;
};

TEST_F(CalibrationStoreTest, ADamagedCalibrationIsRefusedByItsChecksum) {
  const CalibrationStore store(path_);
  store.install(display(1.0));
  damageOneNumber(path_);
  try {
    loadDisplayModel(path_);
    FAIL() << "a damaged calibration loaded";
  } catch (const InputError& e) {
    EXPECT_EQ(e.location().field, "checksum") << e.what();
    EXPECT_EQ(e.location().file, path_);
  }
}

TEST_F(CalibrationStoreTest, DamagedCurrentWithGoodPreviousStartsFromThePrevious) {
  const CalibrationStore store(path_);
  store.install(display(1.0));
  store.install(display(2.0));
  damageOneNumber(path_);
  const std::optional<StoredCalibration> loaded = store.loadFor(display(0.0));
  ASSERT_TRUE(loaded.has_value());
  EXPECT_EQ(loaded->source, store.previousPath());
  EXPECT_TRUE(sameModel(loaded->model, display(1.0)));
  EXPECT_NE(loaded->refused.find("checksum"), std::string::npos) << loaded->refused;
}

TEST_F(CalibrationStoreTest, InstallNeverCopiesADamagedCurrentOverThePrevious) {
  const CalibrationStore store(path_);
  store.install(display(1.0));
  store.install(display(2.0));
  damageOneNumber(path_);
  store.install(display(3.0));
  EXPECT_TRUE(sameModel(loadDisplayModel(store.previousPath()), display(1.0)));
  EXPECT_TRUE(sameModel(loadDisplayModel(path_), display(3.0)));
  // And the good one moves on to .previous at the next install.
  store.install(display(4.0));
  EXPECT_TRUE(sameModel(loadDisplayModel(store.previousPath()), display(3.0)));
}

TEST_F(CalibrationStoreTest, RollbackDropsADamagedCurrentInsteadOfKeepingIt) {
  const CalibrationStore store(path_);
  store.install(display(1.0));
  store.install(display(2.0));
  damageOneNumber(path_);
  EXPECT_TRUE(sameModel(store.rollback(display(0.0)).model, display(1.0)));
  EXPECT_TRUE(sameModel(loadDisplayModel(path_), display(1.0)));
  EXPECT_TRUE(sameModel(loadDisplayModel(store.previousPath()), display(1.0)));
}

// Runs `install(next)` in a child process whose files may not grow beyond `limitBytes`
// (what a full disk does to a write); returns true when the install threw, as it must.
bool installThrowsUnderFileSizeLimit(const std::string& path, const DisplayModel& next,
                                     rlim_t limitBytes) {
  const pid_t child = ::fork();
  if (child == 0) {
    ::signal(SIGXFSZ, SIG_IGN);  // the write fails with EFBIG instead of killing the process
    const rlimit limit{limitBytes, limitBytes};
    ::setrlimit(RLIMIT_FSIZE, &limit);
    try {
      CalibrationStore(path).install(next);
    } catch (const InputError&) {
      ::_exit(0);
    } catch (...) {
      ::_exit(2);
    }
    ::_exit(1);
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

TEST_F(CalibrationStoreTest, AnInstallOnAFullDiskFailsAndLeavesTheOldFilesAsTheyWere) {
  const CalibrationStore store(path_);
  store.install(display(1.0));
  const std::string before = bytesOf(path_);
  ASSERT_FALSE(fs::exists(store.previousPath()));
  // Neither the copy to .previous nor the new file fits.
  EXPECT_TRUE(installThrowsUnderFileSizeLimit(path_, display(2.0), before.size() / 2));
  EXPECT_EQ(bytesOf(path_), before);
  EXPECT_TRUE(sameModel(loadDisplayModel(path_), display(1.0)));
  // No empty or partial .previous, no temporary file left behind.
  if (fs::exists(store.previousPath())) {
    EXPECT_TRUE(sameModel(loadDisplayModel(store.previousPath()), display(1.0)));
  }
  for (const auto& entry : fs::directory_iterator(folder_)) {
    const std::string name = entry.path().filename().string();
    EXPECT_TRUE(name == "calibration.json" || name == "calibration.json.previous") << name;
  }
}

TEST_F(CalibrationStoreTest, AFailedInstallAfterThePreviousWasKeptStillKeepsBothGood) {
  const CalibrationStore store(path_);
  store.install(display(1.0));
  store.install(display(2.0));
  const std::string current = bytesOf(path_);
  // A model with longer numbers: its file is larger than the current one, so the copy to
  // .previous fits under the limit and the new file does not.
  DisplayModel longer = display(0.0);
  for (OpticalModule& m : longer.modules) {
    m.cx += 0.123456789012345;
    m.cy += 0.987654321098765;
    m.fx += 0.111111111111111;
    m.fy += 0.222222222222222;
  }
  const std::string previous = bytesOf(store.previousPath());
  EXPECT_TRUE(installThrowsUnderFileSizeLimit(path_, longer, current.size() + 8));
  EXPECT_EQ(bytesOf(path_), current);
  // .previous is put back too: a rollback still goes to display(1.0), not to display(2.0)
  // which the failed install had copied there.
  EXPECT_EQ(bytesOf(store.previousPath()), previous);
  EXPECT_TRUE(sameModel(store.rollback(display(0.0)).model, display(1.0)));
}

// An install undone because another rank of a cluster could not take it (issue 23): every file
// is put back byte for byte, .previous too, so a later rollback goes where it would have gone
// before the attempt, not to the calibration that was undone.
TEST_F(CalibrationStoreTest, RestoreAfterAnInstallPutsBackTheCurrentAndThePrevious) {
  const CalibrationStore store(path_);
  store.install(display(1.0));
  store.install(display(2.0));
  const std::string current = bytesOf(path_), previous = bytesOf(store.previousPath());
  const CalibrationStore::Files before = store.files();
  store.install(display(3.0));
  store.restore(before);
  EXPECT_EQ(bytesOf(path_), current);
  EXPECT_EQ(bytesOf(store.previousPath()), previous);
  EXPECT_TRUE(sameModel(store.rollback(display(0.0)).model, display(1.0)));
}

TEST_F(CalibrationStoreTest, RestoreAfterTheFirstInstallLeavesNoCalibration) {
  const CalibrationStore store(path_);
  const CalibrationStore::Files before = store.files();
  store.install(display(1.0));
  store.install(display(2.0));  // a .previous too
  store.restore(before);
  EXPECT_TRUE(fs::is_empty(folder_));
  EXPECT_FALSE(store.loadFor(display(0.0)).has_value());
}

// What cannot be read cannot be put back: a folder where the calibration file should be is
// refused before anything is written, naming it.
TEST_F(CalibrationStoreTest, AnInstallOverAFolderChangesNothingAndNamesIt) {
  const CalibrationStore store(path_);
  store.install(display(1.0));
  fs::rename(path_, store.previousPath());
  fs::create_directory(path_);
  const std::string previous = bytesOf(store.previousPath());
  try {
    store.install(display(2.0));
    FAIL() << "installed over a folder";
  } catch (const InputError& e) {
    EXPECT_EQ(e.location().file, path_) << e.what();
  }
  EXPECT_TRUE(fs::is_directory(path_));
  EXPECT_EQ(bytesOf(store.previousPath()), previous);
}

}  // namespace
}  // namespace parallax::daemon
