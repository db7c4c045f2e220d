#pragma once
/// \file report.hpp
/// A self-contained HTML report of a calibration (tables and inline SVG plots).

#include <string>
#include <vector>

#include "mountcal/job.hpp"

namespace mountcal {

/// The report as one HTML document: solver outcome, parameters with sigmas, observability,
/// correlations, per-observation residuals before/after (table and plot), rejected ties, and
/// check-data evaluation when given.
std::string htmlReport(const MountingCalibrator::Summary& summary, const ResultEvaluation* evaluation, const std::string& title);

/// What the visual report draws and where (issue 11). Lengths [m].
struct ReportOptions {
  std::string title = "mountcal calibration";
  /// A profile across an overlap along the line (x0, y0) → (x1, y1), points within width/2.
  struct ProfileLine {
    std::string id;
    double x0_m = 0, y0_m = 0, x1_m = 0, y1_m = 0;
    double width_m = 1.0;
  };
  std::vector<ProfileLine> profiles;  ///< user-given profiles, drawn after the automatic ones
  int automatic_profiles = 2;         ///< at the places where the strips disagreed most before
  /// The automatic profiles' length and width and the overlay's side; 0: from the data — the strips'
  /// largest common extent, at most 30 m and at least 20 point spacings (an
  /// aircraft's block: 30 m; a car seen from a drone: metres), a width of 3 point spacings at
  /// most 1 m — and the profiles' search cells of 4 spacings, at most 2 m.
  double profile_length_m = 0.0;
  double profile_width_m = 0.0;
  double overlay_size_m = 0.0;              ///< side of the intensity overlay's window
  int overlay_px = 180;                     ///< its pixels per side
  int map_px = 720;                         ///< width of the plan-view map
  std::size_t max_points_per_panel = 6000;  ///< larger point sets are thinned evenly for drawing
  bool swath_qc = true;                     ///< the swath QC section (docs/swath-qc.md), job's mounting against the result's
};

/// The visual report of a calibration: htmlReport's tables plus the correlation heat map, a
/// plan-view map (strip footprints and overlaps, ties with residual vectors before and after,
/// plane regions, targets), residual histograms per axis, elevation profiles across overlaps
/// before and after (the first paper's Fig. 10), an intensity overlay of two strips before and
/// after (Fig. 11), the error curves (Figs 1–3) at the estimated boresight, and warnings. One
/// self-contained HTML file: inline SVG and PNG, no scripts, no network. `data` is what was
/// calibrated (the "after" points are its points moved by the estimated mounting, SPEC §2 eq. 1).
std::string visualReport(const MountingCalibrator::Summary& summary, const CalibrationData& data, const ResultEvaluation* evaluation,
                         const ReportOptions& options = {});

/// An 8-bit RGB image as a PNG file (stored deflate blocks, CRC-32 and Adler-32 written here).
std::string encodePng(int width, int height, const std::vector<unsigned char>& rgb);
/// Base64 (RFC 4648) of `bytes`, for data URIs.
std::string base64(const std::string& bytes);

}  // namespace mountcal
