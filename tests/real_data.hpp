#pragma once
// Real data of SPEC §5, read from ../shared/data: a test is skipped with a message when the
// data is absent on a developer's machine, and fails when it is absent in CI (CI=true, as
// `.ci/run` runs).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

inline std::string dataFile(const std::string& rel) { return std::string(MOUNTCAL_SHARED_DIR) + "/data/" + rel; }
inline bool inCi() {
  const char* ci = std::getenv("CI");
  return ci && *ci && std::string(ci) != "false" && std::string(ci) != "0";
}
#define REQUIRE_DATA(rel)                                                                                     \
  if (!std::filesystem::exists(dataFile(rel))) {                                                              \
    if (inCi()) FAIL() << "real data not found in CI: " << dataFile(rel) << " (../shared must be beside the repository)"; \
    GTEST_SKIP() << "real data not found: " << dataFile(rel) << " (needs ../shared beside the repository)";     \
  }
