#pragma once
/// \file detail/vtp_cost.hpp
/// The Ceres cost function of one tie observation (internal; includes Ceres).

#include <ceres/cost_function.h>
#include <ceres/numeric_diff_cost_function.h>

#include "methods/common/vtp_strip.hpp"

namespace mountcal::detail {

/// One tie observation: r = W (P_ki(M) + o_i − X_k) (SPEC §3 step 4), blocks (mounting
/// 6-vector, tie position X_k, strip offset o_i), with W the whitening of the observation's
/// covariance Σ (WᵀW = Σ⁻¹): diag(1/σ) for the picking σ alone, L⁻¹ (Σ = L Lᵀ) with the
/// stochastic model's pulse noise.
struct VtpResidual {
  const VirtualTiePoint* vtp;
  Mat3 W;
  bool operator()(const double* mounting, const double* X, const double* offset, double* r) const {
    // Rule 2 relative to the triangle's centroid: X − centroid is the same in the ± steps of
    // the central difference and cancels exactly, so no map-size round-off enters the Jacobian.
    const Vec3 P_rel = vtp->relativePosition(mounting);
    const Vec3& c = vtp->centroid();
    Vec3 e;
    for (int a = 0; a < 3; ++a) e[a] = P_rel[a] + offset[a] - (X[a] - c[a]);
    const Vec3 we = W * e;
    for (int a = 0; a < 3; ++a) r[a] = we[a];
    return true;
  }
};

/// `ceres::NumericDiffCostFunction<VtpResidual, ceres::CENTRAL, 3, 6, 3, 3>` — the central
/// differences of seed eq. (10) — whitened by `W` (WᵀW = Σ⁻¹). `vtp` must outlive it.
inline ceres::CostFunction* makeVtpCostFunction(const VirtualTiePoint* vtp, const Mat3& W, double relative_step = 1e-6) {
  ceres::NumericDiffOptions nd;
  nd.relative_step_size = relative_step;
  return new ceres::NumericDiffCostFunction<VtpResidual, ceres::CENTRAL, 3, 6, 3, 3>(new VtpResidual{vtp, W}, ceres::TAKE_OWNERSHIP, 3, nd);
}
/// A tie observation with the strip's attitude error δψ at its time (a random effect of the
/// stochastic model): r = W (P_ki(M) + o_i + δψ × u − X_k), blocks (mounting, X_k, o_i, δψ),
/// u = x − p the IMU → point vector [m].
struct VtpAttitudeResidual {
  VtpResidual base;
  Vec3 u;
  bool operator()(const double* mounting, const double* X, const double* offset, const double* dpsi, double* r) const {
    const Vec3 P_rel = base.vtp->relativePosition(mounting);
    const Vec3& c = base.vtp->centroid();
    const Vec3 rot = Vec3(dpsi[0], dpsi[1], dpsi[2]).cross(u);
    Vec3 e;
    for (int a = 0; a < 3; ++a) e[a] = P_rel[a] + offset[a] + rot[a] - (X[a] - c[a]);
    const Vec3 we = base.W * e;
    for (int a = 0; a < 3; ++a) r[a] = we[a];
    return true;
  }
};
inline ceres::CostFunction* makeVtpAttitudeCostFunction(const VirtualTiePoint* vtp, const Mat3& W, const Vec3& u_m,
                                                        double relative_step = 1e-6) {
  ceres::NumericDiffOptions nd;
  nd.relative_step_size = relative_step;
  return new ceres::NumericDiffCostFunction<VtpAttitudeResidual, ceres::CENTRAL, 3, 6, 3, 3, 3>(
      new VtpAttitudeResidual{VtpResidual{vtp, W}, u_m}, ceres::TAKE_OWNERSHIP, 3, nd);
}

/// The same with independent axes of standard deviation `sigma_m` [m].
inline ceres::CostFunction* makeVtpCostFunction(const VirtualTiePoint* vtp, const Vec3& sigma_m, double relative_step = 1e-6) {
  return makeVtpCostFunction(vtp, Mat3(sigma_m.cwiseInverse().asDiagonal()), relative_step);
}

}  // namespace mountcal::detail
