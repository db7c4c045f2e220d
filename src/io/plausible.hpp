#pragma once
// Internal: physical range checks of trajectory records, shared by the CSV and SBET readers.
// An attitude of 1e300 degrees or a position jump of 1e300 m is finite, but no platform flies
// it: refuse it naming the record instead of calibrating with it.
#include <cmath>
#include <cstdio>
#include <string>

#include "mountcal/core/error.hpp"
#include "mountcal/core/rotation.hpp"

namespace mountcal::io::detail {

constexpr double kMaxPlatformSpeed = 1000.0;  // m/s: above any survey aircraft
constexpr double kMaxAbsHeight = 1e5;         // m

/// Roll within ±180°, pitch within ±90°, heading (and wander) within ±720° [rad].
inline void checkAttitude(double roll, double pitch, double heading, const std::string& path, const std::string& where) {
  const double tol = 1e-9;
  if (!(std::abs(roll) <= kPi + tol) || !(std::abs(pitch) <= kPi / 2 + tol) || !(std::abs(heading) <= 4 * kPi + tol)) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "attitude (roll %.6g, pitch %.6g, heading %.6g deg) is out of range (roll within ±180°, pitch ±90°, heading ±720°)",
                  rad2deg(roll), rad2deg(pitch), rad2deg(heading));
    throw FileError(path, where, buf);
  }
}

/// The speed between two records [m] at times t0 < t1 stays below kMaxPlatformSpeed.
inline void checkSpeed(double t0, const Vec3& p0, double t1, const Vec3& p1, const std::string& path, const std::string& where) {
  const double dt = t1 - t0, d = (p1 - p0).norm();
  if (!(dt > 0)) return;  // the time order is checked where it matters, with its own message
  if (!(d / dt <= kMaxPlatformSpeed)) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "the position jumps %.6g m in %.6g s from the previous record (%.3g m/s; no platform flies faster than %.0f m/s)", d, dt,
                  d / dt, kMaxPlatformSpeed);
    throw FileError(path, where, buf);
  }
}

}  // namespace mountcal::io::detail
