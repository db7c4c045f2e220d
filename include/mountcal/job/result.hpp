#pragma once
/// \file job/result.hpp
/// The result file of SPEC §4 (written by `calibrate`, read by `apply` and other programs) and
/// the check-data evaluation stored with it.

#include <string>

#include "mountcal/report/evaluation.hpp"
#include "mountcal/job/load.hpp"
#include "mountcal/mounting_calibrator.hpp"

namespace mountcal {

/// Optional evaluation to store with the result.
struct ResultEvaluation {
  bool any() const { return has_check_points || !check_planes_after.empty() || !discrepancy_after.empty(); }
  bool has_check_points = false;
  CheckPointReport check_points_before, check_points_after;
  std::vector<CheckPlaneResult> check_planes_before, check_planes_after;
  /// The pass-to-pass discrepancy of every overlapping strip pair (DiscrepancyOptions defaults).
  std::vector<PairDiscrepancy> discrepancy_before, discrepancy_after;
  /// Where it lies: by laser, place along the pass, range and surface tilt (DiscrepancyBreakdown).
  DiscrepancyBreakdown breakdown_before, breakdown_after;
};

/// Check points and check planes named by the job, at `mounting_used` and at `mounting`; with
/// `discrepancy` (or in a job with per-point poses, whose strips are passes over one object)
/// also the pass-to-pass discrepancy of every strip pair. `any()` is false when there is none.
ResultEvaluation evaluateJob(const Job& job, const LoadedJob& loaded, const MountingParameters& mounting, bool discrepancy = false,
                             const LaserCorrections& lasers = {});

/// The result file of SPEC §4 as JSON text: the keys of SPEC §4 for every method (`ties` and
/// `residuals` hold the tie section, empty without VTPM), `methods`, `kinds`, and one section
/// per other kind of observation: `planes`, `correspondences`, `control`.
std::string resultJson(const MountingCalibrator::Summary& summary, const ResultEvaluation* evaluation = nullptr);

/// A job calibrated as `mountcal calibrate` does it: the summary, the evaluation stored with it and
/// the result file's text.
struct JobCalibration {
  MountingCalibrator::Summary summary;
  ResultEvaluation evaluation;
  std::string result_json;  ///< resultJson(summary, &evaluation) as `mountcal calibrate` writes it
};

/// Calibrates `loaded` (loadJob(job)) with the job's options, then — with `evaluate` — evaluates
/// the result on the job's check data and overlaps (evaluateJob, with the estimated per-laser
/// offsets). Throws what MountingCalibrator::calibrate and evaluateJob throw; writes nothing.
JobCalibration calibrateJob(const Job& job, const LoadedJob& loaded, bool evaluate = true);

/// Reads the "mounting" of a result file (lever arm [m], boresight [deg]); the nominal rotation
/// must be supplied by the caller (it is a property of the job, not of the result).
MountingParameters readResultMounting(const std::string& path, const Mat3& R_nom);

/// The per-laser intrinsics of a result file (`intrinsics`: `laser_elevation_offset_deg`,
/// `laser_azimuth_offset_deg`, `laser_range_offset_m`, `laser_vertical_offset_m`,
/// `laser_horizontal_offset_m`, by laser id; a group that is absent is zero); empty when the
/// result has none. Throws FileError naming the file and the field for arrays of other lengths,
/// non-numbers, or values beyond ±10° / ±1 m.
LaserCorrections readResultLaserCorrections(const std::string& path);

/// Corrects each laser vector of a strip with laser ids by its laser's intrinsics
/// (correctLaserVector; `lasers` by laser id, empty: nothing) and clears the strips' x_m.
/// Throws InvalidInput for a laser id beyond `lasers`.
void applyLaserCorrections(CalibrationData* data, const LaserCorrections& lasers);

}  // namespace mountcal
