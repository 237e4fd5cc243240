#pragma once
// Is a picture file whole? Image libraries (libpng under both OpenCV and OpenImageIO) print
// their own lines on stderr when a file ends early or a chunk is damaged, beside the one-line
// error we give. Checking the container first turns a truncated or damaged PNG or JPEG into
// one InputError naming the file and the byte where it goes wrong, before any decoder sees it.

#include <cstdint>
#include <string>
#include <string_view>

namespace parallax {

// Throws InputError({path}) when `bytes` is a PNG whose chunks do not run, each with a correct
// CRC, to an IEND chunk, or a JPEG that does not end with its end-of-image marker. Other
// formats are left to their decoder.
void requireCompleteImage(const std::string& path, std::string_view bytes);

// The size a PNG or JPEG says it has, read from its header (the PNG's IHDR, the JPEG's frame
// header) before anything is decoded: a few kilobytes of zlib can claim 30000x30000 pixels,
// which a decoder would allocate (a GiB) before anyone checks the size. False for any other
// format, or a JPEG with no frame header before its first scan.
bool imageHeaderSize(std::string_view bytes, uint32_t* width, uint32_t* height);

}  // namespace parallax
