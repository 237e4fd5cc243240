#pragma once
// Runtime folders and the Unix sockets inside them, made and checked one way for the daemon,
// the simulator and `parallax ctl`. A predictable folder (/tmp/parallax-$UID) can be created
// first by another local user, who could then swap a socket for their own: so a folder is
// used only when it is a real folder (no symlink: opened with O_NOFOLLOW), owned by the
// effective user, mode 0700; a socket only when it is a socket owned by the effective user.
// The client side also accepts root as the owner (root can take any socket anyway).
//
// Failures are std::runtime_error with a one-line reason naming the path and the owner.

#include <string>

namespace parallax {

// Creates `folder` (mode 0700; missing parents 0700 too) or takes the existing one after
// checking it: a folder, not a symlink, owned by us. An existing folder of ours with wider
// permissions is narrowed to 0700 (before any socket is made in it).
void makePrivateFolder(const std::string& folder);

// For a server about to bind `socketPath` in a folder made by makePrivateFolder: true when
// something is in the way that may be removed (a socket of ours), false when nothing is
// there; throws when the path holds anything else (a file, a folder, a symlink, another
// user's socket), which is never deleted.
bool socketPathInUse(const std::string& socketPath);

// For a client about to connect: the socket's folder must be a folder (not a symlink) owned
// by us or root and writable by its owner only; the socket must be a socket owned by us or
// root. Throws naming the path and the owner otherwise; a missing socket is left to connect().
void checkSocketToConnect(const std::string& socketPath);

// bind(2) with a umask of 0177, so the socket is 0600 from the moment it exists.
// Returns bind's result (errno set on failure).
int bindPrivately(int fd, const std::string& socketPath);

}  // namespace parallax
