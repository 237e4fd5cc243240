#pragma once
// Small glTF 2.0 files written by the tests (one JSON file, its buffer inline as base64):
// animated fixtures whose poses are known exactly, and hostile variants of them (NaN keys,
// keys going back in time, nodes and vertices that do not exist, counts past the buffer).

#include <cstdint>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace parallax::test {

class GltfFixture {
 public:
  // Appends the values as one accessor (componentType 5126 float, or 5121 unsigned byte) and
  // returns its index. `type` is "SCALAR", "VEC3", "VEC4" or "MAT4".
  int floats(const std::vector<float>& values, const std::string& type, bool minMax = false) {
    const int components = componentsOf(type);
    align();
    const size_t offset = bytes_.size();
    bytes_.resize(offset + values.size() * sizeof(float));
    std::memcpy(bytes_.data() + offset, values.data(), values.size() * sizeof(float));
    nlohmann::json accessor = view(offset, values.size() * sizeof(float));
    accessor["componentType"] = 5126;
    accessor["count"] = values.size() / static_cast<size_t>(components);
    accessor["type"] = type;
    if (minMax) {  // required for POSITION
      std::vector<float> lo(static_cast<size_t>(components), 1e30f), hi(lo.size(), -1e30f);
      for (size_t i = 0; i < values.size(); ++i) {
        lo[i % lo.size()] = std::min(lo[i % lo.size()], values[i]);
        hi[i % hi.size()] = std::max(hi[i % hi.size()], values[i]);
      }
      accessor["min"] = lo;
      accessor["max"] = hi;
    }
    json["accessors"].push_back(accessor);
    return static_cast<int>(json["accessors"].size() - 1);
  }
  int bytes(const std::vector<std::uint8_t>& values, const std::string& type) {
    align();
    const size_t offset = bytes_.size();
    bytes_.insert(bytes_.end(), values.begin(), values.end());
    nlohmann::json accessor = view(offset, values.size());
    accessor["componentType"] = 5121;
    accessor["count"] = values.size() / static_cast<size_t>(componentsOf(type));
    accessor["type"] = type;
    json["accessors"].push_back(accessor);
    return static_cast<int>(json["accessors"].size() - 1);
  }

  // The file, with the buffer appended as a data URI.
  void write(const std::string& path) {
    nlohmann::json out = json;
    out["asset"] = {{"version", "2.0"}};
    out["buffers"] = nlohmann::json::array(
        {{{"byteLength", bytes_.size()},
          {"uri", "data:application/octet-stream;base64," + base64(bytes_)}}});
    std::ofstream(path) << out.dump(1);
  }

  nlohmann::json json = nlohmann::json::object();

 private:
  static int componentsOf(const std::string& type) {
    return type == "SCALAR" ? 1 : type == "VEC2" ? 2 : type == "VEC3" ? 3 : type == "VEC4" ? 4 : 16;
  }
  void align() {
    while (bytes_.size() % 4 != 0) bytes_.push_back(0);
  }
  nlohmann::json view(size_t offset, size_t length) {
    json["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", length}});
    return {{"bufferView", json["bufferViews"].size() - 1}};
  }
  static std::string base64(const std::vector<std::uint8_t>& data) {
    static const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    for (size_t i = 0; i < data.size(); i += 3) {
      const std::uint32_t n = (std::uint32_t{data[i]} << 16) |
                              (i + 1 < data.size() ? std::uint32_t{data[i + 1]} << 8 : 0) |
                              (i + 2 < data.size() ? std::uint32_t{data[i + 2]} : 0);
      out += table[(n >> 18) & 63];
      out += table[(n >> 12) & 63];
      out += i + 1 < data.size() ? table[(n >> 6) & 63] : '=';
      out += i + 2 < data.size() ? table[n & 63] : '=';
    }
    return out;
  }
  std::vector<std::uint8_t> bytes_;
};

}  // namespace parallax::test
