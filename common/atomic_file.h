#pragma once
// Files a person or a daemon may read at any moment (display models, calibrations, capture
// metadata, cached ray textures) are written to a temporary file beside the target, flushed
// to the disk (fsync), renamed into place and the folder flushed too: a reader sees the old
// file or the new one, never half of one, and once the call returns the new file survives a
// power cut. A full disk or a file-size limit fails the call and leaves the old file as it was.

#include <string>

namespace parallax {

// Throws InputError naming `path` and the system's reason when it cannot be written.
void writeFileAtomically(const std::string& path, const std::string& bytes);

}  // namespace parallax
