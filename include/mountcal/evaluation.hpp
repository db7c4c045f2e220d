#pragma once
/// \file evaluation.hpp
/// Evaluation on check data (seed 000 §3.2, Tables 2 and 3; SPEC §3 step 6): check points
/// (ties not used in the adjustment) and check planes, before and after applying a mounting.

#include <string>
#include <vector>

#include "mountcal/methods/vtpm/tie_observations.hpp"

namespace mountcal {

/// One check-point observation: its position on one strip minus the tie's mean (seed eq. 8).
struct CheckPointResidual {
  std::string tie_id, strip_id;
  Vec3 residual_m = Vec3::Zero();
};

struct CheckPointReport {
  std::vector<CheckPointResidual> residuals;
  std::vector<RejectedTie> rejected;
  Vec3 rms_m = Vec3::Zero();  ///< per axis, √(Σd²/n) as in seed Table 2 [m]
};

/// Builds the virtual tie points of `data.ties` (the check points) at `data.mounting_used` and
/// evaluates them at `mounting` (Rule 2).
CheckPointReport evaluateCheckPoints(const CalibrationData& data, const MountingParameters& mounting,
                                     const VtpOptions& options = {});

struct CheckPlaneResult {
  std::string plane_id;
  int points = 0;
  double rms_m = 0.0;  ///< seed eq. (13): √(Σ d_i² / (n − 3)) about the best-fit plane [m]
};

/// For each region, the points of every strip inside it, georeferenced with `mounting`, are
/// fitted by one plane; the RMS of their distances (seed eq. 13) measures how well the strips
/// agree. A region with fewer than 4 points gets rms NaN.
std::vector<CheckPlaneResult> evaluateCheckPlanes(const CalibrationData& data,
                                                  const std::vector<PlaneRegion>& regions,
                                                  const MountingParameters& mounting);

}  // namespace mountcal
