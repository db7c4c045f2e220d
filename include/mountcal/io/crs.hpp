#pragma once
/// \file io/crs.hpp
/// Coordinate reference systems through PROJ: a projected or geographic CRS ⇄ WGS84 geodetic.

#include <memory>
#include <string>

#include "mountcal/core/geodesy.hpp"

namespace mountcal::io {

/// Converts coordinates in `crs` ("EPSG:32611", any PROJ string) to and from WGS84 geodetic
/// (EPSG:4979). Heights pass through unchanged (ellipsoidal in, ellipsoidal out).
class CrsTransform {
 public:
  /// Throws InvalidInput naming the CRS when PROJ does not know it.
  explicit CrsTransform(const std::string& crs);
  ~CrsTransform();
  CrsTransform(const CrsTransform&) = delete;
  CrsTransform& operator=(const CrsTransform&) = delete;

  /// True for a geographic CRS (coordinates in degrees, such as EPSG:4326): strips and jobs
  /// need a projected one in metres. Throws InvalidInput when PROJ does not know the CRS.
  static bool isGeographic(const std::string& crs);

  Geodetic toGeodetic(const Vec3& x_crs) const;
  Vec3 fromGeodetic(const Geodetic& g) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mountcal::io
