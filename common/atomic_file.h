#pragma once
// Files a person or a daemon may read at any moment (display models, calibrations, capture
// metadata, cached ray textures) are written to a temporary file beside the target, flushed
// to the disk (fsync), renamed into place and the folder flushed too: a reader sees the old
// file or the new one, never half of one, and once the call returns the new file survives a
// power cut. A full disk or a file-size limit fails the call and leaves the old file as it was.

#include <sys/types.h>

#include <string>

namespace parallax {

// Throws InputError naming `path` and the system's reason when it cannot be written. `mode`
// is the new file's permission bits from the moment it exists (a secret: 0600), before the umask.
void writeFileAtomically(const std::string& path, const std::string& bytes, mode_t mode = 0644);

}  // namespace parallax
