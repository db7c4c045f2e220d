#include "mountcal/report/error_curves.hpp"

#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <sstream>

#include "mountcal/core/georeference_model.hpp"
#include "mountcal/io/atomic_file.hpp"
#include "mountcal/core/sensor_model.hpp"
#include "mountcal/report/svg_plot.hpp"

namespace mountcal {

Vec3 boresightErrorFirstOrder(const Vec3& boresight, double scan_angle_rad, double range_m) {
  const double omega = boresight.x(), phi = boresight.y(), kappa = boresight.z();
  const double c = std::cos(scan_angle_rad), s = std::sin(scan_angle_rad);
  return range_m * Vec3(phi * c - kappa * s, -omega * c, omega * s);  // SPEC §2, first order
}

std::vector<ErrorCurveSample> boresightErrorCurves(const Vec3& boresight, const std::vector<double>& scan_angles_rad,
                                                   const std::vector<double>& ranges_m) {
  // Level flight, heading 0 (body x = North), zero lever arm, a local frame: R_mb = R_mn.
  std::vector<TrajectorySample> samples(2);
  samples[0].time_s = 0.0;
  samples[1].time_s = 1.0;
  auto trajectory = std::make_shared<const Trajectory>(samples);
  MountingParameters with_bore;
  with_bore.boresight = boresight;
  const GeoreferenceModel misaligned(trajectory, with_bore);
  const GeoreferenceModel aligned(trajectory, MountingParameters{});
  const Mat3 R_bm = R_mn_local().transpose();  // mapping → body at this pose
  const LineScannerModel scanner;

  std::vector<ErrorCurveSample> out;
  out.reserve(scan_angles_rad.size() * ranges_m.size());
  for (double rho : ranges_m) {
    for (double theta : scan_angles_rad) {
      const Vec3 r_s = scanner.vector(theta, rho);
      ErrorCurveSample e;
      e.scan_angle_rad = theta;
      e.range_m = rho;
      e.exact_b = R_bm * (misaligned.forward(0.5, r_s) - aligned.forward(0.5, r_s));
      e.first_order_b = boresightErrorFirstOrder(boresight, theta, rho);
      out.push_back(e);
    }
  }
  return out;
}

std::vector<ErrorCurveSample> beamErrorCurves(const Mat3& R_bs_used, const Mat3& R_bs_new, const std::vector<Vec3>& r_s,
                                              const std::vector<double>& ranges_m, double bin_deg, int min_beams) {
  const double bin = deg2rad(bin_deg > 0 ? bin_deg : 2.0);
  struct Bin {
    Vec3 sum = Vec3::Zero();
    int n = 0;
  };
  std::map<long, Bin> bins;  // by floor(θ / bin): angles ascending
  for (const Vec3& r : r_s) {
    const double n = r.norm();
    if (!(n > 0) || !std::isfinite(n)) continue;
    const Vec3 u = R_bs_used * (r / n);
    Bin& b = bins[static_cast<long>(std::floor(std::atan2(u.y(), u.z()) / bin))];
    b.sum += u;
    ++b.n;
  }
  const Mat3 dR = R_bs_new * R_bs_used.transpose();  // the change, in body axes
  const Eigen::AngleAxisd aa(dR);
  const Vec3 delta = aa.angle() * aa.axis();
  std::vector<ErrorCurveSample> out;
  for (double rho : ranges_m) {
    for (const auto& [key, b] : bins) {
      if (b.n < min_beams) continue;
      const Vec3 u = b.sum / b.n;
      ErrorCurveSample e;
      e.scan_angle_rad = std::atan2(u.y(), u.z());
      e.range_m = rho;
      e.exact_b = rho * (dR - Mat3::Identity()) * u;
      e.first_order_b = rho * delta.cross(u);
      out.push_back(e);
    }
  }
  return out;
}

std::string errorCurvesCsv(const std::vector<ErrorCurveSample>& samples) {
  std::ostringstream csv;
  csv << "range_m,scan_angle_deg,exact_x_m,exact_y_m,exact_z_m,first_x_m,first_y_m,first_z_m\n";
  char line[256];
  for (const ErrorCurveSample& e : samples) {
    std::snprintf(line, sizeof line, "%.3f,%.4f,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f\n", e.range_m, rad2deg(e.scan_angle_rad), e.exact_b.x(),
                  e.exact_b.y(), e.exact_b.z(), e.first_order_b.x(), e.first_order_b.y(), e.first_order_b.z());
    csv << line;
  }
  return csv.str();
}

std::string errorCurveSvg(const std::vector<ErrorCurveSample>& samples, int axis, const std::string& title) {
  static const char* kAxis[3] = {"along-track error x [m]", "cross-track error y [m]", "vertical error z [m]"};
  SvgLinePlot plot(title, "scan angle θ [deg] (positive to starboard)", kAxis[axis % 3]);
  std::map<double, std::pair<std::vector<double>, std::vector<double>>> by_range;
  for (const ErrorCurveSample& e : samples) {
    auto& xy = by_range[e.range_m];
    xy.first.push_back(rad2deg(e.scan_angle_rad));
    xy.second.push_back(e.exact_b[axis % 3]);
  }
  for (auto& [range, xy] : by_range) {
    char name[64];
    std::snprintf(name, sizeof name, "ρ = %.4g m", range);
    plot.addSeries(name, std::move(xy.first), std::move(xy.second));
  }
  return plot.render();
}

void writeErrorCurves(const std::string& dir, const std::vector<ErrorCurveSample>& samples, double boresight_deg) {
  io::writeFileAtomically(dir + "/fig_errors.csv", errorCurvesCsv(samples));
  static const char* kNames[3] = {"fig1_x.svg", "fig2_y.svg", "fig3_z.svg"};
  static const char* kTitles[3] = {"Fig. 1 — along-track (x) error", "Fig. 2 — cross-track (y) error", "Fig. 3 — vertical (z) error"};
  char delta[32];
  std::snprintf(delta, sizeof delta, "%g", boresight_deg);
  for (int axis = 0; axis < 3; ++axis) {
    io::writeFileAtomically(dir + "/" + kNames[axis],
                            errorCurveSvg(samples, axis, std::string(kTitles[axis]) + " for ω = φ = κ = " + delta + "°"));
  }
}

}  // namespace mountcal
