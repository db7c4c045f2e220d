#include "mountcal/core/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "mountcal/core/error.hpp"

namespace mountcal {

namespace {
bool finite(const Vec3& v) { return v.allFinite(); }
}  // namespace

Trajectory::Trajectory(std::vector<TrajectorySample> samples, PositionInterpolation interpolation)
    : samples_(std::move(samples)), interpolation_(interpolation) {
  const std::size_t n = samples_.size();
  if (n < 2) {
    throw InvalidInput("trajectory: needs at least 2 samples, got " + std::to_string(n));
  }
  time_s_.resize(n);
  q_mb_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const TrajectorySample& s = samples_[i];
    if (!std::isfinite(s.time_s) || !finite(s.p_m) || !std::isfinite(s.roll) || !std::isfinite(s.pitch) || !std::isfinite(s.heading) ||
        !s.R_mn.allFinite()) {
      throw InvalidInput("trajectory: sample " + std::to_string(i) + " has a non-finite value");
    }
    if (i > 0 && !(s.time_s > samples_[i - 1].time_s)) {
      std::ostringstream msg;
      msg.precision(17);
      msg << "trajectory: sample " << i << " time " << s.time_s << " s is "
          << (s.time_s == samples_[i - 1].time_s ? "a duplicate of" : "earlier than") << " sample " << i - 1 << " ("
          << samples_[i - 1].time_s << " s); times must be strictly increasing";
      throw InvalidInput(msg.str());
    }
    time_s_[i] = s.time_s;
    Quat q(s.R_mn * R_nb(s.roll, s.pitch, s.heading));
    q.normalize();
    if (i > 0 && q.dot(q_mb_[i - 1]) < 0) q.coeffs() = -q.coeffs();
    q_mb_[i] = q;
  }
  dq_.resize(n - 1);
  for (std::size_t i = 0; i + 1 < n; ++i) dq_[i] = quatLog(q_mb_[i].conjugate() * q_mb_[i + 1]);

  if (interpolation_ == PositionInterpolation::kCubic) {
    // Three-point finite-difference velocities (exact for quadratic motion on any spacing).
    v_m_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      if (i == 0 || i + 1 == n) {
        const std::size_t a = (i == 0) ? 0 : n - 2;
        v_m_[i] = (samples_[a + 1].p_m - samples_[a].p_m) / (time_s_[a + 1] - time_s_[a]);
        continue;
      }
      const double h0 = time_s_[i] - time_s_[i - 1], h1 = time_s_[i + 1] - time_s_[i];
      const Vec3 d0 = (samples_[i].p_m - samples_[i - 1].p_m) / h0;
      const Vec3 d1 = (samples_[i + 1].p_m - samples_[i].p_m) / h1;
      v_m_[i] = (h1 * d0 + h0 * d1) / (h0 + h1);
    }
  }
}

double Trajectory::startTime() const { return time_s_.empty() ? 0.0 : time_s_.front(); }
double Trajectory::endTime() const { return time_s_.empty() ? 0.0 : time_s_.back(); }

std::size_t Trajectory::locate(double time_s, std::size_t* cursor) const {
  const std::size_t n = time_s_.size();
  if (n < 2 || !(time_s >= time_s_.front() && time_s <= time_s_.back())) {
    throw TimeOutOfRange(time_s, startTime(), endTime());
  }
  std::size_t i = std::min(*cursor, n - 2);
  if (time_s >= time_s_[i] && time_s <= time_s_[i + 1]) {
    // hit
  } else if (time_s > time_s_[i + 1] && i + 2 < n && time_s <= time_s_[i + 2]) {
    ++i;  // the common case for sorted queries: the next interval
  } else {
    auto it = std::upper_bound(time_s_.begin(), time_s_.end(), time_s);
    i = static_cast<std::size_t>(it - time_s_.begin());
    i = (i == 0) ? 0 : std::min(i - 1, n - 2);
  }
  *cursor = i;
  return i;
}

Vec3 Trajectory::positionInInterval(std::size_t i, double time_s) const {
  const double s = (time_s - time_s_[i]) / (time_s_[i + 1] - time_s_[i]);
  // The polynomial form (p₀ plus small terms) rounds less than the Hermite basis applied to two
  // large map coordinates, and is the one the batch georeferencing folds in.
  Vec3 c[4];
  intervalPosition(i, c);
  return ((c[3] * s + c[2]) * s + c[1]) * s + c[0];
}

Pose Trajectory::interpolateInInterval(std::size_t i, double time_s) const {
  const double s = (time_s - time_s_[i]) / (time_s_[i + 1] - time_s_[i]);
  Pose pose;
  pose.p_m = positionInInterval(i, time_s);
  // slerp: q(s) = q_i · exp(s · log(q_i⁻¹ q_{i+1}))
  pose.R_mb = (q_mb_[i] * quatExp(s * dq_[i])).toRotationMatrix();
  return pose;
}

void Trajectory::intervalPosition(std::size_t i, Vec3 c[4]) const {
  const Vec3& p0 = samples_[i].p_m;
  const Vec3& p1 = samples_[i + 1].p_m;
  c[0] = p0;
  if (interpolation_ == PositionInterpolation::kCubic) {
    // The Hermite basis of positionInInterval() collected by powers of s.
    const double h = time_s_[i + 1] - time_s_[i];
    const Vec3 m0 = h * v_m_[i], m1 = h * v_m_[i + 1];
    c[1] = m0;
    c[2] = 3.0 * (p1 - p0) - 2.0 * m0 - m1;
    c[3] = 2.0 * (p0 - p1) + m0 + m1;
  } else {
    c[1] = p1 - p0;
    c[2] = c[3] = Vec3::Zero();
  }
}

void Trajectory::intervalAttitude(std::size_t i, Mat3* R_i, Vec3* omega_i) const {
  *R_i = q_mb_[i].toRotationMatrix();
  *omega_i = dq_[i];
}

Pose Trajectory::pose(double time_s) const {
  std::size_t cursor = 0;
  return pose(time_s, &cursor);
}

Pose Trajectory::pose(double time_s, std::size_t* cursor) const {
  const std::size_t i = locate(time_s, cursor);
  return interpolateInInterval(i, time_s);
}

void TrajectoryAccuracySeries::at(double t, Vec3* position, Vec3* attitude) const {
  if (time_s.empty()) {
    *position = *attitude = Vec3::Zero();
    return;
  }
  const auto hi = std::upper_bound(time_s.begin(), time_s.end(), t);
  if (hi == time_s.begin() || hi == time_s.end()) {
    const std::size_t k = hi == time_s.begin() ? 0 : time_s.size() - 1;
    *position = position_m[k];
    *attitude = attitude_rad[k];
    return;
  }
  const std::size_t b = static_cast<std::size_t>(hi - time_s.begin()), a = b - 1;
  const double span = time_s[b] - time_s[a];
  const double w = span > 0 ? (t - time_s[a]) / span : 0.0;
  *position = (1 - w) * position_m[a] + w * position_m[b];
  *attitude = (1 - w) * attitude_rad[a] + w * attitude_rad[b];
}

bool TrajectoryAccuracySeries::IsValid(std::string* error) const {
  auto fail = [&](const std::string& why) {
    if (error) *error = why;
    return false;
  };
  if (position_m.size() != time_s.size() || attitude_rad.size() != time_s.size())
    return fail("trajectory accuracy series: " + std::to_string(time_s.size()) + " times, " + std::to_string(position_m.size()) +
                " position and " + std::to_string(attitude_rad.size()) + " attitude errors");
  for (std::size_t i = 0; i < time_s.size(); ++i) {
    if (!std::isfinite(time_s[i]) || (i > 0 && time_s[i] < time_s[i - 1]))
      return fail("trajectory accuracy series: record " + std::to_string(i) + ": time not finite or out of order");
    for (int a = 0; a < 3; ++a)
      if (!(position_m[i][a] >= 0) || !(attitude_rad[i][a] >= 0) || !std::isfinite(position_m[i][a]) || !std::isfinite(attitude_rad[i][a]))
        return fail("trajectory accuracy series: record " + std::to_string(i) + ": an error σ negative or not finite");
  }
  return true;
}

}  // namespace mountcal
