#pragma once
/// \file io/pose_fields.hpp
/// Per-point sensor poses stored in LAS extra bytes (SPEC §4 "Per-point poses"): which named
/// attributes hold the sensor position and attitude, in which attitude convention, and their
/// conversion — once, at the edge — into SPEC §2's pose (p_m, R_mb = R_mn·R_nb).

#include <array>
#include <string>
#include <vector>

#include "mountcal/io/las.hpp"
#include "mountcal/core/trajectory.hpp"

namespace mountcal::io {

/// How roll, pitch and yaw of a per-point pose are to be read.
enum class AttitudeConvention {
  /// SPEC §2: R_nb = Rz(heading)·Ry(pitch)·Rx(roll), heading clockwise from North, body
  /// x forward, y right, z down; mapping frame East-North-Up, so R_mb = R_mn·R_nb.
  kNedFrd,
  /// R = Rz(yaw)·Ry(pitch)·Rx(roll) from a body x forward, y left, z up to East-North-Up, yaw
  /// counter-clockwise from East (the Gravity HDL-32E files, SPEC §5). With F = diag(1, −1, −1)
  /// taking SPEC's body (x forward, y right, z down) to that body, R_mb = R·F.
  kEnuFlu,
};

/// "ned_frd" or "enu_flu".
const char* toString(AttitudeConvention c);
/// Throws InvalidInput for an unknown name.
AttitudeConvention attitudeConventionFromString(const std::string& name);

/// SPEC §2's body → mapping rotation from a convention's angles [rad].
Mat3 bodyToMapping(AttitudeConvention c, double roll, double pitch, double yaw);

/// The extra-bytes attributes that hold each point's sensor pose.
struct PoseFields {
  std::array<std::string, 3> position{"SensorX", "SensorY", "SensorZ"};                       ///< in the strips' coordinates [m]
  std::array<std::string, 3> attitude{"SensorRollRads", "SensorPitchRads", "SensorYawRads"};  ///< roll, pitch, yaw/heading
  bool degrees = false;                                                                       ///< attitude unit: radians unless set
  AttitudeConvention convention = AttitudeConvention::kEnuFlu;
};

/// Reads the pose of each point of one LAS file through its Extra Bytes descriptors.
class PoseFieldReader {
 public:
  /// Throws FileError naming `path` and the attribute when a field is missing from the file's
  /// Extra Bytes (the message lists the attributes the file has) or has several elements.
  PoseFieldReader(const LasHeader& header, const std::string& path, const PoseFields& fields);
  /// The pose that measured `p`; throws FileError naming `record` for a non-finite value.
  Pose pose(const LasPoint& p, std::uint64_t record) const;

 private:
  std::string path_;
  PoseFields fields_;
  std::array<ExtraBytesAttribute, 6> attr_;
};

/// Reads a numeric extra-bytes attribute (or a standard one: "gps_time", "point_source_id",
/// "user_data", "intensity", "classification") of each point — the field a strip is split by.
class PointFieldReader {
 public:
  /// Throws FileError naming `path` when the field is neither standard nor in the Extra Bytes.
  PointFieldReader(const LasHeader& header, const std::string& path, const std::string& field);
  double value(const LasPoint& p) const;
  const std::string& name() const { return name_; }

 private:
  std::string name_;
  int standard_ = -1;
  ExtraBytesAttribute attr_;
};

}  // namespace mountcal::io
