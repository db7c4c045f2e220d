#pragma once
/// \file georeference_model.hpp
/// Direct and inverse georeferencing of laser pulses (SPEC §2; seed 000 eq. 1):
///
///   x_m = p_m(t) + R_mn(t) · R_nb(t) · ( R_bore · R_nom · r_s + a_b )
///
/// and its inverse
///
///   r_s = (R_bore R_nom)ᵀ · ( (R_mn R_nb)ᵀ (x_m − p_m(t)) − a_b ).

#include <cstddef>
#include <memory>

#include "mountcal/core/mounting.hpp"
#include "mountcal/core/sensor_model.hpp"
#include "mountcal/core/trajectory.hpp"

namespace mountcal {

/// seed 000 eq. (1) for a known pose: x_m = p_m + R_mb (R_bs r_s + a_b).
inline Vec3 georeference(const Pose& pose, const Mat3& R_bs, const Vec3& a_b, const Vec3& r_s) {
  return pose.p_m + pose.R_mb * (R_bs * r_s + a_b);
}
/// Inverse of georeference(): r_s = R_bsᵀ (R_mbᵀ (x_m − p_m) − a_b).
inline Vec3 inverseGeoreference(const Pose& pose, const Mat3& R_bs, const Vec3& a_b, const Vec3& x_m) {
  return R_bs.transpose() * (pose.R_mb.transpose() * (x_m - pose.p_m) - a_b);
}

/// A trajectory and a mounting: georeferences pulses one at a time or in batches.
///
/// Batches take contiguous arrays, walk the trajectory with a cursor (O(1) per pulse when the
/// times are sorted; unsorted times are handled, only slower) and allocate nothing per pulse.
/// Thread-safe for concurrent const use.
class GeoreferenceModel {
 public:
  /// Throws InvalidInput if `trajectory` is null or has fewer than two samples.
  GeoreferenceModel(std::shared_ptr<const Trajectory> trajectory, MountingParameters mounting);
  GeoreferenceModel(Trajectory trajectory, MountingParameters mounting);

  const Trajectory& trajectory() const { return *trajectory_; }
  const std::shared_ptr<const Trajectory>& trajectoryPtr() const { return trajectory_; }
  const MountingParameters& mounting() const { return mounting_; }
  void setMounting(const MountingParameters& mounting);

  /// x_m [m] of the laser vector r_s [m] emitted at `time_s`. Throws TimeOutOfRange.
  Vec3 forward(double time_s, const Vec3& r_s) const;
  /// r_s [m] of the mapped point x_m [m] emitted at `time_s`. Throws TimeOutOfRange.
  Vec3 inverse(double time_s, const Vec3& x_m) const;

  /// Batch forward: `r_s` and `x_m` hold n interleaved xyz triples [m]. Throws TimeOutOfRange
  /// for the first pulse outside the trajectory (the outputs before it are written).
  void forward(const double* time_s, const double* r_s, double* x_m, std::size_t n) const;
  /// Batch inverse: `x_m` and `r_s` hold n interleaved xyz triples [m].
  void inverse(const double* time_s, const double* x_m, double* r_s, std::size_t n) const;
  /// Batch forward of line-scanner pulses straight from (θ [rad], ρ [m]).
  void forwardLineScan(const LineScannerModel& scanner, const double* time_s, const double* scan_angle_rad, const double* range_m,
                       double* x_m, std::size_t n) const;

 private:
  std::shared_ptr<const Trajectory> trajectory_;
  MountingParameters mounting_;
  Mat3 R_bs_ = Mat3::Identity();
};

/// The points `x_m` (n interleaved xyz triples [m], emitted at `time_s`), georeferenced with
/// `from`'s mounting, as `to`'s mounting places them: each inverse-georeferenced with `from` and
/// georeferenced again with `to` at its time (what `mountcal apply` does to a strip's points, here
/// on arrays). `x_out` may be `x_m` (in place). Blocks of 4096 points on `threads` threads (0: every
/// core); the values do not depend on it. Throws TimeOutOfRange for a point outside either model's
/// trajectory (which outputs were then written is unspecified).
void reGeoreference(const GeoreferenceModel& from, const GeoreferenceModel& to, const double* time_s, const double* x_m, double* x_out,
                    std::size_t n, int threads = 1);

}  // namespace mountcal
