#pragma once
// Is a picture file whole? Image libraries (libpng under both OpenCV and OpenImageIO) print
// their own lines on stderr when a file ends early or a chunk is damaged, beside the one-line
// error we give. Checking the container first turns a truncated or damaged PNG or JPEG into
// one InputError naming the file and the byte where it goes wrong, before any decoder sees it.

#include <string>
#include <string_view>

namespace parallax {

// Throws InputError({path}) when `bytes` is a PNG whose chunks do not run, each with a correct
// CRC, to an IEND chunk, or a JPEG that does not end with its end-of-image marker. Other
// formats are left to their decoder.
void requireCompleteImage(const std::string& path, std::string_view bytes);

}  // namespace parallax
