#include "tracer/ply_header_check.h"

#include <fmt/format.h>

#include <cstdlib>
#include <sstream>
#include <vector>

#include "common/input_error.h"

namespace parallax {
namespace {

// Bytes of one binary value of a PLY type; 0 for an unknown type.
int typeSize(const std::string& type) {
  if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
  if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
  if (type == "int" || type == "uint" || type == "int32" || type == "uint32" || type == "float" ||
      type == "float32")
    return 4;
  if (type == "double" || type == "float64") return 8;
  return 0;
}

struct Element {
  std::string name;
  double count = 0;
  double minBytes = 0;  // of one element: its values, a list's count but none of its entries
};

}  // namespace

void requirePlyCountsFit(const std::string& path, std::string_view bytes, double fileSize) {
  if (bytes.substr(0, 4) != "ply\n" && bytes.substr(0, 5) != "ply\r\n") return;
  const size_t end = bytes.find("end_header");
  if (end == std::string_view::npos) return;  // assimp says what is wrong with it
  const size_t body = bytes.find('\n', end);
  if (body == std::string_view::npos) return;
  const double available = fileSize - static_cast<double>(body + 1);
  std::istringstream header{std::string(bytes.substr(0, end))};
  bool ascii = true;
  std::vector<Element> elements;
  std::string line;
  while (std::getline(header, line)) {
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "format") {
      std::string format;
      words >> format;
      ascii = format == "ascii";
    } else if (keyword == "element") {
      Element e;
      std::string count;
      words >> e.name >> count;
      e.count = std::strtod(count.c_str(), nullptr);
      elements.push_back(e);
    } else if (keyword == "property" && !elements.empty()) {
      std::string type;
      words >> type;
      if (type == "list") words >> type;  // the count's type; the entries may be none
      const int size = typeSize(type);
      elements.back().minBytes += ascii ? 2 : size;
    }
  }
  // The last ASCII value may end the file without its newline.
  const double slack = ascii ? 1.0 : 0.0;
  double needed = 0;
  for (const Element& e : elements) {
    needed += e.count * e.minBytes;
    if (needed > available + slack) {
      throw InputError(
          {path, "element " + e.name, 0},
          fmt::format("the PLY header promises {:.0f} of them, at least {:.0f} bytes with the "
                      "elements before, and the file has {:.0f} after its header",
                      e.count, needed, available));
    }
  }
}

}  // namespace parallax
