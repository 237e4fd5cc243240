#include "daemon/parallaxd/output_file.h"

#include <fmt/format.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <vector>

#include "common/input_error.h"

namespace parallax::daemon {

void writeOutputFile(const std::string& path, std::string_view field,
                     const std::function<void(const std::string&)>& write) {
  namespace fs = std::filesystem;
  const auto refuse = [&](const std::string& why) {
    throw InputError({"", std::string(field), 0}, fmt::format("{}: {}", path, why));
  };
  if (path.empty() || path.front() != '/') refuse("must be an absolute path");
  const fs::path target(path);
  if (!target.has_filename() || target.filename() == "." || target.filename() == "..")
    refuse("names a folder, not a file");
  const std::string folder = target.parent_path().string();
  struct stat st {};
  if (::stat(folder.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
    refuse(fmt::format("the folder {} does not exist (the daemon does not create it)", folder));
  if (::lstat(path.c_str(), &st) == 0) {
    if (S_ISLNK(st.st_mode)) refuse("is a symbolic link (not followed)");
    if (!S_ISREG(st.st_mode)) refuse("exists and is not a regular file");
  } else if (errno != ENOENT) {
    refuse(std::strerror(errno));
  }

  // mkstemps: O_CREAT|O_EXCL, so the temporary file is new and ours, never a link's target.
  const std::string extension = target.extension().string();
  std::string pattern = folder + "/." + target.stem().string() + ".XXXXXX" + extension;
  std::vector<char> name(pattern.begin(), pattern.end());
  name.push_back('\0');
  const int fd = ::mkstemps(name.data(), static_cast<int>(extension.size()));
  if (fd < 0) refuse(fmt::format("cannot create a file in {}: {}", folder, std::strerror(errno)));
  ::fchmod(fd, 0644);
  ::close(fd);
  const std::string temporary(name.data());
  try {
    write(temporary);
  } catch (...) {
    ::unlink(temporary.c_str());
    throw;
  }
  if (::rename(temporary.c_str(), path.c_str()) != 0) {
    const std::string why = std::strerror(errno);
    ::unlink(temporary.c_str());
    throw std::runtime_error(fmt::format("{}: cannot write: {}", path, why));
  }
}

}  // namespace parallax::daemon
