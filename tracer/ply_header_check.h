#pragma once
// A PLY file's header says how many elements follow; assimp believes it and reserves and loops
// that many times before it finds the file ends: a 300-byte file claiming 300 million vertices
// took more than 120 s and 3.6 GB. The counts are checked against the bytes the file has.

#include <string>
#include <string_view>

namespace parallax {

// Throws InputError({path, "element NAME"}) when `bytes` (the file's first bytes, its header
// whole) is a PLY header promising more elements than a file of `fileSize` bytes could hold
// after it (each ASCII value needs at least two bytes, each binary one its type's size).
// Anything that is not a PLY header, or not all of one, is left to assimp.
void requirePlyCountsFit(const std::string& path, std::string_view bytes, double fileSize);

}  // namespace parallax
