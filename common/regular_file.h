#pragma once
// Reading a file named by a user or a config: only a regular file is read, and only up to a
// size stated by the caller. A folder, a FIFO (which would block for ever), a device such as
// /dev/zero (which never ends) or a file larger than the cap is refused before a byte is read,
// with a one-line InputError naming the file and what it is.

#include <cstddef>
#include <string>

namespace parallax {

// The whole file. Throws InputError({path}) when it cannot be opened, is not a regular file or
// has more than `maxBytes` bytes.
std::string readRegularFile(const std::string& path, size_t maxBytes);

}  // namespace parallax
