#pragma once
/// \file data.hpp
/// What every calibration method starts from (DESIGN.md): the strips as raw observations
/// (time, laser vector, position at the mounting used), the trajectory, and what a surveyor
/// adds — tie picks, planar regions, ground control.

#include <memory>
#include <string>
#include <vector>

#include "mountcal/mounting.hpp"
#include "mountcal/observations.hpp"
#include "mountcal/trajectory.hpp"

namespace mountcal {

/// A strip as the calibrators need it: per point the emission time, the raw laser vector and
/// (optionally) the position georeferenced with the reference mounting.
struct StripData {
  std::string id;
  std::vector<double> time_s;  ///< [s]
  std::vector<Vec3> r_s;       ///< laser vectors in the scanner frame [m]
  std::vector<Vec3> x_m;       ///< georeferenced with the reference mounting [m]; filled if empty
};

/// Everything a calibration needs: the delivered trajectory, the mounting the strips were
/// georeferenced with, the strips' raw observations, and the user's input for each method.
struct CalibrationData {
  std::shared_ptr<const Trajectory> trajectory;
  MountingParameters mounting_used;      ///< the reference mounting of the strips
  std::vector<StripData> strips;
  std::vector<TieObservation> ties;      ///< method "vtpm" (SPEC §3)
  std::vector<GroundControlPoint> gcps;  ///< priors on the ties with the same id; with other methods, control points
  /// Method "planes": regions each holding one planar face seen by two or more strips (SPEC §4).
  /// Empty with PlaneOptions::automatic: the patches are found in the overlaps.
  std::vector<PlaneRegion> plane_regions;
};

}  // namespace mountcal
