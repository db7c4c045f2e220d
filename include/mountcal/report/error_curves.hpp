#pragma once
/// \file error_curves.hpp
/// The first paper's Figs 1–3: the georeferencing error a boresight misalignment causes for a
/// line scanner, as a function of scan angle and range (SPEC §2 "The paper's error curves").

#include <string>
#include <vector>

#include "mountcal/core/rotation.hpp"

namespace mountcal {

/// One point of the error curves; errors in body axes (x forward, y right, z down) [m].
struct ErrorCurveSample {
  double scan_angle_rad = 0.0;        ///< θ, positive to starboard [rad]
  double range_m = 0.0;               ///< ρ [m]
  Vec3 exact_b = Vec3::Zero();        ///< error from the library's exact georeferencing [m]
  Vec3 first_order_b = Vec3::Zero();  ///< first-order form of SPEC §2 [m]
};

/// First-order boresight error of a line scanner (SPEC §2):
/// `e_b ≈ ρ (φ cos θ − κ sin θ, −ω cos θ, ω sin θ)`, boresight = (ω, φ, κ) [rad].
Vec3 boresightErrorFirstOrder(const Vec3& boresight, double scan_angle_rad, double range_m);

/// Computes the curves with the library's GeoreferenceModel: a level flight (heading 0, zero
/// lever arm, local frame) georeferenced once with `boresight` and once with none; the
/// difference is rotated back into body axes. One sample per (range, angle) pair, ranges outer.
std::vector<ErrorCurveSample> boresightErrorCurves(const Vec3& boresight, const std::vector<double>& scan_angles_rad,
                                                   const std::vector<double>& ranges_m);

/// The curves at a survey's own beams, for any scanner (the report's Figs 1–3; issue 28: a
/// drone's VLP-16 is not a line scanner's ±30° scan). Each beam's direction in body axes at the
/// mounting used, u_b = R_bs,used r̂_s, is binned by its angle about the body's forward axis,
/// θ = atan2(u_y, u_z) — a line scanner's scan angle, a multi-beam scanner on its side its spin
/// angle. Per bin and range: `exact_b` = ρ (R_bs,new R_bs,usedᵀ − I) ū_b of the bin's mean
/// direction ū_b (the error of its points if the change were ignored), `first_order_b` = ρ δ × ū_b
/// with δ the rotation vector of R_bs,new R_bs,usedᵀ (for a line scanner's beams SPEC §2's form),
/// `scan_angle_rad` the angle of ū_b. Bins of fewer than `min_beams` beams are left out; ranges
/// outer, angles ascending. Zero-length vectors are skipped.
std::vector<ErrorCurveSample> beamErrorCurves(const Mat3& R_bs_used, const Mat3& R_bs_new, const std::vector<Vec3>& r_s,
                                              const std::vector<double>& ranges_m, double bin_deg = 2.0, int min_beams = 5);

/// CSV table: `range_m,scan_angle_deg,exact_x_m,exact_y_m,exact_z_m,first_x_m,first_y_m,first_z_m`.
std::string errorCurvesCsv(const std::vector<ErrorCurveSample>& samples);

/// SVG plot of one body axis (0 = along-track x, 1 = cross-track y, 2 = vertical z) against
/// scan angle, one curve per range.
std::string errorCurveSvg(const std::vector<ErrorCurveSample>& samples, int axis, const std::string& title);

/// Writes `dir`/fig_errors.csv and the three plots fig1_x.svg, fig2_y.svg, fig3_z.svg, each
/// through a temporary file. `boresight_deg` labels the titles. Throws FileError.
void writeErrorCurves(const std::string& dir, const std::vector<ErrorCurveSample>& samples, double boresight_deg);

}  // namespace mountcal
