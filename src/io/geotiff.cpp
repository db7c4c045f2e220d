#include "mountcal/io/geotiff.hpp"

#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

#include "mountcal/core/error.hpp"
#include "mountcal/io/atomic_file.hpp"

namespace mountcal::io {

std::string writeGeoTiff(const std::string& path, const DzRaster& raster, const std::string& crs_wkt, bool place) {
  if (raster.nx <= 0 || raster.ny <= 0 || raster.dz_m.size() != static_cast<std::size_t>(raster.nx) * static_cast<std::size_t>(raster.ny))
    throw FileError(path, "raster", "empty or inconsistent raster");
  GDALAllRegister();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  if (!driver) throw FileError(path, "GDAL", "the GTiff driver is not available");
  const std::string tmp = path + ".tmp-mountcal";
  char** options = nullptr;
  options = CSLSetNameValue(options, "COMPRESS", "DEFLATE");
  std::unique_ptr<GDALDataset> ds(driver->Create(tmp.c_str(), raster.nx, raster.ny, 1, GDT_Float32, options));
  CSLDestroy(options);
  if (!ds) throw FileError(path, "GDAL", "cannot create the file: " + std::string(CPLGetLastErrorMsg()));
  double transform[6] = {raster.x0_m, raster.cell_m, 0.0, raster.y1_m, 0.0, -raster.cell_m};
  bool ok = ds->SetGeoTransform(transform) == CE_None;
  if (ok && !crs_wkt.empty()) {
    OGRSpatialReference srs;
    char* wkt = nullptr;
    ok = srs.SetFromUserInput(crs_wkt.c_str()) == OGRERR_NONE && srs.exportToWkt(&wkt) == OGRERR_NONE;
    if (ok) ok = ds->SetProjection(wkt) == CE_None;
    CPLFree(wkt);
  }
  GDALRasterBand* band = ds->GetRasterBand(1);
  ok = ok && band->SetNoDataValue(kGeoTiffNoData) == CE_None;
  std::vector<float> data(raster.dz_m);
  for (float& v : data)
    if (std::isnan(v)) v = static_cast<float>(kGeoTiffNoData);
  ok = ok && band->RasterIO(GF_Write, 0, 0, raster.nx, raster.ny, data.data(), raster.nx, raster.ny, GDT_Float32, 0, 0) == CE_None;
  ds->FlushCache();
  ds.reset();  // closes the file
  if (!ok) {
    std::remove(tmp.c_str());
    throw FileError(path, "GDAL", "writing failed: " + std::string(CPLGetLastErrorMsg()));
  }
  if (!place) return tmp;
  placeFilesAtomically({{tmp, path}});
  return path;
}

}  // namespace mountcal::io
