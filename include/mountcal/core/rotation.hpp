#pragma once
/// \file rotation.hpp
/// Elementary rotations and the frames of SPEC §2.
///
/// Frames: m mapping (x East, y North, z Up), n navigation (x North, y East, z Down),
/// b body/IMU (x forward, y right, z down), s scanner. A matrix `R_ab` maps a vector expressed
/// in frame b into frame a: `v_a = R_ab * v_b`. All angles are radians.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace mountcal {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Quat = Eigen::Quaterniond;

constexpr double kPi = 3.14159265358979323846;
constexpr double deg2rad(double deg) { return deg * (kPi / 180.0); }
constexpr double rad2deg(double rad) { return rad * (180.0 / kPi); }

/// Active right-handed rotation about x by `a` [rad].
inline Mat3 Rx(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Mat3 R;
  R << 1, 0, 0, 0, c, -s, 0, s, c;
  return R;
}
/// Active right-handed rotation about y by `a` [rad].
inline Mat3 Ry(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Mat3 R;
  R << c, 0, s, 0, 1, 0, -s, 0, c;
  return R;
}
/// Active right-handed rotation about z by `a` [rad].
inline Mat3 Rz(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Mat3 R;
  R << c, -s, 0, s, c, 0, 0, 0, 1;
  return R;
}

/// Body-to-navigation attitude, aerospace 3-2-1 sequence (SPEC §2):
/// `R_nb = Rz(heading) · Ry(pitch) · Rx(roll)`, heading clockwise from North [rad].
inline Mat3 R_nb(double roll, double pitch, double heading) { return Rz(heading) * Ry(pitch) * Rx(roll); }

/// Roll, pitch, heading [rad] of a body-to-navigation matrix (inverse of R_nb()).
/// Heading is returned in (-π, π]; pitch in [-π/2, π/2].
inline Vec3 rollPitchHeading(const Mat3& R_nb_) {
  const double pitch = std::asin(std::max(-1.0, std::min(1.0, -R_nb_(2, 0))));
  const double roll = std::atan2(R_nb_(2, 1), R_nb_(2, 2));
  const double heading = std::atan2(R_nb_(1, 0), R_nb_(0, 0));
  return {roll, pitch, heading};
}

/// Navigation (NED) to mapping (ENU) for a local job: `[[0,1,0],[1,0,0],[0,0,-1]]` (SPEC §2).
inline Mat3 R_mn_local() {
  Mat3 R;
  R << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  return R;
}

/// The Z-Y-X (3-2-1) rotation `Rz(z)·Ry(y)·Rx(x)` of a small-angle triple (ω, φ, κ) [rad]; the
/// boresight matrix of SPEC §2.
inline Mat3 R_zyx(const Vec3& xyz) { return Rz(xyz.z()) * Ry(xyz.y()) * Rx(xyz.x()); }

/// Rotation vector (axis · angle [rad]) of a unit quaternion, angle in [0, π].
inline Vec3 quatLog(const Quat& q_in) {
  Quat q = q_in.w() < 0 ? Quat(-q_in.w(), -q_in.x(), -q_in.y(), -q_in.z()) : q_in;
  const double n = q.vec().norm();
  if (n < 1e-12) return 2.0 * q.vec();  // first order; exact to O(n^3)
  return (2.0 * std::atan2(n, q.w()) / n) * q.vec();
}

/// Unit quaternion of a rotation vector (axis · angle [rad]). Below 0.01 rad the half-angle
/// sine and cosine come from their Taylor series (the first omitted term is < 1e-21 relative),
/// which spares the square root and the trigonometry on the hot path of trajectory slerp.
inline Quat quatExp(const Vec3& rotvec) {
  const double a2 = rotvec.squaredNorm();
  if (a2 < 1e-4) {
    const double h2 = 0.25 * a2;  // (angle/2)²
    const double c = 1.0 - h2 / 2.0 * (1.0 - h2 / 12.0 * (1.0 - h2 / 30.0 * (1.0 - h2 / 56.0)));
    const double s = 0.5 * (1.0 - h2 / 6.0 * (1.0 - h2 / 20.0 * (1.0 - h2 / 42.0 * (1.0 - h2 / 72.0))));
    return Quat(c, s * rotvec.x(), s * rotvec.y(), s * rotvec.z());
  }
  const double angle = std::sqrt(a2);
  const double half = 0.5 * angle;
  const double s = std::sin(half) / angle;
  return Quat(std::cos(half), s * rotvec.x(), s * rotvec.y(), s * rotvec.z());
}

/// Spherical linear interpolation from q0 (s = 0) to q1 (s = 1) along the shorter arc.
inline Quat slerp(const Quat& q0, const Quat& q1, double s) { return (q0 * quatExp(s * quatLog(q0.conjugate() * q1))).normalized(); }

}  // namespace mountcal
