#pragma once
/// \file trajectory.hpp
/// A platform trajectory: time-sorted poses of the body (IMU) frame in the mapping frame,
/// with interpolation (SPEC §2: positions linear or cubic in time, attitude by quaternion
/// slerp; a time outside the trajectory is an error, never an extrapolation).

#include <cstddef>
#include <string>
#include <vector>

#include "mountcal/core/rotation.hpp"

namespace mountcal {

/// One trajectory record as a navigation system delivers it.
struct TrajectorySample {
  double time_s = 0.0;       ///< time [s] (GPS week seconds or any monotonic scale)
  Vec3 p_m = Vec3::Zero();   ///< IMU position in the mapping frame [m]
  double roll = 0.0;         ///< [rad]
  double pitch = 0.0;        ///< [rad]
  double heading = 0.0;      ///< clockwise from North [rad]
  Mat3 R_mn = R_mn_local();  ///< navigation → mapping frame at this sample (SPEC §2)
};

/// How positions are interpolated between samples.
enum class PositionInterpolation {
  kLinear,  ///< piecewise linear in time
  kCubic,   ///< cubic Hermite with finite-difference velocities (C¹); exact for linear motion
};

/// The interpolated pose of the body frame in the mapping frame at one time.
struct Pose {
  Vec3 p_m = Vec3::Zero();       ///< IMU position in the mapping frame [m]
  Mat3 R_mb = Mat3::Identity();  ///< body → mapping rotation, `R_mn · R_nb`
};

/// Time-sorted trajectory with O(1) amortised interpolation for sorted query times.
///
/// The attitude stored per sample is `q_mb = q_mn · q_nb`; it is interpolated by slerp between
/// neighbouring samples (the two factors vary slowly, so interpolating their product equals
/// interpolating each to second order in the sample interval).
class Trajectory {
 public:
  Trajectory() = default;
  /// Validates and stores the samples. Throws InvalidInput (naming the sample index) when there
  /// are fewer than two samples, when times are not strictly increasing, or when any value is
  /// non-finite.
  explicit Trajectory(std::vector<TrajectorySample> samples, PositionInterpolation interpolation = PositionInterpolation::kLinear);

  std::size_t size() const { return samples_.size(); }
  bool empty() const { return samples_.empty(); }
  double startTime() const;  ///< first sample time [s]
  double endTime() const;    ///< last sample time [s]
  const std::vector<TrajectorySample>& samples() const { return samples_; }
  PositionInterpolation interpolation() const { return interpolation_; }

  /// Pose at `time_s`. Throws TimeOutOfRange outside [startTime(), endTime()].
  Pose pose(double time_s) const;

  /// Pose at `time_s`, starting the interval search at `*cursor` (an index kept by the caller
  /// between calls, initially 0). For sorted query times the search is O(1) amortised.
  Pose pose(double time_s, std::size_t* cursor) const;

  /// The index i of the interval [t_i, t_{i+1}] holding `time_s`, searched from `*cursor`.
  /// Throws TimeOutOfRange.
  std::size_t locate(double time_s, std::size_t* cursor) const;

  /// Pose at `time_s` inside interval `i` (as returned by locate()); no range check.
  Pose interpolateInInterval(std::size_t i, double time_s) const;
  /// Position alone at `time_s` inside interval `i` [m]; no range check.
  Vec3 positionInInterval(std::size_t i, double time_s) const;
  /// The attitude of interval `i` as slerp sees it: R_mb(t) = R_i · Exp(s · ω_i) with
  /// s = (t − t_i)/(t_{i+1} − t_i), R_i the attitude at t_i and ω_i the rotation vector [rad]
  /// from it to the next sample's.
  void intervalAttitude(std::size_t i, Mat3* R_i, Vec3* omega_i) const;
  /// The position of interval `i` as a polynomial in s = (t − t_i)/(t_{i+1} − t_i):
  /// p(s) = c[0] + c[1] s + c[2] s² + c[3] s³ [m] (linear or cubic Hermite).
  void intervalPosition(std::size_t i, Vec3 c[4]) const;
  /// Times of the samples (contiguous) [s].
  const std::vector<double>& times() const { return time_s_; }

 private:
  std::vector<TrajectorySample> samples_;
  std::vector<double> time_s_;  // copy of sample times, contiguous for the search
  std::vector<Quat> q_mb_;      // sign-aligned with the previous sample
  std::vector<Vec3> dq_;        // rotation vector of q_i⁻¹ q_{i+1} (slerp increment)
  std::vector<Vec3> v_m_;       // velocity estimate per sample (cubic only) [m/s]
  PositionInterpolation interpolation_ = PositionInterpolation::kLinear;
};

/// A trajectory's stated accuracy along its time — what a GNSS/INS post-processor writes beside
/// its solution (an SBET's "smrmsg" file, io::readSmrmsg): per record the 1σ position error along
/// the mapping frame's axes and the 1σ attitude error about them. TrajectoryAccuracy::series.
struct TrajectoryAccuracySeries {
  std::vector<double> time_s;      ///< non-decreasing, in the strips' time scale [s]
  std::vector<Vec3> position_m;    ///< σ along x, y, z (east, north, up in a tangent frame) [m]
  std::vector<Vec3> attitude_rad;  ///< σ about x and y (the RMS of roll and pitch) and z (heading) [rad]
  bool empty() const { return time_s.empty(); }
  /// σ at time t: linear between the records around it, the first or last record's beyond them.
  void at(double t, Vec3* position_m, Vec3* attitude_rad) const;
  /// False (and why) for unequal lengths, times out of order, or a σ negative or not finite.
  bool IsValid(std::string* error) const;
};

}  // namespace mountcal
