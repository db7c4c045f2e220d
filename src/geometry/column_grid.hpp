#pragma once
// Internal (not installed): exact k nearest neighbours in 3-D over points binned in the vertical
// columns of a plan grid. Built in linear time (a counting sort), where a k-d tree's build is
// O(N log N): for clouds that move and are searched again at a few hundred places each time —
// the dense matching's rounds, which rebuilt a FLANN tree of every strip per round (a third of
// a ten-seed laser test's time, 2026-11-28). The answers are KdTree<float, 3>'s (tested against
// brute force in tests/test_kernels.cpp): the same float distances, nearest first.

#include <cstddef>
#include <cstdint>
#include <vector>

namespace mountcal::detail {

class ColumnGrid {
 public:
  ColumnGrid() = default;
  /// Takes the coordinates (x, y, z per point, centred as for KdTree<float, 3>); the columns'
  /// width follows the points' plan density so that an occupied column holds about `per_column`
  /// of them (at least 1).
  ColumnGrid(std::vector<float> coords, double per_column);

  std::size_t size() const { return coords_.size() / 3; }
  bool empty() const { return coords_.empty(); }

  /// The min(k, size()) nearest points of `query` (3 values), nearest first (ties by index):
  /// their indices and squared distances in the arrays given (room for k each). Returns how
  /// many — or 0, with nothing written, when the nearest point is farther than `max_nearest`
  /// [m] (exactly: a squared distance above max_nearest²).
  std::size_t nearest(const float* query, std::size_t k, double max_nearest, std::size_t* indices, float* squared_distances) const;

 private:
  void bin(double cell);

  std::vector<float> coords_;       // in column order
  std::vector<std::uint32_t> ids_;  // each stored point's index as given
  double cell_ = 1.0;
  double x0_ = 0.0, y0_ = 0.0, x1_ = 0.0, y1_ = 0.0;  // the points' plan extent; (x0_, y0_) the grid's corner
  long nx_ = 0, ny_ = 0;                              // columns along x and y
  std::vector<std::uint32_t> start_;                  // column c holds stored points start_[c] .. start_[c + 1] − 1
};

}  // namespace mountcal::detail
