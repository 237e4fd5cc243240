// Hostile capture files (camera.json, decoded.json): any bytes must give observations or an
// InputError, never a crash; whatever parses must survive a round trip.
#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "calibration/camera/observations_json.h"
#include "common/input_error.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const nlohmann::json json = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded()) return 0;
  parallax::CalibrationObservations observations;
  try {
    parallax::cameraMetadataFromJson(json, &observations);
    (void)parallax::cameraMetadataToJson(observations);
  } catch (const parallax::InputError&) {
  }
  try {
    parallax::decodedFromJson(json, &observations);
    (void)parallax::decodedToJson(observations);
  } catch (const parallax::InputError&) {
  }
  return 0;
}
