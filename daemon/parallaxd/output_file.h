#pragma once
// Files the control socket asks the daemon to write (`frame`, `view` with a path). The request
// comes from another process, so the path is hostile: it must be absolute, its folder must
// already exist (the daemon never creates folders for a client), and a symlink or anything
// but a regular file at the path is refused. The file is written under a temporary name in
// the same folder (created with O_EXCL, never through a link) and renamed over the path, so a
// symlink placed there meanwhile is replaced, not written through.

#include <functional>
#include <string>
#include <string_view>

namespace parallax::daemon {

// `write(tempPath)` writes the file (its extension is the path's, for format detection).
// Throws InputError naming `field` for a path refused, std::runtime_error when writing fails.
void writeOutputFile(const std::string& path, std::string_view field,
                     const std::function<void(const std::string&)>& write);

}  // namespace parallax::daemon
