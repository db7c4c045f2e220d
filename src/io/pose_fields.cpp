#include "mountcal/io/pose_fields.hpp"

#include <cmath>

#include "mountcal/core/error.hpp"
#include "mountcal/core/rotation.hpp"

namespace mountcal::io {

const char* toString(AttitudeConvention c) { return c == AttitudeConvention::kNedFrd ? "ned_frd" : "enu_flu"; }

AttitudeConvention attitudeConventionFromString(const std::string& name) {
  if (name == "ned_frd") return AttitudeConvention::kNedFrd;
  if (name == "enu_flu") return AttitudeConvention::kEnuFlu;
  throw InvalidInput("unknown attitude convention '" + name + "' (expected \"ned_frd\" or \"enu_flu\")");
}

Mat3 bodyToMapping(AttitudeConvention c, double roll, double pitch, double yaw) {
  if (c == AttitudeConvention::kNedFrd) return R_mn_local() * R_nb(roll, pitch, yaw);  // SPEC §2
  // R_{ENU←FLU} · F, F = diag(1, −1, −1): SPEC body (x fwd, y right, z down) → (x fwd, y left, z up).
  Mat3 R = Rz(yaw) * Ry(pitch) * Rx(roll);
  R.col(1) = -R.col(1);
  R.col(2) = -R.col(2);
  return R;
}

namespace {

std::string attributeList(const std::vector<ExtraBytesAttribute>& attrs) {
  std::string list;
  for (const ExtraBytesAttribute& a : attrs) list += (list.empty() ? "" : ", ") + a.name;
  return list.empty() ? "none" : list;
}

ExtraBytesAttribute needAttribute(const std::vector<ExtraBytesAttribute>& attrs, const std::string& path, const std::string& name) {
  const ExtraBytesAttribute* a = findExtraBytesAttribute(attrs, name);
  if (!a) throw FileError(path, "Extra Bytes VLR", "no attribute '" + name + "' (the file has: " + attributeList(attrs) + ")");
  if (a->data_type == 0) throw FileError(path, "Extra Bytes VLR", "attribute '" + name + "' is undocumented bytes (type 0), not a number");
  if (a->elements != 1)
    throw FileError(path, "Extra Bytes VLR",
                    "attribute '" + name + "' has " + std::to_string(a->elements) + " elements; expected one value");
  if (a->hasScale() && a->scale[0] == 0.0)  // every value would read as the offset
    throw FileError(path, "Extra Bytes VLR", "attribute '" + name + "' has a scale of 0: every point's value would be its offset");
  return *a;
}

}  // namespace

PoseFieldReader::PoseFieldReader(const LasHeader& header, const std::string& path, const PoseFields& fields)
    : path_(path), fields_(fields) {
  const std::vector<ExtraBytesAttribute> attrs = extraBytesAttributes(header, path);
  for (int k = 0; k < 3; ++k) {
    attr_[k] = needAttribute(attrs, path, fields.position[k]);
    attr_[3 + k] = needAttribute(attrs, path, fields.attitude[k]);
  }
}

Pose PoseFieldReader::pose(const LasPoint& p, std::uint64_t record) const {
  double v[6];
  for (int k = 0; k < 6; ++k) {
    v[k] = extraBytesValue(p, attr_[k]);
    if (!std::isfinite(v[k])) throw FileError(path_, "record " + std::to_string(record), "attribute '" + attr_[k].name + "' is not finite");
  }
  const double u = fields_.degrees ? kPi / 180.0 : 1.0;
  for (int k = 3; k < 6; ++k) {
    if (std::abs(v[k] * u) > 8 * kPi) {
      throw FileError(path_, "record " + std::to_string(record),
                      "attitude '" + attr_[k].name + "' = " + std::to_string(v[k]) + (fields_.degrees ? " deg" : " rad") +
                          " is not an angle; is the unit right?");
    }
  }
  Pose pose;
  pose.p_m = Vec3(v[0], v[1], v[2]);
  pose.R_mb = bodyToMapping(fields_.convention, v[3] * u, v[4] * u, v[5] * u);
  return pose;
}

PointFieldReader::PointFieldReader(const LasHeader& header, const std::string& path, const std::string& field) : name_(field) {
  static const char* standard[] = {"gps_time", "point_source_id", "user_data", "intensity", "classification"};
  for (int k = 0; k < 5; ++k)
    if (field == standard[k]) standard_ = k;
  if (standard_ < 0) attr_ = needAttribute(extraBytesAttributes(header, path), path, field);
}

double PointFieldReader::value(const LasPoint& p) const {
  switch (standard_) {
    case 0:
      return p.gps_time;
    case 1:
      return p.point_source_id;
    case 2:
      return p.user_data;
    case 3:
      return p.intensity;
    case 4:
      return p.classification;
    default:
      return extraBytesValue(p, attr_);
  }
}

}  // namespace mountcal::io
