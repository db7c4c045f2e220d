#include "mountcal/core/mounting.hpp"

namespace mountcal {

const std::array<std::string, 6>& mountingParameterNames() {
  static const std::array<std::string, 6> kNames = {"lever_arm_x",    "lever_arm_y",     "lever_arm_z",
                                                    "boresight_roll", "boresight_pitch", "boresight_heading"};
  return kNames;
}

}  // namespace mountcal
