#pragma once
// Internal to the method modules: how their Summary sections write numbers in text, JSON and
// HTML (one home for the formats every section uses).

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>

#include "report/html_text.hpp"
#include "mountcal/core/rotation.hpp"

namespace mountcal::detail {

/// A number for a result file: null when not finite.
inline nlohmann::json numOrNull(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }
/// A 3-vector for a result file.
inline nlohmann::json vec3Json(const Vec3& v) { return nlohmann::json::array({v.x(), v.y(), v.z()}); }
/// A number in an HTML table: "—" when not finite.
inline std::string cell(double v, const char* format = "%.4f") { return std::isfinite(v) ? formatNumber(v, format) : "—"; }
/// printf into a std::string.
template <class... Args>
std::string printfString(const char* format, Args... args) {
  const int n = std::snprintf(nullptr, 0, format, args...);
  std::string s(static_cast<std::size_t>(n > 0 ? n : 0), '\0');
  std::snprintf(s.data(), s.size() + 1, format, args...);
  return s;
}

}  // namespace mountcal::detail
