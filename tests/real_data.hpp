#pragma once
// Real data of SPEC §5, read from ../shared/data: a test is skipped with a message when the
// data is absent on a developer's machine, and fails when it is absent in CI: `.ci/run` sets
// MOUNTCAL_REQUIRE_REAL_DATA=1 (a CI=true environment counts too).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

inline std::string dataFile(const std::string& rel) { return std::string(MOUNTCAL_SHARED_DIR) + "/data/" + rel; }
inline bool envTrue(const char* name) {
  const char* v = std::getenv(name);
  return v && *v && std::string(v) != "false" && std::string(v) != "0";
}
inline bool inCi() { return envTrue("MOUNTCAL_REQUIRE_REAL_DATA") || envTrue("CI"); }
#define REQUIRE_DATA(rel)                                                                                                 \
  if (!std::filesystem::exists(dataFile(rel))) {                                                                          \
    if (inCi()) FAIL() << "real data not found in CI: " << dataFile(rel) << " (../shared must be beside the repository)"; \
    GTEST_SKIP() << "real data not found: " << dataFile(rel) << " (needs ../shared beside the repository)";               \
  }
