#pragma once
/// \file sensor_model.hpp
/// Laser scanner models: raw observations → the laser vector `r_s` in the scanner frame, and
/// back (SPEC §2 "Sensor models").

#include <cmath>
#include <string>
#include <vector>

#include "mountcal/core/rotation.hpp"

namespace mountcal {

/// One raw laser observation, as in the raw CSV of SPEC §4.
struct RawPulse {
  double time_s = 0.0;      ///< emission time [s]
  double angle_rad = 0.0;   ///< line scanner: scan angle θ; multi-beam: azimuth α [rad]
  double range_m = 0.0;     ///< measured range ρ [m]
  int laser_id = 0;         ///< multi-beam laser index (0-based); unused otherwise
  float intensity = 0.0f;   ///< return intensity (sensor units)
  Vec3 r_s = Vec3::Zero();  ///< vector sensors: the Cartesian laser vector [m]
};                          // 56 bytes: the simulator keeps one per return

/// Line scanner with an oscillating or rotating mirror (e.g. Leica ALS50-II):
/// `r_s = ρ' · (0, sin θ', cos θ')` with θ positive to starboard and θ = 0 at nadir, where
/// `ρ' = ρ + range_offset_m` and `θ' = scan_angle_scale · θ + scan_angle_offset_rad` apply the
/// optional intrinsics.
struct LineScannerModel {
  double range_offset_m = 0.0;         ///< added to every range [m]
  double scan_angle_scale = 1.0;       ///< multiplies the encoder scan angle [-]
  double scan_angle_offset_rad = 0.0;  ///< added to the scaled scan angle [rad]

  Vec3 vector(double scan_angle_rad, double range_m) const;
  /// Recovers (θ [rad], ρ [m]) from a vector of this model (inverse of vector()).
  void inverse(const Vec3& r_s, double* scan_angle_rad, double* range_m) const;
};

/// One laser of a multi-beam scanner.
struct LaserSpec {
  double elevation_rad = 0.0;       ///< vertical angle ω_i [rad], positive up
  double vertical_offset_m = 0.0;   ///< added to the z component of r_s [m]
  double azimuth_offset_rad = 0.0;  ///< added to the encoder azimuth [rad]
  double range_offset_m = 0.0;      ///< added to the measured range [m]
  double firing_offset_s = 0.0;     ///< firing time after the start of its sequence [s]
};

/// ∂r/∂ω of a multi-beam laser vector r = ρ(cos ω sin α, cos ω cos α, sin ω) (SPEC §2):
/// (−r_z r_x / h, −r_z r_y / h, h), h = |r_xy|; zero on the spin axis.
inline Vec3 elevationTangent(const Vec3& r) {
  const double h = std::hypot(r.x(), r.y());
  if (h <= 0.0) return Vec3::Zero();
  return Vec3(-r.z() * r.x() / h, -r.z() * r.y() / h, h);
}
/// The laser vector with its elevation offset by δ (a per-laser elevation intrinsic), azimuth
/// and range kept: r(ω + δ) = cos δ · r + sin δ · ∂r/∂ω, exactly.
inline Vec3 elevateLaserVector(const Vec3& r, double delta) {
  if (delta == 0.0) return r;
  return std::cos(delta) * r + std::sin(delta) * elevationTangent(r);
}

/// Multi-beam spinning scanner in the Velodyne manual convention:
/// `r_s = ρ' · (cos ω_i sin α', cos ω_i cos α', sin ω_i) + (0, 0, vertical_offset_i)`,
/// α measured clockwise from the sensor's +y (looking down on the sensor), ρ' = ρ + range
/// offset, α' = α + azimuth offset.
class MultiBeamModel {
 public:
  MultiBeamModel() = default;
  /// A custom laser table. Throws InvalidInput when empty or non-finite.
  MultiBeamModel(std::string name, std::vector<LaserSpec> lasers, double sequence_period_s);

  /// Velodyne VLP-16: elevations −15, 1, −13, 3, …, 13, −1, 15 [deg] by laser id, the manual's
  /// per-laser vertical corrections (+11.2 … −11.2 mm), 2.304 µs between lasers, 55.296 µs per
  /// firing sequence.
  static MultiBeamModel VLP16();
  /// Velodyne HDL-32E: elevations −30.67° … +10.67° in 1.333° steps, interleaved by laser id
  /// as in the manual (−30.67, −9.33, −29.33, −8.00, …, −10.67, +10.67), 1.152 µs between
  /// lasers, 46.08 µs per firing sequence.
  static MultiBeamModel HDL32E();

  const std::string& name() const { return name_; }
  int laserCount() const { return static_cast<int>(lasers_.size()); }
  const LaserSpec& laser(int id) const;  ///< throws InvalidInput for an unknown id
  std::vector<LaserSpec>& lasers() { return lasers_; }
  const std::vector<LaserSpec>& lasers() const { return lasers_; }
  double sequencePeriod() const { return sequence_period_s_; }  ///< [s]

  /// Firing time of `laser_id` in firing sequence `sequence` after a packet's start [s].
  double firingTime(int laser_id, long sequence) const;

  Vec3 vector(int laser_id, double azimuth_rad, double range_m) const;
  /// Recovers (α [rad] in [0, 2π), ρ [m]) for a known laser id (inverse of vector()).
  void inverse(const Vec3& r_s, int laser_id, double* azimuth_rad, double* range_m) const;

 private:
  std::string name_;
  std::vector<LaserSpec> lasers_;
  double sequence_period_s_ = 0.0;
};

/// The kind of sensor (SPEC §4 `sensor.type`).
enum class SensorType { kLine, kMultiBeam, kVector };

/// Any of the three sensor kinds behind one interface.
struct SensorModel {
  SensorType type = SensorType::kLine;
  LineScannerModel line;
  MultiBeamModel multibeam;

  static SensorModel lineScanner(const LineScannerModel& m = {});
  static SensorModel multiBeam(const MultiBeamModel& m);
  static SensorModel vectorSensor();

  /// The laser vector r_s [m] of a raw pulse.
  Vec3 vector(const RawPulse& pulse) const;
  /// Fills the raw fields (angle, range, or r_s) of `pulse` from r_s; `pulse->laser_id` must
  /// already hold the laser for a multi-beam sensor.
  void inverse(const Vec3& r_s, RawPulse* pulse) const;
};

}  // namespace mountcal
