#pragma once
// Internal (not installed): the one RANSAC plane search of the library. The plane patches, the
// feature targets and the virtual tie points each draw their candidates in their own
// deterministic way and refine the winner their own way; the hypothesis loop is this one.

#include <cmath>
#include <cstddef>
#include <vector>

#include "mountcal/core/rotation.hpp"

namespace mountcal::detail {

/// The winning plane of ransacPlane(): unit normal and a point on it; `found` is false when
/// every sample was degenerate (collinear or repeated points).
struct PlaneHypothesis {
  bool found = false;
  Vec3 normal = Vec3::UnitZ();
  Vec3 point = Vec3::Zero();
  std::size_t inliers = 0;   // candidates within the threshold
  std::size_t priority = 0;  // of them, among the first `priority_count` candidates
};

/// RANSAC over planes through three of the candidates: `iterations` samples, the positions in
/// `candidates` drawn by `draw()` (which returns a value in [0, candidates.size())). A sample
/// scores by how many of the first `priority_count` candidates lie within `threshold` of its
/// plane (a pick's nearest neighbours, so that the plane found is the one the pick lies on),
/// then by how many candidates do; the first best sample wins.
template <typename Index, typename Draw>
PlaneHypothesis ransacPlane(const std::vector<Vec3>& points, const std::vector<Index>& candidates, double threshold, int iterations,
                            Draw&& draw, std::size_t priority_count = 0) {
  PlaneHypothesis best;
  if (candidates.size() < 3) return best;
  for (int it = 0; it < iterations; ++it) {
    const Vec3& a = points[candidates[draw()]];
    const Vec3& b = points[candidates[draw()]];
    const Vec3& c = points[candidates[draw()]];
    const Vec3 normal = (b - a).cross(c - a);
    if (normal.norm() < 1e-9) continue;
    const Vec3 n = normal.normalized();
    std::size_t count = 0, priority = 0;
    for (std::size_t r = 0; r < candidates.size(); ++r) {
      if (std::abs(n.dot(points[candidates[r]] - a)) <= threshold) {
        ++count;
        priority += r < priority_count;
      }
    }
    if (priority > best.priority || (priority == best.priority && count > best.inliers)) {
      best.found = true;
      best.normal = n;
      best.point = a;
      best.inliers = count;
      best.priority = priority;
    }
  }
  return best;
}

/// The candidates within `threshold` of the plane (normal, point), in candidate order.
template <typename Index>
std::vector<Index> planeInliers(const std::vector<Vec3>& points, const std::vector<Index>& candidates, const Vec3& normal,
                                const Vec3& point, double threshold) {
  std::vector<Index> in;
  for (Index i : candidates)
    if (std::abs(normal.dot(points[i] - point)) <= threshold) in.push_back(i);
  return in;
}

}  // namespace mountcal::detail
