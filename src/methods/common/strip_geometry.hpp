#pragma once
// Internal helpers shared by the methods (not installed): strip points at the mounting used and
// the mounting's motion of a point (plane fits and the plan grid: geometry/point_geometry.hpp).

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "mountcal/data.hpp"
#include "geometry/point_geometry.hpp"
#include "mountcal/core/georeference_model.hpp"

namespace mountcal::detail {

/// How a point moves from the mounting used to mounting m: SPEC §2 eq. (1) differenced,
///   x(M) − x(M_used) = R_mb [ (R_bs(M) − R_bs(M_used)) r_s + (a_b − a_b,used) ],
/// which is exact (p_m cancels), so kilometre-size coordinates never enter a difference.
struct MountingMotion {
  Mat3 dR_bs = Mat3::Zero();
  Vec3 da_b = Vec3::Zero();
  MountingMotion() = default;
  MountingMotion(const Mat3& R_nom, const Mat3& R_bs_used, const Vec3& a_used, const double* m6)
      : dR_bs(R_zyx(Vec3(m6[3], m6[4], m6[5])) * R_nom - R_bs_used), da_b(Vec3(m6[0], m6[1], m6[2]) - a_used) {}
  Vec3 displacement(const Mat3& R_mb, const Vec3& r_s) const { return R_mb * (dR_bs * r_s + da_b); }
};

/// MountingMotion for m6, remembered per thread (the last sixteen inputs, compared exactly): a
/// point residual differentiated by central differences asks for the same thirteen mountings
/// (the current one and ± each of the six) at every point, and building the rotation was most of
/// its cost.
inline MountingMotion cachedMountingMotion(const Mat3& R_nom, const Mat3& R_bs_used, const Vec3& a_used, const double* m6) {
  constexpr int kKey = 27, kSlots = 16;
  struct Slot {
    double key[kKey];
    MountingMotion motion;
  };
  thread_local Slot slots[kSlots];
  thread_local int filled = 0, next = 0;
  double key[kKey];
  std::copy(m6, m6 + 6, key);
  std::copy(R_nom.data(), R_nom.data() + 9, key + 6);
  std::copy(R_bs_used.data(), R_bs_used.data() + 9, key + 15);
  std::copy(a_used.data(), a_used.data() + 3, key + 24);
  for (int i = 0; i < filled; ++i)
    if (std::equal(key, key + kKey, slots[i].key)) return slots[i].motion;  // NaN never equal: recomputed
  Slot& s = slots[next];
  std::copy(key, key + kKey, s.key);
  s.motion = MountingMotion(R_nom, R_bs_used, a_used, m6);
  next = (next + 1) % kSlots;
  filled = std::min(filled + 1, kSlots);
  return s.motion;
}

/// The strip's points at `used` (StripData::x_m, or computed through the per-point poses or the trajectory).
inline std::vector<Vec3> referencePoints(const CalibrationData& data, const StripData& s, const MountingParameters& used) {
  if (!s.x_m.empty()) return s.x_m;
  std::vector<Vec3> x(s.r_s.size());
  std::size_t cursor = 0;
  const Mat3 R_bs = used.R_bs();
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = georeference(data.pose(s, i, &cursor), R_bs, used.a_b, s.r_s[i]);
  return x;
}

}  // namespace mountcal::detail
