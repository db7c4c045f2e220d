#pragma once
/// \file mounting_forms.hpp
/// The mounting in the forms other programs expect (SPEC §2 conventions made explicit), so that
/// nobody works signs out by hand.
///
/// mountcal's body frame is x forward, y right, z down (FRD, SPEC §2); the boresight is
/// R_bore = Rz(κ)·Ry(φ)·Rx(ω) (active, right-handed, roll ω first), R_bs = R_bore·R_nom maps
/// the scanner frame into the body frame, and the lever arm a_b points from the IMU origin to
/// the scanner origin in body axes. A program whose body frame is x forward, y left, z up
/// (FLU, e.g. ROS REP 103's base_link) sees the same physical rotation as T·R_bore·T with
/// T = diag(1, −1, −1): since T is a half turn about x it commutes with Rx and reverses Ry and
/// Rz, so its angles are (ω, −φ, −κ) and its lever arm (a_x, −a_y, −a_z).

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "mountcal/core/mounting.hpp"
#include "mountcal/core/sensor_model.hpp"

namespace mountcal {

/// The axes a body frame is written in.
enum class BodyAxes {
  kForwardRightDown,  ///< mountcal's own (SPEC §2), the aerospace convention
  kForwardLeftUp,     ///< robotics (ROS REP 103)
};
const char* toString(BodyAxes axes);  ///< "forward-right-down" / "forward-left-up"

/// One mounting in one body frame's axes.
struct MountingForm {
  BodyAxes axes = BodyAxes::kForwardRightDown;
  Vec3 lever_arm_m = Vec3::Zero();                             ///< IMU → scanner, in these axes [m]
  Vec3 boresight_rad = Vec3::Zero();                           ///< (roll, pitch, heading) of R_bore = Rz·Ry·Rx in these axes [rad]
  Mat3 R_bore = Mat3::Identity();                              ///< the boresight rotation in these axes [-]
  Eigen::Quaterniond q_bore = Eigen::Quaterniond::Identity();  ///< of R_bore, w ≥ 0 [-]
  Mat3 R_bs = Mat3::Identity();  ///< scanner → body: R_bore·R_nom, body axes as above, scanner axes as the sensor model's [-]
  Eigen::Quaterniond q_bs = Eigen::Quaterniond::Identity();  ///< of R_bs, w ≥ 0 [-]
};

/// The mounting in the given body axes.
MountingForm mountingForm(const MountingParameters& mounting, BodyAxes axes);

/// Every form as text: lever arm, boresight angles in degrees and radians, rotation matrices
/// and quaternions, in FRD and FLU axes; and the per-laser elevation offsets when given [rad].
std::string mountingFormsText(const MountingParameters& mounting, const LaserCorrections& lasers = {});

/// The same as a JSON object's text (for `mountcal mounting --json`).
std::string mountingFormsJson(const MountingParameters& mounting, const LaserCorrections& lasers = {});

}  // namespace mountcal
