#include "mountcal/core/sensor_model.hpp"

#include <algorithm>
#include <cmath>

#include "mountcal/core/error.hpp"

namespace mountcal {

Vec3 LineScannerModel::vector(double scan_angle_rad, double range_m) const {
  const double theta = scan_angle_scale * scan_angle_rad + scan_angle_offset_rad;
  const double rho = range_m + range_offset_m;
  return {0.0, rho * std::sin(theta), rho * std::cos(theta)};  // SPEC §2 line scanner
}

void LineScannerModel::inverse(const Vec3& r_s, double* scan_angle_rad, double* range_m) const {
  const double rho = std::hypot(r_s.y(), r_s.z());
  const double theta = std::atan2(r_s.y(), r_s.z());
  *range_m = rho - range_offset_m;
  *scan_angle_rad = (theta - scan_angle_offset_rad) / scan_angle_scale;
}

MultiBeamModel::MultiBeamModel(std::string name, std::vector<LaserSpec> lasers, double sequence_period_s, double range_accuracy_m)
    : name_(std::move(name)), lasers_(std::move(lasers)), sequence_period_s_(sequence_period_s) {
  setRangeAccuracy(range_accuracy_m);
  if (lasers_.empty()) throw InvalidInput("multi-beam model '" + name_ + "': no lasers");
  for (std::size_t i = 0; i < lasers_.size(); ++i) {
    const LaserSpec& l = lasers_[i];
    if (!std::isfinite(l.elevation_rad) || !std::isfinite(l.vertical_offset_m) || !std::isfinite(l.azimuth_offset_rad) ||
        !std::isfinite(l.range_offset_m) || !std::isfinite(l.firing_offset_s) || !std::isfinite(l.horizontal_offset_m)) {
      throw InvalidInput("multi-beam model '" + name_ + "': laser " + std::to_string(i) + " has a non-finite value");
    }
  }
  if (!std::isfinite(sequence_period_s_) || sequence_period_s_ < 0) {
    throw InvalidInput("multi-beam model '" + name_ + "': invalid sequence period");
  }
}

MultiBeamModel MultiBeamModel::VLP16() {
  // VLP-16 user manual: vertical angle and vertical correction [mm] by laser id.
  static const double kElevationDeg[16] = {-15, 1, -13, 3, -11, 5, -9, 7, -7, 9, -5, 11, -3, 13, -1, 15};
  static const double kVerticalMm[16] = {11.2, -0.7, 9.7, -2.2, 8.1, -3.7, 6.6, -5.1, 5.1, -6.6, 3.7, -8.1, 2.2, -9.7, 0.7, -11.2};
  std::vector<LaserSpec> lasers(16);
  for (int i = 0; i < 16; ++i) {
    lasers[i].elevation_rad = deg2rad(kElevationDeg[i]);
    lasers[i].vertical_offset_m = kVerticalMm[i] * 1e-3;
    lasers[i].firing_offset_s = i * 2.304e-6;
  }
  return MultiBeamModel("VLP-16", std::move(lasers), 55.296e-6, 0.03);  // the manual's ±3 cm
}

MultiBeamModel MultiBeamModel::HDL32E() {
  // HDL-32E user manual: lasers alternate between the lower block (−30.67° upwards) and the
  // upper block (−9.33° upwards), 1.333° apart within each.
  static const double kElevationDeg[32] = {-30.67, -9.33,  -29.33, -8.00,  -28.00, -6.67,  -26.67, -5.33,  -25.33, -4.00,  -24.00,
                                           -2.67,  -22.67, -1.33,  -21.33, 0.00,   -20.00, 1.33,   -18.67, 2.67,   -17.33, 4.00,
                                           -16.00, 5.33,   -14.67, 6.67,   -13.33, 8.00,   -12.00, 9.33,   -10.67, 10.67};
  std::vector<LaserSpec> lasers(32);
  for (int i = 0; i < 32; ++i) {
    lasers[i].elevation_rad = deg2rad(kElevationDeg[i]);
    lasers[i].firing_offset_s = i * 1.152e-6;
  }
  return MultiBeamModel("HDL-32E", std::move(lasers), 46.08e-6, 0.02);  // the manual's ±2 cm
}

void MultiBeamModel::setRangeAccuracy(double range_accuracy_m) {
  if (!(range_accuracy_m >= 0 && std::isfinite(range_accuracy_m)))
    throw InvalidInput("multi-beam model '" + name_ + "': the range accuracy must be a non-negative number of metres");
  range_accuracy_m_ = range_accuracy_m;
}

const LaserSpec& MultiBeamModel::laser(int id) const {
  if (id < 0 || id >= laserCount()) {
    throw InvalidInput("multi-beam model '" + name_ + "': laser id " + std::to_string(id) + " is outside 0.." +
                       std::to_string(laserCount() - 1));
  }
  return lasers_[static_cast<std::size_t>(id)];
}

double MultiBeamModel::firingTime(int laser_id, long sequence) const {
  return static_cast<double>(sequence) * sequence_period_s_ + laser(laser_id).firing_offset_s;
}

Vec3 MultiBeamModel::vector(int laser_id, double azimuth_rad, double range_m) const {
  const LaserSpec& l = laser(laser_id);
  const double rho = range_m + l.range_offset_m;
  const double alpha = azimuth_rad + l.azimuth_offset_rad;
  const double c = std::cos(l.elevation_rad), sa = std::sin(alpha), ca = std::cos(alpha);
  // SPEC §2 multi-beam (Velodyne manual convention; Glennie & Lichti 2010 eq. (1))
  return {rho * c * sa - l.horizontal_offset_m * ca, rho * c * ca + l.horizontal_offset_m * sa,
          rho * std::sin(l.elevation_rad) + l.vertical_offset_m};
}

void MultiBeamModel::inverse(const Vec3& r_s, int laser_id, double* azimuth_rad, double* range_m) const {
  const LaserSpec& l = laser(laser_id);
  const Vec3 w(r_s.x(), r_s.y(), r_s.z() - l.vertical_offset_m);
  // w_xy = a e + H J e with e = (sin α', cos α'), J e = (−e_y, e_x), a = ρ' cos ω:
  // e = (a I − H J) w_xy / (a² + H²), a = √(|w_xy|² − H²).
  const double H = l.horizontal_offset_m;
  double alpha = std::atan2(w.x(), w.y()), rho = w.norm();
  if (H != 0) {
    const double a = std::sqrt(std::max(w.x() * w.x() + w.y() * w.y() - H * H, 0.0));
    alpha = std::atan2(a * w.x() + H * w.y(), a * w.y() - H * w.x());
    rho = std::hypot(a, w.z());
  }
  alpha = std::fmod(alpha - l.azimuth_offset_rad, 2 * kPi);
  if (alpha < 0) alpha += 2 * kPi;
  *azimuth_rad = alpha;
  *range_m = rho - l.range_offset_m;
}

LaserRay::LaserRay(const Vec3& r_s) : r(r_s), u(elevationTangent(r_s)), rho(r_s.norm()) {
  const double h = std::hypot(r_s.x(), r_s.y());
  if (h > 0) p = Vec3(-r_s.y() / h, r_s.x() / h, 0.0);
}

LaserCorrector::LaserCorrector(const LaserCorrection& c)
    : c_(c),
      cw_(std::cos(c.elevation_rad)),
      sw_(std::sin(c.elevation_rad)),
      ca_(std::cos(c.azimuth_rad)),
      sa_(std::sin(c.azimuth_rad)),
      elevation_only_(c.azimuth_rad == 0 && c.range_m == 0 && c.vertical_m == 0 && c.horizontal_m == 0) {}

Vec3 LaserCorrector::apply(const LaserRay& ray, Eigen::Matrix<double, 3, 5>* jacobian) const {
  const double k = ray.rho > 0 ? 1.0 + c_.range_m / ray.rho : 1.0;
  const Vec3 beam = cw_ * ray.r + sw_ * ray.u;  // r(ω + δω), exactly: |u| = |r|, u ⟂ r
  const Vec3 q = k * beam + c_.horizontal_m * ray.p;
  Mat3 Rz;
  Rz << ca_, sa_, 0, -sa_, ca_, 0, 0, 0, 1;  // (sin α, cos α) → (sin(α + δα), cos(α + δα))
  if (jacobian) {
    Mat3 dRz;
    dRz << -sa_, ca_, 0, -ca_, -sa_, 0, 0, 0, 0;
    jacobian->col(0) = Rz * (k * (-sw_ * ray.r + cw_ * ray.u));
    jacobian->col(1) = dRz * q;
    jacobian->col(2) = ray.rho > 0 ? Vec3(Rz * beam / ray.rho) : Vec3::Zero();
    jacobian->col(3) = Vec3::UnitZ();
    jacobian->col(4) = Rz * ray.p;
  }
  return Rz * q + Vec3(0, 0, c_.vertical_m);
}

Vec3 LaserCorrector::operator()(const Vec3& r_s) const {
  if (elevation_only_) return cw_ * r_s + sw_ * elevationTangent(r_s);
  return apply(LaserRay(r_s));
}

std::vector<LaserCorrector> laserCorrectors(const LaserCorrections& lasers) {
  std::vector<LaserCorrector> out;
  out.reserve(lasers.size());
  for (const LaserCorrection& c : lasers) out.emplace_back(c);
  return out;
}

SensorModel SensorModel::lineScanner(const LineScannerModel& m) {
  SensorModel s;
  s.type = SensorType::kLine;
  s.line = m;
  return s;
}

SensorModel SensorModel::multiBeam(const MultiBeamModel& m) {
  SensorModel s;
  s.type = SensorType::kMultiBeam;
  s.multibeam = m;
  return s;
}

SensorModel SensorModel::vectorSensor() {
  SensorModel s;
  s.type = SensorType::kVector;
  return s;
}

Vec3 SensorModel::vector(const RawPulse& pulse) const {
  switch (type) {
    case SensorType::kLine:
      return line.vector(pulse.angle_rad, pulse.range_m);
    case SensorType::kMultiBeam:
      return multibeam.vector(pulse.laser_id, pulse.angle_rad, pulse.range_m);
    case SensorType::kVector:
      break;
  }
  return pulse.r_s;
}

void SensorModel::inverse(const Vec3& r_s, RawPulse* pulse) const {
  switch (type) {
    case SensorType::kLine:
      line.inverse(r_s, &pulse->angle_rad, &pulse->range_m);
      return;
    case SensorType::kMultiBeam:
      multibeam.inverse(r_s, pulse->laser_id, &pulse->angle_rad, &pulse->range_m);
      return;
    case SensorType::kVector:
      pulse->r_s = r_s;
      pulse->range_m = r_s.norm();
      return;
  }
}

}  // namespace mountcal
