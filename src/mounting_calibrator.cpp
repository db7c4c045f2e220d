#include "mountcal/mounting_calibrator.hpp"

#include <ceres/ceres.h>

#include <Eigen/Eigenvalues>
#include <Eigen/QR>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <sstream>

#include "mountcal/detail/vtp_cost.hpp"
#include "mountcal/error.hpp"

namespace mountcal {

const char* toString(TerminationType t) {
  switch (t) {
    case TerminationType::kConvergence: return "CONVERGENCE";
    case TerminationType::kNoConvergence: return "NO_CONVERGENCE";
    case TerminationType::kFailure: return "FAILURE";
    case TerminationType::kInvalidInput: return "INVALID_INPUT";
  }
  return "UNKNOWN";
}

bool MountingCalibrator::Options::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (!(tie_sigma_xy_m > 0) || !(tie_sigma_z_m > 0)) return fail("tie_sigma_xy_m and tie_sigma_z_m must be positive");
  if (loss != LossType::kTrivial && !(loss_scale_m > 0)) return fail("loss_scale_m must be positive for a robust loss");
  if (max_iterations < 1) return fail("max_iterations must be at least 1");
  if (!(function_tolerance >= 0) || !(parameter_tolerance >= 0) || !(gradient_tolerance >= 0)) return fail("tolerances must be non-negative");
  if (!(max_solver_time_s > 0)) return fail("max_solver_time_s must be positive");
  if (num_threads < 1) return fail("num_threads must be at least 1");
  if (!(numeric_diff_relative_step > 0) || numeric_diff_relative_step > 1e-2) return fail("numeric_diff_relative_step must be in (0, 0.01]");
  if (!(observability_threshold > 0) || observability_threshold >= 1) return fail("observability_threshold must be in (0, 1)");
  if (!(outlier_factor > 0)) return fail("outlier_factor must be positive");
  if (!(vtp.radius_m > 0) || !(vtp.ransac_threshold_m > 0) || vtp.ransac_iterations < 1) return fail("vtp radius, RANSAC threshold and iterations must be positive");
  if (!(vtp.max_radius_m >= vtp.radius_m)) return fail("vtp.max_radius_m must be at least vtp.radius_m");
  for (int j = 0; j < 6; ++j) {
    if (!std::isfinite(prior_value[j])) return fail("prior_value[" + std::to_string(j) + "] is not finite");
  }
  return true;
}

namespace {

using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

/// A GCP prior on a tie position: (X_k − X_gcp) / σ, analytic Jacobian.
class GcpPrior final : public ceres::SizedCostFunction<3, 3> {
 public:
  GcpPrior(const Vec3& x, const Vec3& inv_sigma) : x_(x), w_(inv_sigma) {}
  bool Evaluate(double const* const* p, double* r, double** J) const override {
    for (int a = 0; a < 3; ++a) r[a] = (p[0][a] - x_[a]) * w_[a];
    if (J && J[0]) {
      std::fill(J[0], J[0] + 9, 0.0);
      for (int a = 0; a < 3; ++a) J[0][4 * a] = w_[a];
    }
    return true;
  }
 private:
  Vec3 x_, w_;
};

/// A prior on one mounting parameter.
class MountingPrior final : public ceres::SizedCostFunction<1, 6> {
 public:
  MountingPrior(int j, double value, double sigma) : j_(j), v_(value), w_(1.0 / sigma) {}
  bool Evaluate(double const* const* p, double* r, double** J) const override {
    r[0] = (p[0][j_] - v_) * w_;
    if (J && J[0]) {
      std::fill(J[0], J[0] + 6, 0.0);
      J[0][j_] = w_;
    }
    return true;
  }
 private:
  int j_;
  double v_, w_;
};

struct Tie {
  std::string id;
  std::vector<int> obs;         // indices into the vtp list
  std::vector<double*> offset;  // the strip offset block of each observation
  const GroundControlPoint* gcp = nullptr;
  double X[3] = {0, 0, 0};
};

bool priorOn(const MountingCalibrator::Options& o, int j) {
  return o.prior_sigma[j] > 0 && std::isfinite(o.prior_sigma[j]);
}

/// Reduced normal matrix of the mounting block — tie positions and strip offsets eliminated —
/// and the unreduced diagonal, from the Jacobians at `mounting` (SPEC §3 step 5: rank and
/// condition). Ties are eliminated per tie (Schur complement), then the strip offsets densely.
void reducedNormalMatrix(const std::vector<Tie>& ties, const std::vector<ceres::CostFunction*>& costs,
                         const double* mounting, const std::map<double*, int>& offset_index, double offset_sigma,
                         const MountingCalibrator::Options& o, Mat6* N_red, Vec6* diag) {
  const int n_off = offset_sigma > 0 ? 3 * static_cast<int>(offset_index.size()) : 0;
  const int n = 6 + n_off;
  Eigen::MatrixXd N = Eigen::MatrixXd::Zero(n, n);
  Vec6 d = Vec6::Zero();
  for (const Tie& tie : ties) {
    Eigen::MatrixXd NyX = Eigen::MatrixXd::Zero(n, 3);
    Mat3 NXX = Mat3::Zero();
    for (std::size_t q = 0; q < tie.obs.size(); ++q) {
      const double* params[3] = {mounting, tie.X, tie.offset[q]};
      double r[3];
      Eigen::Matrix<double, 3, 6, Eigen::RowMajor> A;
      Eigen::Matrix<double, 3, 3, Eigen::RowMajor> B, C;
      double* jac[3] = {A.data(), B.data(), C.data()};
      costs[static_cast<std::size_t>(tie.obs[q])]->Evaluate(params, r, jac);
      Eigen::MatrixXd Jy = Eigen::MatrixXd::Zero(3, n);  // [A, C at this strip's columns]
      Jy.leftCols(6) = A;
      if (n_off) Jy.middleCols(6 + 3 * offset_index.at(tie.offset[q]), 3) = C;
      N += Jy.transpose() * Jy;
      d += (A.transpose() * A).diagonal();
      NyX += Jy.transpose() * B;
      NXX += B.transpose() * B;
    }
    if (tie.gcp) {
      const double wxy = 1 / (tie.gcp->sigma_xy_m * tie.gcp->sigma_xy_m), wz = 1 / (tie.gcp->sigma_z_m * tie.gcp->sigma_z_m);
      NXX.diagonal() += Vec3(wxy, wxy, wz);
    }
    N -= NyX * NXX.inverse() * NyX.transpose();
  }
  for (int j = 0; j < 6; ++j) {
    if (priorOn(o, j)) {
      N(j, j) += 1.0 / (o.prior_sigma[j] * o.prior_sigma[j]);
      d[j] += 1.0 / (o.prior_sigma[j] * o.prior_sigma[j]);
    }
  }
  if (n_off) {
    N.bottomRightCorner(n_off, n_off).diagonal().array() += 1.0 / (offset_sigma * offset_sigma);
    const Eigen::MatrixXd Noo = N.bottomRightCorner(n_off, n_off);
    const Eigen::MatrixXd Nmo = N.topRightCorner(6, n_off);
    *N_red = N.topLeftCorner(6, 6) - Nmo * Noo.ldlt().solve(Nmo.transpose());
  } else {
    *N_red = N.topLeftCorner(6, 6);
  }
  *diag = d;
}

std::string fmtParam(int j, double v) {
  char buf[64];
  if (j < 3) std::snprintf(buf, sizeof buf, "%+.4f m", v);
  else std::snprintf(buf, sizeof buf, "%+.5f°", rad2deg(v));
  return buf;
}

}  // namespace

MountingCalibrator::Summary MountingCalibrator::calibrate(const CalibrationData& data) const {
  const auto t_start = std::chrono::steady_clock::now();
  const Options& o = options_;
  Summary S;
  S.mounting_used = data.mounting_used;
  S.mounting = data.mounting_used;
  S.sigma.fill(std::nan(""));
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count(); };
  std::string why;
  if (!o.IsValid(&why)) {
    S.termination = TerminationType::kInvalidInput;
    S.message = "invalid options: " + why;
    return S;
  }
  if (!data.trajectory) throw InvalidInput("calibrate: no trajectory");

  // ---- virtual tie points (SPEC §3 steps 1–3) -------------------------------------------
  std::map<std::string, std::size_t> strip_index;
  for (std::size_t i = 0; i < data.strips.size(); ++i) {
    if (!strip_index.emplace(data.strips[i].id, i).second) throw InvalidInput("calibrate: strip id '" + data.strips[i].id + "' appears twice");
  }
  std::set<std::string> needed;
  for (const TieObservation& t : data.ties) {
    if (!strip_index.count(t.strip_id)) {
      throw InvalidInput("tie '" + t.tie_id + "'" + (t.line ? " (line " + std::to_string(t.line) + ")" : std::string()) +
                         " names strip '" + t.strip_id + "', which is not in the job");
    }
    needed.insert(t.strip_id);
  }
  std::map<std::string, VtpStrip> vtp_strips;
  for (const std::string& id : needed) {
    vtp_strips.emplace(id, VtpStrip(data.strips[strip_index[id]], data.trajectory, data.mounting_used));
  }
  std::vector<VirtualTiePoint> vtps;
  vtps.reserve(data.ties.size());
  std::map<std::string, std::vector<int>> by_tie;
  for (const TieObservation& t : data.ties) {
    VirtualTiePoint v;
    std::string reason;
    if (vtp_strips.at(t.strip_id).build(t, o.vtp, &v, &reason)) {
      by_tie[t.tie_id].push_back(static_cast<int>(vtps.size()));
      vtps.push_back(std::move(v));
    } else {
      S.rejected.push_back({t.tie_id, t.strip_id, reason});
    }
  }
  std::map<std::string, const GroundControlPoint*> gcp_by_id;
  for (const GroundControlPoint& g : data.gcps) gcp_by_id[g.id] = &g;
  std::vector<Tie> ties;
  for (auto& [id, obs] : by_tie) {
    Tie tie;
    tie.id = id;
    tie.obs = obs;
    auto g = gcp_by_id.find(id);
    if (g != gcp_by_id.end()) tie.gcp = g->second;
    if (obs.size() < 2 && !tie.gcp) {
      for (int k : obs) S.rejected.push_back({id, vtps[static_cast<std::size_t>(k)].stripId(), "the tie has a usable observation on only one strip"});
      continue;
    }
    ties.push_back(tie);
  }
  // One offset block per strip (random effect, SPEC §3 extension); zero and constant if off.
  std::map<std::string, std::array<double, 3>> offsets;
  for (const StripData& strip : data.strips) offsets[strip.id] = {0.0, 0.0, 0.0};
  std::map<double*, int> offset_index;
  for (Tie& tie : ties) {
    for (int k : tie.obs) {
      double* block = offsets.at(vtps[static_cast<std::size_t>(k)].stripId()).data();
      tie.offset.push_back(block);
      offset_index.emplace(block, 0);
    }
  }
  {
    int i = 0;
    for (auto& entry : offset_index) entry.second = i++;
  }
  const double offset_sigma = o.strip_offset_sigma_m;
  int n_obs = 0;
  for (const Tie& t : ties) n_obs += static_cast<int>(t.obs.size());
  S.ties_used = static_cast<int>(ties.size());
  S.observations_used = n_obs;

  std::array<double, 6> m0 = data.mounting_used.toArray();
  std::array<bool, 6> estimate = o.estimate;
  if (n_obs == 0 || ties.empty()) {
    S.termination = TerminationType::kInvalidInput;
    S.message = "no usable tie: " + std::to_string(S.rejected.size()) + " tie observations rejected (see rejected)";
    S.time_s = elapsed();
    return S;
  }

  S.construction_time_s = elapsed();
  // Residuals before (seed Table 1): P_ki(M_used) − mean_k (seed eqs. 7–8).
  std::vector<Vec3> P_before(vtps.size());
  for (std::size_t k = 0; k < vtps.size(); ++k) P_before[k] = vtps[k].position(m0.data());
  std::vector<Vec3> tie_mean(ties.size(), Vec3::Zero());  // seed eq. (7), at M_used
  for (std::size_t q = 0; q < ties.size(); ++q) {
    for (int k : ties[q].obs) tie_mean[q] += P_before[static_cast<std::size_t>(k)];
    tie_mean[q] /= static_cast<double>(ties[q].obs.size());
  }
  auto startTiesAtMeans = [&] {
    for (std::size_t q = 0; q < ties.size(); ++q)
      for (int a = 0; a < 3; ++a) ties[q].X[a] = tie_mean[q][a];  // initial tie position
  };
  startTiesAtMeans();

  // ---- the adjustment (SPEC §3 step 4) ----------------------------------------------------
  const double inv_sigma_xy = 1.0 / o.tie_sigma_xy_m;
  std::vector<ceres::CostFunction*> costs(vtps.size(), nullptr);
  for (std::size_t k = 0; k < vtps.size(); ++k) {
    costs[k] = detail::makeVtpCostFunction(&vtps[k], Vec3(o.tie_sigma_xy_m, o.tie_sigma_xy_m, o.tie_sigma_z_m),
                                           o.numeric_diff_relative_step);  // seed eq. (10)
  }
  std::vector<std::unique_ptr<ceres::CostFunction>> owned_costs;  // the problem owns none of them
  std::array<double, 6> m = m0;

  auto solve = [&](const std::array<bool, 6>& est, ceres::Solver::Summary* cs, ceres::Problem* problem) {
    ceres::LossFunction* loss = nullptr;
    for (Tie& tie : ties) {
      for (std::size_t q = 0; q < tie.obs.size(); ++q) {
        if (o.loss == LossType::kHuber) loss = new ceres::HuberLoss(o.loss_scale_m * inv_sigma_xy);
        else if (o.loss == LossType::kCauchy) loss = new ceres::CauchyLoss(o.loss_scale_m * inv_sigma_xy);
        else loss = nullptr;
        problem->AddResidualBlock(costs[static_cast<std::size_t>(tie.obs[q])], loss, m.data(), tie.X, tie.offset[q]);
      }
      if (tie.gcp) {
        const Vec3 x(tie.gcp->x_m, tie.gcp->y_m, tie.gcp->z_m);
        owned_costs.emplace_back(new GcpPrior(x, Vec3(1 / tie.gcp->sigma_xy_m, 1 / tie.gcp->sigma_xy_m, 1 / tie.gcp->sigma_z_m)));
        problem->AddResidualBlock(owned_costs.back().get(), nullptr, tie.X);
      }
    }
    for (int j = 0; j < 6; ++j)
      if (est[j] && priorOn(o, j)) {
        owned_costs.emplace_back(new MountingPrior(j, o.prior_value[j], o.prior_sigma[j]));
        problem->AddResidualBlock(owned_costs.back().get(), nullptr, m.data());
      }
    for (auto& entry : offset_index) {
      if (offset_sigma > 0) {
        const double w = 1.0 / offset_sigma;
        owned_costs.emplace_back(new GcpPrior(Vec3::Zero(), Vec3(w, w, w)));
        problem->AddResidualBlock(owned_costs.back().get(), nullptr, entry.first);
      } else {
        problem->SetParameterBlockConstant(entry.first);
      }
    }
    std::vector<int> fixed;
    for (int j = 0; j < 6; ++j)
      if (!est[j]) fixed.push_back(j);
    if (fixed.size() == 6) problem->SetParameterBlockConstant(m.data());
    else if (!fixed.empty()) problem->SetManifold(m.data(), new ceres::SubsetManifold(6, fixed));
    ceres::Solver::Options so;
    so.minimizer_type = ceres::TRUST_REGION;
    so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    so.linear_solver_type = ceres::DENSE_SCHUR;
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    for (Tie& tie : ties) ordering->AddElementToGroup(tie.X, 0);  // eliminated first
    for (auto& entry : offset_index) ordering->AddElementToGroup(entry.first, 1);
    ordering->AddElementToGroup(m.data(), 1);
    so.linear_solver_ordering = ordering;
    so.max_num_iterations = o.max_iterations;
    so.function_tolerance = o.function_tolerance;
    so.parameter_tolerance = o.parameter_tolerance;
    so.gradient_tolerance = o.gradient_tolerance;
    so.max_solver_time_in_seconds = o.max_solver_time_s;
    so.num_threads = o.num_threads;
    so.logging_type = ceres::SILENT;
    so.minimizer_progress_to_stdout = false;
    ceres::Solve(so, problem, cs);
  };

  // The problem does not own the cost functions: they are reused across solves and for the
  // Jacobians of the observability analysis.
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  for (auto* c : costs) owned_costs.emplace_back(c);
  auto problem = std::make_unique<ceres::Problem>(po);
  ceres::Solver::Summary cs;
  double t_mark = elapsed();
  solve(estimate, &cs, problem.get());
  S.solve_time_s += elapsed() - t_mark;
  t_mark = elapsed();
  S.initial_cost = cs.initial_cost;
  int iterations = static_cast<int>(cs.iterations.size()) - 1;

  // ---- observability: reduced normal matrix of the mounting block (SPEC §3 step 5) -------
  Mat6 N_red;
  Vec6 diag;
  reducedNormalMatrix(ties, costs, m.data(), offset_index, offset_sigma, o, &N_red, &diag);
  std::array<bool, 6> est = estimate;
  std::ostringstream obs_report;
  const auto& names = mountingParameterNames();
  bool refixed = false;
  for (int pass = 0; pass < 6; ++pass) {
    std::vector<int> idx;
    for (int j = 0; j < 6; ++j)
      if (est[j]) idx.push_back(j);
    if (idx.empty()) break;
    const int n = static_cast<int>(idx.size());
    Eigen::MatrixXd Sn(n, n);
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b)
        Sn(a, b) = N_red(idx[a], idx[b]) / std::sqrt(std::max(diag[idx[a]], 1e-300) * std::max(diag[idx[b]], 1e-300));
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Sn);
    const double lmin = eig.eigenvalues()(0), lmax = eig.eigenvalues()(n - 1);
    S.condition_number = lmin > 0 ? lmax / lmin : std::numeric_limits<double>::infinity();
    if (lmin >= o.observability_threshold) break;
    // The weakest direction: which parameters take part in it?
    const Eigen::VectorXd v = eig.eigenvectors().col(0);
    std::vector<int> group;
    for (int a = 0; a < n; ++a)
      if (std::abs(v[a]) > 0.3) group.push_back(idx[a]);
    // Hold a lever-arm component first (it can be taped; a boresight cannot), else the largest.
    int pick = -1;
    double best = 0;
    for (int a = 0; a < n; ++a) {
      const double w = std::abs(v[a]) + (idx[a] < 3 ? 1.0 : 0.0);
      if (std::abs(v[a]) > 0.3 && w > best) { best = w; pick = idx[a]; }
    }
    if (pick < 0) {
      int a_max = 0;
      v.cwiseAbs().maxCoeff(&a_max);
      pick = idx[a_max];
    }
    est[pick] = false;
    refixed = true;
    S.unobservable.push_back(names[pick]);
    obs_report << names[pick] << " cannot be determined from these ties (it keeps " << std::max(lmin, 0.0) * 100
               << " % of its information once the tie positions are eliminated)";
    if (group.size() > 1) {
      obs_report << "; it cannot be separated from";
      for (int g : group)
        if (g != pick) obs_report << " " << names[g];
    }
    obs_report << "; held at its used value " << fmtParam(pick, m0[pick]) << ".\n";
  }
  if (refixed) {
    // Re-solve with the undeterminable parameters held at their used values.
    m = m0;
    for (auto& entry : offsets) entry.second = {0.0, 0.0, 0.0};
    startTiesAtMeans();
    problem = std::make_unique<ceres::Problem>(po);
    S.analysis_time_s += elapsed() - t_mark;
    t_mark = elapsed();
    solve(est, &cs, problem.get());
    S.solve_time_s += elapsed() - t_mark;
    t_mark = elapsed();
    iterations += static_cast<int>(cs.iterations.size()) - 1;
    reducedNormalMatrix(ties, costs, m.data(), offset_index, offset_sigma, o, &N_red, &diag);
  }
  S.observability_report = obs_report.str();
  S.estimated = est;
  S.iterations = iterations;
  S.final_cost = cs.final_cost;
  S.mounting = data.mounting_used.withArray(m.data());
  switch (cs.termination_type) {
    case ceres::CONVERGENCE:
    case ceres::USER_SUCCESS: S.termination = TerminationType::kConvergence; break;
    case ceres::NO_CONVERGENCE: S.termination = TerminationType::kNoConvergence; break;
    default: S.termination = TerminationType::kFailure; break;
  }
  S.message = cs.message;

  // ---- covariance (ceres::Covariance), scaled by σ₀² ---------------------------------------
  int n_est_final = 0;
  for (bool e : est) n_est_final += e;
  int n_res = 3 * n_obs;
  for (const Tie& t : ties) n_res += t.gcp ? 3 : 0;
  for (int j = 0; j < 6; ++j) n_res += (est[j] && priorOn(o, j)) ? 1 : 0;
  S.degrees_of_freedom = n_res - n_est_final - 3 * static_cast<int>(ties.size());
  S.variance_factor = S.degrees_of_freedom > 0 ? 2.0 * cs.final_cost / S.degrees_of_freedom : 1.0;
  const double scale = o.scale_covariance_by_variance_factor && S.degrees_of_freedom > 0 ? S.variance_factor : 1.0;
  Mat6 cov = Mat6::Constant(std::nan(""));
  if (n_est_final > 0) {
    ceres::Covariance::Options co;
    co.algorithm_type = ceres::SPARSE_QR;
    co.num_threads = o.num_threads;
    ceres::Covariance covariance(co);
    const std::vector<std::pair<const double*, const double*>> blocks{{m.data(), m.data()}};
    Eigen::Matrix<double, 6, 6, Eigen::RowMajor> c;
    if (covariance.Compute(blocks, problem.get()) && covariance.GetCovarianceBlock(m.data(), m.data(), c.data())) {
      cov = c * scale;
    } else {
      // Fall back on the reduced normal matrix (same marginal covariance in exact arithmetic).
      std::vector<int> idx;
      for (int j = 0; j < 6; ++j)
        if (est[j]) idx.push_back(j);
      Eigen::MatrixXd Nn(idx.size(), idx.size());
      for (std::size_t a = 0; a < idx.size(); ++a)
        for (std::size_t b = 0; b < idx.size(); ++b) Nn(a, b) = N_red(idx[a], idx[b]);
      const Eigen::MatrixXd inv = Nn.completeOrthogonalDecomposition().pseudoInverse();
      for (std::size_t a = 0; a < idx.size(); ++a)
        for (std::size_t b = 0; b < idx.size(); ++b) cov(idx[a], idx[b]) = inv(a, b) * scale;
    }
  }
  for (int j = 0; j < 6; ++j) S.sigma[j] = est[j] ? std::sqrt(std::max(cov(j, j), 0.0)) : std::nan("");
  for (int a = 0; a < 6; ++a)
    for (int b = 0; b < 6; ++b)
      S.correlation(a, b) = (est[a] && est[b]) ? cov(a, b) / (S.sigma[a] * S.sigma[b]) : std::nan("");

  S.analysis_time_s += elapsed() - t_mark;
  // ---- residuals, RMS, outliers ------------------------------------------------------------
  Vec3 ss_before = Vec3::Zero(), ss_after = Vec3::Zero();
  std::vector<double> norms;
  for (std::size_t ti = 0; ti < ties.size(); ++ti) {
    const Tie& tie = ties[ti];
    const Vec3& mean = tie_mean[ti];
    for (std::size_t q = 0; q < tie.obs.size(); ++q) {
      const int k = tie.obs[q];
      const VirtualTiePoint& v = vtps[static_cast<std::size_t>(k)];
      TieResidual r;
      r.tie_id = tie.id;
      r.strip_id = v.stripId();
      r.before_m = P_before[static_cast<std::size_t>(k)] - mean;
      r.after_m = v.position(m.data()) + Eigen::Map<const Vec3>(tie.offset[q]) - Vec3(tie.X[0], tie.X[1], tie.X[2]);
      ss_before += r.before_m.cwiseAbs2();
      ss_after += r.after_m.cwiseAbs2();
      norms.push_back(r.after_m.norm());
      S.residuals.push_back(r);
    }
  }
  for (const auto& [id, o3] : offsets) S.strip_offsets_m.emplace_back(id, Vec3(o3[0], o3[1], o3[2]));
  S.rms_before_m = (ss_before / n_obs).cwiseSqrt();
  S.rms_after_m = (ss_after / n_obs).cwiseSqrt();
  std::vector<double> sorted = norms;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
  const double robust_sigma = 1.4826 * sorted[sorted.size() / 2] / 1.54;  // per axis, from the median norm
  const double threshold = std::max(o.outlier_factor * robust_sigma, 3.0 * std::min(o.tie_sigma_xy_m, o.tie_sigma_z_m));
  for (std::size_t i = 0; i < S.residuals.size(); ++i) S.residuals[i].outlier = norms[i] > threshold;
  S.time_s = elapsed();
  return S;
}

std::string MountingCalibrator::Summary::BriefReport() const {
  char buf[512];
  const Vec3 b = mounting.boresightDeg();
  std::snprintf(buf, sizeof buf,
                "mountcal VTPM: %s, %d iterations, cost %.4g -> %.4g, %d ties / %d observations (%zu rejected); "
                "lever arm (%.4f, %.4f, %.4f) m, boresight (%.5f, %.5f, %.5f) deg; RMS after (%.3f, %.3f, %.3f) m",
                toString(termination), iterations, initial_cost, final_cost, ties_used, observations_used, rejected.size(),
                mounting.a_b.x(), mounting.a_b.y(), mounting.a_b.z(), b.x(), b.y(), b.z(), rms_after_m.x(), rms_after_m.y(),
                rms_after_m.z());
  return buf;
}

std::string MountingCalibrator::Summary::FullReport() const {
  std::ostringstream r;
  char buf[256];
  r << "mountcal — mounting calibration with the virtual tie point model\n\n";
  r << "Termination: " << toString(termination) << " (" << message << ")\n";
  std::snprintf(buf, sizeof buf, "Iterations %d, cost %.6g -> %.6g, %.3f s (construction %.3f, solve %.3f, analysis %.3f)\n",
                iterations, initial_cost, final_cost, time_s, construction_time_s, solve_time_s, analysis_time_s);
  r << buf;
  std::snprintf(buf, sizeof buf, "Ties %d, observations %d, rejected %zu, degrees of freedom %d, variance factor %.4g\n\n",
                ties_used, observations_used, rejected.size(), degrees_of_freedom, variance_factor);
  r << buf;
  r << "parameter            used            estimated       sigma\n";
  const auto& names = mountingParameterNames();
  const auto used = mounting_used.toArray(), est = mounting.toArray();
  for (int j = 0; j < 6; ++j) {
    const bool lin = j < 3;
    const double k = lin ? 1.0 : 180.0 / kPi;
    const char* unit = lin ? "m  " : "deg";
    std::string sig = estimated[j] ? "" : "fixed";
    if (estimated[j]) {
      std::snprintf(buf, sizeof buf, "%.6f %s", sigma[j] * k, unit);
      sig = buf;
    } else if (std::find(unobservable.begin(), unobservable.end(), names[j]) != unobservable.end()) {
      sig = "undeterminable";
    }
    std::snprintf(buf, sizeof buf, "%-18s %+12.6f %s %+12.6f %s  %s\n", names[j].c_str(), used[j] * k, unit, est[j] * k, unit, sig.c_str());
    r << buf;
  }
  if (!observability_report.empty()) r << "\nObservability:\n" << observability_report;
  std::snprintf(buf, sizeof buf, "\nCondition number of the estimated block (normalised): %.3g\n", condition_number);
  r << buf;
  r << "\nCorrelations:\n";
  for (int a = 0; a < 6; ++a) {
    for (int b = 0; b < 6; ++b) {
      if (std::isnan(correlation(a, b))) r << "      -";
      else {
        std::snprintf(buf, sizeof buf, " %+6.3f", correlation(a, b));
        r << buf;
      }
    }
    r << "   " << names[a] << "\n";
  }
  std::snprintf(buf, sizeof buf, "\nRMS before (%.4f, %.4f, %.4f) m, after (%.4f, %.4f, %.4f) m\n", rms_before_m.x(),
                rms_before_m.y(), rms_before_m.z(), rms_after_m.x(), rms_after_m.y(), rms_after_m.z());
  r << buf;
  for (const RejectedTie& t : rejected) r << "rejected tie " << t.tie_id << " on strip " << t.strip_id << ": " << t.reason << "\n";
  for (const TieResidual& t : residuals)
    if (t.outlier) r << "outlier: tie " << t.tie_id << " on strip " << t.strip_id << ", residual " << t.after_m.norm() << " m\n";
  return r.str();
}

MountingCalibrator::Summary calibrate(const CalibrationData& data, const MountingCalibrator::Options& options) {
  return MountingCalibrator(options).calibrate(data);
}

}  // namespace mountcal
