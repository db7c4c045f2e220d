#pragma once
// The priors of per-laser intrinsics a method estimates with the mounting (the dense
// correspondences, the planes; SPEC §2 "per-laser intrinsics"; Glennie & Lichti 2010).

#include <string>

#include "mountcal/core/sensor_model.hpp"

namespace mountcal {

/// Multi-beam strips with laser ids: the prior σ of each group of per-laser intrinsics
/// (LaserCorrection), estimated as a nuisance block of the one adjustment; 0: the group is not
/// estimated. The means of the elevation offsets (a common one is the boresight pitch's), the
/// azimuth offsets (a boresight rotation about the spin axis) and the vertical offsets (the lever
/// arm along it) over the lasers the observations see are held at zero; range and horizontal
/// offsets keep their common part.
struct LaserIntrinsicsPriors {
  double laser_elevation_sigma_deg = 0.0;  ///< [deg]
  double laser_azimuth_sigma_deg = 0.0;    ///< [deg]
  double laser_range_sigma_m = 0.0;        ///< [m]
  double laser_vertical_sigma_m = 0.0;     ///< [m]
  double laser_horizontal_sigma_m = 0.0;   ///< [m]
  /// The five groups' prior σ as a LaserCorrection of σ [rad, m]; 0: not estimated.
  LaserCorrection laserPrior() const {
    return {deg2rad(laser_elevation_sigma_deg), deg2rad(laser_azimuth_sigma_deg), laser_range_sigma_m, laser_vertical_sigma_m,
            laser_horizontal_sigma_m};
  }
  bool estimatesLaserIntrinsics() const {
    const LaserCorrection prior = laserPrior();
    for (const LaserGroup& g : kLaserGroups)
      if (prior.*g.field > 0) return true;
    return false;
  }
  /// Angles in [0, 10] deg, lengths in [0, 1] m; false with the key in `error` otherwise.
  bool laserPriorsValid(std::string* error) const {
    auto fail = [&](const char* m) {
      if (error) *error = m;
      return false;
    };
    if (!(laser_elevation_sigma_deg >= 0 && laser_elevation_sigma_deg <= 10)) return fail("laser_elevation_sigma_deg must be in [0, 10]");
    if (!(laser_azimuth_sigma_deg >= 0 && laser_azimuth_sigma_deg <= 10)) return fail("laser_azimuth_sigma_deg must be in [0, 10]");
    if (!(laser_range_sigma_m >= 0 && laser_range_sigma_m <= 1)) return fail("laser_range_sigma_m must be in [0, 1]");
    if (!(laser_vertical_sigma_m >= 0 && laser_vertical_sigma_m <= 1)) return fail("laser_vertical_sigma_m must be in [0, 1]");
    if (!(laser_horizontal_sigma_m >= 0 && laser_horizontal_sigma_m <= 1)) return fail("laser_horizontal_sigma_m must be in [0, 1]");
    return true;
  }
};

}  // namespace mountcal
