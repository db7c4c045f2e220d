#include "mountcal/georeference_model.hpp"

#include <cmath>

#include "mountcal/error.hpp"

namespace mountcal {

GeoreferenceModel::GeoreferenceModel(std::shared_ptr<const Trajectory> trajectory,
                                     MountingParameters mounting)
    : trajectory_(std::move(trajectory)), mounting_(mounting), R_bs_(mounting.R_bs()) {
  if (!trajectory_ || trajectory_->size() < 2) {
    throw InvalidInput("GeoreferenceModel: the trajectory needs at least 2 samples");
  }
  if (!mounting_.a_b.allFinite() || !mounting_.boresight.allFinite() ||
      !mounting_.R_nom.allFinite()) {
    throw InvalidInput("GeoreferenceModel: the mounting has a non-finite value");
  }
}

GeoreferenceModel::GeoreferenceModel(Trajectory trajectory, MountingParameters mounting)
    : GeoreferenceModel(std::make_shared<const Trajectory>(std::move(trajectory)), mounting) {}

void GeoreferenceModel::setMounting(const MountingParameters& mounting) {
  mounting_ = mounting;
  R_bs_ = mounting.R_bs();
}

Vec3 GeoreferenceModel::forward(double time_s, const Vec3& r_s) const {
  return georeference(trajectory_->pose(time_s), R_bs_, mounting_.a_b, r_s);  // seed eq. (1)
}

Vec3 GeoreferenceModel::inverse(double time_s, const Vec3& x_m) const {
  return inverseGeoreference(trajectory_->pose(time_s), R_bs_, mounting_.a_b, x_m);
}

void GeoreferenceModel::forward(const double* time_s, const double* r_s, double* x_m,
                                std::size_t n) const {
  std::size_t cursor = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = trajectory_->locate(time_s[k], &cursor);
    const Pose pose = trajectory_->interpolateInInterval(i, time_s[k]);
    Eigen::Map<Vec3>(x_m + 3 * k) =
        georeference(pose, R_bs_, mounting_.a_b, Eigen::Map<const Vec3>(r_s + 3 * k));
  }
}

void GeoreferenceModel::inverse(const double* time_s, const double* x_m, double* r_s,
                                std::size_t n) const {
  std::size_t cursor = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = trajectory_->locate(time_s[k], &cursor);
    const Pose pose = trajectory_->interpolateInInterval(i, time_s[k]);
    Eigen::Map<Vec3>(r_s + 3 * k) =
        inverseGeoreference(pose, R_bs_, mounting_.a_b, Eigen::Map<const Vec3>(x_m + 3 * k));
  }
}

void GeoreferenceModel::forwardLineScan(const LineScannerModel& scanner, const double* time_s,
                                        const double* scan_angle_rad, const double* range_m,
                                        double* x_m, std::size_t n) const {
  std::size_t cursor = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = trajectory_->locate(time_s[k], &cursor);
    const Pose pose = trajectory_->interpolateInInterval(i, time_s[k]);
    const Vec3 r_s = scanner.vector(scan_angle_rad[k], range_m[k]);
    Eigen::Map<Vec3>(x_m + 3 * k) = georeference(pose, R_bs_, mounting_.a_b, r_s);
  }
}

}  // namespace mountcal
