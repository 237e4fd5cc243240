#pragma once
// Where `parallaxd` with no configured socket listens, and so where `parallax ctl` looks
// without --socket: $XDG_RUNTIME_DIR/parallax/parallaxd.sock, else
// /tmp/parallax-$UID/parallaxd.sock. Shared by the daemon's config and the light client.

#include <string>

namespace parallax::daemon {

std::string defaultControlSocketPath();

}  // namespace parallax::daemon
