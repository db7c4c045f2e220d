#pragma once
/// \file evaluation.hpp
/// Evaluation on check data (seed 000 §3.2, Tables 2 and 3; SPEC §3 step 6): check points
/// (ties not used in the adjustment) and check planes, before and after applying a mounting.

#include <cmath>
#include <string>
#include <vector>

#include "mountcal/methods/common/tie_observations.hpp"

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
CheckPointReport evaluateCheckPoints(const CalibrationData& data, const MountingParameters& mounting, const VtpOptions& options = {});

struct CheckPlaneResult {
  std::string plane_id;
  int points = 0;
  double rms_m = 0.0;  ///< seed eq. (13): √(Σ d_i² / (n − 3)) about the best-fit plane [m]
};

/// For each region, the points of every strip inside it, georeferenced with `mounting`, are
/// fitted by one plane; the RMS of their distances (seed eq. 13) measures how well the strips
/// agree. A region with fewer than 4 points gets rms NaN.
std::vector<CheckPlaneResult> evaluateCheckPlanes(const CalibrationData& data, const std::vector<PlaneRegion>& regions,
                                                  const MountingParameters& mounting);

/// The pass-to-pass discrepancy (issue "Real UAV data"): each point of the smaller strip of a
/// pair against the local plane of the larger strip. A point counts when its nearest neighbour
/// in the larger strip is within `max_neighbour_distance_m` and the plane of its `neighbours`
/// nearest neighbours there is planar (σ of the fit ≤ `max_plane_sigma_m`), a surface and not
/// a line (second/largest spread ≥ `min_spread_ratio`) and local (largest spread ≤
/// `max_extent_m`). The distance is |n·(x − c)| to that plane.
///
/// The gates' defaults fit UAV passes (centimetre spacing). With `from_spacing` (the default) the
/// two size gates are widened for sparser strips, never narrowed: from the larger strip's mean
/// plan spacing s, k neighbours fill a disc of radius r = s·√(k/π); the extent gate becomes at
/// least 1.5 r and the neighbour distance at least 3 s — an airborne strip at 0.5 m spacing gets
/// 1.34 m and 1.5 m, a UAV pass at 5 cm keeps 0.3 m and 1 m.
struct DiscrepancyOptions {
  int neighbours = 10;                    ///< k [-]
  double max_neighbour_distance_m = 1.0;  ///< [m]
  double max_plane_sigma_m = 0.02;        ///< √λ_min of the neighbours' covariance [m]
  double min_spread_ratio = 0.2;          ///< √(λ_mid/λ_max) [-]
  double max_extent_m = 0.3;              ///< √λ_max [m]
  std::size_t max_queries = 200000;       ///< larger query strips are strided evenly [-]
  bool from_spacing = true;               ///< widen the size gates for sparse strips (above)
  bool IsValid(std::string* why) const;
  /// The gates used against a reference strip of mean plan spacing `spacing_m`.
  DiscrepancyOptions forSpacing(double spacing_m) const;
};

struct DiscrepancyStats {
  std::size_t queries = 0;                                        ///< points of the smaller strip examined
  std::size_t used = 0;                                           ///< points that passed the gates
  double median_m = NAN, rms_m = NAN, p90_m = NAN, mean_m = NAN;  ///< of |distance| [m]
};

/// One strip pair: `query` is the smaller strip, `reference` the larger.
struct PairDiscrepancy {
  std::string query, reference;
  DiscrepancyStats stats;
};

/// The statistics of `query` points against `reference`'s local planes.
DiscrepancyStats pointToPlaneDiscrepancy(const std::vector<Vec3>& query, const std::vector<Vec3>& reference,
                                         const DiscrepancyOptions& options = {});

/// Every strip's points georeferenced with `mounting` (per-point poses or the trajectory).
/// With `lasers` (by laser id, a result's intrinsics) each laser vector is first corrected by its
/// laser's intrinsics (correctLaserVector), as `apply` writes the strips; InvalidInput for a laser
/// id without them.
std::vector<std::vector<Vec3>> georeferencedStrips(const CalibrationData& data, const MountingParameters& mounting,
                                                   const LaserCorrections& lasers = {});
/// One strip of `data` (`strip` is one of data.strips) as georeferencedStrips gives it.
std::vector<Vec3> georeferencedStrip(const CalibrationData& data, const StripData& strip, const MountingParameters& mounting,
                                     const LaserCorrections& lasers = {});

/// Every strip pair of `data` georeferenced with `mounting` (per-point poses or the
/// trajectory); pairs whose smaller strip has no point within reach of the larger are left out.
/// Throws InvalidInput for invalid options.
std::vector<PairDiscrepancy> passDiscrepancies(const CalibrationData& data, const MountingParameters& mounting,
                                               const DiscrepancyOptions& options = {});

/// One class of a discrepancy breakdown: what it holds and the statistics of its points.
struct DiscrepancyClass {
  std::string label;  ///< e.g. "laser 7", "0.3-0.4 of the pass", "12.1-20.5 m", "15-30 deg"
  DiscrepancyStats stats;
};

/// Where the pass-to-pass discrepancy lies (issue 28: the tail of the real data). The used points
/// of every pair, classed by
/// - `by_laser`: the laser that measured the query point (strips with laser ids; empty otherwise);
/// - `by_place`: its place along its strip, in tenths of the strip's time span (of its record
///   order when every point has the same time);
/// - `by_range`: its range |r_s|, five classes bounded at the quintiles of the examined points'
///   ranges — the same classes before and after a calibration;
/// - `by_tilt`: the tilt of the reference surface (the local plane's normal from the vertical),
///   in 15° classes.
/// A class's `queries` counts its examined query points (for tilt, which needs a plane, its used
/// points). Classes with no examined point are left out.
/// A plan-view map of the discrepancy: the used query points' |distance| in square cells of the
/// mapping frame's x, y, the median per cell (NaN where no used point lies). At most
/// kMaxCells cells along the longer side, none smaller than 0.05 m.
struct DiscrepancyMap {
  static constexpr int kMaxCells = 80;
  double x0_m = 0, y1_m = 0;  ///< west and north edges [m]
  double cell_m = 0;          ///< [m]
  int nx = 0, ny = 0;
  std::vector<float> median_m;  ///< ny × nx, row-major from the north [m]
  double median_all_m = NAN;    ///< of every used point [m]
  bool empty() const { return nx == 0 || ny == 0; }
  /// The cell value at (x, y) [m] (NaN outside or where no point lies).
  double at(double x_m, double y_m) const;
};

struct DiscrepancyBreakdown {
  std::vector<DiscrepancyClass> by_laser, by_place, by_range, by_tilt;
  DiscrepancyMap map;  ///< where in plan view (the residual map of the report)
};

/// One class of a group, before and after a calibration.
struct DiscrepancyClassChange {
  std::string label;
  bool in_before = false;   ///< the class had points before (its classes are those after)
  DiscrepancyStats before;  ///< default (NaN) when !in_before
  DiscrepancyStats after;
};
/// One group of the breakdown before and after: the classes after, in order, each with its figures
/// before (matched by label).
struct DiscrepancyGroupChange {
  std::string key;    ///< "by_laser", "by_place", "by_range", "by_tilt" (the result file's keys)
  std::string title;  ///< "laser", "place along the pass", "range", "surface tilt"
  std::vector<DiscrepancyClassChange> classes;
};
/// The four groups of two breakdowns side by side (what the console, the result file and the
/// report show as "where the discrepancy lies").
std::vector<DiscrepancyGroupChange> compareBreakdowns(const DiscrepancyBreakdown& before, const DiscrepancyBreakdown& after);

/// The pairs (as passDiscrepancies) and their breakdown, from one georeferencing of `data` at
/// `mounting`. Throws InvalidInput for invalid options.
struct DiscrepancyReport {
  std::vector<PairDiscrepancy> pairs;
  DiscrepancyBreakdown breakdown;
};
DiscrepancyReport discrepancyReport(const CalibrationData& data, const MountingParameters& mounting,
                                    const DiscrepancyOptions& options = {});

/// The statistics over every pair's used points together (a pair's points are weighted by count).
DiscrepancyStats pooledDiscrepancy(const CalibrationData& data, const MountingParameters& mounting, const DiscrepancyOptions& options = {});

}  // namespace mountcal
