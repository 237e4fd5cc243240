// Hostile display files: any bytes must give a model or an InputError, never a crash.
#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "calibration/display/display_model_json.h"
#include "common/input_error.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const nlohmann::json json = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded()) return 0;
  try {
    const parallax::DisplayModel model = parallax::displayModelFromJson(json);
    (void)parallax::displayModelToJson(model);
  } catch (const parallax::InputError&) {
  }
  return 0;
}
