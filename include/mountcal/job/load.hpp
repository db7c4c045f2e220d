#pragma once
/// \file job/load.hpp
/// Loading what a job names: the computation frame, the trajectory, the strips (LAS → raw
/// vectors by inverse georeferencing with mounting_used; raw CSV → vectors by the sensor
/// model), ties, GCPs, plane regions and check data — all in the computation frame.

#include <memory>
#include <string>
#include <vector>

#include "mountcal/data.hpp"
#include "mountcal/core/geodesy.hpp"
#include "mountcal/io/crs.hpp"
#include "mountcal/job/schema.hpp"

namespace mountcal {

namespace detail {
class PlanHeightIndex;
}

/// The computation frame of a job: for a local job the identity; for a CRS job the ENU tangent
/// frame at the trajectory's first position (height 0), reached through PROJ and WGS84.
class JobFrame {
 public:
  JobFrame() = default;  ///< local: identity
  JobFrame(const std::string& crs, const Geodetic& origin);
  bool isLocal() const { return !crs_; }
  const LocalTangentFrame* tangentFrame() const { return tangent_.get(); }
  Vec3 toLocal(const Vec3& x_crs) const;  ///< CRS coordinates → computation frame [m]
  Vec3 fromLocal(const Vec3& x_m) const;  ///< computation frame → CRS coordinates [m]
  /// The same frame with its own PROJ transformation: a PROJ object must not be used by two
  /// threads at once, so each thread converting coordinates takes its own copy.
  JobFrame forAnotherThread() const { return crs_ ? JobFrame(crs_name_, tangent_->origin()) : *this; }

 private:
  std::string crs_name_;
  std::shared_ptr<io::CrsTransform> crs_;
  std::shared_ptr<LocalTangentFrame> tangent_;
};

/// A job's data and its frame.
struct LoadedJob {
  CalibrationData data;
  JobFrame frame;
  /// CRS jobs: a k-d tree over every strip point's plan position in the CRS, for the height
  /// with which plan picks are lifted before conversion (null in local jobs).
  std::shared_ptr<const detail::PlanHeightIndex> crs_heights;
  /// Height of the strip point nearest to (x, y) in the strips' CRS coordinates [m].
  double crsHeightAt(double x, double y) const;
};

/// How the laser directions of a multi-beam sensor's points agree with its laser table: for each
/// laser id with at least 50 points, the median over its points of the elevation of r_s (less the
/// laser's vertical offset) minus the table's elevation. With the description right these are
/// the mounting's small tilt at most (a boresight error of δ moves them by up to δ); a wrong
/// nominal rotation, attitudes in the wrong unit or a wrong laser field move them by degrees to
/// tens of degrees.
struct LaserTableCheck {
  struct Laser {
    int id = 0;
    std::size_t points = 0;
    double median_deviation_deg = 0.0;
  };
  std::vector<Laser> lasers;             ///< the lasers with ≥ 50 points, by id
  double worst_abs_deviation_deg = 0.0;  ///< largest |median deviation| over them
  int worst_laser = -1;
  int beyond(double tolerance_deg) const;  ///< lasers whose |median deviation| exceeds the tolerance
};

/// The check over every strip with laser ids (empty when none has them).
LaserTableCheck checkLaserTable(const CalibrationData& data, const MultiBeamModel& model);

/// Reads everything a job names for its methods: trajectory, strips, ties (vtpm), plane regions
/// (planes, unless automatic), GCPs. Throws FileError naming the file and record for malformed
/// data, a LAS without GPS time, a GPS-time encoding that disagrees with the trajectory, or
/// points outside the trajectory.
LoadedJob loadJob(const Job& job);
CalibrationData loadJobData(const Job& job);  ///< loadJob(job).data

/// The job's trajectory and frame only (no strips).
LoadedJob loadJobTrajectory(const Job& job);

/// Check data named by the job (empty when absent). Picks are plan positions in the strips'
/// coordinates; in a CRS job they are moved into the computation frame with the height of the
/// nearest strip point (a plan position in the tangent frame moves with height).
std::vector<TieObservation> loadCheckPoints(const Job& job, const LoadedJob& loaded);
std::vector<PlaneRegion> loadCheckPlanes(const Job& job, const LoadedJob& loaded);

}  // namespace mountcal
