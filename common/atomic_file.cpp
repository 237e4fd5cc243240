#include "common/atomic_file.h"

#include <unistd.h>

#include <cstdio>
#include <fstream>

#include "common/input_error.h"

namespace parallax {

void writeFileAtomically(const std::string& path, const std::string& text) {
  const std::string temporary = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) throw InputError({path, "", 0}, "cannot write the file");
    out << text;
    out.flush();
    if (!out) {
      std::remove(temporary.c_str());
      throw InputError({path, "", 0}, "writing the file failed");
    }
  }
  if (std::rename(temporary.c_str(), path.c_str()) != 0) {
    std::remove(temporary.c_str());
    throw InputError({path, "", 0}, "cannot move the file into place");
  }
}

}  // namespace parallax
