#include "common/private_folder.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <pwd.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace parallax {
namespace {

std::string ownerName(uid_t uid) {
  passwd entry{};
  passwd* found = nullptr;
  char buffer[1024];
  if (::getpwuid_r(uid, &entry, buffer, sizeof buffer, &found) == 0 && found)
    return fmt::format("{} (uid {})", found->pw_name, uid);
  return fmt::format("uid {}", uid);
}

[[noreturn]] void refuse(const std::string& path, const std::string& why) {
  throw std::runtime_error(fmt::format("{}: {}; refusing to use it", path, why));
}

// The folder opened without following a final symlink, and its status.
int openFolder(const std::string& folder, struct stat* st) {
  const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) {
    const int e = errno;
    struct stat link {};
    if (::lstat(folder.c_str(), &link) == 0 && S_ISLNK(link.st_mode))
      refuse(folder, "is a symlink, not a folder");
    if (e == ENOTDIR) refuse(folder, "is not a folder");
    throw std::runtime_error(fmt::format("{}: cannot open: {}", folder, std::strerror(e)));
  }
  if (::fstat(fd, st) != 0) {
    const int e = errno;
    ::close(fd);
    throw std::runtime_error(fmt::format("{}: {}", folder, std::strerror(e)));
  }
  return fd;
}

std::string socketFolderOf(const std::string& socketPath) {
  const std::string folder = std::filesystem::path(socketPath).parent_path().string();
  return folder.empty() ? "." : folder;
}

}  // namespace

void makePrivateFolder(const std::string& folder) {
  const std::filesystem::path parent = std::filesystem::path(folder).parent_path();
  if (!parent.empty() && !std::filesystem::exists(parent)) {
    // Our own parents (a configured /run/... or cache path): made 0700 like the folder.
    std::error_code ec;
    std::filesystem::create_directories(parent, ec);
    if (ec)
      throw std::runtime_error(fmt::format("cannot create {}: {}", parent.string(), ec.message()));
  }
  if (::mkdir(folder.c_str(), 0700) != 0 && errno != EEXIST)
    throw std::runtime_error(fmt::format("cannot create {}: {}", folder, std::strerror(errno)));
  struct stat st {};
  const int fd = openFolder(folder, &st);
  if (st.st_uid != ::geteuid()) {
    ::close(fd);
    refuse(folder,
           fmt::format("is owned by {}, not by {}", ownerName(st.st_uid), ownerName(::geteuid())));
  }
  if ((st.st_mode & 07777) != 0700) {
    spdlog::warn("{} had mode {:04o}; narrowing it to 0700", folder, st.st_mode & 07777);
    if (::fchmod(fd, 0700) != 0) {
      const int e = errno;
      ::close(fd);
      throw std::runtime_error(fmt::format("cannot chmod {}: {}", folder, std::strerror(e)));
    }
  }
  ::close(fd);
}

bool socketPathInUse(const std::string& socketPath) {
  struct stat st {};
  if (::lstat(socketPath.c_str(), &st) != 0) {
    if (errno == ENOENT) return false;
    throw std::runtime_error(fmt::format("{}: {}", socketPath, std::strerror(errno)));
  }
  if (S_ISLNK(st.st_mode)) refuse(socketPath, "is a symlink, not a socket");
  if (!S_ISSOCK(st.st_mode)) refuse(socketPath, "exists and is not a socket");
  if (st.st_uid != ::geteuid())
    refuse(socketPath, fmt::format("is a socket owned by {}", ownerName(st.st_uid)));
  return true;
}

void checkSocketToConnect(const std::string& socketPath) {
  const uid_t me = ::geteuid();
  auto trusted = [me](uid_t owner) { return owner == me || owner == 0; };
  const std::string folder = socketFolderOf(socketPath);
  struct stat st {};
  if (::lstat(folder.c_str(), &st) != 0 && errno == ENOENT) return;  // connect() says "no daemon"
  const int fd = openFolder(folder, &st);
  ::close(fd);
  if (!trusted(st.st_uid))
    refuse(folder, fmt::format("is owned by {}, not by {}", ownerName(st.st_uid), ownerName(me)));
  // Sticky shared folders (/tmp) are fine only for root-owned ones: nobody else can swap a file.
  const bool sharedSticky = st.st_uid == 0 && (st.st_mode & S_ISVTX);
  if ((st.st_mode & (S_IWGRP | S_IWOTH)) && !sharedSticky)
    refuse(folder, fmt::format("is writable by other users (mode {:04o})", st.st_mode & 07777));
  struct stat sock {};
  if (::lstat(socketPath.c_str(), &sock) != 0) return;  // nothing there: connect() says so
  if (S_ISLNK(sock.st_mode)) refuse(socketPath, "is a symlink, not a socket");
  if (!S_ISSOCK(sock.st_mode)) refuse(socketPath, "is not a socket");
  if (!trusted(sock.st_uid))
    refuse(socketPath, fmt::format("is a socket owned by {}, not by {}", ownerName(sock.st_uid),
                                   ownerName(me)));
}

int bindPrivately(int fd, const std::string& socketPath) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (socketPath.size() >= sizeof addr.sun_path) {
    errno = ENAMETOOLONG;
    return -1;
  }
  std::memcpy(addr.sun_path, socketPath.c_str(), socketPath.size() + 1);
  const mode_t oldMask = ::umask(0177);
  const int bound = ::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr);
  const int bindErrno = errno;
  ::umask(oldMask);
  errno = bindErrno;
  return bound;
}

}  // namespace parallax
