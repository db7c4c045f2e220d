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
  double elevation_rad = 0.0;        ///< vertical angle ω_i [rad], positive up
  double vertical_offset_m = 0.0;    ///< added to the z component of r_s [m]
  double azimuth_offset_rad = 0.0;   ///< added to the encoder azimuth [rad]
  double range_offset_m = 0.0;       ///< added to the measured range [m]
  double firing_offset_s = 0.0;      ///< firing time after the start of its sequence [s]
  double horizontal_offset_m = 0.0;  ///< the laser's origin off the spin axis, across the beam [m]
};

/// ∂r/∂ω of a multi-beam laser vector r = ρ(cos ω sin α, cos ω cos α, sin ω) (SPEC §2):
/// (−r_z r_x / h, −r_z r_y / h, h), h = |r_xy|; zero on the spin axis.
inline Vec3 elevationTangent(const Vec3& r) {
  const double h = std::hypot(r.x(), r.y());
  if (h <= 0.0) return Vec3::Zero();
  return Vec3(-r.z() * r.x() / h, -r.z() * r.y() / h, h);
}

/// The per-laser intrinsics of a spinning multi-beam scanner as corrections to its laser table
/// (Glennie & Lichti 2010, eq. (1); OA-LICalib's six parameters less the range scale): a laser
/// fires at elevation ω + δω and azimuth α + δα, measures ρ + δρ, from an origin moved by δH
/// across its beam and δV along the spin axis. Result files carry them per laser id
/// (`intrinsics`, docs/command-and-files.md).
struct LaserCorrection {
  double elevation_rad = 0.0;  ///< δω [rad], positive up
  double azimuth_rad = 0.0;    ///< δα [rad], clockwise seen from above (as α)
  double range_m = 0.0;        ///< δρ [m]
  double vertical_m = 0.0;     ///< δV [m], along the spin axis (+z)
  double horizontal_m = 0.0;   ///< δH [m], across the beam: along (−cos α, sin α, 0)
  bool isZero() const { return elevation_rad == 0 && azimuth_rad == 0 && range_m == 0 && vertical_m == 0 && horizontal_m == 0; }
};
/// One correction per laser id; empty: none.
using LaserCorrections = std::vector<LaserCorrection>;

/// Per-laser intrinsics that a method estimated (the dense correspondences', the planes' and the
/// features' `laser_*_sigma` options), by laser id: their section's table, result-file entry,
/// doubts and warnings come from it.
struct LaserIntrinsicEstimates {
  LaserCorrections lasers;      ///< the estimated groups set, the others 0; empty when not estimated
  LaserCorrections sigma;       ///< σ in the mounting's stochastic model; NaN for a group not estimated or a laser without points
  LaserCorrection prior_sigma;  ///< each group's prior σ; 0: not estimated [rad, m]
  std::vector<int> points;      ///< each laser's points in the adjustment's observations
  /// Each laser's largest |correlation| of one of its parameters with a boresight angle (NaN: not seen).
  std::vector<double> boresight_correlation;
  /// Correlation screening (Glennie: laser parameters are highly correlated): each pair of one
  /// laser's parameters, or of a laser parameter and a mounting parameter, that the data do not
  /// separate (|correlation| ≥ 0.95), as "laser 3 range ~ laser 3 vertical (+0.97)".
  std::vector<std::string> unseparated;
  bool empty() const { return lasers.empty(); }
};

/// One group of LaserCorrection: its member, its name (as in the result file's
/// `laser_<name>_offset_<unit>`), the unit a file writes it in, and the factor from the library's
/// unit (rad, m) to that one.
struct LaserGroup {
  double LaserCorrection::*field;
  const char* name;
  const char* unit;
  double to_unit;
};
/// The five groups in LaserCorrection's order: elevation, azimuth [deg]; range, vertical,
/// horizontal [m].
inline constexpr LaserGroup kLaserGroups[5] = {{&LaserCorrection::elevation_rad, "elevation", "deg", 180 / kPi},
                                               {&LaserCorrection::azimuth_rad, "azimuth", "deg", 180 / kPi},
                                               {&LaserCorrection::range_m, "range", "m", 1},
                                               {&LaserCorrection::vertical_m, "vertical", "m", 1},
                                               {&LaserCorrection::horizontal_m, "horizontal", "m", 1}};
/// A per-laser parameter estimated beyond this many times its prior σ makes a result doubtful
/// (MethodSection::doubts()): with the prior a true description of a table's errors (a Gaussian),
/// one parameter in 16 000 lies beyond 4σ — over 160 parameters, one survey in 100.
inline constexpr double kLaserPriorDoubt = 4.0;

/// A measured laser vector split into what the corrections act on (taken from the scanner's
/// origin: the table's own origin offsets v_i, H_i enter only to second order, |v_i| δ ≤ 0.2 mm
/// for |v_i| ≤ 0.1 m and δ ≤ 0.1°): the beam r, its elevation tangent u = ∂r/∂ω (|u| = |r|),
/// the unit across-beam vector p and the range ρ = |r|.
struct LaserRay {
  Vec3 r = Vec3::Zero(), u = Vec3::Zero(), p = Vec3::Zero();
  double rho = 0.0;
  explicit LaserRay(const Vec3& r_s);
};

/// One laser's correction with its trigonometry done once, for the many points of that laser:
/// r' = R_z(δα) [(1 + δρ/ρ)(cos δω r + sin δω u) + δH p] + δV e_z, exactly (R_z(δα) turns α to
/// α + δα; cos δω r + sin δω u is r(ω + δω)).
class LaserCorrector {
 public:
  LaserCorrector() = default;
  explicit LaserCorrector(const LaserCorrection& c);
  /// The corrected vector; `jacobian` (optional) receives ∂r'/∂(δω, δα, δρ, δV, δH).
  Vec3 apply(const LaserRay& ray, Eigen::Matrix<double, 3, 5>* jacobian = nullptr) const;
  /// The corrected laser vector of a measured one.
  Vec3 operator()(const Vec3& r_s) const;

 private:
  LaserCorrection c_;
  double cw_ = 1, sw_ = 0, ca_ = 1, sa_ = 0;
  bool elevation_only_ = true;
};
/// The laser vector with its laser's corrections applied (LaserCorrector).
inline Vec3 correctLaserVector(const Vec3& r_s, const LaserCorrection& c) { return c.isZero() ? r_s : LaserCorrector(c)(r_s); }
/// One corrector per laser id.
std::vector<LaserCorrector> laserCorrectors(const LaserCorrections& lasers);

/// Multi-beam spinning scanner in the Velodyne manual convention (Glennie & Lichti 2010 eq. (1)):
/// `r_s = ρ' · (cos ω_i sin α', cos ω_i cos α', sin ω_i) + H_i (−cos α', sin α', 0) + (0, 0, V_i)`,
/// α measured clockwise from the sensor's +y (looking down on the sensor), ρ' = ρ + range
/// offset, α' = α + azimuth offset, H_i the horizontal and V_i the vertical offset.
class MultiBeamModel {
 public:
  MultiBeamModel() = default;
  /// A custom laser table, with its range accuracy if known (0: unknown) [m]. Throws
  /// InvalidInput when empty, non-finite or the accuracy is negative.
  MultiBeamModel(std::string name, std::vector<LaserSpec> lasers, double sequence_period_s, double range_accuracy_m = 0.0);

  /// Velodyne VLP-16: elevations −15, 1, −13, 3, …, 13, −1, 15 [deg] by laser id, the manual's
  /// per-laser vertical corrections (+11.2 … −11.2 mm), 2.304 µs between lasers, 55.296 µs per
  /// firing sequence; range accuracy ±3 cm (the manual's "typical").
  static MultiBeamModel VLP16();
  /// Velodyne HDL-32E: elevations −30.67° … +10.67° in 1.333° steps, interleaved by laser id
  /// as in the manual (−30.67, −9.33, −29.33, −8.00, …, −10.67, +10.67), 1.152 µs between
  /// lasers, 46.08 µs per firing sequence; range accuracy ±2 cm (the manual's "typical").
  static MultiBeamModel HDL32E();

  const std::string& name() const { return name_; }
  int laserCount() const { return static_cast<int>(lasers_.size()); }
  const LaserSpec& laser(int id) const;  ///< throws InvalidInput for an unknown id
  std::vector<LaserSpec>& lasers() { return lasers_; }
  const std::vector<LaserSpec>& lasers() const { return lasers_; }
  double sequencePeriod() const { return sequence_period_s_; }  ///< [s]
  /// The maker's range accuracy (1σ-like "typical" figure) [m]; 0 when unknown (a custom table
  /// without `sensor.range_accuracy_m`). The one home of these figures: the matching defaults
  /// (a rough plane, the robust loss's scale) and the plausibility of a per-laser range
  /// correction come from it.
  double rangeAccuracy() const { return range_accuracy_m_; }
  void setRangeAccuracy(double range_accuracy_m);  ///< throws InvalidInput when negative or not finite

  /// Firing time of `laser_id` in firing sequence `sequence` after a packet's start [s].
  double firingTime(int laser_id, long sequence) const;

  Vec3 vector(int laser_id, double azimuth_rad, double range_m) const;
  /// Recovers (α [rad] in [0, 2π), ρ [m]) for a known laser id (inverse of vector()).
  void inverse(const Vec3& r_s, int laser_id, double* azimuth_rad, double* range_m) const;

 private:
  std::string name_;
  std::vector<LaserSpec> lasers_;
  double sequence_period_s_ = 0.0;
  double range_accuracy_m_ = 0.0;
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
