#pragma once
// A checksum written into a file beside its content and verified when the file is read back,
// so that a file damaged on disk (a flipped byte, a torn write, a hand edit) is recognised and
// never used as if it were good. 64-bit FNV-1a: not cryptographic (whoever can write the file
// can write its checksum too), but any change of the content changes it with near certainty.

#include <cstddef>
#include <cstdint>
#include <string>

namespace parallax {

uint64_t fnv1a64(const void* data, size_t size);
// "fnv1a64:" and the hash as 16 hex digits, the form stored in JSON files.
std::string contentChecksum(const std::string& bytes);

}  // namespace parallax
