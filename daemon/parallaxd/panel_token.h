#pragma once
// The control panel's secret: 32 random bytes (getrandom), hex, in `<state folder>/panel.token`,
// mode 0600 from the moment the file exists. Every panel request must carry it, so only whoever
// can read that file (the daemon's user, root) or was given the URL (`parallax ctl panel`, over
// the 0600 control socket) can steer the display from a browser.
//
// The token is kept across restarts (a bookmarked URL keeps working); a file that is not a
// regular file of ours, is readable by others or does not hold a well-formed token is replaced
// by a new token, never trusted.

#include <string>
#include <string_view>

namespace parallax::daemon {

constexpr size_t kPanelTokenHexChars = 64;

// Reads the token of `folder`/panel.token or writes a new one there (the folder is made when
// missing). Throws std::runtime_error naming the file when it can be neither read nor written.
std::string loadOrCreatePanelToken(const std::string& folder);

// A fresh random token (kPanelTokenHexChars lowercase hex digits).
std::string newPanelToken();

// Compares in time independent of where the strings differ (no timing oracle for the token).
bool tokensEqual(std::string_view a, std::string_view b);

}  // namespace parallax::daemon
