#pragma once
// Internal to the job module: strict access to the JSON objects of job and result files, with
// the field path in every message (FileError names the file and the field).

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "mountcal/core/error.hpp"
#include "mountcal/core/rotation.hpp"

namespace mountcal::detail {

/// The largest lever-arm component a job, result, scenario or plan may give [m]: beyond any
/// survey platform, small enough that nothing downstream overflows.
constexpr double kMaxLeverArmM = 1000.0;

using nlohmann::json;

/// Strict access to one JSON object of the job, with field paths in every message.
class Fields {
 public:
  Fields(const std::string& file, const json& j, std::string prefix, std::set<std::string> known)
      : file_(file), j_(j), prefix_(std::move(prefix)) {
    if (!j_.is_object()) fail("", "expected a JSON object");
    for (auto it = j_.begin(); it != j_.end(); ++it) {
      if (!known.count(it.key())) {
        std::string list;
        for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
        fail(it.key(), "unknown field (known here: " + list + ")");
      }
    }
  }
  [[noreturn]] void fail(const std::string& key, const std::string& msg) const {
    throw FileError(file_, "field '" + prefix_ + (prefix_.empty() || key.empty() ? "" : ".") + key + "'", msg);
  }
  bool has(const std::string& k) const { return j_.contains(k) && !j_[k].is_null(); }
  const json& at(const std::string& k) const {
    if (!has(k)) fail(k, "missing");
    return j_[k];
  }
  std::string str(const std::string& k) const {
    if (!at(k).is_string()) fail(k, "expected a string");
    return j_[k].get<std::string>();
  }
  std::string str(const std::string& k, const std::string& def) const { return has(k) ? str(k) : def; }
  double num(const std::string& k) const {
    if (!at(k).is_number()) fail(k, "expected a number");
    const double v = j_[k].get<double>();
    if (!std::isfinite(v)) fail(k, "not finite");
    return v;
  }
  double num(const std::string& k, double def) const { return has(k) ? num(k) : def; }
  /// A number in [lo, hi] (a physical range: a radius of 1e6 m or a σ of 1e300 is refused).
  double num(const std::string& k, double def, double lo, double hi) const {
    if (!has(k)) return def;
    const double v = num(k);
    if (!(v >= lo && v <= hi)) {
      std::ostringstream range;
      range << "expected a number in [" << lo << ", " << hi << "]";
      fail(k, range.str());
    }
    return v;
  }
  /// An integer in [lo, hi]: 2.5 or 1e300 is an error, not a truncation.
  int integer(const std::string& k, int def, int lo, int hi) const {
    if (!has(k)) return def;
    const double v = num(k);
    if (v != std::floor(v) || v < lo || v > hi) {
      fail(k, "expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    }
    return static_cast<int>(v);
  }
  /// The index of the string value among `names` ("expected one of …" otherwise).
  int choice(const std::string& k, int def, const std::vector<std::string>& names) const {
    if (!has(k)) return def;
    if (at(k).is_string()) {
      const auto it = std::find(names.begin(), names.end(), j_[k].get<std::string>());
      if (it != names.end()) return static_cast<int>(it - names.begin());
    }
    std::string list;
    for (const std::string& n : names) list += (list.empty() ? "\"" : ", \"") + n + "\"";
    fail(k, "expected one of " + list);
  }
  bool boolean(const std::string& k, bool def) const {
    if (!has(k)) return def;
    if (!at(k).is_boolean()) fail(k, "expected true or false");
    return j_[k].get<bool>();
  }
  Vec3 vec3(const std::string& k) const {
    const json& a = at(k);
    if (!a.is_array() || a.size() != 3) fail(k, "expected an array of 3 numbers");
    Vec3 v;
    for (int i = 0; i < 3; ++i) {
      if (!a[i].is_number()) fail(k, "expected an array of 3 numbers");
      v[i] = a[i].get<double>();
      if (!std::isfinite(v[i])) fail(k, "not finite");
    }
    return v;
  }
  /// A lever arm [m]: vec3(k) with every component within ±kMaxLeverArmM.
  Vec3 leverArmM(const std::string& k) const { return bounded(k, kMaxLeverArmM, "±1000 m (a lever arm)"); }
  /// Boresight angles [deg]: vec3(k) with every component within ±180°.
  Vec3 boresightDeg(const std::string& k) const { return bounded(k, 180.0, "±180°"); }
  std::array<bool, 3> bool3(const std::string& k) const {
    const json& a = at(k);
    if (!a.is_array() || a.size() != 3) fail(k, "expected an array of 3 booleans");
    std::array<bool, 3> v{};
    for (int i = 0; i < 3; ++i) {
      if (!a[i].is_boolean()) fail(k, "expected an array of 3 booleans");
      v[i] = a[i].get<bool>();
    }
    return v;
  }
  Fields sub(const std::string& k, std::set<std::string> known) const {
    return Fields(file_, at(k), prefix_ + (prefix_.empty() ? "" : ".") + k, std::move(known));
  }

 private:
  Vec3 bounded(const std::string& k, double bound, const char* what) const {
    const Vec3 v = vec3(k);
    for (int i = 0; i < 3; ++i)
      if (std::abs(v[i]) > bound) fail(k, std::string("a component beyond ") + what);
    return v;
  }

  const std::string& file_;
  const json& j_;
  std::string prefix_;
};

/// The JSON document of a job, result or scenario file (`what`: "job", "result", ...). Every
/// failure is a FileError naming the file and, for bad JSON, the line and column: a folder, a
/// file that cannot be opened, more than 16 MB (an endless stream is not read into memory),
/// a syntax error, a number that overflows a double.
inline json parseJsonFile(const std::string& path, const std::string& what) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw FileError(path, "", "is a folder, not a " + what + " file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path, "", "cannot open the " + what + " file");
  constexpr std::size_t kMaxBytes = 16u << 20;
  std::string text;
  char buf[65536];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) {
    text.append(buf, static_cast<std::size_t>(in.gcount()));
    if (text.size() > kMaxBytes) throw FileError(path, "", "larger than 16 MB: not a " + what + " file");
  }
  const auto where = [&](std::size_t byte) {  // 1-based line and column of a 0-based byte
    std::size_t line = 1, col = 1;
    for (std::size_t i = 0; i < byte && i < text.size(); ++i) {
      if (text[i] == '\n') {
        ++line;
        col = 1;
      } else {
        ++col;
      }
    }
    return "line " + std::to_string(line) + ", column " + std::to_string(col);
  };
  try {
    return json::parse(text);
  } catch (const json::parse_error& e) {
    // nlohmann's byte is 1-based and points just past the offending character.
    std::string msg = e.what();
    const std::size_t colon = msg.rfind(": ");
    if (colon != std::string::npos) msg = msg.substr(colon + 2);
    throw FileError(path, where(e.byte > 0 ? e.byte - 1 : 0), "invalid JSON: " + msg);
  } catch (const json::exception& e) {
    // e.g. "number overflow parsing '1e999'": find the number to say where it is.
    const std::string msg = e.what();
    const std::size_t a = msg.find("parsing '");
    if (a != std::string::npos) {
      const std::size_t b = msg.find('\'', a + 9);
      const std::string token = b == std::string::npos ? "" : msg.substr(a + 9, b - a - 9);
      const std::size_t at = token.empty() ? std::string::npos : text.find(token);
      if (at != std::string::npos) throw FileError(path, where(at), "invalid JSON: the number " + token + " does not fit a double");
    }
    throw FileError(path, "", std::string("invalid JSON: ") + msg);
  }
}

/// A path of a job file, resolved against the job file's folder.
inline std::string resolvePath(const std::string& job_path, const std::string& p) {
  namespace fs = std::filesystem;
  if (p.empty()) return p;
  const fs::path path(p);
  if (path.is_absolute()) return p;
  return (fs::path(job_path).parent_path() / path).lexically_normal().string();
}

/// A path written into a job file: relative to the job file's folder when it lies below it.
inline std::string relativePath(const std::string& job_path, const std::string& p) {
  namespace fs = std::filesystem;
  if (p.empty()) return p;
  const fs::path base = fs::path(job_path).parent_path();
  const fs::path rel = fs::path(p).lexically_relative(base.empty() ? fs::path(".") : base);
  if (!rel.empty() && *rel.begin() != "..") return rel.string();
  return p;
}

}  // namespace mountcal::detail
