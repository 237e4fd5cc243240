#pragma once
// Debian's assimp-testmodels (tools/debian-packages.txt) are a test dependency like any other: a
// test that needs one of its files fails when it is missing, naming the package, rather than
// passing without having run.

#include <gtest/gtest.h>

#include <filesystem>

#include "tracer/scene_source.h"

#define REQUIRE_ASSIMP_TEST_MODEL(relative)                                                       \
  do {                                                                                            \
    const std::filesystem::path required =                                                        \
        std::filesystem::path(::parallax::assimpTestModelsRoot()) / (relative);                   \
    if (!std::filesystem::exists(required))                                                       \
      GTEST_FAIL() << required << " is missing: install assimp-testmodels (tools/setup.sh does)"; \
  } while (0)
