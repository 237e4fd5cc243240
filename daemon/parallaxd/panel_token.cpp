#include "daemon/parallaxd/panel_token.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include "common/atomic_file.h"

namespace parallax::daemon {
namespace {

bool wellFormed(const std::string& token) {
  return token.size() == kPanelTokenHexChars &&
         token.find_first_not_of("0123456789abcdef") == std::string::npos;
}

// The file's token when it is a regular file of ours that nobody else may read; else "" and
// why in `problem`.
std::string readTrustedToken(const std::string& path, std::string* problem) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) {
    *problem = errno == ENOENT ? "" : fmt::format("cannot be read: {}", std::strerror(errno));
    return "";
  }
  struct stat st {};
  std::string token;
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    *problem = "is not a regular file";
  } else if (st.st_uid != ::geteuid()) {
    *problem = fmt::format("belongs to uid {}, not to the daemon's user", st.st_uid);
  } else if ((st.st_mode & 077) != 0) {
    *problem = fmt::format("is readable by others (mode {:o})", st.st_mode & 0777);
  } else {
    char text[kPanelTokenHexChars + 2] = {};
    const ssize_t n = ::read(fd, text, sizeof text);
    token.assign(text, n > 0 ? static_cast<size_t>(n) : 0);
    while (!token.empty() && (token.back() == '\n' || token.back() == '\r')) token.pop_back();
    if (!wellFormed(token)) {
      *problem = "does not hold a token";
      token.clear();
    }
  }
  ::close(fd);
  return token;
}

}  // namespace

std::string newPanelToken() {
  unsigned char bytes[kPanelTokenHexChars / 2];
  size_t filled = 0;
  while (filled < sizeof bytes) {
    const ssize_t n = ::getrandom(bytes + filled, sizeof bytes - filled, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw std::runtime_error(std::string("getrandom: ") + std::strerror(errno));
    filled += static_cast<size_t>(n);
  }
  std::string token;
  for (unsigned char b : bytes) token += fmt::format("{:02x}", b);
  return token;
}

bool tokensEqual(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  unsigned char diff = 0;
  for (size_t i = 0; i < a.size(); ++i)
    diff |= static_cast<unsigned char>(a[i]) ^ static_cast<unsigned char>(b[i]);
  return diff == 0;
}

std::string loadOrCreatePanelToken(const std::string& folder) {
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  const std::string path = (std::filesystem::path(folder) / "panel.token").string();
  std::string problem;
  if (std::string token = readTrustedToken(path, &problem); !token.empty()) return token;
  if (!problem.empty()) spdlog::warn("panel: {} {}: replaced by a new token", path, problem);
  std::string token = newPanelToken();
  try {
    // A symlink or a foreign file at the path is replaced by the rename, never written through.
    writeFileAtomically(path, token + "\n", 0600);
  } catch (const std::exception& e) {
    throw std::runtime_error(fmt::format("the panel's token: {}", e.what()));
  }
  return token;
}

}  // namespace parallax::daemon
