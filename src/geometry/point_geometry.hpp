#pragma once
// Internal (not installed): point-cloud kernels that know nothing of sensors or mountings — the
// least-squares plane, the angle of two normals, a plan grid of cells and the plan spacing.

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <limits>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "mountcal/core/rotation.hpp"

namespace mountcal::detail {

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
    for (std::size_t i = 0; i < x.size(); ++i) {
      const std::int64_t ix = cellIndex(x[i].x()), iy = cellIndex(x[i].y());
      cells_[pack(ix, iy)].push_back(static_cast<std::uint32_t>(i));
      ix0_ = std::min(ix0_, ix), ix1_ = std::max(ix1_, ix), iy0_ = std::min(iy0_, iy), iy1_ = std::max(iy1_, iy);
    }
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
  /// Indices of the points inside the box. Only the cells within the occupied ones are visited:
  /// a box of ±10⁶ m costs no more than one around the data.
  std::vector<std::uint32_t> box(const std::vector<Vec3>& x, double xmin, double ymin, double xmax, double ymax) const {
    std::vector<std::uint32_t> out;
    if (!(xmin <= xmax && ymin <= ymax)) return out;     // also NaN
    const double lo = -9e15 * cell_, hi = 9e15 * cell_;  // cellIndex() stays within int64
    const std::int64_t ix0 = std::max(ix0_, cellIndex(std::max(xmin, lo))), ix1 = std::min(ix1_, cellIndex(std::min(xmax, hi)));
    const std::int64_t iy0 = std::max(iy0_, cellIndex(std::max(ymin, lo))), iy1 = std::min(iy1_, cellIndex(std::min(ymax, hi)));
    for (std::int64_t ix = ix0; ix <= ix1; ++ix)
      for (std::int64_t iy = iy0; iy <= iy1; ++iy)
        if (const auto* c = find(pack(ix, iy)))
          for (std::uint32_t i : *c)
            if (x[i].x() >= xmin && x[i].x() <= xmax && x[i].y() >= ymin && x[i].y() <= ymax) out.push_back(i);
    return out;
  }

 private:
  double cell_;
  std::unordered_map<std::int64_t, std::vector<std::uint32_t>> cells_;
  std::int64_t ix0_ = std::numeric_limits<std::int64_t>::max(), ix1_ = std::numeric_limits<std::int64_t>::min();  // occupied cells
  std::int64_t iy0_ = std::numeric_limits<std::int64_t>::max(), iy1_ = std::numeric_limits<std::int64_t>::min();
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
