#pragma once
// Internal (not installed): the attitude of one trajectory interval expanded in the interval's
// parameter s, shared by the batch georeferencing (georeference_model.cpp) and the simulator's
// pulse loop (simulation/survey.cpp).

#include "mountcal/core/georeference_model.hpp"
#include "mountcal/core/trajectory.hpp"

namespace mountcal::detail {

// Thousands of pulses share one trajectory interval [t_i, t_{i+1}], where slerp gives
// R_mb(s) = R_i · Exp(s·A), A = [ω_i]×, s ∈ [0, 1]. Expanded in s once per interval,
//   R_mb(s) · (R_bs r_s + a) = Σ_{j=0..4} s^j (M_j r_s + m_j),  C_j = R_i A^j / j!,
//   M_j = C_j R_bs,  m_j = C_j a,
// a pulse costs five 3×3 products in Horner form instead of a quaternion exponential and a
// matrix (the position polynomial, linear or cubic Hermite, is folded into m_0..m_3). The series' remainder is at most |ω|⁵/120 · |R_bs r_s
// + a|: below 1e-11 m for |ω| ≤ 0.004 rad (46°/s at 200 Hz) and 3 km ranges. An interval turning faster takes the exact slerp.
inline constexpr double kMaxExpandedRotation_rad = 0.004;
inline constexpr int kTerms = 5;

struct IntervalExpansion {
  std::size_t interval = static_cast<std::size_t>(-1);
  bool exact = false;
  double t0 = 0, inv_h = 0;
  Mat3 M[kTerms];  // forward: C_j R_bs; inverse: R_bsᵀ C_jᵀ
  Vec3 m[kTerms];  // forward: C_j a + c_j (the position polynomial's coefficients folded in)
  Vec3 c[4];       // the position polynomial p(s) = Σ c_j s^j
};

inline void expandInterval(const Trajectory& T, std::size_t i, const Mat3& R_bs, const Vec3& a, bool inverse, IntervalExpansion* e) {
  e->interval = i;
  Mat3 C;
  Vec3 omega;
  T.intervalAttitude(i, &C, &omega);
  e->exact = !(omega.norm() <= kMaxExpandedRotation_rad);
  if (e->exact) return;
  e->t0 = T.times()[i];
  e->inv_h = 1.0 / (T.times()[i + 1] - T.times()[i]);
  T.intervalPosition(i, e->c);
  Mat3 A;
  A << 0, -omega.z(), omega.y(), omega.z(), 0, -omega.x(), -omega.y(), omega.x(), 0;
  for (int j = 0; j < kTerms; ++j) {
    if (j > 0) C = C * A / static_cast<double>(j);
    if (inverse) {
      e->M[j] = R_bs.transpose() * C.transpose();
    } else {
      e->M[j] = C * R_bs;
      e->m[j] = C * a + (j < 4 ? e->c[j] : Vec3::Zero());
    }
  }
}

/// x_m of the laser vector r at `time_s` from an expanded interval: Σ s^j (M_j r + m_j), Horner.
inline Vec3 forwardExpanded(const IntervalExpansion& e, double time_s, const Vec3& r) {
  const double s = (time_s - e.t0) * e.inv_h;
  Vec3 acc = e.M[kTerms - 1] * r + e.m[kTerms - 1];
  for (int j = kTerms - 2; j >= 0; --j) acc = acc * s + (e.M[j] * r + e.m[j]);
  return acc;  // seed eq. (1): p(s) + R_mb(s) (R_bs r_s + a)
}

/// The rotated part alone: R_mb(s) R_bs r = Σ s^j M_j r (a direction: no lever arm, no position).
inline Vec3 rotateExpanded(const IntervalExpansion& e, double time_s, const Vec3& r) {
  const double s = (time_s - e.t0) * e.inv_h;
  Vec3 acc = e.M[kTerms - 1] * r;
  for (int j = kTerms - 2; j >= 0; --j) acc = acc * s + e.M[j] * r;
  return acc;
}

/// forwardExpanded() of r = (0, y, z), a line scanner's laser vector: the zero component's
/// products left out (the same sums, so the same values).
inline Vec3 forwardExpandedYZ(const IntervalExpansion& e, double time_s, double y, double z) {
  const double s = (time_s - e.t0) * e.inv_h;
  Vec3 acc = e.M[kTerms - 1].col(1) * y + e.M[kTerms - 1].col(2) * z + e.m[kTerms - 1];
  for (int j = kTerms - 2; j >= 0; --j) acc = acc * s + (e.M[j].col(1) * y + e.M[j].col(2) * z + e.m[j]);
  return acc;
}

/// forwardExpanded() of r = 0: the lever arm's end, p(s) + R_mb(s) a, from the m_j alone.
inline Vec3 originExpanded(const IntervalExpansion& e, double time_s) {
  const double s = (time_s - e.t0) * e.inv_h;
  Vec3 acc = e.m[kTerms - 1];
  for (int j = kTerms - 2; j >= 0; --j) acc = acc * s + e.m[j];
  return acc;
}

/// The ray of one pulse, origin p(s) + R_mb(s)(R_bs o + a) and direction R_mb(s) R_bs u: the
/// sums of forwardExpanded(o) and rotateExpanded(u) in one pass, written on scalars. Most pulses of
/// a multi-beam sensor point away from the regions and are dropped after this: no Eigen temporaries
/// (which an unoptimised or instrumented build keeps in memory) for them.
inline void rayExpanded(const IntervalExpansion& e, double time_s, const Vec3& o, const Vec3& u, Vec3* origin, Vec3* dir) {
  const double s = (time_s - e.t0) * e.inv_h;
  double ox = 0, oy = 0, oz = 0, dx = 0, dy = 0, dz = 0;
  for (int j = kTerms - 1; j >= 0; --j) {
    const double* M = e.M[j].data();  // column-major
    const double* m = e.m[j].data();
    dx = dx * s + (M[0] * u[0] + M[3] * u[1] + M[6] * u[2]);
    dy = dy * s + (M[1] * u[0] + M[4] * u[1] + M[7] * u[2]);
    dz = dz * s + (M[2] * u[0] + M[5] * u[1] + M[8] * u[2]);
    ox = ox * s + (M[0] * o[0] + M[3] * o[1] + M[6] * o[2] + m[0]);
    oy = oy * s + (M[1] * o[0] + M[4] * o[1] + M[7] * o[2] + m[1]);
    oz = oz * s + (M[2] * o[0] + M[5] * o[1] + M[8] * o[2] + m[2]);
  }
  *origin = Vec3(ox, oy, oz);
  *dir = Vec3(dx, dy, dz);
}

/// rotateExpanded() of r = (0, y, z), the line scanner's scan direction (sin θ, cos θ): the
/// zero component's products left out.
inline Vec3 rotateExpandedYZ(const IntervalExpansion& e, double time_s, double y, double z) {
  const double s = (time_s - e.t0) * e.inv_h;
  Vec3 acc = e.M[kTerms - 1].col(1) * y + e.M[kTerms - 1].col(2) * z;
  for (int j = kTerms - 2; j >= 0; --j) acc = acc * s + (e.M[j].col(1) * y + e.M[j].col(2) * z);
  return acc;
}

}  // namespace mountcal::detail
