#pragma once
/// \file geodesy.hpp
/// WGS84 geodesy for geodetic jobs (SPEC §2): geodetic ⇄ ECEF, the NED and ENU frames, and a
/// local tangent (ENU) computation frame at a project origin with `R_mn(t) = R_{ENU0←ECEF} ·
/// R_{ECEF←NED}(lat(t), lon(t))` — earth curvature and meridian convergence included.

#include "mountcal/core/rotation.hpp"

namespace mountcal {

/// Geodetic coordinates on WGS84: latitude, longitude [rad], ellipsoidal height [m].
struct Geodetic {
  double lat = 0.0, lon = 0.0, h = 0.0;
};

Vec3 geodeticToEcef(const Geodetic& g);
/// Exact to < 1e-9 m for heights from −10 km to 100 km (Bowring start, three iterations).
Geodetic ecefToGeodetic(const Vec3& x_e);
/// Rotation NED → ECEF at (lat, lon).
Mat3 R_en(double lat, double lon);
/// Rotation ENU → ECEF at (lat, lon).
Mat3 R_e_enu(double lat, double lon);

/// An East-North-Up computation frame tangent to the ellipsoid at an origin.
class LocalTangentFrame {
 public:
  explicit LocalTangentFrame(const Geodetic& origin);
  const Geodetic& origin() const { return origin_; }
  Vec3 toLocal(const Geodetic& g) const;  ///< ENU coordinates [m]
  Geodetic toGeodetic(const Vec3& x_m) const;
  /// Navigation (NED at (lat, lon)) → this frame.
  Mat3 R_mn(double lat, double lon) const;

 private:
  Geodetic origin_;
  Vec3 origin_e_;
  Mat3 R_m_e_;  // ECEF → ENU0
};

}  // namespace mountcal
