#pragma once
// Bad user input (files, scripts, configs, packets) is reported with an InputError that names
// where it came from: the file, the field path inside it and, when known, the line. It is
// raised at the boundary and caught by whoever serves the request (STYLE.md, habit 4).

#include <stdexcept>
#include <string>
#include <utility>

namespace parallax {

struct InputLocation {
  std::string file;   // empty when the input did not come from a file
  std::string field;  // e.g. "modules[3].orientation"; empty for file-level errors
  int line = 0;       // 1-based; 0 when unknown

  std::string describe() const {
    std::string where = file;
    if (line > 0) where += (where.empty() ? "line " : ":") + std::to_string(line);
    if (!field.empty()) where += (where.empty() ? "" : ": ") + field;
    return where;
  }
};

class InputError : public std::runtime_error {
 public:
  InputError(InputLocation location, const std::string& reason)
      : std::runtime_error(compose(location, reason)),
        location_(std::move(location)),
        reason_(reason) {}

  const InputLocation& location() const { return location_; }
  const std::string& reason() const { return reason_; }

  // The same error seen from one level up: used when a loader learns the file name only after
  // a nested parser has already named the field.
  InputError inFile(const std::string& file) const {
    InputLocation loc = location_;
    loc.file = file;
    return InputError(loc, reason_);
  }

 private:
  static std::string compose(const InputLocation& loc, const std::string& reason) {
    const std::string where = loc.describe();
    return where.empty() ? reason : where + ": " + reason;
  }

  InputLocation location_;
  std::string reason_;
};

}  // namespace parallax
