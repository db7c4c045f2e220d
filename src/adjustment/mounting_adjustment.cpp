#include "mountcal/adjustment/mounting_adjustment.hpp"
#include "mountcal/core/rotation.hpp"

#include "adjustment/block_arena.hpp"
#include "adjustment/corrected_cost.hpp"

#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace mountcal {

const char* toString(TerminationType t) {
  switch (t) {
    case TerminationType::kConvergence:
      return "CONVERGENCE";
    case TerminationType::kNoConvergence:
      return "NO_CONVERGENCE";
    case TerminationType::kFailure:
      return "FAILURE";
    case TerminationType::kInvalidInput:
      return "INVALID_INPUT";
  }
  return "UNKNOWN";
}

namespace {
bool failWith(std::string* error, const std::string& m) {
  if (error) *error = m;
  return false;
}
}  // namespace

bool MountingBlockOptions::IsValid(std::string* error) const {
  for (int j = 0; j < 6; ++j) {
    if (!std::isfinite(prior_value[j])) return failWith(error, "prior_value[" + std::to_string(j) + "] is not finite");
  }
  return true;
}

namespace {
/// [u]×, the cross-product matrix: [u]× v = u × v.
Mat3 skew(const Vec3& u) {
  Mat3 U;
  U << 0, -u.z(), u.y(), u.z(), 0, -u.x(), -u.y(), u.x(), 0;
  return U;
}
}  // namespace

Mat3 PulseNoise::pointCovariance(const Vec3& u_m, const Vec3& beam_m, double independent_weight) const {
  Mat3 S = Mat3::Identity() * (position_m * position_m);
  const bool white_attitude = !attitudeRandomEffect();
  const double t = white_attitude ? deg2rad(roll_pitch_deg) : 0.0, k = white_attitude ? deg2rad(heading_deg) : 0.0;
  const Mat3 U = skew(u_m);  // δx = δψ × u = −[u]× δψ
  S += U * Vec3(t * t, t * t, k * k).asDiagonal() * U.transpose();
  const double rho = beam_m.norm();
  if (rho > 0 && (range_m > 0 || beam_deg > 0)) {
    const Vec3 d = beam_m / rho;
    const double b = deg2rad(beam_deg) * rho;
    const Mat3 along = d * d.transpose();
    S += independent_weight * (range_m * range_m * along + b * b * (Mat3::Identity() - along));
  }
  return S;
}

bool PulseNoise::IsValid(std::string* error) const {
  const double v[6] = {position_m, roll_pitch_deg, heading_deg, range_m, beam_deg, attitude_correlation_s};
  const char* names[6] = {"position_m", "roll_pitch_deg", "heading_deg", "range_m", "beam_deg", "attitude_correlation_s"};
  const double upper[6] = {10.0, 10.0, 10.0, 10.0, 10.0, 3600.0};
  for (int i = 0; i < 6; ++i)
    if (!(v[i] >= 0 && v[i] <= upper[i]))
      return failWith(error, std::string("pulse_noise.") + names[i] + " must be in [0, " + (i == 5 ? "3600" : "10") + "]");
  return true;
}

bool TrajectoryAccuracy::IsValid(std::string* error) const {
  const double v[5] = {position_sigma_m, position_correlation_s, roll_pitch_sigma_deg, heading_sigma_deg, attitude_correlation_s};
  const char* names[5] = {"position_sigma_m", "position_correlation_s", "roll_pitch_sigma_deg", "heading_sigma_deg",
                          "attitude_correlation_s"};
  const double upper[5] = {100.0, 86400.0, 10.0, 10.0, 86400.0};
  for (int i = 0; i < 5; ++i)
    if (!(v[i] >= 0 && v[i] <= upper[i]))
      return failWith(error, std::string("trajectory.") + names[i] + " must be in [0, " + std::to_string(static_cast<int>(upper[i])) + "]");
  if (position_sigma_m > 0 && !(position_correlation_s > 0))
    return failWith(error, "trajectory.position_correlation_s must be positive when position_sigma_m is");
  if ((roll_pitch_sigma_deg > 0 || heading_sigma_deg > 0) && !(attitude_correlation_s > 0))
    return failWith(error, "trajectory.attitude_correlation_s must be positive when an attitude sigma is");
  if (!(gnss_sigma_m >= 0 && gnss_sigma_m <= 100.0)) return failWith(error, "trajectory.gnss_sigma_m must be in [0, 100]");
  if (gnss_sigma_m > 0 && !(gnss_correlation_s > 0 && gnss_correlation_s <= 86400.0))
    return failWith(error, "trajectory.gnss_correlation_s must be in (0, 86400] when gnss_sigma_m is positive");
  if (series && !series->empty()) {
    if (!(position_correlation_s > 0 && attitude_correlation_s > 0))
      return failWith(error, "trajectory: the correlation times must be positive with an accuracy series");
    if (!series->IsValid(error)) return false;
  }
  return true;
}

bool TrajectoryCorrections::IsValid(std::string* error) const {
  if (position_degree < 0 || position_degree > 3)
    return failWith(error, "corrections.position_degree must be 0 (the strip offset alone) to 3");
  if (attitude_degree < 0 || attitude_degree > 3)
    return failWith(error, "corrections.attitude_degree must be 0 (none) to 3 (a constant attitude error is the boresight itself)");
  if (position_degree > 0 && !priors_from_accuracy && !(position_sigma_m > 0 && position_sigma_m <= 100))
    return failWith(error, "corrections.position_sigma_m must be in (0, 100] m when position_degree > 0");
  if (priors_from_accuracy) return true;  // the σ keys are not used (StochasticOptions checks the accuracy)
  if (attitude_degree > 0 && !(roll_pitch_sigma_deg > 0 && roll_pitch_sigma_deg <= 10 && heading_sigma_deg > 0 && heading_sigma_deg <= 10))
    return failWith(error, "corrections.roll_pitch_sigma_deg and heading_sigma_deg must be in (0, 10] deg when attitude_degree > 0");
  return true;
}

bool StochasticOptions::IsValid(std::string* error) const {
  if (!pulse_noise.IsValid(error)) return false;
  if (!trajectory.IsValid(error)) return false;
  if (!corrections.IsValid(error)) return false;
  if (corrections.any() && corrections.priors_from_accuracy && !trajectory.any())
    return failWith(error,
                    "corrections.priors_from_accuracy needs the trajectory's accuracy (stochastic.trajectory), "
                    "which is switched off; state the corrections' σ instead");
  if (estimate_time_offset && !(time_offset_sigma_s > 0))
    return failWith(error, "estimate_time_offset needs time_offset_sigma_s > 0 (the time offset's prior)");
  if (!(strip_offset_sigma_m >= 0) || !std::isfinite(strip_offset_sigma_m))
    return failWith(error, "strip_offset_sigma_m must be finite and non-negative");
  if (loss != LossType::kTrivial && !(loss_scale_m > 0)) return failWith(error, "loss_scale_m must be positive for a robust loss");
  if (!(time_offset_sigma_s >= 0) || time_offset_sigma_s > 10)
    return failWith(error, "time_offset_sigma_s must be in [0, 10] s (0: the time offset is not analysed)");
  return true;
}

bool SolverOptions::IsValid(std::string* error) const {
  if (max_iterations < 1) return failWith(error, "max_iterations must be at least 1");
  if (max_iterations_per_matching < 0) return failWith(error, "max_iterations_per_matching must be >= 0");
  if (!(function_tolerance >= 0) || !(parameter_tolerance >= 0) || !(gradient_tolerance >= 0))
    return failWith(error, "tolerances must be non-negative");
  if (!(max_solver_time_s > 0)) return failWith(error, "max_solver_time_s must be positive");
  if (num_threads < 1) return failWith(error, "num_threads must be at least 1");
  if (!(numeric_diff_relative_step > 0) || numeric_diff_relative_step > 1e-2)
    return failWith(error, "numeric_diff_relative_step must be in (0, 0.01]");
  if (max_rematch_rounds < 1) return failWith(error, "max_rematch_rounds must be at least 1");
  if (!(rematch_tolerance_m > 0) || !(rematch_tolerance_rad > 0)) return failWith(error, "rematch tolerances must be positive");
  if (!(rematch_sigma_fraction >= 0) || rematch_sigma_fraction > 1) return failWith(error, "rematch_sigma_fraction must be in [0, 1]");
  return true;
}

bool AnalysisOptions::IsValid(std::string* error) const {
  if (!(rank_tolerance > 0) || rank_tolerance >= 1e-3) return failWith(error, "rank_tolerance must be in (0, 1e-3)");
  if (!(outlier_factor > 0)) return failWith(error, "outlier_factor must be positive");
  if (!(undeterminable_sigma_m > 0) || !(undeterminable_sigma_deg > 0))
    return failWith(error, "undeterminable_sigma_m and undeterminable_sigma_deg must be positive");
  if (!(lever_arm_change_warning_m > 0)) return failWith(error, "lever_arm_change_warning_m must be positive");
  if (!(resolve_reject_sigma >= 2.0)) return failWith(error, "resolve_reject_sigma must be at least 2 (the doubtful bound)");
  return true;
}

bool MountingAdjustment::Options::IsValid(std::string* error) const {
  return MountingBlockOptions::IsValid(error) && StochasticOptions::IsValid(error) && SolverOptions::IsValid(error) &&
         AnalysisOptions::IsValid(error);
}

double robustScaleFromNorms(std::vector<double> norms, int dims) {
  if (norms.empty()) return 0.0;
  std::nth_element(norms.begin(), norms.begin() + static_cast<long>(norms.size() / 2), norms.end());
  const double med = norms[norms.size() / 2];
  // Median of a chi distribution with `dims` degrees of freedom for unit σ: 0.674 (1), 1.177
  // (2), 1.538 (3); the 3-D value with 1.4826 is what the VTPM flags always used.
  if (dims == 1) return 1.4826 * med;
  if (dims == 2) return med / 1.177;
  return 1.4826 * med / 1.54;
}

// ---- AdjustmentProblem ----------------------------------------------------------------------

AdjustmentProblem::AdjustmentProblem(const std::array<double, 6>& mounting, double strip_offset_sigma_m, LossType loss, double loss_scale_m,
                                     double numeric_diff_relative_step)
    : arena_(std::make_unique<detail::BlockArena>()),
      mounting_(arena_->allocate(6, mounting.data())),
      offset_sigma_m_(strip_offset_sigma_m),
      loss_(loss),
      loss_scale_m_(loss_scale_m),
      numeric_diff_relative_step_(numeric_diff_relative_step) {
  ceres::Problem::Options po;  // owns cost functions, losses and manifolds
  problem_ = std::make_unique<ceres::Problem>(po);
}

AdjustmentProblem::~AdjustmentProblem() {
  if (committed_) return;  // Ceres owns them
  for (Record& rec : records_) {
    delete rec.cost;
    delete rec.loss;
  }
}

namespace {

/// A prior (x − x0)/σ on a block, analytic Jacobian.
/// One step of a first-order Gauss–Markov process between two 3-vector samples:
/// r = (x₂ − φ x₁) / σ_step, analytic Jacobians.
class GaussMarkovStep final : public ceres::SizedCostFunction<3, 3, 3> {
 public:
  GaussMarkovStep(double phi, const Vec3& sigma_step) : phi_(phi), w_(sigma_step.cwiseInverse()) {}
  bool Evaluate(double const* const* p, double* r, double** J) const override {
    for (int a = 0; a < 3; ++a) r[a] = (p[1][a] - phi_ * p[0][a]) * w_[a];
    for (int b = 0; b < 2; ++b) {
      if (!J || !J[b]) continue;
      std::fill(J[b], J[b] + 9, 0.0);
      for (int a = 0; a < 3; ++a) J[b][4 * a] = (b == 0 ? -phi_ : 1.0) * w_[a];
    }
    return true;
  }

 private:
  double phi_;
  Vec3 w_;
};

class BlockPrior final : public ceres::CostFunction {
 public:
  /// Independent components: r_a = (x_a − x0_a) / σ_a.
  BlockPrior(int size, std::vector<double> x0, const std::vector<double>& inv_sigma)
      : BlockPrior(std::move(x0), Eigen::VectorXd::Map(inv_sigma.data(), size).asDiagonal().toDenseMatrix()) {}
  /// Correlated components: r = W (x − x0), W the square root of the prior's information.
  BlockPrior(std::vector<double> x0, Eigen::MatrixXd W) : x0_(std::move(x0)), W_(std::move(W)) {
    set_num_residuals(static_cast<int>(W_.rows()));
    mutable_parameter_block_sizes()->push_back(static_cast<int>(W_.cols()));
  }
  bool Evaluate(double const* const* p, double* r, double** J) const override {
    const Eigen::Index n = W_.cols();
    Eigen::VectorXd dx(n);
    for (Eigen::Index a = 0; a < n; ++a) dx[a] = p[0][a] - x0_[static_cast<std::size_t>(a)];
    Eigen::VectorXd::Map(r, W_.rows()) = W_ * dx;
    if (J && J[0]) Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(J[0], W_.rows(), n) = W_;
    return true;
  }

 private:
  std::vector<double> x0_;
  Eigen::MatrixXd W_;
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

}  // namespace

double* AdjustmentProblem::stripOffset(const std::string& strip_id) {
  auto it = offsets_.find(strip_id);
  if (it != offsets_.end()) return it->second;
  const double zero[3] = {0.0, 0.0, 0.0};
  double* block = offsets_.emplace(strip_id, arena_->allocate(3, zero)).first->second;
  problem_->AddParameterBlock(block, 3);
  if (offset_sigma_m_ > 0) {
    const double w = 1.0 / offset_sigma_m_;
    const int src = source_;
    source_ = -1;  // the prior belongs to no source
    addResidualBlock(new BlockPrior(3, {0, 0, 0}, {w, w, w}), 0.0, {block});
    source_ = src;
  } else {
    problem_->SetParameterBlockConstant(block);
  }
  return block;
}

double* AdjustmentProblem::attitudeError(const std::string& strip_id, double time_s) {
  if (!pulse_noise_.attitudeRandomEffect()) return nullptr;
  // Observations closer than τ/20 (correlation > 0.95) share one block.
  const long long key = std::llround(time_s / (pulse_noise_.attitude_correlation_s / 20.0));
  auto it = attitude_errors_.find({strip_id, key});
  if (it != attitude_errors_.end()) return it->second;
  const double zero[3] = {0.0, 0.0, 0.0};
  // Non-eliminable: it shares residual blocks with the sources' own nuisance blocks (tie
  // positions) and with its neighbours in time (the chain prior).
  double* block = addNuisanceBlock(3, zero, nullptr, false);
  attitude_errors_.emplace(std::make_pair(strip_id, key), block);
  return block;
}

void AdjustmentProblem::addRandomEffectPriors() {
  if (attitude_errors_.empty()) return;
  // δψ(t) of each strip is a first-order Gauss–Markov process sampled at its observations'
  // times: δψ(t₀) ~ N(0, σ²), δψ(t₂) − φ δψ(t₁) ~ N(0, σ² (1 − φ²)) with φ = exp(−Δt/τ) —
  // the exact joint distribution of the samples, as a chain of priors.
  const double tau = pulse_noise_.attitude_correlation_s, dt_key = tau / 20.0;
  const double t = deg2rad(pulse_noise_.roll_pitch_deg), k = deg2rad(pulse_noise_.heading_deg);
  // A component without noise is held at zero by a stiff prior (1e-6 of the other's σ).
  const Vec3 sigma(t > 0 ? t : 1e-6 * k, t > 0 ? t : 1e-6 * k, k > 0 ? k : 1e-6 * t);
  const int src = source_;
  source_ = -1;  // the priors belong to no source
  const std::string* strip = nullptr;
  long long prev_key = 0;
  double* prev = nullptr;
  for (const auto& [id_key, block] : attitude_errors_) {  // ordered by strip, then time
    if (!strip || *strip != id_key.first) {
      strip = &id_key.first;
      addResidualBlock(new BlockPrior(3, {0, 0, 0}, {1 / sigma.x(), 1 / sigma.y(), 1 / sigma.z()}), 0.0, {block});
    } else {
      const double phi = std::exp(-static_cast<double>(id_key.second - prev_key) * dt_key / tau);
      addResidualBlock(new GaussMarkovStep(phi, sigma * std::sqrt(std::max(1.0 - phi * phi, 1e-12))), 0.0, {prev, block});
    }
    prev_key = id_key.second;
    prev = block;
  }
  source_ = src;
}

std::string AdjustmentProblem::reportedName(const double* block) const {
  const auto it = reported_names_.find(block);
  return it == reported_names_.end() ? std::string() : it->second;
}

void AdjustmentProblem::reportCovariance(const double* block, const std::string& name) {
  const auto it = std::find_if(nuisance_.begin(), nuisance_.end(), [block](const Block& b) { return b.values == block; });
  if (it == nuisance_.end() || it->manifold)
    throw std::invalid_argument("AdjustmentProblem::reportCovariance: not a nuisance block of this problem without a manifold");
  if (std::find(reported_.begin(), reported_.end(), block) == reported_.end()) reported_.push_back(block);
  if (!name.empty()) reported_names_[block] = name;
}

const Eigen::MatrixXd& AdjustmentProblem::reportedCovariance(const double* block) const {
  static const Eigen::MatrixXd kNone;
  const auto it = reported_covariance_.find(block);
  return it == reported_covariance_.end() ? kNone : it->second;
}

Vec3 AdjustmentProblem::stripOffsetValue(const std::string& strip_id) const {
  auto it = offsets_.find(strip_id);
  if (it == offsets_.end()) return Vec3::Zero();
  return Vec3(it->second[0], it->second[1], it->second[2]);
}

double* AdjustmentProblem::addNuisanceBlock(int size, const double* initial, ceres::Manifold* manifold, bool schur_eliminable) {
  double* values = arena_->allocate(static_cast<std::size_t>(size), initial);
  if (manifold)
    problem_->AddParameterBlock(values, size, manifold);
  else
    problem_->AddParameterBlock(values, size);
  nuisance_.push_back({values, size, manifold, schur_eliminable, false});
  return values;
}

int AdjustmentProblem::addResidualBlock(ceres::CostFunction* cost, double loss_sigma_m, const std::vector<double*>& blocks) {
  return addResidualBlock(cost, loss_sigma_m, blocks, loss_scale_m_);
}

int AdjustmentProblem::addResidualBlock(ceres::CostFunction* cost, double loss_sigma_m, const std::vector<double*>& blocks,
                                        double loss_scale_m) {
  ceres::LossFunction* loss = nullptr;
  if (loss_sigma_m > 0 && loss_ != LossType::kTrivial) {
    const double scale = loss_scale_m / loss_sigma_m;
    if (loss_ == LossType::kHuber)
      loss = new ceres::HuberLoss(scale);
    else
      loss = new ceres::CauchyLoss(scale);
  }
  if (committed_) problem_->AddResidualBlock(cost, loss, blocks);  // after commit(): straight to Ceres
  records_.push_back({cost, blocks, source_, loss_sigma_m, {}, loss});
  return static_cast<int>(records_.size()) - 1;
}

void AdjustmentProblem::setCorrections(const TrajectoryCorrections& corrections, double time_offset_sigma_s,
                                       const TrajectoryAccuracy& accuracy) {
  corrections_ = corrections;
  correction_accuracy_ = accuracy;
  time_offset_sigma_s_ = time_offset_sigma_s;
}

void AdjustmentProblem::commit() {
  if (committed_) return;
  const bool corr = corrections_.any();
  const bool time = time_offset_sigma_s_ > 0;
  if (corr || time) attachCorrections(corr, time);
  for (const Record& rec : records_) problem_->AddResidualBlock(rec.cost, rec.loss, rec.blocks);
  committed_ = true;
}

namespace {

/// var(Σ_k c_k) of one axis (the correction at the span's end, P_k(1) = 1) in a
/// correctionPrior covariance: the coefficients k of axis a sit at first + 3 (k − 1) + a.
double endVariance(const Eigen::MatrixXd& cov, int axis, int first, int degree) {
  double v = 0.0;
  for (int k = 0; k < degree; ++k)
    for (int l = 0; l < degree; ++l) v += cov(first + 3 * k + axis, first + 3 * l + axis);
  return v;
}

}  // namespace

void AdjustmentProblem::attachCorrections(bool corr, bool time) {
  // Each strip's span: the times of its observations (TrajectoryCorrections' τ ∈ [−1, 1]).
  std::map<const double*, std::pair<double, double>> span;  // offset block → (t_min, t_max)
  bool moving = false;
  for (const Record& rec : records_)
    for (const Epoch& e : rec.epochs) {
      auto [it, fresh] = span.try_emplace(e.offset, e.time_s, e.time_s);
      if (!fresh) it->second = {std::min(it->second.first, e.time_s), std::max(it->second.second, e.time_s)};
      moving |= e.moving;
    }
  time = time && moving;
  std::map<const double*, std::size_t> index;  // offset block → corrections_blocks_
  const int src = source_;
  source_ = -1;  // the priors belong to no source
  if (corr) {
    const int n = corrections_.size();
    const std::vector<double> zero(static_cast<std::size_t>(n), 0.0);
    for (const auto& [id, o3] : offsets_) {
      auto it = span.find(o3);
      if (it == span.end()) continue;
      StripCorrection sc{id, nullptr, 0.5 * (it->second.first + it->second.second), 0.5 * (it->second.second - it->second.first)};
      const Eigen::MatrixXd cov = correctionPrior(it->second.first, it->second.second);
      for (int a = 0; a < 3; ++a) {
        sc.prior_end_position_m[a] = std::sqrt(endVariance(cov, a, 0, corrections_.position_degree));
        sc.prior_end_attitude_rad[a] = std::sqrt(endVariance(cov, a, 3 * corrections_.position_degree, corrections_.attitude_degree));
      }
      // r = L⁻¹ c for cov = L Lᵀ: unit covariance.
      // (A covariance too close to singular for Cholesky keeps its variances alone.)
      const Eigen::LLT<Eigen::MatrixXd> llt(cov);
      const Eigen::MatrixXd W = llt.info() == Eigen::Success ? Eigen::MatrixXd(llt.matrixL().solve(Eigen::MatrixXd::Identity(n, n)))
                                                             : Eigen::MatrixXd(cov.diagonal().cwiseSqrt().cwiseInverse().asDiagonal());
      // Non-eliminable: it shares residual blocks with the sources' own nuisance blocks.
      sc.values = addNuisanceBlock(n, zero.data(), nullptr, false);
      addResidualBlock(new BlockPrior(zero, W), 0.0, {sc.values});
      index[o3] = corrections_blocks_.size();
      corrections_blocks_.push_back(sc);
    }
  }
  if (time) {
    const double zero = 0.0;
    time_offset_block_ = addNuisanceBlock(1, &zero, nullptr, false);
    addResidualBlock(new BlockPrior(1, {0.0}, {1.0 / time_offset_sigma_s_}), 0.0, {time_offset_block_});
  }
  source_ = src;
  for (Record& rec : records_) {
    if (rec.epochs.empty()) continue;
    std::vector<detail::CorrectionTerm> terms;
    std::vector<double*> extra;
    for (const Epoch& e : rec.epochs) {
      detail::CorrectionTerm term;
      term.offset_block = e.block;
      term.u_m = e.u_m;
      if (time && e.moving) term.motion_m_s = e.velocity_m_s + e.rate_rad_s.cross(e.u_m);
      auto it = index.find(e.offset);
      if (it != index.end()) {
        const StripCorrection& sc = corrections_blocks_[it->second];
        term.tau = detail::spanTau(e.time_s, sc.t_mid_s, sc.half_span_s);
        term.correction_block = static_cast<int>(rec.blocks.size() + extra.size());
        extra.push_back(sc.values);
      }
      terms.push_back(term);
    }
    const int n_corr = static_cast<int>(extra.size());
    if (time) extra.push_back(time_offset_block_);
    if (extra.empty()) continue;
    rec.cost = new detail::CorrectedCost(rec.cost, std::move(terms), corrections_.position_degree, corr ? corrections_.attitude_degree : 0,
                                         n_corr, time);
    rec.blocks.insert(rec.blocks.end(), extra.begin(), extra.end());
  }
}

Eigen::MatrixXd AdjustmentProblem::correctionPrior(double t0_s, double t1_s) const {
  const TrajectoryCorrections& tc = corrections_;
  const int n = tc.size(), dp = tc.position_degree, da = tc.attitude_degree;
  Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(n, n);
  if (!tc.priors_from_accuracy) {
    for (int j = 0; j < n; ++j) {
      const double s = j < 3 * dp ? tc.position_sigma_m : deg2rad(j % 3 == 2 ? tc.heading_sigma_deg : tc.roll_pitch_sigma_deg);
      cov(j, j) = s * s;
    }
    return cov;
  }
  // Each axis: the Legendre coefficients of its stated error over [t0, t1]; the coefficient k of
  // axis a sits at 3 (k − 1) + a of its group (position, then attitude).
  const TrajectoryAccuracy& acc = correction_accuracy_;
  const TrajectoryAccuracySeries* series = acc.series && !acc.series->empty() ? acc.series.get() : nullptr;
  for (int group = 0; group < 2; ++group) {
    const int degree = group == 0 ? dp : da, first = group == 0 ? 0 : 3 * dp;
    const double tau = group == 0 ? acc.position_correlation_s : acc.attitude_correlation_s;
    for (int a = 0; a < 3 && degree > 0; ++a) {
      const double constant = group == 0 ? acc.position_sigma_m : deg2rad(a == 2 ? acc.heading_sigma_deg : acc.roll_pitch_sigma_deg);
      const auto sigma = [&](double t) {
        if (!series) return constant;
        Vec3 p, q;
        series->at(t, &p, &q);
        return group == 0 ? p[a] : q[a];
      };
      Eigen::MatrixXd C = detail::legendreCoefficientCovariance(degree, t0_s, t1_s, tau, sigma);
      if (group == 0 && acc.gnss_sigma_m > 0)  // the GNSS process beside the drift: independent, the covariances add
        C += detail::legendreCoefficientCovariance(degree, t0_s, t1_s, acc.gnss_correlation_s, [&](double) { return acc.gnss_sigma_m; });
      for (int k = 0; k < degree; ++k)
        for (int l = 0; l < degree; ++l) cov(first + 3 * k + a, first + 3 * l + a) = C(k, l);
    }
  }
  // A span of one instant, or an axis stated without error, has nothing to correct: a floor far
  // below any survey's error keeps the prior invertible (1 µm, 1 nrad).
  for (int j = 0; j < n; ++j) cov(j, j) = std::max(cov(j, j), j < 3 * dp ? 1e-12 : 1e-18);
  return cov;
}

PointShifts AdjustmentProblem::pointShifts() const {
  PointShifts s;
  for (const auto& [id, o] : offsets_) s.strips_[id].offset_m = Vec3(o[0], o[1], o[2]);
  if (!corrections_blocks_.empty()) {
    s.position_degree_ = corrections_.position_degree;
    s.attitude_degree_ = corrections_.attitude_degree;
  }
  for (const StripCorrection& c : corrections_blocks_) {
    PointShifts::Terms& t = s.strips_[c.strip_id];
    t.coefficients.assign(c.values, c.values + corrections_.size());
    t.t_mid_s = c.t_mid_s;
    t.half_span_s = c.half_span_s;
  }
  if (time_offset_block_ && motion_) {
    s.time_offset_s_ = *time_offset_block_;
    s.motion_ = motion_;
  }
  return s;
}

PointShifts::Strip PointShifts::strip(const std::string& strip_id) const {
  Strip out;
  out.all_ = this;
  out.id_ = strip_id;
  auto it = strips_.find(strip_id);
  if (it != strips_.end()) out.terms_ = &it->second;
  return out;
}

Vec3 PointShifts::Strip::at(double time_s, const Vec3& u_m) const {
  Vec3 d = Vec3::Zero();
  if (terms_) {
    // The offset plus the correction, as detail::CorrectedCost passes them to the source.
    d = terms_->offset_m;
    if (!terms_->coefficients.empty())
      d += detail::correctionShift(all_->position_degree_, all_->attitude_degree_,
                                   detail::spanTau(time_s, terms_->t_mid_s, terms_->half_span_s), u_m, terms_->coefficients.data());
  }
  Vec3 v, w;
  if (all_ && all_->time_offset_s_ != 0.0 && all_->motion_(id_, time_s, &v, &w)) d += all_->time_offset_s_ * (v + w.cross(u_m));
  return d;
}

void AdjustmentProblem::setEpoch(int record, const std::string& strip_id, double time_s, const Vec3& u_m, bool in_sigma) {
  Record& rec = records_.at(static_cast<std::size_t>(record));
  auto it = offsets_.find(strip_id);
  if (it == offsets_.end()) return;
  const double* offset = it->second;
  for (std::size_t b = 0; b < rec.blocks.size(); ++b)
    if (rec.blocks[b] == offset) {
      Epoch e{static_cast<int>(b), offset, time_s, u_m, in_sigma};
      if (motion_) e.moving = motion_(strip_id, time_s, &e.velocity_m_s, &e.rate_rad_s);
      rec.epochs.push_back(e);
      return;
    }
}

Eigen::VectorXd AdjustmentProblem::residual(int index) const {
  const Record& rec = records_.at(static_cast<std::size_t>(index));
  Eigen::VectorXd r(rec.cost->num_residuals());
  std::vector<const double*> params(rec.blocks.begin(), rec.blocks.end());
  rec.cost->Evaluate(params.data(), r.data(), nullptr);
  return r;
}

// ---- MountingAdjustment ---------------------------------------------------------------------

namespace {

using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using RowMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

bool priorOn(const MountingBlockOptions& options, int j) { return options.prior_sigma[j] > 0 && std::isfinite(options.prior_sigma[j]); }

/// The columns of the linearisation: 0..5 the mounting, then the tangent coordinates of every
/// variable nuisance block (the sources' blocks, then the strip offsets when they are estimated).
struct Columns {
  std::map<const double*, std::pair<int, int>> col;  // block → (first column, tangent size)
  std::map<const double*, const ceres::Manifold*> manifold;
  int n = 6;
};

Columns columnsOf(const AdjustmentProblem& problem) {
  Columns c;
  auto add = [&c](const AdjustmentProblem::Block& b) {
    const int t = b.manifold ? b.manifold->TangentSize() : b.size;
    c.col[b.values] = {c.n, t};
    if (b.manifold) c.manifold[b.values] = b.manifold;
    c.n += t;
  };
  // The blocks a source asked the covariance of (reportCovariance) first, in the order asked:
  // columns 6… of reducedSystem() when it keeps them.
  const std::vector<const double*>& reported = problem.reportedBlocks();
  for (const double* r : reported)
    for (const auto& b : problem.nuisanceBlocks())
      if (b.values == r) add(b);
  for (const auto& b : problem.nuisanceBlocks())
    if (std::find(reported.begin(), reported.end(), b.values) == reported.end()) add(b);
  if (problem.stripOffsetSigma() > 0) {
    for (const auto& entry : problem.stripOffsets()) {
      c.col[entry.second] = {c.n, 3};
      c.n += 3;
    }
  }
  return c;
}

/// The Jacobians of one residual block at the current values, each block's (constant ones
/// too) — a nuisance block on a manifold in its tangent space; `residual` (optional) its value.
std::vector<RowMat> blockJacobians(const AdjustmentProblem::Record& rec, const Columns& cols, Eigen::VectorXd* residual = nullptr) {
  const int nr = rec.cost->num_residuals();
  const auto& sizes = rec.cost->parameter_block_sizes();
  std::vector<RowMat> J(rec.blocks.size());
  std::vector<double*> jac(rec.blocks.size());
  for (std::size_t b = 0; b < rec.blocks.size(); ++b) {
    J[b].resize(nr, sizes[b]);
    jac[b] = J[b].data();
  }
  std::vector<const double*> params(rec.blocks.begin(), rec.blocks.end());
  Eigen::VectorXd r(nr);
  rec.cost->Evaluate(params.data(), r.data(), jac.data());
  if (residual) *residual = r;
  for (std::size_t b = 0; b < rec.blocks.size(); ++b) {
    auto man = cols.manifold.find(rec.blocks[b]);
    if (man == cols.manifold.end()) continue;
    RowMat plus(man->second->AmbientSize(), man->second->TangentSize());
    man->second->PlusJacobian(rec.blocks[b], plus.data());
    J[b] = RowMat(J[b] * plus);
  }
  return J;
}

/// The non-zero Jacobian entries of one residual block at rows `row`…: the mounting's in columns
/// 0–5, each nuisance block's at its Columns index + `shift` (constant blocks left out).
void addTriplets(const AdjustmentProblem::Record& rec, const std::vector<RowMat>& J, const Columns& cols, const double* m, int row,
                 int shift, std::vector<Eigen::Triplet<double>>* trip) {
  const int nr = rec.cost->num_residuals();
  for (std::size_t b = 0; b < rec.blocks.size(); ++b) {
    const double* blk = rec.blocks[b];
    int first = 0;
    if (blk != m) {
      auto it = cols.col.find(blk);
      if (it == cols.col.end()) continue;  // a constant block
      first = it->second.first + shift;
    }
    for (int i = 0; i < nr; ++i)
      for (int c = 0; c < J[b].cols(); ++c)
        if (J[b](i, c) != 0.0) trip->emplace_back(row + i, first + c, J[b](i, c));
  }
}

/// Every record's Jacobian at the current values stacked in record order over `cols` (the
/// mounting `m`'s 6 columns first, constant blocks left out), and each record's first row.
/// `weighted` (optional, with the mounting's `estimated` columns): each record's rows and its
/// residual weighted by the loss's √ρ′ there (as Ceres' last step weighs them) and the held
/// columns zero, the weighted residuals returned — linearise(); without it the plain Jacobian
/// (reducedSystem()).
struct StackedJacobian {
  Eigen::SparseMatrix<double> J;
  std::vector<int> first_row;
  std::vector<Eigen::VectorXd> residual;  ///< weighted only
};

StackedJacobian stackJacobians(const AdjustmentProblem& problem, const double* m, const Columns& cols,
                               const std::array<bool, 6>* weighted = nullptr) {
  const auto& records = problem.records();
  StackedJacobian out;
  out.first_row.assign(records.size(), 0);
  if (weighted) out.residual.assign(records.size(), Eigen::VectorXd());
  std::vector<Eigen::Triplet<double>> trip;
  int row = 0;
  for (std::size_t i = 0; i < records.size(); ++i) {
    const AdjustmentProblem::Record& rec = records[i];
    const int nr = rec.cost->num_residuals();
    Eigen::VectorXd r;
    std::vector<RowMat> J = blockJacobians(rec, cols, weighted ? &r : nullptr);
    if (weighted) {
      if (rec.loss) {  // the loss's weight ρ′ at this residual
        double rho[3] = {r.squaredNorm(), 1.0, 0.0};
        rec.loss->Evaluate(rho[0], rho);
        const double w = std::sqrt(std::max(rho[1], 0.0));
        for (RowMat& Jb : J) Jb *= w;
        r *= w;
      }
      out.residual[i] = r;
      for (std::size_t b = 0; b < rec.blocks.size(); ++b)
        if (rec.blocks[b] == m)
          for (int j = 0; j < 6; ++j)
            if (!(*weighted)[static_cast<std::size_t>(j)]) J[b].col(j).setZero();  // held
    }
    out.first_row[i] = row;
    addTriplets(rec, J, cols, m, row, 0, &trip);
    row += nr;
  }
  out.J.resize(row, cols.n);
  out.J.setFromTriplets(trip.begin(), trip.end());
  return out;
}

/// The whole adjustment linearised at the current values: every record's Jacobian (stackJacobians:
/// tangent spaces, the mounting's held columns zero, each residual and its rows weighted by the
/// loss's √ρ′ as the solve's last step weighs them), N = JᵀJ factorised (held and unseen columns
/// decoupled, a free direction regularised as reducedSystem() does), and each record's rows.
struct Linearised {
  Columns cols;
  Eigen::SparseMatrix<double, Eigen::RowMajor> J;
  std::vector<int> first_row;
  std::vector<Eigen::VectorXd> residual;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  bool ok = false;
  Eigen::MatrixXd rows(std::size_t record, int nr) const { return Eigen::MatrixXd(J.middleRows(first_row[record], nr)); }
  /// A record's diagonal block of the hat matrix from its rows `Jr` (rows()), J_r N⁻¹ J_rᵀ (symmetrised).
  Eigen::MatrixXd hat(const Eigen::MatrixXd& Jr) const {
    const Eigen::MatrixXd H = Jr * ldlt.solve(Eigen::MatrixXd(Jr.transpose()));
    return 0.5 * (H + H.transpose());
  }
};

void linearise(const AdjustmentProblem& problem, const double* mounting, const std::array<bool, 6>& estimated, Linearised* L) {
  L->cols = columnsOf(problem);
  StackedJacobian stacked = stackJacobians(problem, mounting, L->cols, &estimated);
  const int n = L->cols.n;
  Eigen::SparseMatrix<double> N = Eigen::SparseMatrix<double>(stacked.J.transpose()) * stacked.J;
  const double eps = 1e-12 * std::max(1.0, Eigen::VectorXd(N.diagonal()).cwiseAbs().maxCoeff());
  for (int c = 0; c < n; ++c) N.coeffRef(c, c) += N.coeff(c, c) == 0.0 ? 1.0 : eps;
  L->ldlt.compute(N);
  L->ok = L->ldlt.info() == Eigen::Success;
  L->J = stacked.J;
  L->first_row = std::move(stacked.first_row);
  L->residual = std::move(stacked.residual);
}

}  // namespace

std::vector<Eigen::MatrixXd> AdjustmentProblem::leverage(const std::vector<int>& indices) const {
  Linearised L;
  linearise(*this, mounting_, estimated_, &L);
  std::vector<Eigen::MatrixXd> out;
  out.reserve(indices.size());
  for (int index : indices) {
    const std::size_t i = static_cast<std::size_t>(index);
    const int nr = records_.at(i).cost->num_residuals();
    if (!L.ok) {
      out.push_back(Eigen::MatrixXd::Constant(nr, nr, std::nan("")));
      continue;
    }
    out.push_back(L.hat(L.rows(i, nr)));
  }
  return out;
}

Eigen::MatrixXd AdjustmentProblem::leaveOneOutCovariance(const double* block, const std::vector<int>& indices,
                                                         Eigen::MatrixXd* formal) const {
  Linearised L;
  linearise(*this, mounting_, estimated_, &L);
  const auto it = L.cols.col.find(block);
  if (it == L.cols.col.end()) throw std::invalid_argument("leaveOneOutCovariance: not a variable block of this adjustment");
  const auto [first, size] = it->second;
  if (!L.ok) {
    if (formal) *formal = Eigen::MatrixXd::Constant(size, size, std::nan(""));
    return Eigen::MatrixXd::Constant(size, size, std::nan(""));
  }
  Eigen::MatrixXd E = Eigen::MatrixXd::Zero(L.cols.n, size);
  for (int a = 0; a < size; ++a) E(first + a, a) = 1.0;
  const Eigen::MatrixXd X = L.ldlt.solve(E);  // N⁻¹ E: the block's columns of N⁻¹
  std::vector<bool> listed(records_.size(), false);
  for (int i : indices) listed.at(static_cast<std::size_t>(i)) = true;
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(size, size), F = Eigen::MatrixXd::Zero(size, size);
  for (std::size_t i = 0; i < records_.size(); ++i) {
    const int nr = records_[i].cost->num_residuals();
    const Eigen::MatrixXd Jr = L.rows(i, nr);
    const Eigen::MatrixXd G = Jr * X;  // the record's rows of J N⁻¹ E
    F += G.transpose() * G;
    if (!listed[i]) {
      C += G.transpose() * G;
      continue;
    }
    // (I − H_rr)⁻¹ e: the residual the record would have had without itself in the solve (its
    // eigenvalues floored at 1e-9: a record that alone determines a direction stays finite).
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Eigen::MatrixXd::Identity(nr, nr) - L.hat(Jr));
    const Eigen::VectorXd loo =
        eig.eigenvectors() * eig.eigenvalues().cwiseMax(1e-9).cwiseInverse().asDiagonal() * eig.eigenvectors().transpose() * L.residual[i];
    const Eigen::VectorXd g = G.transpose() * loo;
    C += g * g.transpose();
  }
  if (formal) *formal = 0.5 * (F + F.transpose());
  return 0.5 * (C + C.transpose());
}

namespace {

/// One residual block's reduced Jacobian Ĵ = J_kept − J_e X over the first `kept` columns of
/// reducedSystem() (its blocks' Jacobians `J`, blockJacobians; X = N_ee⁻¹ N_ek from it).
Eigen::MatrixXd reducedJacobian(const AdjustmentProblem::Record& rec, const std::vector<RowMat>& J, const Columns& cols,
                                const Eigen::MatrixXd& X, const double* m, int kept) {
  Eigen::MatrixXd Jr = Eigen::MatrixXd::Zero(rec.cost->num_residuals(), kept);
  for (std::size_t b = 0; b < rec.blocks.size(); ++b) {
    if (rec.blocks[b] == m) {
      Jr.leftCols(6) += J[b];
      continue;
    }
    auto it = cols.col.find(rec.blocks[b]);
    if (it == cols.col.end()) continue;
    const auto [first, size] = it->second;
    if (first < kept)
      Jr.middleCols(first, size) += J[b];
    else if (X.rows() > 0)
      Jr -= J[b] * X.middleRows(first - kept, size);
  }
  return Jr;
}

/// Reduced normal matrix of the first `kept` columns — the mounting's 6, then (kept > 6) the
/// blocks asked for by reportCovariance — every other nuisance block (the sources' blocks and the
/// strip offsets) eliminated by a Schur complement, and the unreduced diagonal, from the
/// Jacobians of every residual block at the current values (SPEC §3 step 5: rank and
/// condition). Nuisance blocks on a manifold enter in their tangent space. `X` (optional):
/// N_ee⁻¹ N_ek, the eliminated blocks' response to the kept ones (rows: columns `kept`… of
/// `cols`), for the reduced Jacobian J_k − J_e X of any residual.
/// `offset_variance` (optional): per strip offset its posterior variance per axis with the kept
/// columns held (the diagonal of N_ee⁻¹ there; its prior is one of the records).
void reducedSystem(AdjustmentProblem& problem, int kept, Eigen::MatrixXd* N_red, Eigen::VectorXd* diag, Eigen::MatrixXd* X_out = nullptr,
                   Columns* cols_out = nullptr, std::map<const double*, Vec3>* offset_variance = nullptr) {
  const Columns cols = columnsOf(problem);
  const int n = cols.n, k = kept;
  const Eigen::SparseMatrix<double> Js = std::move(stackJacobians(problem, problem.mounting(), cols).J);
  const Eigen::SparseMatrix<double> Jt_s = Js.transpose();
  const Eigen::SparseMatrix<double> N = Jt_s * Js;
  const Eigen::MatrixXd Nkk = Eigen::MatrixXd(N.topLeftCorner(k, k));
  *diag = Nkk.diagonal();
  if (cols_out) *cols_out = cols;
  if (n == k) {
    *N_red = Nkk;
    if (X_out) X_out->resize(0, k);
    return;
  }
  const Eigen::SparseMatrix<double> Nee = N.bottomRightCorner(n - k, n - k);
  const Eigen::MatrixXd Nek = Eigen::MatrixXd(N.bottomLeftCorner(n - k, k));
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(Nee);
  Eigen::MatrixXd X;
  if (ldlt.info() == Eigen::Success) X = ldlt.solve(Nek);
  const bool regularised = ldlt.info() != Eigen::Success || !X.allFinite();
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> reg;
  if (regularised) {
    // A nuisance direction the data leave free (it cannot couple to the mounting): regularise.
    Eigen::SparseMatrix<double> R = Nee;
    const double eps = 1e-12 * std::max(1.0, Eigen::VectorXd(Nee.diagonal()).cwiseAbs().maxCoeff());
    for (int i = 0; i < n - k; ++i) R.coeffRef(i, i) += eps;
    reg.compute(R);
    X = reg.solve(Nek);
  }
  if (offset_variance && problem.stripOffsetSigma() > 0) {
    const auto& offsets = problem.stripOffsets();
    Eigen::MatrixXd E = Eigen::MatrixXd::Zero(n - k, 3 * static_cast<Eigen::Index>(offsets.size()));
    Eigen::Index c = 0;
    for (const auto& entry : offsets)
      for (int a = 0; a < 3; ++a) E(cols.col.at(entry.second).first - k + a, c++) = 1.0;
    const Eigen::MatrixXd V = regularised ? Eigen::MatrixXd(reg.solve(E)) : Eigen::MatrixXd(ldlt.solve(E));
    c = 0;
    for (const auto& entry : offsets) {
      Vec3 v;
      for (int a = 0; a < 3; ++a, ++c) v(a) = V(cols.col.at(entry.second).first - k + a, c);
      (*offset_variance)[entry.second] = v;
    }
  }
  *N_red = Nkk - Nek.transpose() * X;
  *N_red = 0.5 * (*N_red + N_red->transpose());
  if (X_out) *X_out = std::move(X);
}

/// A σ that a kind estimated at the start is taken from its residuals at the solution below this
/// σ₀² (ObservationSource::sigmaFromStart): the residuals scatter by less than 0.71 of it.
constexpr double kStartSigmaCheck = 0.5;

/// What the covariance takes off where kinds' σ came from the start and their residuals scatter
/// less (ObservationSource::sigmaFromStart): the estimate was computed at the stated weights W,
/// and with kind k's residuals scattering by s_k ≤ 1 times what W states its covariance is the
/// sandwich
///
///   N⁻¹ (Σ_k s_k Ĵ_kᵀ W_k Ĵ_k + the rest) N⁻¹ = N⁻¹ − N⁻¹ D N⁻¹,  D = Σ_k (1 − s_k) Ĵ_kᵀ W_k Ĵ_k,
///
/// Ĵ the reduced Jacobian (J_kept − J_e X, every other nuisance block eliminated; priors are the
/// rest). Returns D over the first `kept` columns of reducedSystem(), whose X and columns it takes
/// (the caller has just built them); `scale` per record (1:
/// unchanged), `robust` per record the loss's weight ρ′ at its residual (as Ceres' covariance
/// weighs it).
Eigen::MatrixXd startSigmaCorrection(AdjustmentProblem& problem, int kept, const Eigen::MatrixXd& X, const Columns& cols,
                                     const std::vector<double>& scale, const std::vector<double>& robust) {
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(kept, kept);
  const double* m = problem.mounting();
  const auto& recs = problem.records();
  for (std::size_t i = 0; i < recs.size(); ++i) {
    if (!(scale[i] < 1.0)) continue;
    const auto& rec = recs[i];
    const std::vector<RowMat> J = blockJacobians(rec, cols);
    const Eigen::MatrixXd Jr = reducedJacobian(rec, J, cols, X, m, kept);
    D += (1.0 - scale[i]) * robust[i] * Jr.transpose() * Jr;
  }
  return 0.5 * (D + D.transpose());
}

/// reducedSystem() of the mounting block alone (every nuisance block eliminated).
void reducedNormalMatrix(AdjustmentProblem& problem, Mat6* N_red, Vec6* diag, Eigen::MatrixXd* X_out = nullptr,
                         Columns* cols_out = nullptr) {
  Eigen::MatrixXd N;
  Eigen::VectorXd d;
  reducedSystem(problem, 6, &N, &d, X_out, cols_out);
  *N_red = N;
  *diag = d;
}

/// The trajectory errors' part of the mounting's covariance, in normal-matrix units (the
/// "consider" term of TrajectoryAccuracy, before N_red⁻¹ on both sides):
///
///   M = Σ_strips Σ_{u,v} exp(−|t_u − t_v| / τ) H(u) Σ_c H(v)ᵀ,   H(u) = Σ_{epochs in bin u} Ĵᵀ J_c,
///
/// Ĵ = J_m − J_n X the residual block's reduced Jacobian (its nuisance eliminated), J_c its
/// Jacobian with respect to the strip's position (the offset block) or attitude (the offset's
/// times −[u]×). Epochs are binned at τ/20 (correlation > 0.95 within a bin); the double sum over bins runs
/// as the exponential kernel's recursion (linear in the bins). Position and attitude separately; attitude only
/// when `attitude` (not already estimated as PulseNoise's random effect).
///
/// An epoch whose own variance is in its block's estimated σ (Epoch::in_sigma) holds there only
/// the part of its trajectory error that the strip's estimated terms do not absorb (the offset,
/// the corrections' polynomials: residualShare); that part is returned as `self`, to be taken
/// off M (the correlations stay).
///
/// Over the first `kept` columns of reducedSystem() (the mounting's 6, or with the blocks asked
/// for by reportCovariance): Rows = 6 for the mounting alone (fixed-size), Eigen::Dynamic else.
template <int Rows>
struct TrajectoryTerm {
  using Mat = Eigen::Matrix<double, Rows, Rows>;
  Mat M, self;  ///< every epoch's error, own variances included; Σ share · h C hᵀ of the in_sigma epochs
};

/// One process of the trajectory errors (position drift, attitude, the GNSS error) in
/// trajectoryErrorTerm(): its correlation time, bin width and variance per axis, and per strip
/// offset and time bin the summed H and the in_sigma epochs' own terms.
template <int Rows>
struct TrajectoryGroup {
  using Mat = Eigen::Matrix<double, Rows, Rows>;
  using Mat63 = Eigen::Matrix<double, Rows, 3>;
  struct Own {  // one bin of in_sigma epochs: Σ h C hᵀ per axis of C and its count
    std::array<Mat, 3> hch;
    double count = 0;
  };
  double tau, bin;
  Vec3 var;
  std::map<const double*, std::map<long long, Mat63>> H;  // strip offset → bin → H
  std::map<const double*, std::map<long long, Own>> own;  // strip offset → bin → in_sigma epochs
  std::vector<int> absorbed;                              // polynomial degrees the strip's terms absorb
};

/// The part of the in_sigma epochs' own errors that their kind's estimated σ hold (what the
/// strip's estimated terms leave: detail::residualShare), added to `self`. `attitude`: the
/// attitude process (the offsets absorb none of it).
template <int Rows>
void addOwnShare(const TrajectoryGroup<Rows>& g, bool attitude, const Columns& cols, const std::map<const double*, Vec3>& offset_var,
                 double prior, typename TrajectoryGroup<Rows>::Mat* self) {
  for (const auto& [strip, bins] : g.own) {
    // A strip offset held constant absorbs nothing (nor do corrections without it).
    const bool estimated = cols.col.count(strip) > 0;
    std::vector<double> times, weights;
    for (const auto& [b, o] : bins) {
      times.push_back(static_cast<double>(b) * g.bin);
      weights.push_back(o.count);
    }
    // The offset is a random effect: of a strip-constant error it takes only what the data
    // resolve, κ = 1 − σ²_posterior / σ²_prior per axis (a strip whose few observations hardly
    // determine its offset keeps nearly all of its own error in their residuals).
    const auto v = offset_var.find(strip);
    Eigen::VectorXd share;
    double share_kappa = std::nan("");  // axes of one κ (every attitude axis: 1) share one computation
    for (int a = 0; a < 3; ++a) {
      const double kappa = !attitude && v != offset_var.end() && prior > 0 ? 1.0 - v->second(a) / prior : 1.0;
      if (!(kappa == share_kappa)) {
        share = detail::residualShare(times, weights, g.tau, estimated ? g.absorbed : std::vector<int>{}, kappa);
        share_kappa = kappa;
      }
      Eigen::Index i = 0;
      for (const auto& [b, o] : bins) *self += share(i++) * o.hch[static_cast<std::size_t>(a)];
    }
  }
}

/// Σ_u Σ_v exp(−|t_u − t_v| / τ) H_u C H_vᵀ over each strip's bins, added to `M`, by the
/// exponential kernel's recursion over the sorted bins:
/// T_u = Σ_{v<u} exp(−(t_u − t_v) / τ) H_v = exp(−(t_u − t_{u−1}) / τ) (T_{u−1} + H_{u−1}).
template <int Rows>
void addKernelSum(const TrajectoryGroup<Rows>& g, typename TrajectoryGroup<Rows>::Mat* M) {
  using Mat = typename TrajectoryGroup<Rows>::Mat;
  using Mat63 = typename TrajectoryGroup<Rows>::Mat63;
  const Eigen::DiagonalMatrix<double, 3> C(g.var);
  for (const auto& [strip, bins] : g.H) {
    (void)strip;
    Mat63 T = Mat63::Zero(M->rows(), 3);
    const Mat63* previous = nullptr;
    long long previous_bin = 0;
    for (const auto& [bin, H] : bins) {
      if (previous) T = std::exp(-static_cast<double>(bin - previous_bin) * g.bin / g.tau) * (T + *previous);
      const Mat cross = H * C * T.transpose();
      *M += H * C * H.transpose() + cross + cross.transpose();
      previous = &H;
      previous_bin = bin;
    }
  }
}

/// `N_red_out`, `X_out` (optional): the reduced system of the kept columns it worked with
/// (reducedSystem()'s N_red and X).
template <int Rows>
TrajectoryTerm<Rows> trajectoryErrorTerm(AdjustmentProblem& problem, const TrajectoryAccuracy& acc, bool attitude, int kept = 6,
                                         Eigen::MatrixXd* N_red_out = nullptr, Eigen::MatrixXd* X_out = nullptr) {
  using Mat = typename TrajectoryTerm<Rows>::Mat;
  Eigen::MatrixXd N_red, X;
  Eigen::VectorXd diag;
  Columns cols;
  // The offsets' posterior variances only where a kind's σ hold their own epochs' errors.
  bool any_in_sigma = false;
  for (const auto& rec : problem.records())
    for (const auto& e : rec.epochs) any_in_sigma = any_in_sigma || e.in_sigma;
  std::map<const double*, Vec3> offset_var;
  reducedSystem(problem, kept, &N_red, &diag, &X, &cols, any_in_sigma ? &offset_var : nullptr);
  if (N_red_out) *N_red_out = N_red;
  if (X_out) *X_out = X;
  using Mat63 = Eigen::Matrix<double, Rows, 3>;
  const Mat zero = Mat::Zero(kept, kept);
  const Mat63 zero3 = Mat63::Zero(kept, 3);
  using Group = TrajectoryGroup<Rows>;
  using Own = typename Group::Own;
  const double t = deg2rad(acc.roll_pitch_sigma_deg), k = deg2rad(acc.heading_sigma_deg), p = acc.position_sigma_m;
  // With a series, σ(t) scale each epoch's columns (H diag σ(t)) and the processes have unit variance.
  const TrajectoryAccuracySeries* series = acc.series && !acc.series->empty() ? acc.series.get() : nullptr;
  Group pos{
      acc.position_correlation_s, acc.position_correlation_s / 20.0, series ? Vec3(Vec3::Ones()) : Vec3(Vec3::Constant(p * p)), {}, {}, {}};
  Group att{
      acc.attitude_correlation_s, acc.attitude_correlation_s / 20.0, series ? Vec3(Vec3::Ones()) : Vec3(t * t, t * t, k * k), {}, {}, {}};
  // The GNSS solution's own slow error beside the drift: a position process of its own σ and τ
  // (never scaled by a series).
  const double g2 = acc.gnss_sigma_m * acc.gnss_sigma_m;
  Group gnss{acc.gnss_correlation_s, acc.gnss_correlation_s / 20.0, Vec3::Constant(g2), {}, {}, {}};
  const bool use_pos = series || p > 0, use_att = attitude && (series || t > 0 || k > 0), use_gnss = g2 > 0;
  TrajectoryTerm<Rows> out{zero, zero};
  if (!use_pos && !use_att && !use_gnss) return out;
  const TrajectoryCorrections& corr = problem.corrections();
  for (int d = 0; d <= corr.position_degree; ++d) pos.absorbed.push_back(d);
  for (int d = 1; d <= corr.attitude_degree; ++d) att.absorbed.push_back(d);
  gnss.absorbed = pos.absorbed;
  // The offsets' random effect that the formal covariance already counts, per strip: H̄ = Σ H of
  // its epochs (TrajectoryAccuracy::offsets_within_drift).
  const double offset_prior_var = problem.stripOffsetSigma() * problem.stripOffsetSigma();
  const bool within = acc.offsets_within_drift && (use_pos || use_gnss) && offset_prior_var > 0;
  std::map<const double*, Mat63> hbar;
  const double* m = problem.mounting();
  for (const auto& rec : problem.records()) {
    if (rec.epochs.empty()) continue;
    const std::vector<RowMat> J = blockJacobians(rec, cols);
    const Eigen::MatrixXd Jr = reducedJacobian(rec, J, cols, X, m, kept);  // Ĵ
    for (const auto& e : rec.epochs) {
      Mat63 hp = Jr.transpose() * J[static_cast<std::size_t>(e.block)];
      Mat63 ha = -hp * skew(e.u_m);  // ∂x/∂δψ = −[u]×
      if (within && cols.col.count(e.offset) > 0) hbar.try_emplace(e.offset, zero3).first->second += hp;
      Mat63 hg;  // the GNSS process's, unscaled: a copy only where a series scales hp
      if (use_gnss && series) hg = hp;
      const Mat63* hgp = series ? &hg : &hp;
      if (series) {
        Vec3 s_p, s_a;
        series->at(e.time_s, &s_p, &s_a);
        hp = hp * s_p.asDiagonal();
        ha = ha * s_a.asDiagonal();
      }
      for (auto [g, h, on] : {std::tuple<Group*, const Mat63*, bool>{&pos, &hp, use_pos}, {&att, &ha, use_att}, {&gnss, hgp, use_gnss}}) {
        if (!on) continue;
        const long long bin = std::llround(e.time_s / g->bin);
        g->H[e.offset].try_emplace(bin, zero3).first->second += *h;
        if (!e.in_sigma) continue;
        Own& o = g->own[e.offset].try_emplace(bin, Own{{zero, zero, zero}, 0.0}).first->second;
        for (int a = 0; a < 3; ++a) o.hch[static_cast<std::size_t>(a)] += g->var(a) * h->col(a) * h->col(a).transpose();
        o.count += 1;
      }
    }
  }
  for (const Group* g : {&pos, &att, &gnss}) {
    addOwnShare(*g, g == &att, cols, offset_var, offset_prior_var, &out.self);
    addKernelSum(*g, &out.M);
  }
  // Σ_strips H̄ σ_o² H̄ᵀ = Xᵀ P X: the strip-constant error the formal covariance holds as the
  // offsets' random effect, which the drift above holds too.
  for (const auto& [strip, h] : hbar) {
    (void)strip;
    out.M -= offset_prior_var * h * h.transpose();
  }
  out.M = 0.5 * (out.M + out.M.transpose());
  out.self = 0.5 * (out.self + out.self.transpose());
  return out;
}

/// What the estimated σ hold cannot exceed what they state: `self` scaled down, when needed,
/// so that self ≤ 0.9 N (N the reduced normal matrix of the estimated parameters) — the white
/// part left in every estimated σ at least a tenth of its variance.
template <typename Mat>
Mat boundedSelf(const Mat& self, const Mat& N, const std::vector<bool>& est) {
  std::vector<int> idx;
  for (std::size_t j = 0; j < est.size(); ++j)
    if (est[j]) idx.push_back(static_cast<int>(j));
  const Eigen::Index n = static_cast<Eigen::Index>(idx.size());
  if (n == 0) return self;
  Eigen::MatrixXd S(n, n), A(n, n);
  for (Eigen::Index a = 0; a < n; ++a)
    for (Eigen::Index b = 0; b < n; ++b) {
      S(a, b) = self(idx[static_cast<std::size_t>(a)], idx[static_cast<std::size_t>(b)]);
      A(a, b) = N(idx[static_cast<std::size_t>(a)], idx[static_cast<std::size_t>(b)]);
    }
  Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> ges(S, A);
  if (ges.info() != Eigen::Success) return self;
  const double lambda = ges.eigenvalues().maxCoeff();
  return lambda > 0.9 ? Mat(self * (0.9 / lambda)) : self;
}

/// The time offset δt beside the mounting: SPEC §2 eq. (1) at t + δt gives ∂x/∂δt = v + ω × u
/// (u the IMU → point vector in the mapping frame), through each epoch's strip-offset Jacobian.
/// Every nuisance block eliminated (Schur complement), the 7 × 7 reduced normal matrix of
/// (mounting, δt) and the reduced gradient Jᵀr at the current values. `any`: some epoch moves.
struct TimeOffsetSystem {
  Eigen::Matrix<double, 7, 7> N = Eigen::Matrix<double, 7, 7>::Zero();
  Eigen::Matrix<double, 7, 1> g = Eigen::Matrix<double, 7, 1>::Zero();
  bool any = false;
};

TimeOffsetSystem timeOffsetSystem(AdjustmentProblem& problem) {
  TimeOffsetSystem out;
  const Columns cols = columnsOf(problem);
  const int n = cols.n + 1;  // 0–5 mounting, 6 δt, 7… the nuisance (Columns' index + 1)
  std::vector<Eigen::Triplet<double>> trip;
  std::vector<double> res;
  int row = 0;
  const double* m = problem.mounting();
  for (int index = 0; index < problem.residualBlockCount(); ++index) {
    const auto& rec = problem.records()[static_cast<std::size_t>(index)];
    const int nr = rec.cost->num_residuals();
    const std::vector<RowMat> J = blockJacobians(rec, cols);
    Eigen::VectorXd jt = Eigen::VectorXd::Zero(nr);
    for (const auto& e : rec.epochs) {
      if (!e.moving) continue;
      jt += J[static_cast<std::size_t>(e.block)] * (e.velocity_m_s + e.rate_rad_s.cross(e.u_m));
      out.any = true;
    }
    addTriplets(rec, J, cols, m, row, 1, &trip);
    for (int i = 0; i < nr; ++i)
      if (jt[i] != 0.0) trip.emplace_back(row + i, 6, jt[i]);
    const Eigen::VectorXd r = problem.residual(index);
    res.insert(res.end(), r.data(), r.data() + nr);
    row += nr;
  }
  if (!out.any) return out;
  Eigen::SparseMatrix<double> Js(row, n);
  Js.setFromTriplets(trip.begin(), trip.end());
  const Eigen::SparseMatrix<double> Jt_s = Js.transpose();
  const Eigen::SparseMatrix<double> N = Jt_s * Js;
  const Eigen::VectorXd g = Jt_s * Eigen::Map<const Eigen::VectorXd>(res.data(), row);
  out.N = Eigen::MatrixXd(N.topLeftCorner(7, 7));
  out.g = g.head(7);
  if (n == 7) return out;
  const Eigen::SparseMatrix<double> Nnn = N.bottomRightCorner(n - 7, n - 7);
  Eigen::MatrixXd rhs(n - 7, 8);
  rhs.leftCols(7) = Eigen::MatrixXd(N.bottomLeftCorner(n - 7, 7));
  rhs.col(7) = g.tail(n - 7);
  Eigen::SparseMatrix<double> R = Nnn;  // regularised as reducedNormalMatrix does, for a free nuisance direction
  const double eps = 1e-12 * std::max(1.0, Eigen::VectorXd(Nnn.diagonal()).cwiseAbs().maxCoeff());
  for (int i = 0; i < n - 7; ++i) R.coeffRef(i, i) += eps;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(R);
  const Eigen::MatrixXd X = ldlt.solve(rhs);
  if (ldlt.info() != Eigen::Success || !X.allFinite()) {
    out.any = false;
    return out;
  }
  out.N -= rhs.leftCols(7).transpose() * X.leftCols(7);
  out.N = 0.5 * (out.N + out.N.transpose()).eval();
  out.g -= rhs.leftCols(7).transpose() * X.col(7);
  return out;
}

/// The (pseudo-)inverse of the estimated parameters' block of a normal matrix, placed back at
/// their indices (zero elsewhere).
Eigen::MatrixXd inverseOnEstimated(const Eigen::MatrixXd& N, const std::vector<bool>& est) {
  std::vector<int> idx;
  for (std::size_t j = 0; j < est.size(); ++j)
    if (est[j]) idx.push_back(static_cast<int>(j));
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(N.rows(), N.cols());
  if (idx.empty()) return out;
  Eigen::MatrixXd Nn(idx.size(), idx.size());
  for (std::size_t a = 0; a < idx.size(); ++a)
    for (std::size_t b = 0; b < idx.size(); ++b) Nn(a, b) = N(idx[a], idx[b]);
  const Eigen::MatrixXd inv = Nn.completeOrthogonalDecomposition().pseudoInverse();
  for (std::size_t a = 0; a < idx.size(); ++a)
    for (std::size_t b = 0; b < idx.size(); ++b) out(idx[a], idx[b]) = inv(a, b);
  return out;
}

Mat6 inverseOnEstimated(const Mat6& N, const std::array<bool, 6>& est) {
  return inverseOnEstimated(Eigen::MatrixXd(N), std::vector<bool>(est.begin(), est.end()));
}

/// A σ for the report: [m] or [deg] as given, three significant digits.
std::string fmtSigma(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

std::string fmtParam(int j, double v) {
  char buf[64];
  if (j < 3)
    std::snprintf(buf, sizeof buf, "%+.4f m", v);
  else
    std::snprintf(buf, sizeof buf, "%+.5f°", rad2deg(v));
  return buf;
}

}  // namespace

namespace {

/// One solve of MountingAdjustment, in steps: build the problem at a mounting, solve and
/// re-match until the mounting settles (estimate), find what the data cannot determine
/// (holdUndeterminable), then σ₀², covariance and the per-kind counts (analyse).
class Estimation {
 public:
  Estimation(const MountingAdjustment::Options& options, const MotionFunction& motion, const MountingParameters& mounting_used,
             const std::vector<ObservationSource*>& sources, const std::array<double, 6>* start, AdjustmentSummary* summary)
      : o_(options),
        motion_(motion),
        sources_(sources),
        start_(start),
        m0_(mounting_used.toArray()),
        S_(*summary),
        t_start_(std::chrono::steady_clock::now()) {
    for (ObservationSource* s : sources_) any_rematch_ |= s->rematches();
  }
  double elapsed() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start_).count(); }
  AdjustmentProblem& problem() { return *P_; }

  /// Starting values: the used mounting, or the caller's start for the estimated parameters.
  std::array<double, 6> initial(const std::array<bool, 6>& est) const {
    std::array<double, 6> m = m0_;
    if (start_)
      for (int j = 0; j < 6; ++j)
        if (est[j] && std::isfinite((*start_)[j])) m[j] = (*start_)[j];
    return m;
  }

  /// One estimation: build the problem at the current mounting, solve, and — for matching
  /// sources — re-match and solve again until the mounting stops changing. False when no
  /// source has an observation.
  bool estimate(const std::array<bool, 6>& est, const std::array<double, 6>& m) {
    S_.rematch_rounds = 0;
    S_.boresight_first_restart = false;
    if (!stages(est, m, false)) return false;
    // A matching source's first matches at a mounting far from the truth are biased, and a lever
    // arm that the data see only weakly (level patches: through the aircraft's attitude changes)
    // can take up what the boresight should and stay at a self-consistent matching far from the
    // truth (planes "auto" from a boresight 0.4° off: 5 m, at 57σ). When the lever arm has moved
    // further than a mounting is mis-measured (AnalysisOptions::lever_arm_change_warning_m), the
    // estimation starts again with the boresight first: it settles with the lever arm held at its
    // start, then the lever arm joins.
    if (!any_rematch_ || !(est[kLeverX] || est[kLeverY] || est[kLeverZ]) ||
        !(est[kBoresightRoll] || est[kBoresightPitch] || est[kBoresightHeading]))
      return true;
    const std::array<double, 6> first = P_->mountingValues();
    double moved = 0.0;
    for (int j : {kLeverX, kLeverY, kLeverZ})
      if (est[j]) moved = std::max(moved, std::abs(first[j] - m[j]));
    if (!(moved > o_.lever_arm_change_warning_m)) return true;
    S_.boresight_first_restart = true;  // rematch_rounds counts on: the first run's solves were made
    return stages(est, m, true);
  }

  /// estimate()'s stages from m: with `boresight_first`, the boresight alone (the lever arm held
  /// at m); then, with trajectory corrections or an estimated time offset, everything but them
  /// (a matching source matches at the mounting alone: from an a-priori mounting its first
  /// matches are biased, and per-strip corrections in time — many weakly determined directions —
  /// would follow them); then everything.
  bool stages(const std::array<bool, 6>& est, std::array<double, 6> m, bool boresight_first) {
    const bool staged = any_rematch_ && (o_.corrections.any() || o_.estimate_time_offset);
    if (boresight_first) {
      std::array<bool, 6> boresight = est;
      boresight[kLeverX] = boresight[kLeverY] = boresight[kLeverZ] = false;
      without_corrections_ = staged;
      const bool ok = rematchLoop(boresight, m);
      without_corrections_ = false;
      if (!ok) return false;
      m = P_->mountingValues();
    }
    if (staged) {
      without_corrections_ = true;
      const bool ok = rematchLoop(est, m);
      without_corrections_ = false;
      if (!ok) return false;
      m = P_->mountingValues();
    }
    return rematchLoop(est, m);
  }

  bool rematchLoop(const std::array<bool, 6>& est, std::array<double, 6> m) {
    std::vector<std::array<double, 6>> history;  // the mountings each round started from
    for (int round = 0; round < o_.max_rematch_rounds; ++round) {
      if (!buildProblem(est, m)) return false;
      double t_mark = elapsed();
      ceres::Solver::Options so = solverOptions();
      ceres::Solve(so, &P_->ceresProblem(), &cs_);
      afterSolve(t_mark);
      ++S_.rematch_rounds;
      const std::array<double, 6> m_new = P_->mountingValues();
      const double change = rematchChange(est, m, m_new, history);
      bool settled = true;
      for (ObservationSource* s : sources_) settled &= s->settled();
      if (!settled)
        history.clear();  // a coarse stage's fixed points are not the fine stage's
      else
        history.push_back(m);
      m = m_new;
      const bool done = !any_rematch_ || (change < 1.0 && settled);
      if ((done || round + 1 >= o_.max_rematch_rounds) && capped() && cs_.termination_type == ceres::NO_CONVERGENCE) {
        t_mark = elapsed();
        so.max_num_iterations = o_.max_iterations;  // the estimate's last solve: to convergence
        ceres::Solve(so, &P_->ceresProblem(), &cs_);
        afterSolve(t_mark);
      }
      if (done) break;
    }
    return true;
  }

  /// The mounting's reduced normal matrix at the current values (reducedNormalMatrix()), its X
  /// and columns kept for the start-σ check of the covariance that follows.
  void reducedNormal(Mat6* N_red, Vec6* diag) { reducedNormalMatrix(*P_, N_red, diag, &reduced_X_, &reduced_cols_); }

  /// Observability (SPEC §3 step 5) by an absolute rule: while an estimated parameter's
  /// marginal σ exceeds its physical bound (AnalysisOptions), hold the most undetermined one
  /// (named in the summary with its σ and what it cannot be separated from). True when
  /// something was held.
  bool holdUndeterminable(std::array<bool, 6>* est, Mat6* N_red, Vec6* diag) {
    reducedNormal(N_red, diag);
    bool refixed = false;
    for (int pass = 0; pass < 6; ++pass) {
      const MarginalSigmas ms = marginalSigmas(*N_red, *est);
      if (ms.idx.empty()) break;
      S_.condition_number = ms.condition_number;
      int pick = -1;
      double worst = 1.0;
      for (std::size_t a = 0; a < ms.idx.size(); ++a) {
        if (ms.ratio[a] > worst) {
          worst = ms.ratio[a];
          pick = ms.idx[a];
        }
      }
      if (pick < 0) break;
      reportHeld(pick, ms);
      (*est)[pick] = false;
      refixed = true;
    }
    return refixed;
  }

  /// Each estimated parameter's marginal σ against its bound, from the eigen-decomposition of
  /// the bound-scaled reduced normal matrix (directions below rank_tolerance: infinite σ).
  struct MarginalSigmas {
    std::vector<int> idx;
    std::vector<double> ratio;      // σ / bound (infinite along a rank deficiency)
    Eigen::VectorXd weakest;        // the weakest scaled direction over idx
    double condition_number = 0.0;  // of the correlation-scaled block
  };
  MarginalSigmas marginalSigmas(const Mat6& N, const std::array<bool, 6>& est) const {
    MarginalSigmas out;
    for (int j = 0; j < 6; ++j)
      if (est[j]) out.idx.push_back(j);
    const int n = static_cast<int>(out.idx.size());
    if (n == 0) return out;
    auto bound = [&](int j) { return j < 3 ? o_.undeterminable_sigma_m : deg2rad(o_.undeterminable_sigma_deg); };
    Eigen::MatrixXd Ns(n, n), Nc(n, n);
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        const int i = out.idx[a], k = out.idx[b];
        Ns(a, b) = N(i, k) * bound(i) * bound(k);
        Nc(a, b) = N(i, k) / std::sqrt(std::max(N(i, i), 1e-300) * std::max(N(k, k), 1e-300));
      }
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Ns);
    const double lmax = std::max(eig.eigenvalues()(n - 1), 0.0);
    out.ratio.assign(out.idx.size(), 0.0);
    for (int k = 0; k < n; ++k) {
      const double l = eig.eigenvalues()(k);
      const bool deficient = !(l > o_.rank_tolerance * lmax) || lmax == 0.0;
      for (int a = 0; a < n; ++a) {
        const double v2 = eig.eigenvectors()(a, k) * eig.eigenvectors()(a, k);
        if (deficient && v2 > 1e-6)
          out.ratio[static_cast<std::size_t>(a)] = std::numeric_limits<double>::infinity();
        else if (!deficient)
          out.ratio[static_cast<std::size_t>(a)] += v2 / l;  // squared, until the square root below
      }
    }
    for (double& r : out.ratio) r = std::sqrt(r);
    out.weakest = eig.eigenvectors().col(0);
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig_c(Nc, Eigen::EigenvaluesOnly);
    const double cmin = eig_c.eigenvalues()(0), cmax = eig_c.eigenvalues()(n - 1);
    out.condition_number = cmin > 0 ? cmax / cmin : std::numeric_limits<double>::infinity();
    return out;
  }

  /// The summary's account of a held parameter: its σ against the bound, the parameters of its
  /// weak direction, and (Summary::held_sensitivity) how far each other estimated parameter
  /// moves per unit error of the held value: −N_ee⁻¹ N_eh.
  void reportHeld(int pick, const MarginalSigmas& ms) {
    const auto& names = mountingParameterNames();
    S_.unobservable.push_back(names[pick]);
    std::size_t at = 0;
    while (ms.idx[at] != pick) ++at;
    const double bound = pick < 3 ? o_.undeterminable_sigma_m : o_.undeterminable_sigma_deg;
    const char* unit = pick < 3 ? " m" : "°";
    report_ << names[pick] << " cannot be determined from these observations (";
    if (std::isfinite(ms.ratio[at]))
      report_ << "its σ would be " << fmtSigma(ms.ratio[at] * bound) << unit << ", beyond the bound of " << bound << unit;
    else
      report_ << "no observation fixes it once the tie positions, planes and strip offsets are eliminated";
    report_ << ")";
    std::vector<int> group;
    for (std::size_t a = 0; a < ms.idx.size(); ++a)
      if (std::abs(ms.weakest[static_cast<int>(a)]) > 0.3 && ms.idx[a] != pick) group.push_back(ms.idx[a]);
    if (!group.empty()) {
      report_ << "; it cannot be separated from";
      for (int g : group) report_ << " " << names[g];
    }
    report_ << "; held at its used value " << fmtParam(pick, m0_[pick]) << ".\n";
  }

  /// Summary::held_sensitivity at the final estimate: each estimated parameter's shift per
  /// unit error of each held or fixed one, −N_ee⁻¹ N_eh (exact for the linearised problem), and
  /// a line of the report per held or fixed parameter with the shifts a 1 cm / 0.01° error causes.
  void heldSensitivity(const Mat6& N, const std::array<bool, 6>& est) {
    const auto& names = mountingParameterNames();
    const Mat6 C = inverseOnEstimated(N, est);
    for (int h = 0; h < 6; ++h) {
      if (est[h]) continue;
      const bool rule = std::find(S_.unobservable.begin(), S_.unobservable.end(), names[h]) != S_.unobservable.end();
      const std::string held = std::string(rule ? "held " : "fixed ") + names[h];
      Vec6 shift = Vec6::Zero();
      for (int e = 0; e < 6; ++e)
        if (est[e])
          for (int k = 0; k < 6; ++k)
            if (est[k]) shift[e] -= C(e, k) * N(k, h);
      S_.held_sensitivity.col(h) = shift;
      const double unit_error = h < 3 ? 0.01 : deg2rad(0.01);
      bool first = true;
      for (int e = 0; e < 6; ++e) {
        if (!est[e] || std::abs(shift[e] * unit_error) < (e < 3 ? 1e-4 : deg2rad(1e-5))) continue;
        report_ << (first ? std::string(h < 3 ? "A 1 cm error in the " : "A 0.01° error in the ") + held + " moves " : ", ") << names[e]
                << " by " << fmtParam(e, shift[e] * unit_error);
        first = false;
      }
      if (!first) report_ << " (not in their σ).\n";
    }
  }

  /// σ₀², degrees of freedom, covariance and correlations, the per-kind counts and strip
  /// offsets, and each source's residual section.
  void analyse(const std::array<bool, 6>& est, const Mat6& N_red, const MountingParameters& mounting_used) {
    S_.reduced_normal_matrix = N_red;
    heldSensitivity(N_red, est);
    S_.observability_report = report_.str();
    S_.estimated = est;
    S_.iterations = iterations_;
    S_.final_cost = cs_.final_cost;
    const std::array<double, 6> m = P_->mountingValues();
    S_.mounting = mounting_used.withArray(m.data());
    switch (cs_.termination_type) {
      case ceres::CONVERGENCE:
      case ceres::USER_SUCCESS:
        S_.termination = TerminationType::kConvergence;
        break;
      case ceres::NO_CONVERGENCE:
        S_.termination = TerminationType::kNoConvergence;
        break;
      default:
        S_.termination = TerminationType::kFailure;
        break;
    }
    S_.message = cs_.message;
    varianceFactor(est);
    covariance(est, N_red);
    modelSensitivity(est, N_red);
    timeOffset(est);
    trajectoryCorrections(est);
    for (std::size_t k = 0; k < sources_.size(); ++k) {
      S_.kinds.push_back({sources_[k]->kind(), 0, 0, kind_variance_factor_[k], kind_scale_[k]});
    }
    for (const auto& r : P_->records()) {
      if (r.source < 0) continue;
      auto& kc = S_.kinds[static_cast<std::size_t>(r.source)];
      ++kc.blocks;
      kc.residuals += r.cost->num_residuals();
    }
    for (const auto& [id, o3] : P_->stripOffsets()) S_.strip_offsets_m.emplace_back(id, Vec3(o3[0], o3[1], o3[2]));
    for (ObservationSource* s : sources_) s->finish(m0_, m, *P_, o_);
  }

 private:
  /// A fresh problem at mounting `m` with every source's blocks, the priors and the held
  /// parameters. False when no source added an observation.
  bool buildProblem(const std::array<bool, 6>& est, const std::array<double, 6>& m) {
    const double t_mark = elapsed();
    P_ = std::make_unique<AdjustmentProblem>(m, o_.strip_offset_sigma_m, o_.loss, o_.loss_scale_m, o_.numeric_diff_relative_step);
    P_->setPulseNoise(o_.pulse_noise);
    if (o_.time_offset_sigma_s > 0) P_->setMotion(motion_);
    if (!without_corrections_) P_->setCorrections(o_.corrections, o_.estimate_time_offset ? o_.time_offset_sigma_s : 0.0, o_.trajectory);
    for (std::size_t k = 0; k < sources_.size(); ++k) {
      P_->setSource(static_cast<int>(k));
      sources_[k]->addBlocks(m, P_.get());
    }
    P_->setSource(-1);
    P_->addRandomEffectPriors();
    S_.construction_time_s += elapsed() - t_mark;
    int observations = 0;
    for (const auto& r : P_->records()) observations += r.source >= 0;
    if (observations == 0) return false;
    ceres::Problem& problem = P_->ceresProblem();
    if (!problem.HasParameterBlock(P_->mounting())) problem.AddParameterBlock(P_->mounting(), 6);
    for (int j = 0; j < 6; ++j)
      if (est[j] && priorOn(o_, j)) P_->addResidualBlock(new MountingPrior(j, o_.prior_value[j], o_.prior_sigma[j]), 0.0, {P_->mounting()});
    P_->setEstimated(est);
    std::vector<int> fixed;
    for (int j = 0; j < 6; ++j)
      if (!est[j]) fixed.push_back(j);
    if (fixed.size() == 6)
      problem.SetParameterBlockConstant(P_->mounting());
    else if (!fixed.empty())
      problem.SetManifold(P_->mounting(), new ceres::SubsetManifold(6, fixed));
    P_->commit();
    return true;
  }

  /// With re-matching sources and max_iterations_per_matching: solves between matchings are capped.
  bool capped() const { return any_rematch_ && o_.max_iterations_per_matching > 0 && o_.max_iterations_per_matching < o_.max_iterations; }

  /// Levenberg–Marquardt; the eliminable nuisance blocks (tie positions, planes) first in a
  /// Schur ordering, then strip offsets and the mounting.
  ceres::Solver::Options solverOptions() const {
    ceres::Solver::Options so;
    so.minimizer_type = ceres::TRUST_REGION;
    so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    bool any_e = false;
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    for (const auto& b : P_->nuisanceBlocks()) {
      if (b.eliminable) {
        ordering->AddElementToGroup(b.values, 0);  // eliminated first
        any_e = true;
      } else {
        ordering->AddElementToGroup(b.values, 1);
      }
    }
    for (auto& entry : P_->stripOffsets()) ordering->AddElementToGroup(entry.second, 1);
    ordering->AddElementToGroup(P_->mounting(), 1);
    // The blocks that are not eliminated first: dense while few (the mounting and the strip
    // offsets), sparse once per-strip trajectory corrections make them many (each observation
    // holds the blocks of its one or two strips only). The largest block is not counted: one
    // block that every observation holds (the per-laser intrinsics) fills the normal equations
    // whatever its size, and a sparse solver only adds its bookkeeping (Ceres' inner products
    // were 17 % of the ten-seed laser test).
    int kept = 6 + 3 * static_cast<int>(P_->stripOffsets().size()), largest = 6;
    for (const auto& b : P_->nuisanceBlocks())
      if (!b.eliminable) kept += b.size, largest = std::max(largest, b.size);
    const bool sparse = kept - largest > 120 && (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE) ||
                                                 ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::EIGEN_SPARSE));
    if (any_e) {
      so.linear_solver_type = sparse ? ceres::SPARSE_SCHUR : ceres::DENSE_SCHUR;
      so.linear_solver_ordering = ordering;
    } else {
      so.linear_solver_type = sparse ? ceres::SPARSE_NORMAL_CHOLESKY : ceres::DENSE_QR;
    }
    // Eigen's sparse Cholesky for the same reason as the covariance's QR (covariance()): no BLAS
    // whose rounding follows the heap; the trajectory tests' times are unchanged by it.
    if (sparse && ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::EIGEN_SPARSE))
      so.sparse_linear_algebra_library_type = ceres::EIGEN_SPARSE;
    so.max_num_iterations = capped() ? o_.max_iterations_per_matching : o_.max_iterations;
    so.function_tolerance = o_.function_tolerance;
    so.parameter_tolerance = o_.parameter_tolerance;
    so.gradient_tolerance = o_.gradient_tolerance;
    so.max_solver_time_in_seconds = o_.max_solver_time_s;
    so.num_threads = o_.num_threads;
    so.logging_type = ceres::SILENT;
    so.minimizer_progress_to_stdout = false;
    return so;
  }

  void afterSolve(double t_mark) {
    for (ObservationSource* s : sources_) s->solved(*P_);
    S_.solve_time_s += elapsed() - t_mark;
    if (first_) {
      S_.initial_cost = cs_.initial_cost;
      first_ = false;
    }
    iterations_ += static_cast<int>(cs_.iterations.size()) - 1;
  }

  /// How far the mounting moved in this round, in units of its tolerance: a parameter's
  /// tolerance is the larger of the fixed one and a fraction of its σ (a re-matching moves the
  /// estimate by a small part of its uncertainty as the matched points change; chasing that is
  /// pointless). Back where an earlier round ended is a fixed point too (a matching can flip
  /// between two sets of matches): 0.
  double rematchChange(const std::array<bool, 6>& est, const std::array<double, 6>& m, const std::array<double, 6>& m_new,
                       const std::vector<std::array<double, 6>>& history) const {
    std::array<double, 6> sigma_now;
    sigma_now.fill(0.0);
    if (any_rematch_) {
      Mat6 N;
      Vec6 dg;
      reducedNormalMatrix(*P_, &N, &dg);
      const Mat6 C = inverseOnEstimated(N, est);
      for (int j = 0; j < 6; ++j) sigma_now[j] = est[j] ? std::sqrt(std::max(C(j, j), 0.0)) : 0.0;
    }
    auto changeFrom = [&](const std::array<double, 6>& prev) {
      double change = 0;
      for (int j = 0; j < 6; ++j) {
        const double tol = std::max(j < 3 ? o_.rematch_tolerance_m : o_.rematch_tolerance_rad, o_.rematch_sigma_fraction * sigma_now[j]);
        change = std::max(change, std::abs(m_new[j] - prev[j]) / tol);
      }
      return change;
    };
    double change = changeFrom(m);
    for (const auto& earlier : history)
      if (changeFrom(earlier) < 1.0) change = 0.0;
    return change;
  }

  void varianceFactor(const std::array<bool, 6>& est) {
    int n_res = 0, n_unknowns = 0;
    for (const auto& r : P_->records()) n_res += r.cost->num_residuals();
    for (int j = 0; j < 6; ++j) n_unknowns += est[j];
    for (const auto& b : P_->nuisanceBlocks()) n_unknowns += b.manifold ? b.manifold->TangentSize() : b.size;
    if (P_->stripOffsetSigma() > 0) n_unknowns += 3 * static_cast<int>(P_->stripOffsets().size());
    S_.degrees_of_freedom = n_res - n_unknowns;
    n_residuals_ = n_res;
    n_unknowns_ = n_unknowns;
    S_.variance_factor = S_.degrees_of_freedom > 0 ? 2.0 * cs_.final_cost / S_.degrees_of_freedom : 1.0;
  }

  /// The mounting's covariance from ceres::Covariance, or from the reduced normal matrix when
  /// Ceres cannot compute it (the same marginal covariance in exact arithmetic).
  void covariance(const std::array<bool, 6>& est, const Mat6& N_red) {
    const double scale = o_.scale_covariance_by_variance_factor && S_.degrees_of_freedom > 0 ? S_.variance_factor : 1.0;
    std::map<const double*, Eigen::MatrixXd> reported_formal;  // reportedFormal(): mounting, then the block
    Mat6 cov = Mat6::Constant(std::nan(""));
    int n_est = 0;
    for (bool e : est) n_est += e;
    if (n_est > 0) {
      ceres::Covariance::Options co;
      co.algorithm_type = ceres::SPARSE_QR;
      // Eigen's sparse QR, not SuiteSparseQR: SuiteSparse passes its fronts to the system BLAS,
      // and Debian's ATLAS rounds a product differently with the alignment of the matrices it is
      // given — heap state: the same job gave other last digits of every σ in the second call of a
      // Python process, or with another environment's size (scripts/experiments/laser-sigma/README.md).
      // Eigen's has no BLAS under it; the suite's times (tests/costs) did not change with it.
      co.sparse_linear_algebra_library_type = ceres::EIGEN_SPARSE;
      co.num_threads = o_.num_threads;
      ceres::Covariance covariance(co);
      double* mb = P_->mounting();
      std::vector<std::pair<const double*, const double*>> blocks{{mb, mb}};
      const std::vector<const double*> extra = estimatedNuisance();
      for (std::size_t a = 0; a < extra.size(); ++a) {
        blocks.emplace_back(mb, extra[a]);
        for (std::size_t b = a; b < extra.size(); ++b) blocks.emplace_back(extra[a], extra[b]);
      }
      const std::vector<const double*> reported = variableReported();
      for (const double* r : reported) blocks.emplace_back(mb, r), blocks.emplace_back(r, r);
      Eigen::Matrix<double, 6, 6, Eigen::RowMajor> c;
      if (covariance.Compute(blocks, &P_->ceresProblem()) && covariance.GetCovarianceBlock(mb, mb, c.data())) {
        cov = c * scale;
        S_.covariance_source = "ceres::Covariance";
        nuisanceCovariance(covariance, extra, scale);
        reported_formal = reportedFormal(covariance, reported, scale);
      } else {
        const Mat6 inv = inverseOnEstimated(N_red, est);
        for (int a = 0; a < 6; ++a)
          for (int b = 0; b < 6; ++b)
            if (est[a] && est[b]) cov(a, b) = inv(a, b) * scale;
        S_.covariance_source = "reduced normal matrix";
      }
    }
    for (int j = 0; j < 6; ++j) S_.formal_sigma[j] = est[j] ? std::sqrt(std::max(cov(j, j), 0.0)) : std::nan("");
    S_.sigma_model = "formal";
    startSigmaScales();
    const bool start_check = n_est > 0 && any_start_scaled_;
    if (n_est > 0 && o_.trajectory.any()) {
      // TrajectoryAccuracy: C = N⁻¹ + N⁻¹ M N⁻¹ (consider parameters), on the estimated block.
      const TrajectoryTerm<6> term = trajectoryErrorTerm<6>(*P_, o_.trajectory, !o_.pulse_noise.attitudeRandomEffect());
      const Mat6 Pinv = inverseOnEstimated(N_red, est);
      const Mat6 extra = Pinv * (term.M - boundedSelf(term.self, N_red, std::vector<bool>(est.begin(), est.end()))) * Pinv;
      if (extra.allFinite() && extra.norm() > 0) {
        for (int a = 0; a < 6; ++a)
          for (int b = 0; b < 6; ++b)
            if (est[a] && est[b]) cov(a, b) += extra(a, b);
        S_.sigma_model = "formal + trajectory errors in time";
        if (o_.trajectory.series && !o_.trajectory.series->empty()) S_.sigma_model += " (their σ along time as the trajectory states them)";
      }
    }
    if (start_check) {
      // Kinds whose σ came from the start and whose residuals scatter less: the sandwich
      // (startSigmaCorrection) on the formal part; the formal σ stay as they were. X and the
      // columns: the reduced system that gave N_red (reducedNormal()).
      const Mat6 Pinv = inverseOnEstimated(N_red, est);
      const Mat6 less = Pinv * Mat6(startSigmaCorrection(*P_, 6, reduced_X_, reduced_cols_, record_scale_, record_robust_)) * Pinv;
      for (int a = 0; a < 6; ++a)
        for (int b = 0; b < 6; ++b)
          if (est[a] && est[b]) cov(a, b) -= scale * less(a, b);
    }
    if (n_est > 0 && o_.time_offset_sigma_s > 0 && !o_.estimate_time_offset) {
      // The time offset as a consider parameter: the mounting moves by s = −N⁻¹ n_mt per second.
      time_ = timeOffsetSystem(*P_);
      if (time_.any) {
        const Vec6 shift = -inverseOnEstimated(N_red, est) * time_.N.block<6, 1>(0, 6);
        const double var = o_.time_offset_sigma_s * o_.time_offset_sigma_s;
        for (int a = 0; a < 6; ++a)
          for (int b = 0; b < 6; ++b)
            if (est[a] && est[b]) cov(a, b) += shift[a] * shift[b] * var;
        S_.sigma_model += " + time offset";
      }
    }
    if (n_est > 0 && any_start_scaled_) S_.sigma_model += startSigmaLabel();
    for (int a = 0; a < 6; ++a)
      for (int b = 0; b < 6; ++b) S_.covariance(a, b) = (est[a] && est[b]) ? cov(a, b) : std::nan("");
    for (int j = 0; j < 6; ++j) S_.sigma[j] = est[j] ? std::sqrt(std::max(cov(j, j), 0.0)) : std::nan("");
    for (int a = 0; a < 6; ++a)
      for (int b = 0; b < 6; ++b) S_.correlation(a, b) = (est[a] && est[b]) ? cov(a, b) / (S_.sigma[a] * S_.sigma[b]) : std::nan("");
    reportedCovariances(est, scale, reported_formal);
  }

  /// Each source's own σ₀² where its σ came from the start (ObservationSource::sigmaFromStart):
  /// Σ ρ(r²) over its observations (the blocks with a σ; its priors not) over their redundancy,
  /// their residuals less their share of the unknowns — and per record the factor of its share
  /// in the covariance: that σ₀² where it is below ½, not below (floor/σ)²; 1 elsewhere. With the
  /// loss's weight ρ′ at each residual.
  void startSigmaScales() {
    const auto& recs = P_->records();
    record_scale_.assign(recs.size(), 1.0);
    record_robust_.assign(recs.size(), 1.0);
    kind_variance_factor_.assign(sources_.size(), std::nan(""));
    kind_scale_.assign(sources_.size(), 1.0);
    any_start_scaled_ = false;
    std::vector<ObservationSource::StartSigma> start(sources_.size());
    for (std::size_t k = 0; k < sources_.size(); ++k) start[k] = sources_[k]->sigmaFromStart();
    std::vector<double> sum(sources_.size(), 0.0), count(sources_.size(), 0.0);
    auto eligible = [&start](const AdjustmentProblem::Record& r) {
      return r.source >= 0 && r.loss_sigma_m > 0 && start[static_cast<std::size_t>(r.source)].sigma_m > 0;
    };
    const double n_all = n_residuals_;  // varianceFactor()'s count
    for (std::size_t i = 0; i < recs.size(); ++i) {
      const auto& r = recs[i];
      if (!eligible(r)) continue;
      const double sq = P_->residual(static_cast<int>(i)).squaredNorm();
      double rho[3] = {sq, 1.0, 0.0};
      if (r.loss) r.loss->Evaluate(sq, rho);
      record_robust_[i] = rho[1];
      sum[static_cast<std::size_t>(r.source)] += rho[0];
      count[static_cast<std::size_t>(r.source)] += r.cost->num_residuals();
    }
    const double unknowns = n_unknowns_;
    for (std::size_t k = 0; k < sources_.size(); ++k) {
      const double redundancy = count[k] - (n_all > 0 ? unknowns * count[k] / n_all : 0.0);
      if (count[k] > 0 && redundancy > 0) kind_variance_factor_[k] = sum[k] / redundancy;
      const double vf = kind_variance_factor_[k], least = start[k].floor_m / start[k].sigma_m;
      if (vf < kStartSigmaCheck) kind_scale_[k] = std::min(1.0, std::max(vf, least * least));
    }
    // A covariance scaled by the whole σ₀² already takes every kind's scatter.
    if (o_.scale_covariance_by_variance_factor) std::fill(kind_scale_.begin(), kind_scale_.end(), 1.0);
    for (std::size_t i = 0; i < recs.size(); ++i) {
      if (!eligible(recs[i])) continue;
      record_scale_[i] = kind_scale_[static_cast<std::size_t>(recs[i].source)];
      any_start_scaled_ = any_start_scaled_ || record_scale_[i] < 1.0;
    }
  }

  /// The σ model's note of the kinds whose σ startSigmaScales() took from their residuals.
  std::string startSigmaLabel() const {
    std::string out;
    for (std::size_t k = 0; k < sources_.size(); ++k) {
      if (!(kind_scale_[k] < 1.0)) continue;
      char buf[160];
      std::snprintf(buf, sizeof buf, "%s%s σ₀² %.3g", out.empty() ? "" : ", ", sources_[k]->kind().c_str(), kind_variance_factor_[k]);
      out += buf;
    }
    return out.empty() ? out : " (σ of a distance from the residuals at the solution: " + out + ")";
  }

  /// The mounting's first-order move when a free lever arm (estimated, no prior) is held at its
  /// used value instead: the boresight re-solved, −N_bb⁻¹ N_ba (a_used − â), against the σ the
  /// held model states (conditional on the lever arm).
  void modelSensitivity(const std::array<bool, 6>& est, const Mat6& N_red) {
    std::array<bool, 6> rest = est;
    std::vector<int> free_lever;
    for (int j = 0; j < 3; ++j)
      if (est[j] && !priorOn(o_, j)) {
        free_lever.push_back(j);
        rest[j] = false;
      }
    bool others = false;
    for (bool r : rest) others |= r;
    if (free_lever.empty() || !others) return;
    const std::array<double, 6> m = P_->mountingValues();
    Vec6 delta = Vec6::Zero();  // a_used − â on the free lever arm
    for (int j : free_lever) delta[j] = m0_[static_cast<std::size_t>(j)] - m[static_cast<std::size_t>(j)];
    const Mat6 C = inverseOnEstimated(N_red, rest);
    const Vec6 shift = -C * (N_red * delta);
    // The σ the held model states: conditional on the lever arm, Σ_bb − Σ_ba Σ_aa⁻¹ Σ_ab — the
    // smaller of the two models' σ, so that "moves by k σ" is against what either one claims.
    const int nl = static_cast<int>(free_lever.size());
    Eigen::MatrixXd Saa(nl, nl);
    for (int a = 0; a < nl; ++a)
      for (int b = 0; b < nl; ++b) Saa(a, b) = S_.covariance(free_lever[a], free_lever[b]);
    const Eigen::MatrixXd Saa_inv = Saa.completeOrthogonalDecomposition().pseudoInverse();
    AdjustmentSummary::ModelSensitivity ms;
    ms.change = "the lever arm held at its used value";
    ms.part = AdjustmentSummary::ModelSensitivity::Part::kLeverArm;
    for (int j : free_lever)
      if (S_.sigma[j] > 0) ms.rejected_in_sigma = std::max(ms.rejected_in_sigma, std::abs(delta[j]) / S_.sigma[j]);
    for (int j = 0; j < 6; ++j) {
      if (!rest[j]) continue;
      Eigen::VectorXd Sja(nl);
      for (int a = 0; a < nl; ++a) Sja[a] = S_.covariance(j, free_lever[a]);
      const double var_held = S_.covariance(j, j) - Sja.dot(Saa_inv * Sja);
      const double sigma_held = std::sqrt(std::max(var_held, 1e-6 * S_.covariance(j, j)));
      ms.shift[static_cast<std::size_t>(j)] = shift[j];
      ms.shift_in_sigma[static_cast<std::size_t>(j)] = sigma_held > 0 ? std::abs(shift[j]) / sigma_held : 0.0;
    }
    S_.model_sensitivity.push_back(ms);
  }

  /// The data's own first-order estimate of the time offset (one Gauss–Newton step of the
  /// problem with δt added, under its prior), its σ, how far it would move the mounting
  /// (model_sensitivity: "the time offset estimated"), and — when the data leave its σ above
  /// 0.7 of the prior — that it is not determined, with the parameter it is most correlated with
  /// (at one speed δt is an along-track lever arm, v·δt).
  void timeOffset(const std::array<bool, 6>& est) {
    if (o_.estimate_time_offset) {
      estimatedTimeOffset(est);
      return;
    }
    if (!time_.any) {
      if (o_.time_offset_sigma_s > 0)
        S_.observability_report += "The time offset is not analysed: no strip's motion is known (per-point poses carry their own time).\n";
      return;
    }
    std::vector<int> idx;
    for (int j = 0; j < 6; ++j)
      if (est[j]) idx.push_back(j);
    idx.push_back(6);
    const int k = static_cast<int>(idx.size());
    Eigen::MatrixXd A(k, k);
    Eigen::VectorXd g(k);
    for (int a = 0; a < k; ++a) {
      g[a] = time_.g[idx[a]];
      for (int b = 0; b < k; ++b) A(a, b) = time_.N(idx[a], idx[b]);
    }
    A(k - 1, k - 1) += 1.0 / (o_.time_offset_sigma_s * o_.time_offset_sigma_s);
    const Eigen::MatrixXd Ainv = A.completeOrthogonalDecomposition().pseudoInverse();
    const Eigen::VectorXd step = -Ainv * g;
    S_.time_offset_s = step[k - 1];
    S_.time_offset_sigma_s = std::sqrt(std::max(Ainv(k - 1, k - 1), 0.0));
    AdjustmentSummary::ModelSensitivity ms;
    char buf[160];
    std::snprintf(buf, sizeof buf, "the time offset estimated (%+.3g ± %.3g ms) instead of 0", 1e3 * S_.time_offset_s,
                  1e3 * S_.time_offset_sigma_s);
    ms.change = buf;
    ms.part = AdjustmentSummary::ModelSensitivity::Part::kTimeOffset;
    ms.rejected_in_sigma = S_.time_offset_sigma_s > 0 ? std::abs(S_.time_offset_s) / S_.time_offset_sigma_s : 0.0;
    int worst = -1;
    double worst_rho = 0;
    for (int a = 0; a + 1 < k; ++a) {
      const int j = idx[static_cast<std::size_t>(a)];
      ms.shift[static_cast<std::size_t>(j)] = step[a];
      ms.shift_in_sigma[static_cast<std::size_t>(j)] = S_.sigma[j] > 0 ? std::abs(step[a]) / S_.sigma[j] : 0.0;
      const double rho = Ainv(a, k - 1) / std::sqrt(std::max(Ainv(a, a) * Ainv(k - 1, k - 1), 1e-300));
      if (std::abs(rho) > std::abs(worst_rho)) worst = j, worst_rho = rho;
    }
    reportTimeOffsetDetermination(worst, worst_rho);
    S_.model_sensitivity.push_back(ms);
  }

  /// An absolute rule, as for the mounting: the data determine δt only if they shrink its σ
  /// (S_.time_offset_sigma_s) well below the prior's; if not, the report says so and names the
  /// parameter `worst` it is most correlated with (correlation `rho`; −1: none).
  void reportTimeOffsetDetermination(int worst, double rho) {
    if (!(S_.time_offset_sigma_s > 0.7 * o_.time_offset_sigma_s)) return;
    char buf[200];
    std::snprintf(buf, sizeof buf, "The time offset is not determined by these data (σ %.3g ms against its prior %.3g ms)",
                  1e3 * S_.time_offset_sigma_s, 1e3 * o_.time_offset_sigma_s);
    S_.observability_report += buf;
    if (worst >= 0) {
      std::snprintf(buf, sizeof buf, "; it can hardly be told from %s (correlation %+.3f)", mountingParameterNames()[worst].c_str(), rho);
      S_.observability_report += buf;
    }
    S_.observability_report += ": at one speed it acts as an along-track lever arm (v·δt); fly the lines at two speeds.\n";
  }

  /// The blocks a source asked the covariance of (AdjustmentProblem::reportCovariance) that the
  /// solve estimated (a constant block has none).
  std::vector<const double*> variableReported() const {
    std::vector<const double*> out;
    for (const double* r : P_->reportedBlocks())
      if (!P_->ceresProblem().IsParameterBlockConstant(const_cast<double*>(r))) out.push_back(r);
    return out;
  }

  /// The formal joint covariance of the mounting and each reported block, scaled as the
  /// mounting's, from the computed ceres::Covariance (reportedCovariances adds the rest).
  std::map<const double*, Eigen::MatrixXd> reportedFormal(const ceres::Covariance& covariance, const std::vector<const double*>& reported,
                                                          double scale) const {
    using RM = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    std::map<const double*, Eigen::MatrixXd> out;
    const double* mb = P_->mounting();
    for (const double* r : reported) {
      const int n = P_->ceresProblem().ParameterBlockSize(r);
      RM mm(6, 6), mr(6, n), rr(n, n);
      if (!covariance.GetCovarianceBlock(mb, mb, mm.data()) || !covariance.GetCovarianceBlock(mb, r, mr.data()) ||
          !covariance.GetCovarianceBlock(r, r, rr.data()))
        continue;
      Eigen::MatrixXd C(6 + n, 6 + n);
      C << mm, mr, mr.transpose(), rr;
      out[r] = C * scale;
    }
    return out;
  }

  /// The joint covariance of the mounting and each reported block in the mounting's stochastic
  /// model: the formal part (reportedFormal; else the reduced system's inverse, scaled alike)
  /// plus the trajectory errors in time, C = N⁻¹ + N⁻¹ M N⁻¹ over the mounting and every
  /// reported block kept together (trajectoryErrorTerm with their columns), less what the kinds
  /// whose σ came from the start do not scatter (startSigmaCorrection). Held mounting
  /// parameters: NaN rows and columns.
  void reportedCovariances(const std::array<bool, 6>& est, double scale, const std::map<const double*, Eigen::MatrixXd>& reported_formal) {
    const std::vector<const double*> reported = variableReported();
    if (reported.empty()) return;
    const Columns cols = columnsOf(*P_);
    int kept = 6;
    for (const double* r : reported) kept += cols.col.at(r).second;
    std::vector<bool> keep(static_cast<std::size_t>(kept), true);
    for (std::size_t j = 0; j < 6; ++j) keep[j] = est[j];
    Eigen::MatrixXd N_red, X;  // X: reducedSystem()'s, for the start-σ check
    Eigen::MatrixXd* X_out = any_start_scaled_ ? &X : nullptr;
    TrajectoryTerm<Eigen::Dynamic> term;
    if (o_.trajectory.any()) {
      // The term's own reduced system serves the inverse and the start-σ check as well.
      term = trajectoryErrorTerm<Eigen::Dynamic>(*P_, o_.trajectory, !o_.pulse_noise.attitudeRandomEffect(), kept, &N_red, X_out);
    } else {
      Eigen::VectorXd diag;
      reducedSystem(*P_, kept, &N_red, &diag, X_out);
    }
    const Eigen::MatrixXd Pinv = inverseOnEstimated(N_red, keep);
    Eigen::MatrixXd beyond = Eigen::MatrixXd::Zero(kept, kept);  // what the formal part does not state
    if (any_start_scaled_) {
      const Eigen::MatrixXd less = Pinv * startSigmaCorrection(*P_, kept, X, cols, record_scale_, record_robust_) * Pinv;
      if (less.allFinite()) beyond -= scale * less;
    }
    if (term.M.size() > 0) {
      const Eigen::MatrixXd extra = Pinv * (term.M - boundedSelf(term.self, N_red, keep)) * Pinv;
      if (extra.allFinite()) beyond += extra;
    }
    for (const double* r : reported) {
      const int first = cols.col.at(r).first, n = cols.col.at(r).second;
      std::vector<int> idx{0, 1, 2, 3, 4, 5};
      for (int i = 0; i < n; ++i) idx.push_back(first + i);
      Eigen::MatrixXd C(6 + n, 6 + n);
      const auto formal = reported_formal.find(r);
      for (int a = 0; a < 6 + n; ++a)
        for (int b = 0; b < 6 + n; ++b) {
          const double f = formal != reported_formal.end() ? formal->second(a, b) : scale * Pinv(idx[a], idx[b]);
          const bool held = (a < 6 && !est[a]) || (b < 6 && !est[b]);
          C(a, b) = held ? std::nan("") : f + beyond(idx[a], idx[b]);
        }
      reportedSensitivity(r, C, est);
      P_->setReportedCovariance(r, std::move(C));
    }
  }

  /// A named reported block held at 0 instead of estimated (heldAtZero).
  void reportedSensitivity(const double* block, const Eigen::MatrixXd& C, const std::array<bool, 6>& est) {
    const std::string name = P_->reportedName(block);
    const int n = static_cast<int>(C.rows()) - 6;
    if (name.empty() || n <= 0 || !C.bottomRightCorner(n, n).allFinite()) return;
    heldAtZero(name + " held at 0 instead of estimated", AdjustmentSummary::ModelSensitivity::Part::kReported, C,
               Eigen::Map<const Eigen::VectorXd>(block, n), est);
  }

  /// Model sensitivity of a nuisance block b held at 0 instead of estimated, from C, the joint
  /// covariance of the mounting (0–5) and b (6…): the mounting's first-order move −C_mb C_bb⁻¹ b̂
  /// (its conditional mean given b = 0) against its σ, and how strongly the data reject b = 0 —
  /// χ² = b̂ᵀ C_bb⁻¹ b̂ with as many degrees of freedom as values, as a normal deviate
  /// (Wilson–Hilferty).
  void heldAtZero(const std::string& change, AdjustmentSummary::ModelSensitivity::Part part, const Eigen::MatrixXd& C,
                  const Eigen::VectorXd& b, const std::array<bool, 6>& est) {
    const int n = static_cast<int>(b.size());
    const Eigen::VectorXd z = C.bottomRightCorner(n, n).completeOrthogonalDecomposition().solve(b);
    AdjustmentSummary::ModelSensitivity ms;
    ms.change = change;
    ms.part = part;
    const double chi2 = std::max(b.dot(z), 0.0), h = 2.0 / (9.0 * n);
    ms.rejected_in_sigma = std::max(0.0, (std::cbrt(chi2 / n) - (1.0 - h)) / std::sqrt(h));
    for (int j = 0; j < 6; ++j) {
      if (!est[j] || !(S_.sigma[j] > 0)) continue;
      const double shift = -C.row(j).tail(n).dot(z);
      ms.shift[static_cast<std::size_t>(j)] = shift;
      ms.shift_in_sigma[static_cast<std::size_t>(j)] = std::abs(shift) / S_.sigma[j];
    }
    S_.model_sensitivity.push_back(ms);
  }

  /// The nuisance blocks estimated beside the mounting whose covariance the summary reports:
  /// each strip's trajectory corrections, then the time offset (StochasticOptions).
  std::vector<const double*> estimatedNuisance() const {
    std::vector<const double*> out;
    for (const auto& sc : P_->stripCorrections()) out.push_back(sc.values);
    if (P_->timeOffsetBlock()) out.push_back(P_->timeOffsetBlock());
    return out;
  }

  /// Joint covariance of the mounting and the estimated nuisance blocks (estimatedNuisance()
  /// order, after the mounting's 6 columns), from the computed ceres::Covariance.
  void nuisanceCovariance(const ceres::Covariance& covariance, const std::vector<const double*>& extra, double scale) {
    if (extra.empty()) return;
    std::vector<int> first{6};
    for (const double* b : extra) first.push_back(first.back() + blockSize(b));
    const int n = first.back();
    Eigen::MatrixXd C = Eigen::MatrixXd::Zero(n, n);
    using RM = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    const double* mb = P_->mounting();
    for (std::size_t a = 0; a < extra.size(); ++a) {
      const int na = blockSize(extra[a]);
      RM ma(6, na);
      if (!covariance.GetCovarianceBlock(mb, extra[a], ma.data())) return;
      C.block(0, first[a], 6, na) = ma;
      C.block(first[a], 0, na, 6) = ma.transpose();
      for (std::size_t b = a; b < extra.size(); ++b) {
        const int nb = blockSize(extra[b]);
        RM ab(na, nb);
        if (!covariance.GetCovarianceBlock(extra[a], extra[b], ab.data())) return;
        C.block(first[a], first[b], na, nb) = ab;
        C.block(first[b], first[a], nb, na) = ab.transpose();
      }
    }
    nuisance_cov_ = C * scale;
    nuisance_first_ = first;
  }
  /// Size of an estimatedNuisance() block: the time offset's 1, a strip's corrections' size().
  int blockSize(const double* b) const { return b == P_->timeOffsetBlock() ? 1 : o_.corrections.size(); }

  /// StochasticOptions::estimate_time_offset: the solved δt, its σ, and how far the mounting
  /// would move with δt held at 0 instead (first order, −C_mt C_tt⁻¹ δt̂).
  void estimatedTimeOffset(const std::array<bool, 6>& est) {
    const double* tb = P_->timeOffsetBlock();
    if (!tb) {
      S_.observability_report += "The time offset is not estimated: no strip's motion is known (per-point poses carry their own time).\n";
      return;
    }
    S_.time_offset_in_solve = true;
    S_.time_offset_s = *tb;
    const auto extra = estimatedNuisance();
    const int k = nuisance_first_.empty() ? -1 : nuisance_first_[extra.size() - 1];
    if (k < 0) return;  // no covariance: the estimate alone
    const double var_t = nuisance_cov_(k, k);
    S_.time_offset_sigma_s = std::sqrt(std::max(var_t, 0.0));
    if (!(var_t > 0)) return;
    AdjustmentSummary::ModelSensitivity ms;
    char buf[200];
    std::snprintf(buf, sizeof buf, "the time offset held at 0 instead of estimated (%+.3g ± %.3g ms)", 1e3 * S_.time_offset_s,
                  1e3 * S_.time_offset_sigma_s);
    ms.change = buf;
    ms.part = AdjustmentSummary::ModelSensitivity::Part::kTimeOffset;
    ms.rejected_in_sigma = std::abs(S_.time_offset_s) / S_.time_offset_sigma_s;
    int worst = -1;
    double worst_rho = 0;
    for (int j = 0; j < 6; ++j) {
      if (!est[j] || !(S_.sigma[j] > 0)) continue;
      const double c_mt = nuisance_cov_(j, k);
      ms.shift[static_cast<std::size_t>(j)] = -c_mt / var_t * S_.time_offset_s;
      ms.shift_in_sigma[static_cast<std::size_t>(j)] = std::abs(ms.shift[static_cast<std::size_t>(j)]) / S_.sigma[j];
      const double rho = c_mt / (S_.sigma[j] * S_.time_offset_sigma_s);
      if (std::abs(rho) > std::abs(worst_rho)) worst = j, worst_rho = rho;
    }
    S_.model_sensitivity.push_back(ms);
    reportTimeOffsetDetermination(worst, worst_rho);
  }

  /// StochasticOptions::corrections: each strip's correction at its ends, and how far the
  /// mounting would move with every correction held at 0 (first order, −C_mc C_cc⁻¹ ĉ).
  void trajectoryCorrections(const std::array<bool, 6>& est) {
    const auto& blocks = P_->stripCorrections();
    if (blocks.empty()) return;
    const TrajectoryCorrections& tc = o_.corrections;
    Eigen::VectorXd c_hat(static_cast<Eigen::Index>(blocks.size()) * tc.size());
    for (std::size_t i = 0; i < blocks.size(); ++i) {
      const auto& b = blocks[i];
      AdjustmentSummary::StripCorrection out;
      out.strip_id = b.strip_id;
      out.t_start_s = b.t_mid_s - b.half_span_s;
      out.t_end_s = b.t_mid_s + b.half_span_s;
      out.prior_end_position_m = b.prior_end_position_m;
      out.prior_end_attitude_rad = b.prior_end_attitude_rad;
      for (int j = 0; j < tc.size(); ++j) c_hat[static_cast<Eigen::Index>(i) * tc.size() + j] = b.values[j];
      for (int k = 1; k <= tc.position_degree; ++k)
        for (int a = 0; a < 3; ++a) {
          const double c = b.values[3 * (k - 1) + a];
          out.position_end_m[a] += c * detail::legendre(k, 1.0);
          out.position_start_m[a] += c * detail::legendre(k, -1.0);
        }
      for (int k = 1; k <= tc.attitude_degree; ++k)
        for (int a = 0; a < 3; ++a) {
          const double c = b.values[3 * tc.position_degree + 3 * (k - 1) + a];
          out.attitude_end_rad[a] += c * detail::legendre(k, 1.0);
          out.attitude_start_rad[a] += c * detail::legendre(k, -1.0);
        }
      S_.strip_corrections.push_back(out);
    }
    if (nuisance_first_.empty()) return;
    // The corrections are the first blocks after the mounting in nuisance_cov_.
    const int n = static_cast<int>(c_hat.size());
    heldAtZero("the trajectory corrections held at 0 (strip offsets only)",
               AdjustmentSummary::ModelSensitivity::Part::kTrajectoryCorrections, nuisance_cov_.topLeftCorner(6 + n, 6 + n), c_hat, est);
  }

  const MountingAdjustment::Options& o_;
  const MotionFunction& motion_;
  const std::vector<ObservationSource*>& sources_;
  // startSigmaScales(): per record the factor of its share in the covariance and the loss's ρ′,
  // per source its own σ₀² (NaN unless its σ came from the start).
  std::vector<double> record_scale_, record_robust_, kind_variance_factor_, kind_scale_;
  int n_residuals_ = 0, n_unknowns_ = 0;  // varianceFactor(): the residuals of every record, the unknowns
  // The reduced system of the mounting's 6 columns at the solution (reducedNormalMatrix() in
  // holdUndeterminable or after its re-solve): X and columns, for the start-σ check.
  Eigen::MatrixXd reduced_X_;
  Columns reduced_cols_;
  bool any_start_scaled_ = false;
  const std::array<double, 6>* start_;
  const std::array<double, 6> m0_;
  AdjustmentSummary& S_;
  const std::chrono::steady_clock::time_point t_start_;
  bool any_rematch_ = false;
  std::unique_ptr<AdjustmentProblem> P_;
  ceres::Solver::Summary cs_;
  int iterations_ = 0;
  bool first_ = true;
  std::ostringstream report_;
  TimeOffsetSystem time_;
  bool without_corrections_ = false;  ///< estimate()'s first stage (see there)
  Eigen::MatrixXd nuisance_cov_;      ///< nuisanceCovariance(): mounting, then estimatedNuisance()
  std::vector<int> nuisance_first_;   ///< first column of each estimated nuisance block there
};

}  // namespace

bool AdjustmentSummary::ModelSensitivity::unpredicted(int j) const {
  const std::size_t k = static_cast<std::size_t>(j);
  if (!solved || !(solved_shift_in_sigma[k] > 3.0)) return false;
  const double sigma = std::abs(solved_shift[k]) / solved_shift_in_sigma[k], miss = std::abs(solved_shift[k] - shift[k]);
  return miss > std::max(0.5 * std::abs(solved_shift[k]), 3.0 * sigma);
}

bool AdjustmentSummary::ModelSensitivity::model_dependent() const {
  for (int j = 0; j < 6; ++j) {
    const std::size_t k = static_cast<std::size_t>(j);
    if (rejected_in_sigma < 2.0 && (shift_in_sigma[k] > 3.0 || (solved && solved_shift_in_sigma[k] > 3.0))) return true;
    if (unpredicted(j)) return true;
  }
  return false;
}

std::string AdjustmentSummary::ModelSensitivity::text() const {
  // First order: −C_mb C_bb⁻¹ b̂ with the same observations. A solve without the part re-matches
  // and re-weights, and can move further (Gravity Car's heading: 0.31° here, 1.1–1.35° solved).
  std::string t = change + " moves (first order, same matches) ";
  bool first = true;
  const auto& names = mountingParameterNames();
  for (int j = 0; j < 6; ++j) {
    if (shift[j] == 0.0 || !(shift_in_sigma[j] >= 1.0)) continue;
    char buf[96];
    std::snprintf(buf, sizeof buf, " by %s (%.1fσ)", fmtParam(j, shift[j]).c_str(), shift_in_sigma[j]);
    t += (first ? "" : ", ") + names[j] + buf;
    first = false;
  }
  if (first) return change + " moves no parameter by 1σ or more";
  if (solved) {
    int worst = 0;
    for (int j = 1; j < 6; ++j)
      if (solved_shift_in_sigma[j] > solved_shift_in_sigma[worst]) worst = j;
    char s_buf[160];
    std::snprintf(s_buf, sizeof s_buf, "; solved again without it: %s by %s (%.1fσ)", names[worst].c_str(),
                  fmtParam(worst, solved_shift[worst]).c_str(), solved_shift_in_sigma[worst]);
    t += s_buf;
    for (int j = 0; j < 6; ++j)
      if (unpredicted(j)) {
        t += ", not what the first order predicts (another matching: the data's rejection, a first-order test, does not settle it)";
        break;
      }
  }
  char buf[160];
  std::snprintf(buf, sizeof buf, "; the data %s it (%.1fσ)", rejected_in_sigma >= 2.0 ? "reject" : "cannot reject", rejected_in_sigma);
  return t + buf + (model_dependent() ? ": model-dependent" : "");
}

AdjustmentSummary MountingAdjustment::solve(const MountingParameters& mounting_used, const std::vector<ObservationSource*>& sources,
                                            const std::array<double, 6>* start) const {
  Summary summary;
  summary.mounting_used = mounting_used;
  summary.mounting = mounting_used;
  summary.sigma.fill(std::nan(""));
  summary.formal_sigma.fill(std::nan(""));
  std::string why;
  if (!options_.IsValid(&why)) {
    summary.message = "invalid options: " + why;
    return summary;
  }
  Estimation e(options_, motion_, mounting_used, sources, start, &summary);
  std::array<bool, 6> est = options_.estimate;
  if (!e.estimate(est, e.initial(est))) {
    summary.message = "no usable observation: every method's input was rejected (see the rejected lists)";
    summary.time_s = e.elapsed();
    return summary;
  }
  double t_mark = e.elapsed();
  Mat6 N_red;
  Vec6 diag;
  if (e.holdUndeterminable(&est, &N_red, &diag)) {
    // Re-solve with the undeterminable parameters held at their used values.
    summary.analysis_time_s += e.elapsed() - t_mark;
    if (!e.estimate(est, e.initial(est))) {
      summary.message = "no usable observation";
      summary.time_s = e.elapsed();
      return summary;
    }
    t_mark = e.elapsed();
    e.reducedNormal(&N_red, &diag);
  }
  e.analyse(est, N_red, mounting_used);
  summary.analysis_time_s += e.elapsed() - t_mark;
  summary.time_s = e.elapsed();
  return summary;
}

}  // namespace mountcal
