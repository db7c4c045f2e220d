#pragma once
/// \file detail/vtp_cost.hpp
/// The Ceres cost function of one tie observation (internal; includes Ceres).

#include <ceres/cost_function.h>
#include <ceres/numeric_diff_cost_function.h>

#include "mountcal/detail/vtp_strip.hpp"

namespace mountcal::detail {

/// One tie observation: r = (P_ki(M) + o_i − X_k) / σ per axis (SPEC §3 step 4), blocks
/// (mounting 6-vector, tie position X_k, strip offset o_i).
struct VtpResidual {
  const VirtualTiePoint* vtp;
  Vec3 inv_sigma;
  bool operator()(const double* mounting, const double* X, const double* offset, double* r) const {
    // Rule 2 relative to the triangle's centroid: X − centroid is the same in the ± steps of
    // the central difference and cancels exactly, so no map-size round-off enters the Jacobian.
    const Vec3 P_rel = vtp->relativePosition(mounting);
    const Vec3& c = vtp->centroid();
    for (int a = 0; a < 3; ++a) r[a] = (P_rel[a] + offset[a] - (X[a] - c[a])) * inv_sigma[a];
    return true;
  }
};

/// `ceres::NumericDiffCostFunction<VtpResidual, ceres::CENTRAL, 3, 6, 3, 3>` — the central
/// differences of seed eq. (10). `vtp` must outlive the cost function.
inline ceres::CostFunction* makeVtpCostFunction(const VirtualTiePoint* vtp, const Vec3& sigma_m,
                                                double relative_step = 1e-6) {
  ceres::NumericDiffOptions nd;
  nd.relative_step_size = relative_step;
  return new ceres::NumericDiffCostFunction<VtpResidual, ceres::CENTRAL, 3, 6, 3, 3>(
      new VtpResidual{vtp, sigma_m.cwiseInverse()}, ceres::TAKE_OWNERSHIP, 3, nd);
}

}  // namespace mountcal::detail
