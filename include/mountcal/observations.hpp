#pragma once
/// \file observations.hpp
/// What a surveyor supplies besides the strips (SPEC §4): tie picks, planar regions, ground
/// control points.

#include <cstddef>
#include <string>

namespace mountcal {

/// The picked plan position of tie `tie_id` on strip `strip_id` (Ties CSV row).
struct TieObservation {
  std::string tie_id;
  std::string strip_id;
  double x_m = 0, y_m = 0;  ///< in the strip's (uncalibrated) coordinates [m]
  std::size_t line = 0;     ///< line in the source file, 0 if none (for messages)
};

/// An axis-aligned region (check plane, planar patch, target region).
struct PlaneRegion {
  std::string id;
  double xmin = 0, ymin = 0, xmax = 0, ymax = 0;  ///< [m]
  std::size_t line = 0;                           ///< its line in the CSV file it was read from (0: not read from a file)
};

/// A ground control point, observed through the ties with the same id.
struct GroundControlPoint {
  std::string id;
  double x_m = 0, y_m = 0, z_m = 0;            ///< [m]
  double sigma_xy_m = 0.02, sigma_z_m = 0.02;  ///< [m]
};

}  // namespace mountcal
