#include "mountcal/georeference_model.hpp"

#include <cmath>

#include "mountcal/error.hpp"

namespace mountcal {

GeoreferenceModel::GeoreferenceModel(std::shared_ptr<const Trajectory> trajectory,
                                     MountingParameters mounting)
    : trajectory_(std::move(trajectory)), mounting_(mounting), R_bs_(mounting.R_bs()) {
  if (!trajectory_ || trajectory_->size() < 2) {
    throw InvalidInput("GeoreferenceModel: the trajectory needs at least 2 samples");
  }
  if (!mounting_.a_b.allFinite() || !mounting_.boresight.allFinite() ||
      !mounting_.R_nom.allFinite()) {
    throw InvalidInput("GeoreferenceModel: the mounting has a non-finite value");
  }
}

GeoreferenceModel::GeoreferenceModel(Trajectory trajectory, MountingParameters mounting)
    : GeoreferenceModel(std::make_shared<const Trajectory>(std::move(trajectory)), mounting) {}

void GeoreferenceModel::setMounting(const MountingParameters& mounting) {
  mounting_ = mounting;
  R_bs_ = mounting.R_bs();
}

Vec3 GeoreferenceModel::forward(double time_s, const Vec3& r_s) const {
  return georeference(trajectory_->pose(time_s), R_bs_, mounting_.a_b, r_s);  // seed eq. (1)
}

Vec3 GeoreferenceModel::inverse(double time_s, const Vec3& x_m) const {
  return inverseGeoreference(trajectory_->pose(time_s), R_bs_, mounting_.a_b, x_m);
}

namespace {

// Thousands of pulses share one trajectory interval [t_i, t_{i+1}], where slerp gives
// R_mb(s) = R_i · Exp(s·A), A = [ω_i]×, s ∈ [0, 1]. Expanded in s once per interval,
//   R_mb(s) · (R_bs r_s + a) = Σ_{j=0..4} s^j (M_j r_s + m_j),  C_j = R_i A^j / j!,
//   M_j = C_j R_bs,  m_j = C_j a,
// a pulse costs five 3×3 products in Horner form instead of a quaternion exponential and a
// matrix (the position polynomial, linear or cubic Hermite, is folded into m_0..m_3). The series' remainder is at most |ω|⁵/120 · |R_bs r_s + a|: below 1e-11 m for
// |ω| ≤ 0.004 rad (46°/s at 200 Hz) and 3 km ranges. An interval turning faster takes the
// exact slerp.
constexpr double kMaxExpandedRotation_rad = 0.004;
constexpr int kTerms = 5;

struct IntervalExpansion {
  std::size_t interval = static_cast<std::size_t>(-1);
  bool exact = false;
  double t0 = 0, inv_h = 0;
  Mat3 M[kTerms];  // forward: C_j R_bs; inverse: R_bsᵀ C_jᵀ
  Vec3 m[kTerms];  // forward: C_j a + c_j (the position polynomial's coefficients folded in)
  Vec3 c[4];       // the position polynomial p(s) = Σ c_j s^j
};

void expandInterval(const Trajectory& T, std::size_t i, const Mat3& R_bs, const Vec3& a, bool inverse,
                    IntervalExpansion* e) {
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

/// The batch forward of every pulse k with laser vector laser(k): the interval walk, the
/// expansion per interval, the exact slerp where an interval turns too fast.
template <typename LaserVector>
void forwardBatch(const Trajectory& T, const Mat3& R_bs, const Vec3& a, const double* time_s, double* x_m, std::size_t n,
                  LaserVector laser) {
  std::size_t cursor = 0;
  IntervalExpansion e;
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = T.locate(time_s[k], &cursor);
    const Vec3 r = laser(k);
    if (i != e.interval) expandInterval(T, i, R_bs, a, false, &e);
    Eigen::Map<Vec3>(x_m + 3 * k) =
        e.exact ? georeference(T.interpolateInInterval(i, time_s[k]), R_bs, a, r) : forwardExpanded(e, time_s[k], r);
  }
}

}  // namespace

void GeoreferenceModel::forward(const double* time_s, const double* r_s, double* x_m,
                                std::size_t n) const {
  forwardBatch(*trajectory_, R_bs_, mounting_.a_b, time_s, x_m, n,
               [&](std::size_t k) { return Vec3(r_s[3 * k], r_s[3 * k + 1], r_s[3 * k + 2]); });
}

void GeoreferenceModel::inverse(const double* time_s, const double* x_m, double* r_s,
                                std::size_t n) const {
  std::size_t cursor = 0;
  IntervalExpansion e;
  const Vec3 a_s = R_bs_.transpose() * mounting_.a_b;
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = trajectory_->locate(time_s[k], &cursor);
    const Eigen::Map<const Vec3> x(x_m + 3 * k);
    if (i != e.interval) expandInterval(*trajectory_, i, R_bs_, mounting_.a_b, true, &e);
    if (e.exact) {
      Eigen::Map<Vec3>(r_s + 3 * k) = inverseGeoreference(trajectory_->interpolateInInterval(i, time_s[k]), R_bs_, mounting_.a_b, x);
      continue;
    }
    // r_s = R_bsᵀ (R_mb(s)ᵀ (x − p) − a) = Σ s^j R_bsᵀ C_jᵀ (x − p) − R_bsᵀ a
    const double s = (time_s[k] - e.t0) * e.inv_h;
    const Vec3 d = x - (((e.c[3] * s + e.c[2]) * s + e.c[1]) * s + e.c[0]);
    Vec3 acc = e.M[kTerms - 1] * d;
    for (int j = kTerms - 2; j >= 0; --j) acc = acc * s + e.M[j] * d;
    Eigen::Map<Vec3>(r_s + 3 * k) = acc - a_s;
  }
}

void GeoreferenceModel::forwardLineScan(const LineScannerModel& scanner, const double* time_s,
                                        const double* scan_angle_rad, const double* range_m,
                                        double* x_m, std::size_t n) const {
  forwardBatch(*trajectory_, R_bs_, mounting_.a_b, time_s, x_m, n,
               [&](std::size_t k) { return scanner.vector(scan_angle_rad[k], range_m[k]); });
}

}  // namespace mountcal
