#pragma once
// Ray textures as files a person can open: per module three EXRs written through OpenImageIO,
//   module_NNN_origins.exr     RGB float: o (m, physical)
//   module_NNN_directions.exr  RGB float: unit primary-ray direction
//   module_NNN_mask.exr        Y float:  1 valid, 0 masked
// Masked pixels hold 0 in origins and directions.

#include <string>

#include "calibration/display/ray_textures.h"

namespace parallax {

struct RayTextureFileNames {
  std::string origins, directions, mask;
};

RayTextureFileNames rayTextureFileNames(const std::string& directory, int moduleId);

// Throws InputError naming the file when it cannot be written.
void writeRayTextureFiles(const RayTextures& textures, const std::string& directory, int moduleId);

}  // namespace parallax
