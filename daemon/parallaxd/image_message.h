#pragma once
// Images as the bytes of one cluster message (cluster.h): per image a small header (an id —
// a module's display index, or a pattern's number — its size and pixel format) and its pixels.
// Rank 0 gathers the modules' frames this way (`view`, `frame`) and sends the calibration
// patterns to the ranks that show them.

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "hw/link/image.h"

namespace parallax::daemon {

void appendImageMessage(std::string* out, int id, const hw::Image& image);
// Every image of `message` from byte `from` on, with its id. The messages come from ranks of
// the same job: a malformed one is our bug (CHECK).
std::vector<std::pair<int, std::shared_ptr<const hw::Image>>> readImageMessage(
    const std::string& message, size_t from = 0);

}  // namespace parallax::daemon
