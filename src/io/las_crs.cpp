#include "mountcal/io/las_crs.hpp"

#include <proj.h>

#include <cstring>

#include "io/bytes.hpp"
#include "mountcal/core/error.hpp"

namespace mountcal::io {

namespace {

const LasVlr* findRecord(const LasHeader& h, std::uint16_t record_id) {
  for (const auto* list : {&h.vlrs, &h.evlrs})
    for (const LasVlr& v : *list)
      if (v.user_id == "LASF_Projection" && v.record_id == record_id) return &v;
  return nullptr;
}

/// The text of a WKT name or ID: the quoted string after `at`, or empty.
std::string quotedAfter(const std::string& s, std::size_t at) {
  const std::size_t a = s.find('"', at);
  if (a == std::string::npos) return "";
  const std::size_t b = s.find('"', a + 1);
  return b == std::string::npos ? "" : s.substr(a + 1, b - a - 1);
}

/// "EPSG:n" of the WKT's own authority: the last AUTHORITY["EPSG","n"] (WKT 1) or ID["EPSG",n]
/// (WKT 2) at the outermost bracket level — the components' authorities sit deeper.
std::string wktEpsg(const std::string& wkt) {
  int depth = 0;
  std::string code;
  for (std::size_t i = 0; i < wkt.size(); ++i) {
    const char c = wkt[i];
    if (c == '"') {  // a quoted string holds no brackets
      const std::size_t end = wkt.find('"', i + 1);
      if (end == std::string::npos) break;
      i = end;
    } else if (c == '[' || c == '(') {
      ++depth;
    } else if (c == ']' || c == ')') {
      --depth;
    } else if (depth == 1) {
      for (const char* key : {"AUTHORITY[\"EPSG\",", "ID[\"EPSG\","}) {
        const std::size_t n = std::strlen(key);
        if (wkt.compare(i, n, key) == 0) {
          std::size_t k = i + n;
          while (k < wkt.size() && (wkt[k] == '"' || wkt[k] == ' ')) ++k;
          std::size_t e = k;
          while (e < wkt.size() && wkt[e] >= '0' && wkt[e] <= '9') ++e;
          if (e > k) code = "EPSG:" + wkt.substr(k, e - k);
        }
      }
    }
  }
  return code;
}

}  // namespace

std::string GeoKey::name() const {
  switch (id) {
    case 1024:
      return "GTModelTypeGeoKey";
    case 1025:
      return "GTRasterTypeGeoKey";
    case 1026:
      return "GTCitationGeoKey";
    case 2048:
      return "GeographicTypeGeoKey";
    case 2049:
      return "GeogCitationGeoKey";
    case 2054:
      return "GeogAngularUnitsGeoKey";
    case 3072:
      return "ProjectedCSTypeGeoKey";
    case 3073:
      return "PCSCitationGeoKey";
    case 3076:
      return "ProjLinearUnitsGeoKey";
    case 4096:
      return "VerticalCSTypeGeoKey";
    case 4097:
      return "VerticalCitationGeoKey";
    case 4099:
      return "VerticalUnitsGeoKey";
    default:
      return "key " + std::to_string(id);
  }
}

std::string LasCrs::summary() const {
  if (!wkt.empty()) {
    const std::size_t open = wkt.find('[');
    const std::string name = open == std::string::npos ? "" : quotedAfter(wkt, open);
    const std::string epsg = wktEpsg(wkt);
    return (epsg.empty() ? "" : epsg + " ") + "'" + name + "' (WKT)";
  }
  if (geo_keys.empty()) return "none declared";
  std::string horizontal, vertical;
  for (const GeoKey& k : geo_keys) {
    if (k.location != 0) continue;
    // 32767: user-defined (the other keys then describe it); 0: undefined.
    const std::string code = k.value == 32767 ? "user-defined" : "EPSG:" + std::to_string(k.value);
    if (k.id == 3072 || (k.id == 2048 && horizontal.empty())) horizontal = code + " (GeoTIFF " + k.name() + ")";
    if (k.id == 4096) vertical = code;
  }
  if (horizontal.empty()) horizontal = "no EPSG code (GeoTIFF keys without ProjectedCSTypeGeoKey or GeographicTypeGeoKey)";
  return horizontal + (vertical.empty() ? "" : ", vertical " + vertical);
}

LasCrs lasCrs(const LasHeader& header, const std::string& path) {
  LasCrs out;
  if (const LasVlr* w = findRecord(header, 2112)) {
    out.wkt.assign(w->data.begin(), w->data.end());
    while (!out.wkt.empty() && out.wkt.back() == '\0') out.wkt.pop_back();
  }
  const LasVlr* dir = findRecord(header, 34735);
  if (!dir) return out;
  const std::string where = "GeoKeyDirectory VLR (LASF_Projection/34735)";
  const std::vector<std::uint8_t>& d = dir->data;
  auto u16 = [&](std::size_t k) { return bytes::get<std::uint16_t>(d.data(), 2 * k); };
  if (d.size() < 8) throw FileError(path, where, "its " + std::to_string(d.size()) + " bytes hold no header (8 bytes)");
  const std::size_t keys = u16(3);
  if (8 + 8 * keys > d.size())
    throw FileError(path, where, "announces " + std::to_string(keys) + " keys; its " + std::to_string(d.size()) + " bytes hold fewer");
  const LasVlr* doubles = findRecord(header, 34736);
  const LasVlr* ascii = findRecord(header, 34737);
  for (std::size_t k = 0; k < keys; ++k) {
    GeoKey g;
    g.id = u16(4 + 4 * k);
    g.location = u16(5 + 4 * k);
    g.count = u16(6 + 4 * k);
    g.value = u16(7 + 4 * k);
    const std::string key = "key " + std::to_string(k) + " (" + g.name() + ")";
    if (g.location == 34736) {
      if (!doubles || (static_cast<std::size_t>(g.value) + g.count) * 8 > doubles->data.size())
        throw FileError(path, where, key + ": its doubles lie beyond the GeoDoubleParams record");
      for (std::size_t i = 0; i < g.count; ++i) g.numbers.push_back(bytes::get<double>(doubles->data.data(), 8 * (g.value + i)));
    } else if (g.location == 34737) {
      if (!ascii || static_cast<std::size_t>(g.value) + g.count > ascii->data.size())
        throw FileError(path, where, key + ": its text lies beyond the GeoAsciiParams record");
      g.text.assign(ascii->data.begin() + g.value, ascii->data.begin() + g.value + g.count);
      while (!g.text.empty() && (g.text.back() == '|' || g.text.back() == '\0')) g.text.pop_back();  // GeoTIFF's terminator
    } else if (g.location != 0) {
      throw FileError(path, where, key + ": location " + std::to_string(g.location) + " (expected 0, 34736 or 34737)");
    }
    out.geo_keys.push_back(g);
  }
  return out;
}

LasVlr wktVlr(const std::string& crs) {
  PJ_CONTEXT* ctx = proj_context_create();
  proj_log_level(ctx, PJ_LOG_NONE);
  PJ* p = proj_create(ctx, crs.c_str());
  const char* wkt = p ? proj_as_wkt(ctx, p, PJ_WKT1_GDAL, nullptr) : nullptr;
  std::string text = wkt ? wkt : "";
  if (p) proj_destroy(p);
  proj_context_destroy(ctx);
  if (text.empty()) throw InvalidInput("unknown or unsupported CRS '" + crs + "' (PROJ gives no WKT for it)");
  LasVlr v;
  v.user_id = "LASF_Projection";
  v.record_id = 2112;
  v.description = "OGC WKT coordinate system";
  v.data.assign(text.begin(), text.end());
  v.data.push_back(0);
  return v;
}

}  // namespace mountcal::io
