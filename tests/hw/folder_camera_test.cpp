// `folder:DIR`, pictures taken by hand (hw/camera/folder_camera.h). The folder is filled the way
// an installer fills it: a live session through the link shows each pattern on parallax-simhw's
// modules and asks for a picture by file name; the "operator" takes it with the simulator's
// camera (the calibration physics of a seeded truth) and saves it there. Then, offline (no
// display), from that folder: the same pictures; and from copies of it that went wrong —
// pictures swapped, one missing, one of the wrong pattern, one blurred, one over-exposed: each
// refused with the file named, none decoded as something it is not. End to end, the
// calibration from the folder matches the link path's on the same display.

#include "hw/camera/folder_camera.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "calibration/capture/capture_decoder.h"
#include "calibration/display/ray_error.h"
#include "calibration/fit/display_fit.h"
#include "common/input_error.h"
#include "hw/camera/calibration_capture.h"
#include "hw/camera/camera.h"
#include "hw/camera/camera_name.h"
#include "hw/camera/picture_manifest.h"
#include "hw/link/socket_transport.h"
#include "hw/simulator/calibration_physics.h"
#include "sim_fixture.h"
#include "small_session.h"

namespace parallax::hw {
namespace {
namespace fs = std::filesystem;

void savePicture(const Image& image, const std::string& path) {
  ASSERT_FALSE(image.empty());
  const bool grey = image.format == PixelFormat::kGray8;
  cv::Mat mat(image.height, image.width, grey ? CV_8U : CV_8UC3,
              const_cast<uint8_t*>(image.pixels.data()));
  if (!grey) cv::cvtColor(mat, mat, cv::COLOR_RGB2BGR);
  ASSERT_TRUE(cv::imwrite(path, mat)) << path;
}

fs::path freshFolder(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / fmt::format("plx-folder-{}-{}", ::getpid(), name);
  fs::remove_all(dir);
  return dir;
}

// What the live session made: the folder, its pictures as the session recorded them, and the
// requests the operator answered.
struct FilledFolder {
  fs::path dir;
  CalibrationCaptures captures;
  std::vector<PictureRequest> requests;
  int asked = 0;
};

// The live session: the operator answers every request with the simulator camera's picture.
FilledFolder fillFolder(const SmallSession& s, const std::string& name) {
  FilledFolder filled;
  filled.dir = freshFolder(name);
  InProcessSimhw sim(modulesOf(s.truth),
                     std::make_unique<CalibrationPhysics>(s.truth, s.rig.truth));
  LinkClient link(std::make_unique<SocketTransport>(sim.path()));
  SimulatedCamera hand(link);  // the operator's camera, on the same link
  FolderCameraOptions options;
  options.pictureTimeoutS = 5.0;
  options.onRequest = [&](const PictureRequest& request) {
    filled.requests.push_back(request);
    ++filled.asked;
    hand.setStation(request.station);
    std::string error;
    savePicture(hand.capture(&error), request.path);
  };
  FolderCamera camera(filled.dir.string(), options);
  filled.captures = captureCalibration(link, camera, s.nominal, s.rig.metadata, {});
  return filled;
}

// One live fill for the whole suite; each test works on its own copy.
const FilledFolder& filledFolder() {
  static const FilledFolder filled = fillFolder(twoStationSession(), "filled");
  return filled;
}

fs::path copyOf(const std::string& name) {
  const fs::path dir = freshFolder(name);
  fs::copy(filledFolder().dir, dir);
  return dir;
}

CalibrationCaptures offline(const SmallSession& s, const fs::path& dir) {
  FolderCameraOptions options;
  options.waitForPictures = false;
  FolderCamera camera(dir.string(), options);
  return captureCalibrationOffline(camera, s.nominal, s.rig.metadata, {});
}

// The error an offline session from `dir` stops with (empty when it does not).
std::string offlineError(const SmallSession& s, const fs::path& dir) {
  try {
    offline(s, dir);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

// The requests by what they showed: the n-th coded picture of the first column set.
const PictureRequest& requestShowing(const std::string& shows) {
  for (const PictureRequest& r : filledFolder().requests)
    if (r.shows.find(shows) != std::string::npos) return r;
  throw std::runtime_error("no request shows " + shows);
}

double maxAbsDifference(const cv::Mat& a, const cv::Mat& b) {
  double worst = 0.0;
  cv::minMaxLoc(cv::abs(a - b), nullptr, &worst);
  return worst;
}

void expectSameCaptures(const CalibrationCaptures& got, const CalibrationCaptures& want) {
  ASSERT_EQ(got.stations.size(), want.stations.size());
  for (size_t i = 0; i < want.stations.size(); ++i) {
    EXPECT_EQ(got.stations[i].station, want.stations[i].station);
    EXPECT_EQ(got.stations[i].group, want.stations[i].group);
    ASSERT_EQ(got.stations[i].columnFrames.size(), want.stations[i].columnFrames.size());
    ASSERT_EQ(got.stations[i].rowFrames.size(), want.stations[i].rowFrames.size());
    for (size_t f = 0; f < want.stations[i].columnFrames.size(); ++f) {
      EXPECT_LT(maxAbsDifference(got.stations[i].columnFrames[f], want.stations[i].columnFrames[f]),
                1e-6)
          << "set " << i << " column frame " << f;
    }
    for (size_t f = 0; f < want.stations[i].rowFrames.size(); ++f) {
      EXPECT_LT(maxAbsDifference(got.stations[i].rowFrames[f], want.stations[i].rowFrames[f]), 1e-6)
          << "set " << i << " row frame " << f;
    }
  }
}

TEST(FolderCamera, LiveSessionNamesEachPictureAndOfflineReadsTheSame) {
  const SmallSession s = twoStationSession();
  const FilledFolder& filled = filledFolder();
  // Every frame asked for once, by a file name that sorts in order, all in the manifest.
  const PictureManifest manifest =
      loadPictureManifest((filled.dir / kPictureManifestName).string());
  ASSERT_EQ(static_cast<int>(manifest.pictures.size()), filled.asked);
  EXPECT_GT(filled.asked, 100);
  for (size_t i = 0; i < manifest.pictures.size(); ++i) {
    EXPECT_EQ(manifest.pictures[i].file,
              pictureFileName(static_cast<int>(i), manifest.pictures[i].shows));
    EXPECT_TRUE(fs::exists(filled.dir / manifest.pictures[i].file));
  }
  EXPECT_EQ(manifest.pictures[0].shows, "station 0, modules 0,3, column pattern 0");
  // Offline: nothing shown, nothing waited for, the same pictures.
  const fs::path dir = copyOf("offline");
  expectSameCaptures(offline(s, dir), filled.captures);
  // And live again on a full folder: every picture is there, none asked for.
  InProcessSimhw sim(modulesOf(s.truth),
                     std::make_unique<CalibrationPhysics>(s.truth, s.rig.truth));
  LinkClient link(std::make_unique<SocketTransport>(sim.path()));
  int asked = 0;
  FolderCameraOptions options;
  options.onRequest = [&](const PictureRequest&) { ++asked; };
  FolderCamera camera(dir.string(), options);
  expectSameCaptures(captureCalibration(link, camera, s.nominal, s.rig.metadata, {}),
                     filled.captures);
  EXPECT_EQ(asked, 0);
  fs::remove_all(dir);
}

TEST(FolderCamera, PicturesRenamedOutOfOrderArePutRightByTheManifest) {
  const SmallSession s = twoStationSession();
  const fs::path dir = copyOf("renamed");
  // A camera's own names, in reverse order of the frames: the manifest says which is which.
  PictureManifest manifest = loadPictureManifest((dir / kPictureManifestName).string());
  const int n = static_cast<int>(manifest.pictures.size());
  for (int i = 0; i < n; ++i) {
    ManifestPicture& p = manifest.pictures[static_cast<size_t>(i)];
    const std::string own = fmt::format("IMG_{:04d}.png", n - i);
    fs::rename(dir / p.file, dir / own);
    p.file = own;
  }
  savePictureManifest(manifest, (dir / kPictureManifestName).string());
  expectSameCaptures(offline(s, dir), filledFolder().captures);
  fs::remove_all(dir);
}

TEST(FolderCamera, PicturesSwappedAreNamedNotDecoded) {
  const SmallSession s = twoStationSession();
  const fs::path dir = copyOf("swapped");
  // Two coded pictures of the same set saved under each other's names.
  const fs::path a = requestShowing("modules 0,3, column pattern 4").path;
  const fs::path b = requestShowing("modules 0,3, column pattern 5").path;
  fs::rename(dir / a.filename(), dir / "tmp.png");
  fs::rename(dir / b.filename(), dir / a.filename());
  fs::rename(dir / "tmp.png", dir / b.filename());
  const std::string error = offlineError(s, dir);
  EXPECT_NE(error.find((dir / a.filename()).string() + " refused: a picture of another frame"),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("station 0, modules 0,3, column pattern 4"), std::string::npos) << error;
  EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  fs::remove_all(dir);
}

TEST(FolderCamera, AMissingPictureIsNamed) {
  const SmallSession s = twoStationSession();
  const fs::path dir = copyOf("missing");
  const fs::path gone = requestShowing("station 1, modules 1,4, row pattern 2").path;
  fs::remove(dir / gone.filename());
  const std::string error = offlineError(s, dir);
  EXPECT_NE(error.find("picture " + (dir / gone.filename()).string() +
                       " (of station 1, modules 1,4, row pattern 2) is missing"),
            std::string::npos)
      << error;
  fs::remove_all(dir);
}

TEST(FolderCamera, APictureOfTheWrongPatternIsRefused) {
  const SmallSession s = twoStationSession();
  for (const auto& [wanted, instead] :
       {std::pair{"modules 1,4, column pattern 6", "modules 1,4, column pattern 0"},  // a white
        std::pair{"modules 1,4, column pattern 1", "modules 1,4, column pattern 0"},  // for black
        std::pair{"modules 1,4, column pattern 0", "modules 0,3, column pattern 0"},  // other set
        std::pair{"modules 2,5, row pattern 3", "modules 1,4, row pattern 3"}}) {
    const fs::path dir = copyOf("wrong");
    const fs::path target = requestShowing(wanted).path;
    fs::copy_file(dir / fs::path(requestShowing(instead).path).filename(), dir / target.filename(),
                  fs::copy_options::overwrite_existing);
    const std::string error = offlineError(s, dir);
    EXPECT_NE(error.find("picture " + (dir / target.filename()).string() + " refused"),
              std::string::npos)
        << wanted << " as " << instead << ": " << error;
    EXPECT_NE(error.find(wanted), std::string::npos) << error;
    fs::remove_all(dir);
  }
}

TEST(FolderCamera, BlurredAndOverExposedPicturesAreNamed) {
  const SmallSession s = twoStationSession();
  // Blur is judged against the session's other pictures: a picture late in the session at once,
  // the first coded picture at the end (nothing to judge it against before).
  for (const char* shows : {"modules 0,3, row pattern 4", "modules 0,3, column pattern 2"}) {
    const fs::path dir = copyOf("blurred");
    const fs::path target = dir / fs::path(requestShowing(shows).path).filename();
    cv::Mat picture = cv::imread(target.string(), cv::IMREAD_UNCHANGED);
    cv::GaussianBlur(picture, picture, cv::Size(), 2.0);  // a camera that shook
    ASSERT_TRUE(cv::imwrite(target.string(), picture));
    const std::string error = offlineError(s, dir);
    EXPECT_NE(error.find(target.string() + " refused: blurred"), std::string::npos) << error;
    EXPECT_NE(error.find(shows), std::string::npos) << error;
    fs::remove_all(dir);
  }
  {
    const fs::path dir = copyOf("overexposed");
    const fs::path target =
        dir / fs::path(requestShowing("modules 1,4, column pattern 3").path).filename();
    // Six times the exposure: the recorded values (response gamma 2.2) 6^(1/2.2) = 2.26 times
    // as high, clipped at full scale, as the sensor would record them.
    cv::Mat picture = cv::imread(target.string(), cv::IMREAD_UNCHANGED);
    picture.convertTo(picture, CV_8U, std::pow(6.0, 1.0 / s.rig.metadata.responseGamma));
    ASSERT_TRUE(cv::imwrite(target.string(), picture));
    const std::string error = offlineError(s, dir);
    EXPECT_NE(error.find(target.string() + " refused: over-exposed"), std::string::npos) << error;
    fs::remove_all(dir);
  }
}

TEST(FolderCamera, AFolderOfAnotherSessionOrAHostileManifestIsRefused) {
  SmallSession s = twoStationSession();
  {
    const fs::path dir = copyOf("other");
    FolderCameraOptions options;
    options.waitForPictures = false;
    FolderCamera camera(dir.string(), options);
    CalibrationCaptureOptions one;
    one.stations = {1};
    try {
      captureCalibrationOffline(camera, s.nominal, s.rig.metadata, one);
      ADD_FAILURE() << "pictures of another session were used";
    } catch (const InputError& e) {
      EXPECT_EQ(e.location().field, "session.stations") << e.what();
    }
    fs::remove_all(dir);
  }
  const fs::path dir = freshFolder("hostile");
  fs::create_directories(dir);
  const nlohmann::json manifest{
      {"format", "parallax picture manifest"},
      {"version", 1},
      {"session", nlohmann::json::object()},
      {"pictures", {{{"file", "../../etc/passwd"}, {"shows", "station 0"}}}}};
  std::ofstream(dir / kPictureManifestName) << manifest.dump();
  try {
    FolderCamera camera(dir.string(), {});
    ADD_FAILURE() << "a manifest naming a file outside the folder was read";
  } catch (const InputError& e) {
    EXPECT_EQ(e.location().field, "pictures[0].file") << e.what();
  }
  fs::remove_all(dir);
}

TEST(FolderCamera, LiveItWaitsForThePictureThenGivesUpNamingIt) {
  const SmallSession s = twoStationSession();
  const fs::path dir = freshFolder("waiting");
  InProcessSimhw sim(modulesOf(s.truth),
                     std::make_unique<CalibrationPhysics>(s.truth, s.rig.truth));
  LinkClient link(std::make_unique<SocketTransport>(sim.path()));
  FolderCameraOptions options;
  options.pictureTimeoutS = 0.3;
  options.pollS = 0.02;
  std::string asked;
  options.onRequest = [&](const PictureRequest& r) { asked = r.path; };
  FolderCamera camera(dir.string(), options);
  try {
    captureCalibration(link, camera, s.nominal, s.rig.metadata, {});
    ADD_FAILURE() << "no picture was taken, yet the session went on";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("picture " + asked +
                                         " (of station 0, modules 0,3, "
                                         "column pattern 0) not taken within 0.3 s"),
              std::string::npos)
        << e.what();
  }
  sim.stop();
  EXPECT_EQ(sim.hardware().mode(), DisplayMode::kPlayback);
  fs::remove_all(dir);
}

TEST(CameraName, FolderNeedsADirectoryAndOnlyItWorksOffline) {
  EXPECT_TRUE(isCameraName("folder:/tmp/pictures"));
  EXPECT_FALSE(isCameraName("folder:"));
  try {
    parseCameraName("folder:", "--camera");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("needs the pictures' folder"), std::string::npos);
  }
  try {
    openCamera(parseCameraName("opencv:0", "--camera"), nullptr);
    ADD_FAILURE();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("it needs the link"), std::string::npos) << e.what();
  }
  try {
    openCamera(parseCameraName("folder:/nonexistent/pictures", "--camera"), nullptr);
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
}

// End to end: the calibration from the folder, offline, against the link path's on the same
// display (the same truth and camera; the simulator's sensor noise follows the pictures taken,
// and both sessions take one picture per frame, in the same order).
TEST(FolderCameraEndToEnd, CalibrationFromTheFolderMatchesTheLinkPath) {
  const SmallSession s = twoStationSession();
  CalibrationCaptures viaLink;
  {
    InProcessSimhw sim(modulesOf(s.truth),
                       std::make_unique<CalibrationPhysics>(s.truth, s.rig.truth));
    LinkClient link(std::make_unique<SocketTransport>(sim.path()));
    SimulatedCamera camera(link);
    viaLink = captureCalibration(link, camera, s.nominal, s.rig.metadata, {});
  }
  const fs::path dir = copyOf("end-to-end");
  const CalibrationCaptures viaFolder = offline(s, dir);
  const auto calibrate = [&](const CalibrationCaptures& captures) {
    CaptureDecoderOptions decoder;
    const CalibrationObservations obs = decodeCaptures(captures, s.nominal, decoder);
    FitOptions fit;
    const FitResult result = fitDisplay(s.nominal, obs, fit);
    return totalRayError(compareRays(s.truth, result.model));
  };
  const RayErrorStats link = calibrate(viaLink), folder = calibrate(viaFolder);
  std::printf("ray error: link %.4f px RMS (worst %.3f), folder %.4f px RMS (worst %.3f)\n",
              link.rmsPx, link.maxPx, folder.rmsPx, folder.maxPx);
  EXPECT_LT(link.rmsPx, 0.5);
  // The same pictures, so the same calibration (up to the solver threads' summation order).
  EXPECT_NEAR(folder.rmsPx, link.rmsPx, 0.01 * link.rmsPx + 0.001);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace parallax::hw
