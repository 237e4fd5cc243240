#pragma once
// A video of what a viewer sees while walking the observer line (`parallax view --sweep`),
// written through OpenCV's VideoWriter (FFmpeg on Debian). The container follows the file's
// extension: .mp4 (H.264, else MPEG-4 part 2 when this FFmpeg has no H.264 encoder), .avi
// (Motion JPEG), .mkv (H.264, else MPEG-4).

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "tracer/frame.h"

namespace cv {
class VideoWriter;
}

namespace parallax::cli {

class SweepVideo {
 public:
  // Throws InputError naming `option` when the extension is unknown or no codec opens.
  SweepVideo(const std::string& path, int width, int height, double fps,
             const std::string& option = "--out");
  ~SweepVideo();
  SweepVideo(const SweepVideo&) = delete;
  SweepVideo& operator=(const SweepVideo&) = delete;

  // One frame, linear RGB of the video's size, encoded as sRGB (what a screen shows).
  void add(const Frame& frame);
  // Finishes the file (also done by the destructor).
  void close();
  const std::string& codec() const { return codec_; }
  int frames() const { return frames_; }

 private:
  std::unique_ptr<cv::VideoWriter> writer_;
  std::string path_, codec_;
  int width_ = 0, height_ = 0, frames_ = 0;
};

// X0:X1 → the two numbers; throws InputError naming `option`.
std::pair<double, double> parseRange(const std::string& text, const std::string& option);

// A frame sequence (`parallax render --time A:B`): frame f's module frames in
// `folder`/frame_NNNN/.
std::string sequenceFrameFolder(const std::string& folder, int frame);
// The sequence's frame folders in order (frame_0000, frame_0001, ... while they exist); empty
// when `folder` holds no sequence.
std::vector<std::string> sequenceFrameFolders(const std::string& folder);

}  // namespace parallax::cli
