#include "mountcal/core/geodesy.hpp"

#include <cmath>

namespace mountcal {

namespace {
constexpr double kA = 6378137.0;            // WGS84 semi-major axis [m]
constexpr double kF = 1.0 / 298.257223563;  // flattening
constexpr double kE2 = kF * (2.0 - kF);     // first eccentricity squared
constexpr double kB = kA * (1.0 - kF);
constexpr double kEp2 = kE2 / (1.0 - kE2);  // second eccentricity squared
}  // namespace

Vec3 geodeticToEcef(const Geodetic& g) {
  const double s = std::sin(g.lat), c = std::cos(g.lat);
  const double N = kA / std::sqrt(1.0 - kE2 * s * s);
  return {(N + g.h) * c * std::cos(g.lon), (N + g.h) * c * std::sin(g.lon), (N * (1.0 - kE2) + g.h) * s};
}

Geodetic ecefToGeodetic(const Vec3& x) {
  const double p = std::hypot(x.x(), x.y());
  Geodetic g;
  g.lon = std::atan2(x.y(), x.x());
  // Bowring's initial value, then fixed-point refinement.
  const double theta = std::atan2(x.z() * kA, p * kB);
  double lat = std::atan2(x.z() + kEp2 * kB * std::pow(std::sin(theta), 3), p - kE2 * kA * std::pow(std::cos(theta), 3));
  double h = 0.0;
  for (int it = 0; it < 3; ++it) {
    const double s = std::sin(lat);
    const double N = kA / std::sqrt(1.0 - kE2 * s * s);
    h = p / std::cos(lat) - N;
    lat = std::atan2(x.z(), p * (1.0 - kE2 * N / (N + h)));
  }
  const double s = std::sin(lat);
  const double N = kA / std::sqrt(1.0 - kE2 * s * s);
  g.lat = lat;
  g.h = std::abs(std::cos(lat)) > 1e-10 ? p / std::cos(lat) - N : std::abs(x.z()) - kB;
  return g;
}

Mat3 R_en(double lat, double lon) {
  const double sl = std::sin(lat), cl = std::cos(lat), so = std::sin(lon), co = std::cos(lon);
  Mat3 R;  // columns: North, East, Down in ECEF
  R << -sl * co, -so, -cl * co, -sl * so, co, -cl * so, cl, 0, -sl;
  return R;
}

Mat3 R_e_enu(double lat, double lon) {
  const double sl = std::sin(lat), cl = std::cos(lat), so = std::sin(lon), co = std::cos(lon);
  Mat3 R;  // columns: East, North, Up in ECEF
  R << -so, -sl * co, cl * co, co, -sl * so, cl * so, 0, cl, sl;
  return R;
}

LocalTangentFrame::LocalTangentFrame(const Geodetic& origin)
    : origin_(origin), origin_e_(geodeticToEcef(origin)), R_m_e_(R_e_enu(origin.lat, origin.lon).transpose()) {}

Vec3 LocalTangentFrame::toLocal(const Geodetic& g) const { return R_m_e_ * (geodeticToEcef(g) - origin_e_); }

Geodetic LocalTangentFrame::toGeodetic(const Vec3& x_m) const { return ecefToGeodetic(origin_e_ + R_m_e_.transpose() * x_m); }

Mat3 LocalTangentFrame::R_mn(double lat, double lon) const { return R_m_e_ * R_en(lat, lon); }

}  // namespace mountcal
