#pragma once
/// \file io/geotiff.hpp
/// GeoTIFF rasters through GDAL (Debian's libgdal-dev): the dZ rasters of the swath QC.

#include <string>

#include "mountcal/report/swath_qc.hpp"

namespace mountcal::io {

/// The no-data value of the rasters written here: the USGS Lidar Base Specification's −999999.
constexpr double kGeoTiffNoData = -999999.0;

/// Writes `raster` as a one-band 32-bit float GeoTIFF to `path` (temporary file, then renamed):
/// origin at its north-west corner, square cells, north up, NaN cells as kGeoTiffNoData, and
/// `crs_wkt` as its CRS — WKT or what GDAL's SetFromUserInput takes ("EPSG:25832"); empty: none,
/// a local frame. Throws FileError naming `path`.
/// Returns the temporary file's name when `place` is false (for placeFilesAtomically).
std::string writeGeoTiff(const std::string& path, const DzRaster& raster, const std::string& crs_wkt, bool place = true);

}  // namespace mountcal::io
