#include "adjustment/corrected_cost.hpp"

#include <Eigen/QR>

#include <algorithm>
#include <array>
#include <cmath>

namespace mountcal::detail {

double legendre(int k, double tau) {
  switch (k) {
    case 0:
      return 1.0;
    case 1:
      return tau;
    case 2:
      return 0.5 * (3.0 * tau * tau - 1.0);
    default:
      return 0.5 * (5.0 * tau * tau - 3.0) * tau;
  }
}

double spanTau(double time_s, double t_mid_s, double half_span_s) {
  return half_span_s > 0 ? std::clamp((time_s - t_mid_s) / half_span_s, -1.0, 1.0) : 0.0;
}

void correctionBasis(int position_degree, int attitude_degree, double tau, const Vec3& u_m, double* B) {
  const int dp = std::max(position_degree, 0), n = 3 * dp + 3 * std::max(attitude_degree, 0);
  std::fill(B, B + 3 * n, 0.0);
  for (int k = 1; k <= dp; ++k) {
    const double w = legendre(k, tau);
    for (int a = 0; a < 3; ++a) B[a * n + 3 * (k - 1) + a] = w;
  }
  // δψ × u = −[u]× δψ
  const Vec3& u = u_m;
  const double ux[3][3] = {{0, u.z(), -u.y()}, {-u.z(), 0, u.x()}, {u.y(), -u.x(), 0}};
  for (int k = 1; k <= attitude_degree; ++k) {
    const double w = legendre(k, tau);
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) B[a * n + 3 * dp + 3 * (k - 1) + b] = w * ux[a][b];
  }
}

Vec3 correctionShift(int position_degree, int attitude_degree, double tau, const Vec3& u_m, const double* c) {
  constexpr int kMaxSize = 18;  // degrees up to 3 (TrajectoryCorrections)
  const int n = 3 * std::max(position_degree, 0) + 3 * std::max(attitude_degree, 0);
  std::array<double, 3 * kMaxSize> B{};
  correctionBasis(position_degree, attitude_degree, tau, u_m, B.data());
  Vec3 d = Vec3::Zero();
  for (int a = 0; a < 3; ++a)
    for (int j = 0; j < n; ++j) d[a] += B[static_cast<std::size_t>(a * n + j)] * c[j];
  return d;
}

CorrectedCost::CorrectedCost(ceres::CostFunction* inner, std::vector<CorrectionTerm> terms, int position_degree, int attitude_degree,
                             int correction_blocks, bool time_block)
    : inner_(inner),
      terms_(std::move(terms)),
      dp_(std::max(position_degree, 0)),
      da_(attitude_degree),
      n_inner_(static_cast<int>(inner->parameter_block_sizes().size())),
      n_corr_(correction_blocks),
      size_(3 * dp_ + 3 * std::max(attitude_degree, 0)),
      time_(time_block) {
  set_num_residuals(inner->num_residuals());
  *mutable_parameter_block_sizes() = inner->parameter_block_sizes();
  for (int c = 0; c < n_corr_; ++c) mutable_parameter_block_sizes()->push_back(size_);
  if (time_) mutable_parameter_block_sizes()->push_back(1);
}

bool CorrectedCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const int nr = num_residuals();
  const std::size_t nt = terms_.size();
  const double dt = time_ ? parameters[n_inner_ + n_corr_][0] : 0.0;
  std::vector<const double*> params(parameters, parameters + n_inner_);
  std::vector<std::array<double, 3>> offsets(nt);
  std::vector<double> B(nt * 3 * static_cast<std::size_t>(size_));
  for (std::size_t t = 0; t < nt; ++t) {
    const CorrectionTerm& term = terms_[t];
    const double* o = parameters[term.offset_block];
    Vec3 x(o[0], o[1], o[2]);
    if (term.correction_block >= 0) {
      double* Bt = B.data() + t * 3 * static_cast<std::size_t>(size_);
      correctionBasis(dp_, da_, term.tau, term.u_m, Bt);
      const double* c = parameters[term.correction_block];
      for (int a = 0; a < 3; ++a)
        for (int j = 0; j < size_; ++j) x[a] += Bt[a * size_ + j] * c[j];
    }
    x += dt * term.motion_m_s;
    offsets[t] = {x.x(), x.y(), x.z()};
    params[static_cast<std::size_t>(term.offset_block)] = offsets[t].data();
  }
  if (!jacobians) return inner_->Evaluate(params.data(), residuals, nullptr);
  // The source's Jacobian with respect to each offset is needed for the corrections' and the
  // time offset's, also when Ceres does not ask for the offset's own (a constant block).
  std::vector<double*> jin(jacobians, jacobians + n_inner_);
  std::vector<std::vector<double>> local(nt);
  const bool time_jac = time_ && jacobians[n_inner_ + n_corr_];
  for (std::size_t t = 0; t < nt; ++t) {
    const CorrectionTerm& term = terms_[t];
    const bool needed = time_jac || (term.correction_block >= 0 && jacobians[term.correction_block]);
    if (needed && !jin[static_cast<std::size_t>(term.offset_block)]) {
      local[t].resize(static_cast<std::size_t>(nr) * 3);
      jin[static_cast<std::size_t>(term.offset_block)] = local[t].data();
    }
  }
  if (!inner_->Evaluate(params.data(), residuals, jin.data())) return false;
  for (int c = 0; c < n_corr_; ++c)
    if (jacobians[n_inner_ + c]) std::fill(jacobians[n_inner_ + c], jacobians[n_inner_ + c] + nr * size_, 0.0);
  if (time_jac) std::fill(jacobians[n_inner_ + n_corr_], jacobians[n_inner_ + n_corr_] + nr, 0.0);
  for (std::size_t t = 0; t < nt; ++t) {
    const CorrectionTerm& term = terms_[t];
    const double* Jo = jin[static_cast<std::size_t>(term.offset_block)];
    if (!Jo) continue;
    if (term.correction_block >= 0 && jacobians[term.correction_block]) {
      const double* Bt = B.data() + t * 3 * static_cast<std::size_t>(size_);
      double* Jc = jacobians[term.correction_block];
      for (int i = 0; i < nr; ++i)
        for (int a = 0; a < 3; ++a) {
          const double g = Jo[i * 3 + a];
          if (g == 0.0) continue;
          for (int j = 0; j < size_; ++j) Jc[i * size_ + j] += g * Bt[a * size_ + j];
        }
    }
    if (time_jac) {
      double* Jt = jacobians[n_inner_ + n_corr_];
      for (int i = 0; i < nr; ++i)
        Jt[i] += Jo[i * 3] * term.motion_m_s.x() + Jo[i * 3 + 1] * term.motion_m_s.y() + Jo[i * 3 + 2] * term.motion_m_s.z();
    }
  }
  return true;
}

Eigen::MatrixXd legendreCoefficientCovariance(int degree, double t0_s, double t1_s, double tau_s,
                                              const std::function<double(double)>& sigma, int nodes) {
  const Eigen::Index d = std::max(degree, 0);
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(d, d);
  const double span = t1_s - t0_s;
  if (d == 0 || !(span > 0) || nodes < 1) return C;
  const Eigen::Index n = nodes;
  const double h = span / static_cast<double>(n), ds = 2.0 / static_cast<double>(n), rho = std::exp(-h / tau_s);
  // f(i, k) = P_k(τ_i) σ(t_i) ds, and g = f's running sum with the kernel's memory.
  Eigen::MatrixXd f(n, d), g(n, d);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double tau = -1.0 + (static_cast<double>(i) + 0.5) * ds;
    const double s = sigma(t0_s + (static_cast<double>(i) + 0.5) * h) * ds;
    for (Eigen::Index k = 0; k < d; ++k) {
      f(i, k) = legendre(static_cast<int>(k) + 1, tau) * s;
      g(i, k) = f(i, k) + (i > 0 ? rho * g(i - 1, k) : 0.0);
    }
  }
  // Σ_ij f_i f'_j ρ^|i−j| = Σ_i f_i g'_i + Σ_i f'_i g_i − Σ_i f_i f'_i
  const Eigen::MatrixXd fg = f.transpose() * g;
  C = fg + fg.transpose() - f.transpose() * f;
  for (Eigen::Index k = 0; k < d; ++k)
    for (Eigen::Index l = 0; l < d; ++l) C(k, l) *= (2.0 * static_cast<double>(k) + 3.0) * (2.0 * static_cast<double>(l) + 3.0) / 4.0;
  return C;
}

Eigen::VectorXd residualShare(const std::vector<double>& times, const std::vector<double>& weights, double tau,
                              const std::vector<int>& degrees, double constant_absorbed) {
  const Eigen::Index n = static_cast<Eigen::Index>(times.size());
  if (degrees.empty() || n == 0) return Eigen::VectorXd::Ones(n);
  const double t0 = times.front(), span = std::max(times.back() - times.front(), 1e-9);
  Eigen::MatrixXd B(n, static_cast<Eigen::Index>(degrees.size())), rho(n, n);
  Eigen::VectorXd w(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double x = 2.0 * (times[static_cast<std::size_t>(i)] - t0) / span - 1.0;
    for (std::size_t d = 0; d < degrees.size(); ++d) B(i, static_cast<Eigen::Index>(d)) = std::pow(x, degrees[d]);
    w(i) = weights[static_cast<std::size_t>(i)];
    for (Eigen::Index j = 0; j < n; ++j)
      rho(i, j) = std::exp(-std::abs(times[static_cast<std::size_t>(i)] - times[static_cast<std::size_t>(j)]) / tau);
  }
  const Eigen::MatrixXd BtW = B.transpose() * w.asDiagonal();
  Eigen::MatrixXd P = B * (BtW * B).completeOrthogonalDecomposition().pseudoInverse() * BtW;
  const double kappa = std::clamp(constant_absorbed, 0.0, 1.0);
  if (kappa < 1.0 && std::find(degrees.begin(), degrees.end(), 0) != degrees.end() && w.sum() > 0) {
    // The W-orthogonal projection on the constant (the weighted mean) is nested in P's span.
    P -= (1.0 - kappa) * Eigen::VectorXd::Ones(n) * (w.transpose() / w.sum());
  }
  const Eigen::MatrixXd R = Eigen::MatrixXd::Identity(n, n) - P;
  return (R * rho * R.transpose()).diagonal().cwiseMax(0.0);
}

}  // namespace mountcal::detail
