#pragma once
/// \file swath_qc.hpp
/// Swath-to-swath quality control (issue 29): the measures a survey is accepted by — the
/// interswath height differences on smooth open surfaces (RMSDz, mean, largest |dZ|, the share of
/// cells beyond thresholds) and each strip's intraswath smooth-surface precision — before and
/// after a mounting, with a verdict per quality level, dZ rasters and their GeoTIFF files.
///
/// The raster: cells of `cell_size_m` on the mapping frame's plan. In each cell every strip's
/// points (at least `min_points`) get a least-squares plane z = a + b x + c y about the cell's
/// centre; the cell is *smooth and open* for that strip when the plane's slope is at most
/// `max_slope_deg` and the RMS of the points' residuals to it (its roughness) at most
/// `max_roughness_m` — ASPRS/USGS measure swath differences on such surfaces only (no
/// vegetation, no building edges, no steep ground). dZ of a pair at a cell is a − a' (the two
/// planes at the cell's centre) where both strips are smooth.

#include <map>
#include <string>
#include <vector>

#include "mountcal/core/mounting.hpp"
#include "mountcal/data.hpp"
#include "mountcal/report/evaluation.hpp"

namespace mountcal {

/// One row of the verdict table: a quality level and its limits [m]; a limit ≤ 0 is not tested.
struct QualityLevel {
  std::string name;               ///< e.g. "USGS QL2"
  double intraswath_max_m = 0;    ///< smooth-surface repeatability (intraswath): within-cell range (StripQc::intraswath_max_m)
  double interswath_rmsdz_m = 0;  ///< interswath RMSDz
  double interswath_max_m = 0;    ///< interswath largest |dZ|
  std::string source;             ///< where the limits come from
};

/// The USGS Lidar Base Specification's data-precision limits for quality levels 0–3 (USGS
/// Techniques and Methods 11-B4, v1.2 2014 / v1.3 2018, the table "Data precision
/// requirements"; values as widely quoted — see docs/swath-qc.md for what was and was not
/// confirmed). Settable: SwathQcOptions::levels.
std::vector<QualityLevel> usgsQualityLevels();

/// The lidar relative-accuracy limits of an ASPRS vertical accuracy class of RMSE_V = `rmse_v_m`
/// ("X-cm class"): intraswath smooth-surface repeatability ≤ 0.6 X, interswath RMSDz ≤ 0.8 X,
/// largest interswath |dZ| ≤ 1.6 X (ASPRS Positional Accuracy Standards for Digital Geospatial
/// Data, Edition 1 2014, the table of lidar data internal precision; carried into Edition 2,
/// 2023 — see docs/swath-qc.md for what was and was not confirmed).
QualityLevel asprsVerticalClass(double rmse_v_m);

/// The ASPRS classes of 1, 2.5, 5, 10, 15, 20 and 33.3 cm (the standard's examples that lidar
/// reaches), each by asprsVerticalClass.
std::vector<QualityLevel> asprsVerticalClasses();

/// The default verdict table: usgsQualityLevels() then asprsVerticalClasses().
std::vector<QualityLevel> defaultQualityLevels();

struct SwathQcOptions {
  double cell_size_m = 0.0;       ///< raster cell [m]; 0: from the point spacing (below)
  int min_points = 8;             ///< points of one strip in a cell for its plane [-]
  double max_slope_deg = 10.0;    ///< smooth: the cell's plane at most this steep [deg]
  double max_roughness_m = 0.05;  ///< smooth: RMS of the residuals to the plane at most this [m]
  /// Sloped planes (roofs, the ASPRS 2018 roof-plane measure): cells steeper than max_slope_deg
  /// up to this slope whose points lie on a plane within max_roughness_m (along its normal) [deg].
  double max_plane_slope_deg = 60.0;
  bool sloped_planes = true;  ///< the sloped-plane measure (PairQc::sloped_planes_*)
  /// Conjugate planes: the two strips' planes in a cell differ in direction by at most this, or
  /// they see different surfaces there (occlusion), not one surface misaligned [deg].
  double max_plane_angle_deg = 10.0;
  /// Its own grid's cell [m]; 0: half the dZ cell (a roof face holds few cells of the dZ grid).
  double plane_cell_m = 0.0;
  /// Roof edges (PairQc::roof_edges_*): two planar cells of a strip within two cells of each other
  /// whose planes turn by more than this are two faces of a roof, and meet in a ridge or valley;
  /// each face's tilt determined to 1° by its points (roughness / (√n · spread)) [deg].
  double min_edge_turn_deg = 20.0;
  /// The intraswath within-cell range is taken in sub-cells of this size [m]; 0: twice the
  /// strip's mean plan spacing (about four points: 1 m at 0.5 m spacing). A range widens with
  /// the points it spans, so the measure is taken where a cell holds a few, as on the small
  /// cells of the USGS's smooth-surface repeatability test.
  double intraswath_cell_m = 0.0;
  /// Shares of cells with |dZ| beyond each of these are reported [m].
  std::vector<double> thresholds_m = {0.04, 0.08, 0.16};
  std::vector<QualityLevel> levels = defaultQualityLevels();
  /// The ASPRS 2018 guidelines' first 3-D measure beside dZ: each point of a pair's smaller strip
  /// against the tangent plane of the larger (pointToPlaneDiscrepancy, its gates from the
  /// spacing), at most `point_to_plane_queries` points per pair; it sees horizontal
  /// misalignment on sloped and vertical surfaces, which dZ on flat ground cannot.
  bool point_to_plane = true;
  std::size_t point_to_plane_queries = 20000;
  /// The cell size used when cell_size_m is 0: the sparsest strip's mean plan spacing s, a cell
  /// holding 2·min_points points at it, s·√(2·min_points), rounded up to 1-2-5 steps.
  double cellSizeFor(double spacing_m) const;
  bool IsValid(std::string* why) const;
};

/// A dZ raster of one strip pair: row 0 is the northernmost; NaN where a cell is not measured.
struct DzRaster {
  double x0_m = 0, y1_m = 0;  ///< west edge and north edge of the raster [m]
  double cell_m = 1;
  int nx = 0, ny = 0;
  std::vector<float> dz_m;  ///< ny × nx, row-major
};

struct DzStats {
  std::size_t cells = 0;  ///< cells where both strips are smooth
  double rmsdz_m = NAN, mean_dz_m = NAN, max_abs_dz_m = NAN;
  std::vector<double> share_over;  ///< per SwathQcOptions::thresholds_m [-]
};

struct PairQc {
  std::string a, b;
  DzStats before, after;
  /// The ASPRS 2018 roof-plane measure at cell scale: on the plane grid (SwathQcOptions::
  /// plane_cell_m), at the cells where both strips are planar
  /// and sloped (max_slope_deg < slope ≤ max_plane_slope_deg), the distance of B's centroid from
  /// A's plane along its normal (sign as dZ: A − B). A horizontal shift h across a roof of slope
  /// θ gives h·sin θ — what dZ on flat ground cannot see. `cells` counts those cells.
  DzStats sloped_planes_before, sloped_planes_after;
  /// The ASPRS 2018 roof-edge measure at cell scale: where two planar cells of A within two cells
  /// of each other turn by more than min_edge_turn_deg, the line where their planes meet (a ridge
  /// or valley between them), and the same two cells' line in B: B's distance from A's line,
  /// across it (unsigned; a horizontal shift h across a ridge gives h). `cells` counts the pairs
  /// of cells.
  DzStats roof_edges_before, roof_edges_after;
  /// Point to tangent plane (SwathQcOptions::point_to_plane), before and after; empty stats when off.
  DiscrepancyStats point_to_plane_before, point_to_plane_after;
  DzRaster raster_before, raster_after;
};

struct StripQc {
  std::string id;
  std::size_t smooth_cells = 0;
  double intraswath_precision_m = NAN;  ///< RMS of residuals to the cells' planes over smooth cells
  double intraswath_max_m = NAN;        ///< 95th percentile over sub-cells (intraswath_cell_m) of (max − min residual)
};

struct LevelVerdict {
  QualityLevel level;
  bool intraswath_pass = false, rmsdz_pass = false, max_pass = false;
  bool pass() const { return intraswath_pass && rmsdz_pass && max_pass; }
};

struct SwathQcResult {
  double cell_size_m = 0;
  double plane_cell_size_m = 0;                       ///< the sloped-plane measure's cell; 0 when it is off
  std::vector<double> thresholds_m;                   ///< SwathQcOptions::thresholds_m, for DzStats::share_over
  std::vector<PairQc> pairs;                          ///< the pairs with at least one common smooth or sloped-plane cell
  std::vector<StripQc> strips;                        ///< at the mounting after
  DzStats overall_before, overall_after;              ///< every pair's cells pooled
  DzStats sloped_planes_before, sloped_planes_after;  ///< every pair's sloped-plane distances pooled
  DzStats roof_edges_before, roof_edges_after;        ///< every pair's roof-edge distances pooled
  std::vector<LevelVerdict> verdicts;                 ///< at the mounting after
};

/// QC of `data` at `before` and `after` (the job's mounting and a result's; pass the same twice
/// for one state). Per-point poses or the trajectory, as the data hold them. A result's per-laser
/// intrinsics (by laser id; its `intrinsics`) are applied to the "after" state, as `apply` writes
/// it. Throws InvalidInput for invalid options or data without poses.
SwathQcResult swathQc(const CalibrationData& data, const MountingParameters& before, const MountingParameters& after,
                      const SwathQcOptions& options = {}, const LaserCorrections& lasers_after = {});

/// The same for strips already georeferenced (one point set per strip id, before and after), in
/// the frame the rasters are to be in (a CRS job's strips converted to its CRS).
SwathQcResult swathQcOfPoints(const std::vector<std::string>& ids, const std::vector<std::vector<Vec3>>& before,
                              const std::vector<std::vector<Vec3>>& after, const SwathQcOptions& options = {});

/// The dZ cell swathQcOfPoints takes when options.cell_size_m is 0: cellSizeFor the sparsest
/// strip's mean plan spacing. A block's pairs measured one by one need this cell, found once over
/// every strip (mountcal qc --print-cell), for their cells to be the whole block's.
double swathQcCellSize(const std::vector<std::vector<Vec3>>& strips, const SwathQcOptions& options = {});

/// Reads `qc.json` (swathQcJson) back; the rasters are not in it (they are in the GeoTIFFs), nor
/// the pooled figures and verdicts (mergeSwathQc makes them). Throws InvalidInput naming what is wrong.
SwathQcResult swathQcFromJson(const std::string& text);

/// QC results of disjoint pairs (one per pair, as the block workflow measures them, on one cell)
/// as one: the pairs in order, each strip once, the pooled figures from the pairs' own sums —
/// equal to one swathQcOfPoints over the same pairs — and the verdicts against `levels`.
/// Throws InvalidInput when the parts differ in cells or thresholds or share a pair.
SwathQcResult mergeSwathQc(const std::vector<SwathQcResult>& parts, const std::vector<QualityLevel>& levels = defaultQualityLevels());

/// The statistics of dZ values against `thresholds_m`.
DzStats dzStats(const std::vector<double>& dz, const std::vector<double>& thresholds_m);

/// `qc.json` (docs/swath-qc.md): pairs[], strips[], summary with the levels' pass/fail.
std::string swathQcJson(const SwathQcResult& qc);
/// `qc.html`: the tables and each pair's dZ map before and after, in the levels' classes.
std::string swathQcHtml(const SwathQcResult& qc, const std::string& title);
/// The same as a section of another page (the calibration report), headed at <h`level`>.
std::string swathQcSection(const SwathQcResult& qc, int level = 2);

}  // namespace mountcal
