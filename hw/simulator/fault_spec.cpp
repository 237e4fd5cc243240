#include "hw/simulator/fault_spec.h"

#include <fmt/format.h>

#include <charconv>
#include <vector>

#include "common/input_error.h"

namespace parallax::hw {
namespace {

uint32_t parseNumber(const std::string& text, const std::string& part, const char* what) {
  uint32_t value = 0;
  const auto [end, ec] = std::from_chars(part.data(), part.data() + part.size(), value);
  if (ec != std::errc() || end != part.data() + part.size() || part.empty()) {
    throw InputError(
        {"", "--fault", 0},
        fmt::format("\"{}\": {} must be a non-negative integer, got \"{}\"", text, what, part));
  }
  return value;
}

}  // namespace

FaultSpec parseFaultSpec(const std::string& text) {
  std::vector<std::string> parts;
  size_t start = 0;
  while (true) {
    const size_t colon = text.find(':', start);
    parts.push_back(text.substr(start, colon - start));
    if (colon == std::string::npos) break;
    start = colon + 1;
  }
  if (parts.size() < 2 || parts.size() > 4) {
    throw InputError({"", "--fault", 0},
                     fmt::format("\"{}\": expected MODULE:KIND[:COUNT[:PARAM]]", text));
  }
  FaultSpec spec;
  spec.module = static_cast<int>(parseNumber(text, parts[0], "MODULE"));
  bool known = false;
  for (uint8_t k = 1; k <= kMaxFaultKind; ++k) {
    if (faultKindName(static_cast<FaultKind>(k)) == parts[1]) {
      spec.fault.kind = static_cast<FaultKind>(k);
      known = true;
    }
  }
  if (!known) {
    throw InputError({"", "--fault", 0},
                     fmt::format("\"{}\": unknown fault \"{}\" (drop, flip, stall, slow, "
                                 "disconnect, crash)",
                                 text, parts[1]));
  }
  spec.fault.count = parts.size() > 2 ? parseNumber(text, parts[2], "COUNT") : 1;
  spec.fault.param = parts.size() > 3 ? parseNumber(text, parts[3], "PARAM") : 0;
  if (spec.fault.kind == FaultKind::kSlowLink && spec.fault.param == 0) {
    spec.fault.param = 1000;  // "slow" alone: 1 ms per chunk
  }
  return spec;
}

}  // namespace parallax::hw
