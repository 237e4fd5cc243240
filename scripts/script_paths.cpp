#include "scripts/script_paths.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace parallax {
namespace fs = std::filesystem;

namespace {

// True when `inner` is `outer` or lies below it (both canonical).
bool isBelow(const fs::path& outer, const fs::path& inner) {
  auto o = outer.begin();
  auto i = inner.begin();
  for (; o != outer.end(); ++o, ++i) {
    if (i == inner.end() || *o != *i) return false;
  }
  return true;
}

}  // namespace

std::string resolvePathBelow(const std::string& folder, const std::string& relative) {
  if (relative.empty()) throw std::runtime_error("empty path");
  if (relative.find('\0') != std::string::npos)
    throw std::runtime_error("path contains a NUL byte");
  const fs::path rel(relative);
  // Refused on sight, before touching the file system: the script names files relative to
  // its own folder, and ".." has no use there but to climb out.
  if (rel.is_absolute() || rel.has_root_name() || rel.has_root_directory()) {
    throw std::runtime_error(
        "\"" + relative + "\": absolute paths are not allowed (name files relative to the script)");
  }
  for (const fs::path& part : rel) {
    if (part == "..")
      throw std::runtime_error("\"" + relative + "\": \"..\" is not allowed in a script's paths");
  }
  std::error_code ec;
  const fs::path root = fs::canonical(folder, ec);
  if (ec)
    throw std::runtime_error("the script's folder \"" + folder +
                             "\" cannot be resolved: " + ec.message());
  // canonical() follows every symlink, so a link inside the folder that points outside it is
  // caught here.
  const fs::path target = fs::canonical(root / rel, ec);
  if (ec) throw std::runtime_error("\"" + relative + "\": " + ec.message());
  if (!isBelow(root, target)) {
    throw std::runtime_error("\"" + relative +
                             "\" leads outside the script's folder (through a symlink)");
  }
  if (!fs::is_regular_file(target, ec))
    throw std::runtime_error("\"" + relative + "\" is not a regular file");
  return target.string();
}

std::string readSmallFile(const std::string& path, std::uintmax_t maxBytes) {
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) throw std::runtime_error("cannot read \"" + path + "\": " + ec.message());
  if (size > maxBytes) {
    throw std::runtime_error("\"" + path + "\" is " + std::to_string(size) +
                             " bytes, more than the " + std::to_string(maxBytes) +
                             " allowed for a script");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open \"" + path + "\"");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace parallax
