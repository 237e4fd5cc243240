#pragma once
// Files a person or a daemon may read at any moment (display models, calibrations, capture
// metadata) are written to a temporary file beside the target and renamed into place, so a
// reader sees the old file or the new one, never half of one.

#include <string>

namespace parallax {

// Throws InputError naming `path` when it cannot be written.
void writeFileAtomically(const std::string& path, const std::string& text);

}  // namespace parallax
