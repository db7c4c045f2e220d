#pragma once
/// \file data.hpp
/// What every calibration method starts from (DESIGN.md): the strips as raw observations
/// (time, laser vector, position at the mounting used), the trajectory, and what a surveyor
/// adds — tie picks, planar regions, ground control.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mountcal/core/error.hpp"
#include "mountcal/core/mounting.hpp"
#include "mountcal/core/sensor_model.hpp"
#include "mountcal/observations.hpp"
#include "mountcal/core/trajectory.hpp"

namespace mountcal {

struct PairCandidates;

/// A strip as the calibrators need it: per point the emission time, the raw laser vector and
/// (optionally) the position georeferenced with the reference mounting.
struct StripData {
  std::string id;
  std::vector<double> time_s;  ///< [s]
  std::vector<Vec3> r_s;       ///< laser vectors in the scanner frame [m]
  std::vector<Vec3> x_m;       ///< georeferenced with the reference mounting [m]; filled if empty
  /// Per-point sensor poses (SPEC §4 "Per-point poses"): when not empty, poses[i] is the IMU
  /// pose (SPEC §2 frames: p_m, R_mb = R_mn·R_nb) that measured point i, and the trajectory is
  /// not consulted for this strip (time_s may then be coarse, e.g. rounded to seconds).
  std::vector<Pose> poses;
  /// Laser (ring) of each point of a multi-beam scanner, when the strip file records it (job
  /// key `sensor.laser_field`); empty otherwise. Needed to estimate per-laser intrinsics.
  std::vector<std::uint16_t> laser;
  /// Intensity of each point (LAS intensity, simulator reflectance); empty when not loaded.
  /// Needed by method "features".
  std::vector<float> intensity;
};

/// Everything a calibration needs: the delivered trajectory, the mounting the strips were
/// georeferenced with, the strips' raw observations, and the user's input for each method.
struct CalibrationData {
  std::shared_ptr<const Trajectory> trajectory;
  MountingParameters mounting_used;  ///< the reference mounting of the strips
  std::vector<StripData> strips;
  std::vector<TieObservation> ties;      ///< method "vtpm" (SPEC §3)
  std::vector<GroundControlPoint> gcps;  ///< priors on the ties with the same id; with other methods, control points
  /// Method "planes": regions each holding one planar face seen by two or more strips (SPEC §4).
  /// Empty with PlaneOptions::automatic: the patches are found in the overlaps.
  std::vector<PlaneRegion> plane_regions;
  /// Method "features": regions each holding one high-intensity target seen by two or more
  /// strips (SPEC §4 `"targets"`, check-planes format).
  std::vector<PlaneRegion> target_regions;
  /// Method "correspondences": the candidate neighbourhoods of the strip pairs, found earlier
  /// (a workflow's `mountcal match` jobs, read with readPairCandidates); strips then need only
  /// their ids. Null: found from the strips' points.
  std::shared_ptr<const std::vector<PairCandidates>> correspondence_candidates;
  /// The trajectory's stated accuracy along its time (an SBET's smrmsg file, io::readSmrmsg), in
  /// the strips' time scale. Null: the σ of MountingCalibrator::Options::trajectory. Set, and
  /// those σ not switched off: its σ(t) take their place (TrajectoryAccuracy::series).
  std::shared_ptr<const TrajectoryAccuracySeries> trajectory_accuracy;

  /// The pose that measured point `i` of `strip`: its per-point pose, else the trajectory at
  /// its time (`cursor` speeds up lookups in time order). Call requirePoses() first.
  Pose pose(const StripData& strip, std::size_t i, std::size_t* cursor = nullptr) const {
    if (!strip.poses.empty()) return strip.poses[i];
    return cursor ? trajectory->pose(strip.time_s[i], cursor) : trajectory->pose(strip.time_s[i]);
  }
  /// Throws InvalidInput naming the strip when a strip has neither per-point poses (of its
  /// length) nor a trajectory to take them from.
  void requirePoses() const {
    for (const StripData& s : strips) {
      if (s.time_s.empty() && s.poses.empty()) continue;  // no points (given correspondence candidates)
      if (!s.poses.empty() && s.poses.size() != s.time_s.size()) {
        throw InvalidInput("strip '" + s.id + "': " + std::to_string(s.poses.size()) + " per-point poses for " +
                           std::to_string(s.time_s.size()) + " points");
      }
      if (s.poses.empty() && !trajectory)
        throw InvalidInput("calibrate: strip '" + s.id + "' has no per-point poses and there is no trajectory");
    }
  }
};

}  // namespace mountcal
