#pragma once
/// \file io/las_crs.hpp
/// The coordinate reference system a LAS file declares (ASPRS LAS 1.4 R15 §2.5.1–2.5.3): OGC
/// WKT (VLR LASF_Projection/2112) or GeoTIFF keys (LASF_Projection/34735, with the doubles of
/// 34736 and the ASCII of 34737).

#include <cstdint>
#include <string>
#include <vector>

#include "mountcal/io/las.hpp"

namespace mountcal::io {

/// One GeoTIFF key of a GeoKeyDirectory (GeoTIFF 1.0 §2.4): its value is `value` (location 0),
/// `text` (location 34737) or `numbers` (location 34736).
struct GeoKey {
  std::uint16_t id = 0;
  std::uint16_t location = 0;  ///< 0: the value itself; 34736: doubles; 34737: ASCII
  std::uint16_t count = 0;
  std::uint16_t value = 0;
  std::string text;
  std::vector<double> numbers;
  /// The key's name ("ProjectedCSTypeGeoKey"), or "key <id>" for keys this reader does not name.
  std::string name() const;
};

/// What a LAS header declares about its CRS.
struct LasCrs {
  std::string wkt;               ///< the WKT VLR's text (trailing NULs removed); empty without one
  std::vector<GeoKey> geo_keys;  ///< the GeoKeyDirectory's keys, in file order
  bool empty() const { return wkt.empty() && geo_keys.empty(); }
  /// The horizontal CRS in a line: "EPSG:32611 'WGS 84 / UTM zone 11N' (WKT)", the EPSG codes of
  /// the GeoTIFF keys ("EPSG:32611 (GeoTIFF ProjectedCSTypeGeoKey), vertical EPSG:5703"), or
  /// "none declared".
  std::string summary() const;
};

/// The CRS declared by `header`'s VLRs and EVLRs. Throws FileError naming `path` and the record
/// when a GeoKeyDirectory is malformed (a count or an index beyond its records).
LasCrs lasCrs(const LasHeader& header, const std::string& path);

/// The LAS 1.4 WKT VLR (LASF_Projection/2112, NUL-terminated OGC WKT 1) for `crs` (any CRS PROJ
/// knows, e.g. "EPSG:32611"). Throws InvalidInput naming the CRS when PROJ does not know it.
LasVlr wktVlr(const std::string& crs);

}  // namespace mountcal::io
