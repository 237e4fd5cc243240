#pragma once
// The file fixtures of the tests that install, roll back and compare files byte for byte: a
// fresh folder per test (named by the test, so parallel runs never share one) and whole-file
// reads.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace parallax::test_support {

// The file's bytes; empty when it cannot be read.
inline std::string bytesOf(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// temp/PREFIX-PID-TEST, emptied and created: one per running test.
inline std::filesystem::path freshTestFolder(const std::string& prefix) {
  namespace fs = std::filesystem;
  const fs::path folder =
      fs::temp_directory_path() / (prefix + "-" + std::to_string(::getpid()) + "-" +
                                   ::testing::UnitTest::GetInstance()->current_test_info()->name());
  fs::remove_all(folder);
  fs::create_directories(folder);
  return folder;
}

}  // namespace parallax::test_support
