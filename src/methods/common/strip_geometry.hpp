#pragma once
// Internal helpers shared by the methods (not installed): strip points at the mounting used,
// the mounting's motion of a point, plane fits and a plan grid.

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "mountcal/data.hpp"
#include "mountcal/core/georeference_model.hpp"

namespace mountcal::detail {

/// How a point moves from the mounting used to mounting m: SPEC §2 eq. (1) differenced,
///   x(M) − x(M_used) = R_mb [ (R_bs(M) − R_bs(M_used)) r_s + (a_b − a_b,used) ],
/// which is exact (p_m cancels), so kilometre-size coordinates never enter a difference.
struct MountingMotion {
  Mat3 dR_bs = Mat3::Zero();
  Vec3 da_b = Vec3::Zero();
  MountingMotion() = default;
  MountingMotion(const Mat3& R_nom, const Mat3& R_bs_used, const Vec3& a_used, const double* m6)
      : dR_bs(R_zyx(Vec3(m6[3], m6[4], m6[5])) * R_nom - R_bs_used), da_b(Vec3(m6[0], m6[1], m6[2]) - a_used) {}
  Vec3 displacement(const Mat3& R_mb, const Vec3& r_s) const { return R_mb * (dR_bs * r_s + da_b); }
};

/// MountingMotion for m6, remembered per thread (the last sixteen inputs, compared exactly): a
/// point residual differentiated by central differences asks for the same thirteen mountings
/// (the current one and ± each of the six) at every point, and building the rotation was most of
/// its cost.
inline MountingMotion cachedMountingMotion(const Mat3& R_nom, const Mat3& R_bs_used, const Vec3& a_used, const double* m6) {
  constexpr int kKey = 27, kSlots = 16;
  struct Slot {
    double key[kKey];
    MountingMotion motion;
  };
  thread_local Slot slots[kSlots];
  thread_local int filled = 0, next = 0;
  double key[kKey];
  std::copy(m6, m6 + 6, key);
  std::copy(R_nom.data(), R_nom.data() + 9, key + 6);
  std::copy(R_bs_used.data(), R_bs_used.data() + 9, key + 15);
  std::copy(a_used.data(), a_used.data() + 3, key + 24);
  for (int i = 0; i < filled; ++i)
    if (std::equal(key, key + kKey, slots[i].key)) return slots[i].motion;  // NaN never equal: recomputed
  Slot& s = slots[next];
  std::copy(key, key + kKey, s.key);
  s.motion = MountingMotion(R_nom, R_bs_used, a_used, m6);
  next = (next + 1) % kSlots;
  filled = std::min(filled + 1, kSlots);
  return s.motion;
}

/// The strip's points at `used` (StripData::x_m, or computed through the per-point poses or the trajectory).
inline std::vector<Vec3> referencePoints(const CalibrationData& data, const StripData& s, const MountingParameters& used) {
  if (!s.x_m.empty()) return s.x_m;
  std::vector<Vec3> x(s.r_s.size());
  std::size_t cursor = 0;
  const Mat3 R_bs = used.R_bs();
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = georeference(data.pose(s, i, &cursor), R_bs, used.a_b, s.r_s[i]);
  return x;
}

/// Least-squares plane (principal component analysis): centroid, unit normal (upwards, or
/// towards +y/+x for vertical planes), σ of the distances.
struct PlaneFit {
  Vec3 centroid = Vec3::Zero();
  Vec3 normal = Vec3::UnitZ();
  double sigma_m = 0.0;
  /// √(λ_mid / λ_max) of the points' covariance: near 0 for points along a line (one scan
  /// line of a multi-beam scanner), whose "plane" normal is arbitrary.
  double spread_ratio = 0.0;
  double extent_m = 0.0;  ///< √λ_max: the spread along the plane's longest direction [m]
  int n = 0;
};
template <typename Get>
PlaneFit fitPlane(std::size_t count, Get get) {
  PlaneFit f;
  f.n = static_cast<int>(count);
  if (count < 3) return f;
  Vec3 c = Vec3::Zero();
  for (std::size_t i = 0; i < count; ++i) c += get(i);
  c /= static_cast<double>(count);
  Mat3 C = Mat3::Zero();
  for (std::size_t i = 0; i < count; ++i) {
    const Vec3 d = get(i) - c;
    C += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(C);
  Vec3 n = eig.eigenvectors().col(0);
  if (n.z() < -1e-9 || (std::abs(n.z()) <= 1e-9 && (n.y() < 0 || (n.y() == 0 && n.x() < 0)))) n = -n;
  f.centroid = c;
  f.normal = n;
  f.sigma_m = std::sqrt(std::max(eig.eigenvalues()(0), 0.0) / static_cast<double>(count));
  f.extent_m = std::sqrt(std::max(eig.eigenvalues()(2), 0.0) / static_cast<double>(count));
  f.spread_ratio = eig.eigenvalues()(2) > 0 ? std::sqrt(std::max(eig.eigenvalues()(1), 0.0) / eig.eigenvalues()(2)) : 0.0;
  return f;
}

inline double angleDeg(const Vec3& a, const Vec3& b) {
  return rad2deg(std::acos(std::min(1.0, std::abs(a.normalized().dot(b.normalized())))));
}

/// Points of one strip hashed into square plan cells.
class PlanGrid {
 public:
  PlanGrid(const std::vector<Vec3>& x, double cell_m) : cell_(cell_m) {
    for (std::size_t i = 0; i < x.size(); ++i) cells_[key(x[i].x(), x[i].y())].push_back(static_cast<std::uint32_t>(i));
  }
  static std::int64_t pack(std::int64_t ix, std::int64_t iy) {
    return static_cast<std::int64_t>((static_cast<std::uint64_t>(ix) << 32) ^ (static_cast<std::uint64_t>(iy) & 0xffffffffULL));
  }
  std::int64_t key(double x, double y) const { return pack(cellIndex(x), cellIndex(y)); }
  std::int64_t cellIndex(double v) const { return static_cast<std::int64_t>(std::floor(v / cell_)); }
  double cell() const { return cell_; }
  const std::unordered_map<std::int64_t, std::vector<std::uint32_t>>& cells() const { return cells_; }
  const std::vector<std::uint32_t>* find(std::int64_t k) const {
    auto it = cells_.find(k);
    return it == cells_.end() ? nullptr : &it->second;
  }
  /// Indices of the points inside the box.
  std::vector<std::uint32_t> box(const std::vector<Vec3>& x, double xmin, double ymin, double xmax, double ymax) const {
    std::vector<std::uint32_t> out;
    for (std::int64_t ix = cellIndex(xmin); ix <= cellIndex(xmax); ++ix)
      for (std::int64_t iy = cellIndex(ymin); iy <= cellIndex(ymax); ++iy)
        if (const auto* c = find(pack(ix, iy)))
          for (std::uint32_t i : *c)
            if (x[i].x() >= xmin && x[i].x() <= xmax && x[i].y() >= ymin && x[i].y() <= ymax) out.push_back(i);
    return out;
  }

 private:
  double cell_;
  std::unordered_map<std::int64_t, std::vector<std::uint32_t>> cells_;
};

/// Mean plan spacing of a strip's points [m]: from the density in the occupied 2 m cells.
inline double planSpacing(const std::vector<Vec3>& x) {
  if (x.empty()) return 0.0;
  const PlanGrid g(x, 2.0);
  std::vector<double> counts;
  for (const auto& c : g.cells()) counts.push_back(static_cast<double>(c.second.size()));
  std::sort(counts.begin(), counts.end());
  const double per_cell = counts[counts.size() * 3 / 4];  // well-filled cells (edges of the data are half empty)
  return std::sqrt(4.0 / std::max(per_cell, 1.0));
}

}  // namespace mountcal::detail
