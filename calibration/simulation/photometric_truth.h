#pragma once
// The simulator's photometric ground truth: how each module turns the 8-bit codes it is sent
// into light, seeded like the geometric truth (ground_truth.h). Per module and channel a
// response curve (code/255)^γ with γ in 1.8–2.6, a gain, a black level; a 3×3 mixing of the
// channels (primaries that differ from module to module); a smooth spatial falloff over the
// module image (vignetting, 10–30% at the farthest corner); and one or two weak or tinted
// modules. Off unless asked for: the default simulator's modules are ideal sRGB emitters.
//
// Light is linear RGB with sRGB primaries, white (1, 1, 1) being an ideal module's full white.
// Module m's light at pixel (u, v) for codes k (each 0..255):
//
//   light = falloff(u, v) · (primaries · (k/255)^γ + black)
//
// with primaries' columns each channel's light at full drive (gain and mixing together).
//
// JSON (photometric_truth.json, beside ground_truth.json; only the simulator and tests open it):
//   {"format": "parallax-photometric-truth", "version": 1, "seed": S,
//    "modules": [{"gamma": [3], "primaries": [9, row-major], "black": [3],
//                 "vignetting": v, "vignetting_centre": [x, y]}]}

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace parallax {

struct ModulePhotometricTruth {
  Eigen::Vector3d gamma{2.2, 2.2, 2.2};
  Eigen::Matrix3d primaries = Eigen::Matrix3d::Identity();
  Eigen::Vector3d black = Eigen::Vector3d::Zero();
  double vignetting = 0.0;  // the falloff at the farthest image corner from the centre below
  // The falloff's centre in the image, in units of the half width / half height from the
  // image centre (0, 0).
  Eigen::Vector2d vignettingCentre = Eigen::Vector2d::Zero();

  // 1 at the centre, 1 − vignetting at the farthest corner, quadratic in between.
  double falloff(double u, double v, int width, int height) const;
  // Light of codes k (0..255 each) at pixel position (u, v) (centres at +0.5).
  Eigen::Vector3d light(const Eigen::Vector3d& codes, double u, double v, int width,
                        int height) const;
  // A dead module: no light at all, whatever it is sent.
  bool dead() const { return primaries.isZero() && black.isZero(); }
};

struct PhotometricTruth {
  std::uint64_t seed = 1;
  std::vector<ModulePhotometricTruth> modules;

  // The light a module shows for an 8-bit RGB frame (width × height × 3 bytes, row-major):
  // CV_32FC3 in R, G, B order. Throws std::invalid_argument for a wrong byte count.
  cv::Mat emittedLight(int module, int width, int height, const std::uint8_t* rgb) const;
};

struct PhotometricTruthOptions {
  std::uint64_t seed = 1;
  double gammaMin = 1.8, gammaMax = 2.6;
  double gainSigma = 0.05;                    // per channel, relative
  double mixingMax = 0.08;                    // each off-diagonal, uniform in [0, max]
  double blackMin = 0.002, blackMax = 0.008;  // of full white, per channel
  double vignettingMin = 0.10, vignettingMax = 0.30;
  int weakModules = 1;    // overall gain 0.6–0.7
  int tintedModules = 1;  // one channel at 0.6–0.7

  // Throws InputError naming the option.
  void validate() const;
};

PhotometricTruth makePhotometricTruth(int moduleCount, const PhotometricTruthOptions& options);

void savePhotometricTruth(const PhotometricTruth& truth, const std::string& path);
// Throws InputError naming the file and the field.
PhotometricTruth loadPhotometricTruth(const std::string& path);

}  // namespace parallax
