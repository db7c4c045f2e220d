#pragma once
// Internal to the HTML reports (not installed): text escaping and number formatting.

#include <cstdio>
#include <string>

namespace mountcal::detail {

/// `s` as HTML text or attribute value: < > & " escaped.
inline std::string htmlEscape(const std::string& s) {
  std::string o;
  for (char c : s) o += c == '<' ? "&lt;" : c == '>' ? "&gt;" : c == '&' ? "&amp;" : c == '"' ? "&quot;" : std::string(1, c);
  return o;
}

/// One number through a printf format ("%.1f" by default).
inline std::string formatNumber(double v, const char* format = "%.1f") {
  char b[64];
  std::snprintf(b, sizeof b, format, v);
  return b;
}

}  // namespace mountcal::detail
