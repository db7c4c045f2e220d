#pragma once
/// \file mounting.hpp
/// The mounting of a laser scanner on an IMU: lever arm and boresight angles (SPEC §2).

#include <array>
#include <string>

#include "mountcal/core/rotation.hpp"

namespace mountcal {

/// Index of each mounting parameter in the 6-vector used by the calibrators and the result
/// file: lever arm x, y, z [m] (body frame), then boresight ω (roll), φ (pitch), κ (heading) [rad].
enum MountingIndex : int {
  kLeverX = 0,
  kLeverY = 1,
  kLeverZ = 2,
  kBoresightRoll = 3,
  kBoresightPitch = 4,
  kBoresightHeading = 5,
};

/// Names of the six mounting parameters as they appear in results ("lever_arm_x", ...,
/// "boresight_heading").
const std::array<std::string, 6>& mountingParameterNames();

/// Lever arm and boresight of a scanner on an IMU, with its nominal installation rotation.
///
/// `R_bs = R_bore · R_nom` maps scanner vectors to the body frame (SPEC §2), with
/// `R_bore = Rz(κ) · Ry(φ) · Rx(ω)`.
struct MountingParameters {
  Vec3 a_b = Vec3::Zero();        ///< lever arm, IMU origin → scanner origin, body frame [m]
  Vec3 boresight = Vec3::Zero();  ///< (ω roll, φ pitch, κ heading) [rad], small
  Mat3 R_nom = Mat3::Identity();  ///< nominal installation rotation, scanner → body

  /// Boresight matrix `Rz(κ)·Ry(φ)·Rx(ω)`.
  Mat3 R_bore() const { return R_zyx(boresight); }
  /// Scanner-to-body rotation `R_bore · R_nom`.
  Mat3 R_bs() const { return R_bore() * R_nom; }

  /// The 6-vector (a_x, a_y, a_z [m], ω, φ, κ [rad]) in MountingIndex order.
  std::array<double, 6> toArray() const { return {a_b.x(), a_b.y(), a_b.z(), boresight.x(), boresight.y(), boresight.z()}; }
  /// Sets lever arm and boresight from a 6-vector in MountingIndex order; R_nom is unchanged.
  void setFromArray(const double* p) {
    a_b = Vec3(p[0], p[1], p[2]);
    boresight = Vec3(p[3], p[4], p[5]);
  }
  /// Same mounting with another lever arm/boresight 6-vector (R_nom kept).
  MountingParameters withArray(const double* p) const {
    MountingParameters m = *this;
    m.setFromArray(p);
    return m;
  }

  /// Builds a mounting from edge units: lever arm [m], boresight [deg], nominal rotation
  /// (roll, pitch, heading) [deg] composed as Rz·Ry·Rx.
  static MountingParameters fromDegrees(const Vec3& lever_arm_m, const Vec3& boresight_deg,
                                        const Vec3& nominal_rotation_deg = Vec3::Zero()) {
    MountingParameters m;
    m.a_b = lever_arm_m;
    m.boresight = boresight_deg * (kPi / 180.0);
    m.R_nom = R_zyx(nominal_rotation_deg * (kPi / 180.0));
    return m;
  }
  /// Boresight in degrees (edge units).
  Vec3 boresightDeg() const { return boresight * (180.0 / kPi); }
};

}  // namespace mountcal
