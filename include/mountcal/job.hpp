#pragma once
/// \file job.hpp
/// The job file of SPEC §4 (`mountcal calibrate JOB.json`) and the result file it writes.
/// Paths in a job are relative to the job file.

#include <string>
#include <vector>

#include <memory>

#include "mountcal/evaluation.hpp"
#include "mountcal/geodesy.hpp"
#include "mountcal/io/crs.hpp"
#include "mountcal/mounting_calibrator.hpp"
#include "mountcal/sensor_model.hpp"

namespace mountcal {

/// One strip entry of a job.
struct JobStrip {
  std::string id;
  std::string path;             ///< absolute (resolved against the job file)
  std::string format = "las";   ///< "las" or "raw_csv"
};

/// A parsed job file (SPEC §4).
struct Job {
  std::string path;              ///< the job file itself
  std::string frame_type = "local";
  std::string crs;               ///< for frame type "crs"
  std::string trajectory_path;
  std::string trajectory_format = "csv";
  double time_offset_s = 0.0;
  SensorModel sensor;
  MountingParameters mounting_used;
  std::vector<JobStrip> strips;
  std::string ties_path, gcps_path, check_points_path, check_planes_path;
  std::string method = "vtpm";
  MountingCalibrator::Options options;
  std::string result_path, report_path;  ///< empty when not requested
};

/// The computation frame of a job: for a local job the identity; for a CRS job the ENU tangent
/// frame at the trajectory's first position (height 0), reached through PROJ and WGS84.
class JobFrame {
 public:
  JobFrame() = default;  ///< local: identity
  JobFrame(const std::string& crs, const Geodetic& origin);
  bool isLocal() const { return !crs_; }
  const LocalTangentFrame* tangentFrame() const { return tangent_.get(); }
  Vec3 toLocal(const Vec3& x_crs) const;    ///< CRS coordinates → computation frame [m]
  Vec3 fromLocal(const Vec3& x_m) const;    ///< computation frame → CRS coordinates [m]

 private:
  std::shared_ptr<io::CrsTransform> crs_;
  std::shared_ptr<LocalTangentFrame> tangent_;
};

/// A job's data and its frame.
struct LoadedJob {
  CalibrationData data;
  JobFrame frame;
  std::vector<std::vector<Vec3>> crs_strips;  ///< CRS jobs: every strip point in the CRS [m]
};

/// Parses and validates a job file. Throws FileError naming the file and the field for an
/// unreadable file, invalid JSON, an unknown or missing field, or a value of the wrong type.
Job readJob(const std::string& path);

/// Reads everything a job names: trajectory, strips (LAS → raw vectors by inverse
/// georeferencing with mounting_used; raw CSV → vectors by the sensor model), ties, GCPs.
/// Throws FileError naming the file and record for malformed data, a LAS without GPS time, a
/// GPS-time encoding that disagrees with the trajectory, or points outside the trajectory.
CalibrationData loadJobData(const Job& job);
/// The same, with the frame (needed to write results back in the job's CRS).
LoadedJob loadJob(const Job& job);

/// Check data named by the job (empty when absent).
/// Ties and check points are picked in the strips' coordinates; in a CRS job they are moved into
/// the computation frame with the height of the nearest strip point.
std::vector<TieObservation> loadCheckPoints(const Job& job, const LoadedJob& loaded);
std::vector<PlaneRegion> loadCheckPlanes(const Job& job, const LoadedJob& loaded);

/// The job's trajectory and frame only (no strips).
LoadedJob loadJobTrajectory(const Job& job);

/// Statistics of an apply run.
struct ApplyStats {
  std::size_t strips = 0;
  std::uint64_t points = 0;
  double max_shift_m = 0.0;  ///< largest point displacement [m]
};

/// Rewrites every LAS strip of `job` into `out_dir` (same file names) with `mounting` in place
/// of `mounting_used`: each point is inverse-georeferenced with the used mounting and
/// georeferenced again with the new one, through the job's frame. Every other field, the VLRs,
/// EVLRs and extra bytes are kept; the strips are streamed in chunks of `chunk_points`, so
/// memory does not grow with the strip. Files are written through a temporary name. Throws
/// FileError (raw CSV strips cannot be rewritten; an output path equal to an input).
ApplyStats applyMounting(const Job& job, const MountingParameters& mounting, const std::string& out_dir,
                         std::size_t chunk_points = 1u << 20);

/// Optional evaluation to store with the result.
struct ResultEvaluation {
  bool any() const { return has_check_points || !check_planes_after.empty(); }
  bool has_check_points = false;
  CheckPointReport check_points_before, check_points_after;
  std::vector<CheckPlaneResult> check_planes_before, check_planes_after;
};

/// Check points and check planes named by the job, at `mounting_used` and at `mounting`.
/// `any()` is false when the job names neither.
ResultEvaluation evaluateJob(const Job& job, const LoadedJob& loaded, const MountingParameters& mounting);

/// The result file of SPEC §4 as JSON text.
std::string resultJson(const MountingCalibrator::Summary& summary, const ResultEvaluation* evaluation = nullptr);

/// Reads the "mounting" of a result file (lever arm [m], boresight [deg]); the nominal rotation
/// must be supplied by the caller (it is a property of the job, not of the result).
MountingParameters readResultMounting(const std::string& path, const Mat3& R_nom);

}  // namespace mountcal
