#pragma once
// The sanitizer build (scripts/test.sh --sanitize) looks for memory errors and undefined
// behaviour, on the same tests as the Release suite. A test whose substance is statistics over
// many seeds runs its code on a few seeds there and then reports itself SKIPPED with the reason —
// never a PASS that asserted less than the Release suite does.

#include <gtest/gtest.h>

namespace mountcal_tests {

#ifdef MOUNTCAL_SANITIZE_BUILD
inline constexpr bool kSanitizerBuild = true;
#else
inline constexpr bool kSanitizerBuild = false;
#endif

/// `release` seeds in the Release build, `sanitizer` in the sanitizer build.
constexpr int seedsFor(int release, int sanitizer) { return kSanitizerBuild ? sanitizer : release; }

}  // namespace mountcal_tests

/// In the sanitizer build: the test's code has run (on fewer seeds), its statistical checks are
/// not made — SKIPPED, naming what the Release suite checks. No effect in the Release build.
#define MOUNTCAL_STATISTICS_IN_RELEASE_ONLY(what)                                                                                          \
  do {                                                                                                                                     \
    if (::mountcal_tests::kSanitizerBuild)                                                                                                 \
      GTEST_SKIP() << "sanitizer build: the code ran on fewer seeds, for memory errors; " << (what) << " is checked in the Release suite"; \
  } while (0)
