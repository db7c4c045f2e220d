// The layout shows the plan (DESIGN.md), checked by the includes of the source tree: methods are
// modules that do not include each other or the job layer, the simulator does not reach the
// methods, core is georeferencing alone, and installed headers hold no Ceres types outside the
// adjustment's extension point.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "support.hpp"

namespace fs = std::filesystem;

using namespace mountcal_tests;

namespace {

const fs::path kRoot = MOUNTCAL_SOURCE_DIR;

/// The project's own includes of a file, as paths relative to the root ("include/mountcal/…",
/// "src/…"); system and third-party includes are left out.
std::vector<std::string> ownIncludes(const fs::path& file) {
  static const std::regex inc(R"(#include\s+"([^"]+)\")");
  std::vector<std::string> out;
  const std::string text = slurp(file);
  for (std::sregex_iterator it(text.begin(), text.end(), inc), end; it != end; ++it) {
    const std::string name = (*it)[1];
    for (const fs::path& candidate : {file.parent_path() / name, kRoot / "include" / name, kRoot / "src" / name}) {
      if (fs::exists(candidate)) {
        out.push_back(fs::relative(fs::weakly_canonical(candidate), kRoot).string());
        break;
      }
    }
  }
  return out;
}

/// Every project file a file includes, directly or not.
std::set<std::string> closure(const std::string& start) {
  std::set<std::string> seen;
  std::vector<std::string> todo{start};
  while (!todo.empty()) {
    const std::string f = todo.back();
    todo.pop_back();
    for (const std::string& i : ownIncludes(kRoot / f))
      if (seen.insert(i).second) todo.push_back(i);
  }
  return seen;
}

std::vector<std::string> filesUnder(const std::string& dir) {
  std::vector<std::string> out;
  if (!fs::exists(kRoot / dir)) return out;
  for (const auto& e : fs::recursive_directory_iterator(kRoot / dir)) {
    const std::string ext = e.path().extension().string();
    if (e.is_regular_file() && (ext == ".cpp" || ext == ".hpp")) out.push_back(fs::relative(e.path(), kRoot).string());
  }
  return out;
}

/// "planes" for "src/methods/planes/x.cpp" or "include/mountcal/methods/planes/x.hpp"; empty otherwise.
std::string methodOf(const std::string& path) {
  static const std::regex m(R"((?:src|include/mountcal)/methods/([a-z_]+)/)");
  std::smatch s;
  return std::regex_search(path, s, m) ? std::string(s[1]) : "";
}

}  // namespace

TEST(Layout, MethodsIncludeNeitherEachOtherNorTheJobLayer) {
  int checked = 0;
  for (const char* dir : {"src/methods", "include/mountcal/methods"}) {
    for (const std::string& f : filesUnder(dir)) {
      const std::string own = methodOf(f);
      if (own.empty() || own == "common") continue;
      ++checked;
      for (const std::string& inc : ownIncludes(kRoot / f)) {
        const std::string other = methodOf(inc);
        EXPECT_TRUE(other.empty() || other == own || other == "common") << f << " includes " << inc;
        EXPECT_EQ(inc.find("/job"), std::string::npos) << f << " includes " << inc;
      }
    }
  }
  EXPECT_GT(checked, 15);
}

TEST(Layout, TheSimulatorDoesNotReachTheMethods) {
  int checked = 0;
  for (const char* dir : {"src/simulation", "include/mountcal/simulation"}) {
    for (const std::string& f : filesUnder(dir)) {
      ++checked;
      for (const std::string& inc : closure(f)) {
        const std::string m = methodOf(inc);
        EXPECT_TRUE(m.empty()) << f << " reaches " << inc;
        EXPECT_EQ(inc.find("adjustment/"), std::string::npos) << f << " reaches " << inc;
      }
    }
  }
  EXPECT_GT(checked, 4);
}

TEST(Layout, CoreIsGeoreferencingAlone) {
  int checked = 0;
  for (const char* dir : {"src/core", "include/mountcal/core"}) {
    for (const std::string& f : filesUnder(dir)) {
      ++checked;
      for (const std::string& inc : closure(f))
        EXPECT_TRUE(inc.rfind("src/core/", 0) == 0 || inc.rfind("include/mountcal/core/", 0) == 0) << f << " reaches " << inc;
      const std::string text = slurp(kRoot / f);
      for (const char* lib : {"<ceres/", "<flann/", "<OpenMesh/", "<proj"})
        EXPECT_EQ(text.find(lib), std::string::npos) << f << " includes " << lib;
    }
  }
  EXPECT_GT(checked, 10);
}

TEST(Layout, InstalledHeadersHoldNoCeresTypesOutsideTheAdjustment) {
  static const std::regex comment(R"(//[^\n]*)");
  int checked = 0;
  for (const std::string& f : filesUnder("include/mountcal")) {
    if (f == "include/mountcal/adjustment/mounting_adjustment.hpp") continue;  // the documented extension point
    ++checked;
    const std::string code = std::regex_replace(slurp(kRoot / f), comment, "");
    EXPECT_EQ(code.find("ceres"), std::string::npos) << f;
  }
  EXPECT_GT(checked, 30);
  EXPECT_FALSE(fs::exists(kRoot / "include/mountcal/detail")) << "internals live in src/";
}
