// parallax camera board --out board.png|board.pdf [BOARD] [--dpi N]
// parallax camera calibrate --camera opencv:SPEC --out camera.json [BOARD] [--views N]
//                           [--max-pictures N]
//   BOARD: [--board checkerboard|charuco] [--squares 10x7] [--square-mm 25] [--marker-mm 18]
//          [--dictionary 4X4_50]
// The calibration camera's own intrinsics, for a real installation (issue 19): print the
// board at true scale, then show it to the camera from many sides. Every picture the camera
// delivers is searched for the board (calibration_board.h); a view is kept when the board
// stands somewhere new, and the terminal says at once what was found, how much of the picture
// the kept views cover and the RMS of a calibration with them so far. It ends after --views
// views (or when the source has no more pictures, or at Ctrl-C) with cv::calibrateCamera
// (k1, k2: our model, checkerboard_calibration.h) and writes the intrinsics into camera.json —
// the metadata file the display calibration reads; an existing one keeps its stations,
// fiducials and response.

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "calibration/camera/observations_json.h"
#include "calibration/capture/calibration_board.h"
#include "calibration/capture/checkerboard_calibration.h"
#include "calibration/display/json_file.h"
#include "common/atomic_file.h"
#include "common/input_error.h"
#include "common/width_height.h"
#include "daemon/cli/board_sheet_file.h"
#include "daemon/cli/command_line.h"
#include "daemon/cli/commands.h"
#include "hw/camera/camera.h"
#include "hw/camera/camera_name.h"

namespace parallax::cli {
namespace {

using nlohmann::json;

std::atomic<bool> gStopCapture{false};
static_assert(std::atomic<bool>::is_always_lock_free, "set from a signal handler");
extern "C" void onStopCapture(int) { gStopCapture.store(true); }

// Ctrl-C while the views are gathered ends the gathering, not the command: the views so far
// are calibrated and written.
class InterruptEndsCapture {
 public:
  InterruptEndsCapture() {
    gStopCapture = false;
    previous_ = std::signal(SIGINT, onStopCapture);
  }
  ~InterruptEndsCapture() { std::signal(SIGINT, previous_); }
  InterruptEndsCapture(const InterruptEndsCapture&) = delete;
  InterruptEndsCapture& operator=(const InterruptEndsCapture&) = delete;

 private:
  void (*previous_)(int);
};

// Views the intrinsics need (checkerboard_calibration.h's default).
const int kMinViews = CheckerboardCalibrationOptions{}.minPictures;

struct BoardArgs {
  std::string kind = "checkerboard";
  std::string squares = "10x7";
  CalibrationBoard board;

  CalibrationBoard resolve() const {
    CalibrationBoard b = board;
    if (!parseBoardKind(kind, &b.kind))
      throw InputError({"", "--board", 0},
                       fmt::format("\"{}\": give checkerboard or charuco", kind));
    const WidthHeight size = parseWidthHeight(squares, "--squares");
    b.squaresX = size.width;
    b.squaresY = size.height;
    b.validate("--");
    return b;
  }
};

void addBoardOptions(CLI::App* command, BoardArgs& args) {
  command->add_option("--board", args.kind, "checkerboard (all of it must be seen) or charuco")
      ->capture_default_str();
  command->add_option("--squares", args.squares, "squares along a row x down a column")
      ->capture_default_str();
  command->add_option("--square-mm", args.board.squareMm, "side of a square as printed (mm)")
      ->capture_default_str();
  command->add_option("--marker-mm", args.board.markerMm, "charuco: side of a marker (mm)")
      ->capture_default_str();
  command->add_option("--dictionary", args.board.dictionary, "charuco: ArUco dictionary (DICT_...)")
      ->capture_default_str();
}

// ---- parallax camera board ---------------------------------------------------------------

struct SheetArgs {
  BoardArgs board;
  std::string out;
  double dpi = 300.0;
};

void runBoard(const SheetArgs& args) {
  const CalibrationBoard board = args.board.resolve();
  writeBoardSheet(board, args.out, args.dpi);
  const BoardSheet sheet = boardSheet(board);
  std::cout << fmt::format(
      "{} written to {} (sheet {:g} x {:g} mm); print it at 100%, then "
      "measure a square: it must be {:g} mm, or give --square-mm as "
      "measured\n",
      board.describe(), std::filesystem::absolute(args.out).string(), sheet.widthMm, sheet.heightMm,
      board.squareMm);
}

// ---- parallax camera calibrate -----------------------------------------------------------

struct CalibrateCameraArgs {
  BoardArgs board;
  std::string camera;
  std::string out;
  int views = 15;
  int maxPictures = 0;  // 0: until --views views (a live camera) or the source ends
};

cv::Mat greyOf(const hw::Image& image) {
  const int type = image.format == hw::PixelFormat::kGray8 ? CV_8UC1 : CV_8UC3;
  const cv::Mat wrapped(image.height, image.width, type,
                        const_cast<std::uint8_t*>(image.pixels.data()));
  cv::Mat grey;
  if (type == CV_8UC1)
    grey = wrapped.clone();
  else
    cv::cvtColor(wrapped, grey, cv::COLOR_RGB2GRAY);
  return grey;
}

// Kept views of the board, their coverage of the picture and the calibration so far.
class ViewCollector {
 public:
  ViewCollector(int width, int height) : width_(width), height_(height) {}

  // A new view unless the board stands as a kept one stood: the corners both saw within 2% of
  // the picture's diagonal of each other on average (a camera and a board held still give the
  // same view at every frame, which adds nothing; a turn or a tilt moves the corners).
  int sameAs(const BoardView& view) const {
    const double diagonal = std::hypot(width_, height_);
    for (size_t k = 0; k < views_.size(); ++k) {
      const BoardView& kept = views_[k];
      double sum = 0.0;
      int shared = 0;
      for (size_t i = 0; i < view.board.size(); ++i) {
        for (size_t j = 0; j < kept.board.size(); ++j) {
          if ((view.board[i] - kept.board[j]).norm() < 1e-9) {
            sum += (view.pixels[i] - kept.pixels[j]).norm();
            ++shared;
            break;
          }
        }
      }
      if (shared >= 4 && sum / shared < 0.02 * diagonal) return static_cast<int>(k) + 1;
    }
    return 0;
  }
  void keep(BoardView view, const std::string& name) {
    for (const Eigen::Vector2d& q : view.pixels) {
      const int cx = std::clamp(static_cast<int>(q.x() / width_ * kCellsX), 0, kCellsX - 1);
      const int cy = std::clamp(static_cast<int>(q.y() / height_ * kCellsY), 0, kCellsY - 1);
      covered_[static_cast<size_t>(cy * kCellsX + cx)] = true;
    }
    views_.push_back(std::move(view));
    names_.push_back(name);
  }
  int views() const { return static_cast<int>(views_.size()); }
  // The share of an 8 x 6 grid over the picture that some kept corner falls in: the corners
  // (where distortion shows) must be seen too.
  double coverage() const {
    return static_cast<double>(std::count(covered_.begin(), covered_.end(), true)) /
           static_cast<double>(covered_.size());
  }
  CheckerboardCalibration calibrate() const {
    return calibrateFromViews(names_, views_, width_, height_);
  }

 private:
  static constexpr int kCellsX = 8, kCellsY = 6;
  int width_, height_;
  std::vector<BoardView> views_;
  std::vector<std::string> names_;
  std::array<bool, kCellsX * kCellsY> covered_{};
};

// camera.json with these intrinsics: an existing file keeps everything else (its stations,
// fiducials, response), but must describe pictures of this size.
void writeIntrinsics(const CheckerboardCalibration& calibration, const std::string& path) {
  const CameraIntrinsics& intrinsics = calibration.intrinsics;
  CalibrationObservations frame;
  frame.intrinsics = intrinsics;
  frame.intrinsicsCovariance = calibration.covariance;
  json j = cameraMetadataToJson(frame);
  if (std::filesystem::exists(path)) {
    json existing = readJsonFile(path);  // names the file and line when it is not JSON
    const json& in = existing.contains("intrinsics") ? existing["intrinsics"] : json::object();
    if (in.value("width", intrinsics.width) != intrinsics.width ||
        in.value("height", intrinsics.height) != intrinsics.height) {
      throw InputError(
          {path, "intrinsics", 0},
          fmt::format("describes {}x{} pictures, the camera gave {}x{}", in.value("width", 0),
                      in.value("height", 0), intrinsics.width, intrinsics.height));
    }
    existing["intrinsics"] = j["intrinsics"];
    j = std::move(existing);
  }
  writeFileAtomically(path, j.dump(2) + "\n");
}

void runCalibrateCamera(const CalibrateCameraArgs& args) {
  const CalibrationBoard board = args.board.resolve();
  if (args.views < kMinViews || args.views > 200) {
    throw InputError({"", "--views", 0},
                     fmt::format("must be {}..200, got {}", kMinViews, args.views));
  }
  if (args.maxPictures < 0) throw InputError({"", "--max-pictures", 0}, "must be >= 0");
  const hw::CameraName name = hw::parseCameraName(args.camera, "--camera");
  if (name.kind != hw::CameraKind::kOpenCv) {
    throw InputError({"", "--camera", 0},
                     "the camera behind the link is the simulator's, whose intrinsics are known: "
                     "give opencv:SPEC (a webcam, a GStreamer pipeline, gphoto2, or pictures "
                     "such as opencv:boards/board_%02d.png)");
  }
  hw::OpenCvCamera camera;
  std::string error;
  if (!camera.open(name.argument, &error)) throw std::runtime_error(error);

  std::optional<InterruptEndsCapture> interrupt(std::in_place);
  const bool live = isatty(STDERR_FILENO) != 0;
  const auto say = [&](const std::string& line, bool final) {
    if (quiet()) return;
    if (live)
      std::fprintf(stderr, "\r%-100s%s", line.c_str(), final ? "\n" : "");
    else if (final)
      std::fprintf(stderr, "%s\n", line.c_str());
    std::fflush(stderr);
  };
  if (!quiet()) {
    std::cerr << fmt::format(
        "show the {} to {} from many sides: near the picture's corners and edges, tilted up to "
        "45°; {} views are kept (Ctrl-C ends with the views so far)\n",
        board.describe(), camera.name(), args.views);
  }
  std::optional<ViewCollector> views;
  std::string rms = "-";
  int pictures = 0, found = 0;
  while (!gStopCapture && (args.maxPictures == 0 || pictures < args.maxPictures) &&
         (!views || views->views() < args.views)) {
    const hw::Image image = camera.capture(&error);
    if (image.empty()) {
      if (pictures == 0) throw std::runtime_error(error);
      break;  // a file or a sequence that has ended
    }
    ++pictures;
    const cv::Mat grey = greyOf(image);
    if (!views) views.emplace(grey.cols, grey.rows);
    const std::string pictureName = fmt::format("picture {}", pictures);
    const std::optional<BoardView> view = detectBoard(grey, board);
    std::string what;
    bool kept = false;  // a line of its own (a log keeps only these): every picture with the board
    if (!view) {
      what = "no board";
    } else if (const int same = views->sameAs(*view); same > 0) {
      ++found;
      what =
          fmt::format("{} corners, where view {} was: move the board", view->pixels.size(), same);
      kept = true;
    } else {
      ++found;
      what = fmt::format("{} corners, kept as view {}", view->pixels.size(), views->views() + 1);
      views->keep(*view, pictureName);
      kept = true;
      if (views->views() >= kMinViews) {
        try {
          rms = fmt::format("{:.3f} px", views->calibrate().rmsPx);
        } catch (const InputError& e) {
          rms = "none (" + std::string(e.what()) + ")";
        }
      }
    }
    say(fmt::format("{}: {}; {} of {} views, coverage {:.0f}%, RMS {}", pictureName, what,
                    views->views(), args.views, 100.0 * views->coverage(), rms),
        kept);
  }
  interrupt.reset();
  if (live && !quiet()) std::fprintf(stderr, "\n");  // past the last status line
  if (!views || views->views() < kMinViews) {
    throw std::runtime_error(fmt::format(
        "{} pictures, the board found in {}, {} different views: the intrinsics need at least "
        "{} (and {} are asked for); {} not written",
        pictures, found, views ? views->views() : 0, kMinViews, args.views, args.out));
  }
  const CheckerboardCalibration result = views->calibrate();
  std::cout << fmt::format("{} pictures, the board found in {}, {} views kept, coverage {:.0f}%\n",
                           pictures, found, views->views(), 100.0 * views->coverage());
  std::cout << formatCheckerboardCalibration(result);
  writeIntrinsics(result, args.out);
  std::cout << fmt::format("camera intrinsics written to {}\n",
                           std::filesystem::absolute(args.out).string());
}

}  // namespace

void addCameraCommand(CLI::App& app) {
  CLI::App* camera =
      app.add_subcommand("camera", "the calibration camera's own intrinsics: a board, then views");
  camera->require_subcommand(1);

  auto sheet = std::make_shared<SheetArgs>();
  CLI::App* board =
      camera->add_subcommand("board", "write a printable calibration board at true scale");
  addBoardOptions(board, sheet->board);
  board->add_option("--out", sheet->out, "board.png or board.pdf")->required();
  board->add_option("--dpi", sheet->dpi, "PNG: dots per inch (stored in the file)")
      ->capture_default_str();
  board->callback([sheet] { runBoard(*sheet); });

  auto args = std::make_shared<CalibrateCameraArgs>();
  CLI::App* calibrate = camera->add_subcommand(
      "calibrate", "the camera's intrinsics from views of the board, written into camera.json");
  addBoardOptions(calibrate, args->board);
  calibrate
      ->add_option("--camera", args->camera,
                   "opencv:SPEC: /dev/video0 or an index, a GStreamer pipeline ending in appsink, "
                   "gphoto2, a stream URL, or a picture sequence (opencv:dir/board_%02d.png)")
      ->required();
  calibrate
      ->add_option("--out", args->out,
                   "camera.json to write (an existing one keeps its stations and fiducials)")
      ->required();
  calibrate->add_option("--views", args->views, "different views of the board to keep")
      ->capture_default_str();
  calibrate->add_option("--max-pictures", args->maxPictures,
                        "stop after this many pictures (default: when the views are kept)");
  calibrate->callback([args] { runCalibrateCamera(*args); });
}

}  // namespace parallax::cli
