#pragma once
/// \file job.hpp
/// The job file of SPEC §4 (`mountcal calibrate JOB.json`) and the result file it writes.
/// Paths in a job are relative to the job file.

#include <string>
#include <vector>

#include "mountcal/evaluation.hpp"
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

/// Parses and validates a job file. Throws FileError naming the file and the field for an
/// unreadable file, invalid JSON, an unknown or missing field, or a value of the wrong type.
Job readJob(const std::string& path);

/// Reads everything a job names: trajectory, strips (LAS → raw vectors by inverse
/// georeferencing with mounting_used; raw CSV → vectors by the sensor model), ties, GCPs.
/// Throws FileError naming the file and record for malformed data, a LAS without GPS time, a
/// GPS-time encoding that disagrees with the trajectory, or points outside the trajectory.
CalibrationData loadJobData(const Job& job);

/// Check data named by the job (empty when absent).
std::vector<TieObservation> loadCheckPoints(const Job& job);
std::vector<PlaneRegion> loadCheckPlanes(const Job& job);

/// Optional evaluation to store with the result.
struct ResultEvaluation {
  bool has_check_points = false;
  CheckPointReport check_points_before, check_points_after;
  std::vector<CheckPlaneResult> check_planes_before, check_planes_after;
};

/// The result file of SPEC §4 as JSON text.
std::string resultJson(const MountingCalibrator::Summary& summary, const ResultEvaluation* evaluation = nullptr);

/// Reads the "mounting" of a result file (lever arm [m], boresight [deg]); the nominal rotation
/// must be supplied by the caller (it is a property of the job, not of the result).
MountingParameters readResultMounting(const std::string& path, const Mat3& R_nom);

}  // namespace mountcal
