#pragma once
// Internal (not installed): priors on a block of per-laser intrinsics, shared by the methods
// that estimate them (dense correspondences, features).

#include <ceres/ceres.h>

#include <utility>
#include <vector>

#include "mountcal/adjustment/mounting_adjustment.hpp"

namespace mountcal::detail {

/// The mean of the values at `indices` of one block ~ N(0, σ) (one index: a value's own prior).
struct LaserPrior {
  std::vector<int> indices;
  double sigma;
  template <typename T>
  bool operator()(T const* const* p, T* r) const {
    T s(0.0);
    for (int i : indices) s += p[0][i];
    r[0] = s / T(static_cast<double>(indices.size()) * sigma);
    return true;
  }
};

/// Adds LaserPrior{indices, sigma} on `block` (of `block_size` values) to the adjustment.
inline void addLaserPrior(AdjustmentProblem* problem, double* block, int block_size, std::vector<int> indices, double sigma) {
  auto* cost = new ceres::DynamicAutoDiffCostFunction<LaserPrior>(new LaserPrior{std::move(indices), sigma});
  cost->AddParameterBlock(block_size);
  cost->SetNumResiduals(1);
  problem->addResidualBlock(cost, 0.0, {block});
}

}  // namespace mountcal::detail
