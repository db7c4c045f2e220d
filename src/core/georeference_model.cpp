#include "mountcal/core/georeference_model.hpp"

#include <algorithm>
#include <cmath>

#include "mountcal/core/error.hpp"
#include "core/interval_expansion.hpp"
#include "core/parallel.hpp"
#include "core/sincos_batch.hpp"

namespace mountcal {

GeoreferenceModel::GeoreferenceModel(std::shared_ptr<const Trajectory> trajectory, MountingParameters mounting)
    : trajectory_(std::move(trajectory)), mounting_(mounting), R_bs_(mounting.R_bs()) {
  if (!trajectory_ || trajectory_->size() < 2) {
    throw InvalidInput("GeoreferenceModel: the trajectory needs at least 2 samples");
  }
  if (!mounting_.a_b.allFinite() || !mounting_.boresight.allFinite() || !mounting_.R_nom.allFinite()) {
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

using detail::expandInterval;
using detail::forwardExpanded;
using detail::IntervalExpansion;
using detail::kTerms;

/// The batch forward of every pulse k with laser vector laser(k): the interval walk, the
/// expansion per interval, the exact slerp where an interval turns too fast. `cursor` and `e`
/// carry the walk from one call to the next.
template <typename LaserVector>
void forwardBatch(const Trajectory& T, const Mat3& R_bs, const Vec3& a, const double* time_s, double* x_m, std::size_t n, LaserVector laser,
                  std::size_t* cursor, IntervalExpansion* e) {
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = T.locate(time_s[k], cursor);
    const Vec3 r = laser(k);
    if (i != e->interval) expandInterval(T, i, R_bs, a, false, e);
    Eigen::Map<Vec3>(x_m + 3 * k) =
        e->exact ? georeference(T.interpolateInInterval(i, time_s[k]), R_bs, a, r) : forwardExpanded(*e, time_s[k], r);
  }
}

}  // namespace

void GeoreferenceModel::forward(const double* time_s, const double* r_s, double* x_m, std::size_t n) const {
  std::size_t cursor = 0;
  IntervalExpansion e;
  forwardBatch(
      *trajectory_, R_bs_, mounting_.a_b, time_s, x_m, n, [&](std::size_t k) { return Vec3(r_s[3 * k], r_s[3 * k + 1], r_s[3 * k + 2]); },
      &cursor, &e);
}

void GeoreferenceModel::inverse(const double* time_s, const double* x_m, double* r_s, std::size_t n) const {
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

void GeoreferenceModel::forwardLineScan(const LineScannerModel& scanner, const double* time_s, const double* scan_angle_rad,
                                        const double* range_m, double* x_m, std::size_t n) const {
  // Blocks of pulses: the scan angles' sines and cosines in one vectorised loop
  // (sincos_batch.hpp), then the laser vectors of SPEC §2 (0, ρ sin θ, ρ cos θ) as
  // LineScannerModel::vector forms them.
  constexpr std::size_t kBlock = 512;
  double theta[kBlock], sin_theta[kBlock], cos_theta[kBlock], rho[kBlock];
  std::size_t cursor = 0;
  IntervalExpansion e;
  for (std::size_t k0 = 0; k0 < n; k0 += kBlock) {
    const std::size_t m = std::min(kBlock, n - k0);
    for (std::size_t k = 0; k < m; ++k) {
      theta[k] = scanner.scan_angle_scale * scan_angle_rad[k0 + k] + scanner.scan_angle_offset_rad;
      rho[k] = range_m[k0 + k] + scanner.range_offset_m;
    }
    detail::sinCosBatch(theta, sin_theta, cos_theta, m);
    forwardBatch(
        *trajectory_, R_bs_, mounting_.a_b, time_s + k0, x_m + 3 * k0, m,
        [&](std::size_t k) { return Vec3(0.0, rho[k] * sin_theta[k], rho[k] * cos_theta[k]); }, &cursor, &e);
  }
}

void reGeoreference(const GeoreferenceModel& from, const GeoreferenceModel& to, const double* time_s, const double* x_m, double* x_out,
                    std::size_t n, int threads) {
  constexpr std::size_t kBlock = 4096;
  detail::parallelFor((n + kBlock - 1) / kBlock, threads, [&](std::size_t b) {
    const std::size_t k0 = b * kBlock, m = std::min(kBlock, n - k0);
    double r_s[3 * kBlock];
    from.inverse(time_s + k0, x_m + 3 * k0, r_s, m);
    to.forward(time_s + k0, r_s, x_out + 3 * k0, m);
  });
}

}  // namespace mountcal
