#pragma once
/// \file corrected_cost.hpp
/// A source's residual block at corrected strip offsets (internal to the adjustment): the
/// trajectory corrections in time and the time offset of StochasticOptions, attached to any
/// source's cost through its strip-offset blocks — a strip offset o enters an observation as a
/// shift of its point, so a correction δ(t, u) of that point is the offset o + δ.

#include <functional>
#include <memory>
#include <vector>

#include <ceres/cost_function.h>

#include "mountcal/core/rotation.hpp"

namespace mountcal::detail {

/// Legendre polynomial P_k(τ), k ≤ 3.
double legendre(int k, double tau);

/// An epoch's place τ ∈ [−1, 1] on a strip's span (centre, half width [s]); 0 on a span of one
/// instant. Epochs outside the span are clamped to its ends.
double spanTau(double time_s, double t_mid_s, double half_span_s);

/// The 3 × n basis (row-major, n = 3 d_p + 3 d_a) of a correction's point shift at τ and u:
/// δ = B c with c in TrajectoryCorrections order, i.e. Σ c_k P_k(τ) + (Σ e_k P_k(τ)) × u.
void correctionBasis(int position_degree, int attitude_degree, double tau, const Vec3& u_m, double* B);

/// The point shift δ = B c of correctionBasis for the coefficients `c`.
Vec3 correctionShift(int position_degree, int attitude_degree, double tau, const Vec3& u_m, const double* c);

/// The share of a Gauss–Markov error (correlation exp(−|Δt|/τ), unit variance) at each of one
/// strip's epochs that stays in their residuals when the strip's estimated terms absorb a
/// polynomial in time of the listed degrees (the strip offset: degree 0; trajectory corrections:
/// 1, 2, …): the diagonal of (I − P) ρ (I − P)ᵀ, P the least-squares projection (weights
/// `weights`) onto those polynomials. `times` ascending; no degrees: every share is 1.
/// `constant_absorbed` κ ∈ [0, 1]: how much of a strip-constant error the strip's offset takes
/// (a random effect with a prior takes only the data's share of it: κ = 1 − σ²_posterior / σ²_prior);
/// the degree-0 part of P is then κ times the weighted mean (P = P_all − (1 − κ) P_0).
Eigen::VectorXd residualShare(const std::vector<double>& times, const std::vector<double>& weights, double tau,
                              const std::vector<int>& degrees, double constant_absorbed = 1.0);

/// Covariance (degree × degree; rows and columns k = 1 … degree) of the Legendre coefficients of
/// an error e(t) = σ(t) u(t) over a strip's span [t0, t1], u a unit Gauss–Markov process of
/// correlation time `tau_s` (cov(e(t), e(t')) = σ(t) σ(t') exp(−|t − t'|/τ)): the coefficients of
/// its least-squares projection on the span, c_k = (2k+1)/2 ∫ e P_k dτ over τ ∈ [−1, 1], so
///   cov(c_k, c_l) = (2k+1)(2l+1)/4 ∫∫ P_k(τ) P_l(τ') σ(t) σ(t') exp(−|t − t'|/τ_c) dτ dτ'.
/// The double integral by the midpoint rule on `nodes` epochs, in O(nodes) per pair (k, l): the
/// kernel is ρ^|i−j| there, ρ = exp(−h/τ_c), summed by the recursion g_i = f_i + ρ g_{i−1}.
/// `sigma(t)` ≥ 0; a span of one instant has a zero covariance.
Eigen::MatrixXd legendreCoefficientCovariance(int degree, double t0_s, double t1_s, double tau_s,
                                              const std::function<double(double)>& sigma, int nodes = 4096);

/// Where one strip's offset block enters the source's cost and how the point moves there.
struct CorrectionTerm {
  int offset_block = 0;            ///< index of the strip's offset among the source's blocks
  int correction_block = -1;       ///< index of the strip's correction block in the wrapped cost, −1: none
  double tau = 0.0;                ///< the epoch's time on the strip's span, [−1, 1]
  Vec3 u_m = Vec3::Zero();         ///< IMU → point, mapping frame [m]
  Vec3 motion_m_s = Vec3::Zero();  ///< ∂x/∂δt = v + ω × u [m/s]; zero: no time offset
};

/// The wrapped cost: the source's blocks, then the correction blocks, then (time_block ≥ 0)
/// the time offset's block of size 1. Point shift at a term (TrajectoryCorrections):
///   δ = Σ_{k=1..d_p} c_k P_k(τ) + (Σ_{k=1..d_a} e_k P_k(τ)) × u + δt (v + ω × u),
/// passed to the source as its offset o + δ; Jacobians by the chain rule through ∂r/∂o.
class CorrectedCost final : public ceres::CostFunction {
 public:
  CorrectedCost(ceres::CostFunction* inner, std::vector<CorrectionTerm> terms, int position_degree, int attitude_degree,
                int correction_blocks, bool time_block);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  std::unique_ptr<ceres::CostFunction> inner_;
  std::vector<CorrectionTerm> terms_;
  int dp_, da_, n_inner_, n_corr_, size_;
  bool time_;
};

}  // namespace mountcal::detail
