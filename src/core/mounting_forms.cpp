#include "mountcal/core/mounting_forms.hpp"

#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>

namespace mountcal {

const char* toString(BodyAxes axes) { return axes == BodyAxes::kForwardRightDown ? "forward-right-down" : "forward-left-up"; }

namespace {
Eigen::Quaterniond positive(const Mat3& R) {
  Eigen::Quaterniond q(R);
  q.normalize();
  if (q.w() < 0) q.coeffs() *= -1.0;
  return q;
}
}  // namespace

MountingForm mountingForm(const MountingParameters& m, BodyAxes axes) {
  // T: FRD body axes → the requested body axes (a half turn about x for FLU).
  const Mat3 T = axes == BodyAxes::kForwardRightDown ? Mat3::Identity() : Vec3(1, -1, -1).asDiagonal().toDenseMatrix();
  MountingForm f;
  f.axes = axes;
  f.lever_arm_m = T * m.a_b;
  f.R_bore = T * m.R_bore() * T.transpose();
  f.boresight_rad = rollPitchHeading(f.R_bore);  // the Rz·Ry·Rx angles of the rotation in these axes
  f.q_bore = positive(f.R_bore);
  f.R_bs = T * m.R_bs();
  f.q_bs = positive(f.R_bs);
  return f;
}

std::string mountingFormsText(const MountingParameters& m, const LaserCorrections& lasers) {
  std::ostringstream out;
  char b[256];
  out << "Conventions: R_bore = Rz(heading) * Ry(pitch) * Rx(roll), active, right-handed; R_bs = R_bore * R_nom maps the\n"
         "scanner frame into the body frame; the lever arm points from the IMU origin to the scanner origin.\n";
  for (BodyAxes axes : {BodyAxes::kForwardRightDown, BodyAxes::kForwardLeftUp}) {
    const MountingForm f = mountingForm(m, axes);
    out << "\nBody axes " << toString(axes) << (axes == BodyAxes::kForwardRightDown ? " (mountcal's, SPEC §2)" : " (ROS REP 103)") << ":\n";
    std::snprintf(b, sizeof b, "  lever arm          %+.6f %+.6f %+.6f m\n", f.lever_arm_m.x(), f.lever_arm_m.y(), f.lever_arm_m.z());
    out << b;
    std::snprintf(b, sizeof b, "  boresight (r,p,h)  %+.6f %+.6f %+.6f deg = %+.9f %+.9f %+.9f rad\n", rad2deg(f.boresight_rad.x()),
                  rad2deg(f.boresight_rad.y()), rad2deg(f.boresight_rad.z()), f.boresight_rad.x(), f.boresight_rad.y(),
                  f.boresight_rad.z());
    out << b;
    std::snprintf(b, sizeof b, "  q_bore (w,x,y,z)   %+.12f %+.12f %+.12f %+.12f\n", f.q_bore.w(), f.q_bore.x(), f.q_bore.y(),
                  f.q_bore.z());
    out << b;
    out << "  R_bore             ";
    for (int r = 0; r < 3; ++r) {
      std::snprintf(b, sizeof b, "%s[%+.12f %+.12f %+.12f]\n", r ? "                     " : "", f.R_bore(r, 0), f.R_bore(r, 1),
                    f.R_bore(r, 2));
      out << b;
    }
    std::snprintf(b, sizeof b, "  q_bs (w,x,y,z)     %+.12f %+.12f %+.12f %+.12f   (R_bs = R_bore * R_nom)\n", f.q_bs.w(), f.q_bs.x(),
                  f.q_bs.y(), f.q_bs.z());
    out << b;
  }
  if (!lasers.empty()) {
    out << "\nPer-laser intrinsics (add to each laser's table value, by laser id; docs/command-and-files.md maps them to\n"
           "a driver's calibration file):\n  laser  elevation [deg]  azimuth [deg]  range [m]  vertical [m]  horizontal [m]\n";
    for (std::size_t i = 0; i < lasers.size(); ++i) {
      const LaserCorrection& l = lasers[i];
      std::snprintf(b, sizeof b, "  %5zu  %+15.5f  %+13.5f  %+9.4f  %+12.4f  %+14.4f\n", i, rad2deg(l.elevation_rad),
                    rad2deg(l.azimuth_rad), l.range_m, l.vertical_m, l.horizontal_m);
      out << b;
    }
  }
  return out.str();
}

std::string mountingFormsJson(const MountingParameters& m, const LaserCorrections& lasers) {
  using nlohmann::json;
  auto vec = [](const Vec3& v) { return json::array({v.x(), v.y(), v.z()}); };
  auto mat = [](const Mat3& R) {
    json rows = json::array();
    for (int r = 0; r < 3; ++r) rows.push_back({R(r, 0), R(r, 1), R(r, 2)});
    return rows;
  };
  auto quat = [](const Eigen::Quaterniond& q) { return json::array({q.w(), q.x(), q.y(), q.z()}); };
  json j;
  j["conventions"] = {{"R_bore", "Rz(heading) * Ry(pitch) * Rx(roll), active, right-handed"},
                      {"R_bs", "R_bore * R_nom, scanner frame -> body frame"},
                      {"lever_arm", "IMU origin -> scanner origin, body axes"},
                      {"quaternion_order", "w, x, y, z"}};
  for (BodyAxes axes : {BodyAxes::kForwardRightDown, BodyAxes::kForwardLeftUp}) {
    const MountingForm f = mountingForm(m, axes);
    j[toString(axes)] = {{"lever_arm_m", vec(f.lever_arm_m)},
                         {"boresight_deg", vec(f.boresight_rad * (180.0 / kPi))},
                         {"boresight_rad", vec(f.boresight_rad)},
                         {"R_bore", mat(f.R_bore)},
                         {"q_bore", quat(f.q_bore)},
                         {"R_bs", mat(f.R_bs)},
                         {"q_bs", quat(f.q_bs)}};
  }
  if (!lasers.empty()) {
    json e = json::array(), a = json::array(), r = json::array(), v = json::array(), h = json::array();
    for (const LaserCorrection& l : lasers) {
      e.push_back(rad2deg(l.elevation_rad));
      a.push_back(rad2deg(l.azimuth_rad));
      r.push_back(l.range_m);
      v.push_back(l.vertical_m);
      h.push_back(l.horizontal_m);
    }
    j["laser_elevation_offset_deg"] = e;
    j["laser_azimuth_offset_deg"] = a;
    j["laser_range_offset_m"] = r;
    j["laser_vertical_offset_m"] = v;
    j["laser_horizontal_offset_m"] = h;
  }
  return j.dump(2) + "\n";
}

}  // namespace mountcal
