#pragma once
/// \file adjustment/mounting_adjustment.hpp
/// The one adjustment every kind of observation plugs into (DESIGN.md, "One adjustment, many
/// kinds of observation").
///
/// A method (virtual tie points, plane patches, automatic correspondences, ground control, …)
/// is an ObservationSource: at a given mounting it adds residual blocks and the nuisance
/// parameter blocks they need (tie positions, planes) to an AdjustmentProblem. The adjustment
/// owns everything else — the mounting block (6 parameters, any subset held, priors), one 3-D
/// offset per strip as a random effect, the Levenberg–Marquardt solve, re-matching for the
/// methods that match, the observability analysis by eliminating every nuisance block
/// (Schur complement), `ceres::Covariance`, correlations and σ₀². It never knows what a tie
/// or a plane is: it sees parameter blocks, residual blocks, which blocks are nuisance, and
/// the kind of each residual block for the summary.

#include <ceres/cost_function.h>
#include <ceres/manifold.h>

#include <array>
#include <cmath>
#include <deque>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mountcal/core/mounting.hpp"
#include "mountcal/core/trajectory.hpp"

namespace ceres {
class Problem;
class LossFunction;
}  // namespace ceres

namespace mountcal {

namespace detail {
class BlockArena;
}

/// How an adjustment ended (after Ceres' TerminationType).
enum class TerminationType {
  kConvergence,    ///< a tolerance was met: the solution is usable
  kNoConvergence,  ///< iteration or time limit reached first: not usable
  kFailure,        ///< the solver failed (numerical trouble)
  kInvalidInput,   ///< options or data invalid; see Summary::message
};
const char* toString(TerminationType t);

/// Robust loss applied to the observations (never to priors).
enum class LossType { kTrivial, kHuber, kCauchy };

/// The mounting block: which parameters are estimated and their priors.
struct MountingBlockOptions {
  /// Which of the six parameters to estimate, in MountingIndex order. Default: all but the
  /// vertical lever arm, which flat ground and level flight cannot determine without GCPs.
  std::array<bool, 6> estimate{true, true, false, true, true, true};
  /// Optional priors on the mounting (MountingIndex order); a prior with sigma ≤ 0 or NaN is
  /// off. Values [m, rad]; sigmas [m, rad].
  std::array<double, 6> prior_value{0, 0, 0, 0, 0, 0};
  std::array<double, 6> prior_sigma{0, 0, 0, 0, 0, 0};
  bool IsValid(std::string* error) const;
};

/// Noise of each georeferenced laser point (the error budget of direct georeferencing, SPEC §2
/// eq. 1), propagated into the covariance of every observation built from points: a tie's
/// position, a point-to-plane distance. All off (0) by default: the observations then carry
/// only their method's own σ (picking, plane fit).
///
/// For a point x = p + R_mb (R_bs r_s + a) with u = x − p (IMU → point) and the beam b (the
/// laser vector in the mapping frame, |b| = ρ, d = b/ρ):
///
///   Σ_x = σ_p² I + [u]× diag(σ_t², σ_t², σ_κ²) [u]×ᵀ + w (σ_ρ² d dᵀ + σ_β² ρ² (I − d dᵀ))
///
/// — position noise, attitude (tilt about the horizontal axes, heading about the vertical),
/// range along the beam, pointing across it. Attitude and position are common to points
/// emitted within a moment; range and pointing are independent per pulse, so a point
/// interpolated from several pulses with weights w_i carries them with w = Σ w_i².
///
/// Attitude noise is correlated in time (an INS: Gauss–Markov, tenths of a second): every
/// observation of one strip within that time shares it — ties in one scan line see one heading
/// error, which displaces them exactly as a boresight heading would. With
/// `attitude_correlation_s` > 0 it is therefore not in Σ_x but a random effect: the attitude
/// error δψ (3 angles, σ_t, σ_t, σ_κ) of each strip is a Gauss–Markov process with that
/// correlation time, sampled at the observations' times and estimated with the mounting, so its
/// uncertainty enters the mounting's covariance.
struct PulseNoise {
  double position_m = 0.0;      ///< trajectory position noise between pulses, per axis [m] (the slow part is the strip offset)
  double roll_pitch_deg = 0.0;  ///< attitude noise about the horizontal axes [deg]
  double heading_deg = 0.0;     ///< attitude noise about the vertical [deg]
  double range_m = 0.0;         ///< range noise [m]
  double beam_deg = 0.0;        ///< pointing noise across the beam (scan-angle encoder, divergence) [deg]
  /// Correlation time of the attitude noise [s]; > 0: a Gauss–Markov random effect per strip
  /// instead of a term of Σ_x (0: white, in Σ_x).
  double attitude_correlation_s = 0.0;
  bool any() const { return position_m > 0 || roll_pitch_deg > 0 || heading_deg > 0 || range_m > 0 || beam_deg > 0; }
  bool attitudeRandomEffect() const { return attitude_correlation_s > 0 && (roll_pitch_deg > 0 || heading_deg > 0); }
  /// Σ_x above [m²] (without the attitude term when it is a random effect); `u_m` = x − p,
  /// `beam_m` the laser vector, both in the mapping frame [m]; `independent_weight` = Σ w_i² of
  /// the pulses the point is interpolated from [-].
  Mat3 pointCovariance(const Vec3& u_m, const Vec3& beam_m, double independent_weight = 1.0) const;
  bool IsValid(std::string* error) const;
};

/// Trajectory errors in time: what a GNSS/INS solution carries within a strip (position and
/// attitude errors that wander with periods of seconds to minutes). The adjustment does not
/// estimate them; it states their effect on the mounting — *consider parameters* (Bierman
/// 1977, ch. VI; Montenbruck & Gill 2000, §8.1.4): with the estimate linearised as
/// δθ̂ = N⁻¹ Jᵀ W (ε + J_c c) and c the trajectory errors at the observations' times,
///
///   C_θ = N⁻¹ + N⁻¹ (Jᵀ W J_c) C_c (Jᵀ W J_c)ᵀ N⁻¹,
///
/// every nuisance block (tie positions, planes, strip offsets) eliminated. Each strip's errors
/// are first-order Gauss–Markov processes, C_c(t, t') = σ² exp(−|t − t'| / τ), independent
/// between strips and axes. An observation at time t of strip s moves by δp(t) + δψ(t) × u
/// (u = x − p, IMU → point, mapping frame), so J_c is the residual's Jacobian with respect to
/// the strip's offset, times (I, −[u]×).
///
/// A kind whose σ is estimated from its residuals (variance components: ties, features) holds
/// in that σ the part of each observation's own trajectory error that its strip's estimated
/// terms (offset, corrections) do not absorb — for a Gauss–Markov error the share left by
/// removing those polynomials in time (detail::residualShare); only that part is taken off, and
/// never more than nine tenths of what the estimated σ state. The strip offset, a random effect
/// with its prior, takes of a strip-constant error only the share its data resolve,
/// κ = 1 − σ²_posterior / σ²_prior per axis: a strip whose few observations hardly determine its
/// offset (nine targets of a UAV flight) keeps most of its own error in their residuals.
///
/// Thousands of point-to-plane distances that share one trajectory error are not independent
/// observations: without this term their σ are too small by the square root of how many share
/// it. The defaults are a post-processed survey-grade GNSS/INS (Applanix POS AV / NovAtel SPAN
/// class: position drift 2 cm, attitude 0.002° about the horizontal axes and 0.004° in heading);
/// state yours, or give the trajectory's accuracy along its time (`series`: an SBET's smrmsg
/// file) — the σ are as honest as these numbers. All zero: the formal σ (independent observations)
/// alone.
struct TrajectoryAccuracy {
  double position_sigma_m = 0.02;        ///< per axis [m]; the constant part is the strip offset
  double position_correlation_s = 30.0;  ///< τ of the position errors [s]
  double roll_pitch_sigma_deg = 0.002;   ///< attitude about the horizontal axes [deg]
  double heading_sigma_deg = 0.004;      ///< attitude about the vertical [deg]
  double attitude_correlation_s = 5.0;   ///< τ of the attitude errors [s]
  /// The σ along time, as the GNSS/INS solution states them (io::readSmrmsg, io::smrmsgToAccuracy):
  /// when set, σ(t) at each observation's epoch take the place of the three σ above (per axis:
  /// the error process is e(t) = σ(t) u(t), u a unit Gauss–Markov process of the τ above, so
  /// cov(e(t), e(t')) = σ(t) σ(t') exp(−|t − t'|/τ)). MountingCalibrator sets it from
  /// CalibrationData::trajectory_accuracy unless the σ are switched off.
  std::shared_ptr<const TrajectoryAccuracySeries> series;
  /// Whether the position drift above (with the GNSS error below) is the strip's whole slow
  /// position error, its strip-constant part included (as the planner's noise states it). The
  /// strip offsets' prior (StochasticOptions::strip_offset_sigma_m) then only regularises their
  /// estimate: the formal covariance counts it as a random constant error of that σ
  /// (N⁻¹ = N⁻¹ (Ĵᵀ W Ĵ + Xᵀ P X) N⁻¹, X the offsets' response to the mounting, P their prior's
  /// weight), and the same constant is in this drift — so that share, Σ_strips H̄ σ_o² H̄ᵀ with H̄
  /// the sum of the strip's epochs' H, is taken off the consider term and the constant part is
  /// counted once. false (the default): the offsets' prior states a bias beyond the drift,
  /// independent of it.
  bool offsets_within_drift = false;
  /// A second position error beside the drift above, independent of it: the GNSS solution's own
  /// slow error (per axis [m], its τ [s]) where the drift above is the INS's shorter one — a
  /// plan's GNSS error (`gnss_sigma_m`, `gnss_correlation_s`). Nearly constant over an airborne
  /// line of 15 s at τ = 100 s, it wanders within a UAV's line of 40 s. 0: none.
  double gnss_sigma_m = 0.0;
  double gnss_correlation_s = 100.0;
  bool any() const {
    return position_sigma_m > 0 || roll_pitch_sigma_deg > 0 || heading_sigma_deg > 0 || gnss_sigma_m > 0 || (series && !series->empty());
  }
  /// No trajectory errors in time (a simulated survey without them; the formal σ alone).
  static TrajectoryAccuracy none() { return {0.0, 30.0, 0.0, 0.0, 5.0, nullptr}; }
  bool IsValid(std::string* error) const;
};

/// Trajectory corrections estimated per strip — what TerraMatch, OPALS StripAdjust (Glira et al.
/// 2016) and BayesStripAlign estimate beside the mounting: a strip's position and attitude errors
/// as polynomials in its time,
///
///   δp(t) = o + Σ_{k=1..d_p} c_k P_k(τ),   δψ(t) = Σ_{k=1..d_a} e_k P_k(τ),
///
/// τ ∈ [−1, 1] over the time span of the strip's observations, P_k the Legendre polynomials
/// (P₁ = τ, P₂ = (3τ² − 1)/2, P₃ = (5τ³ − 3τ)/2). The constant strip offset o (strip_offset_sigma_m)
/// is the degree-0 position term. The attitude has no degree-0 term: a constant attitude error of a
/// strip rotates its every beam as that strip's boresight would (for level flight exactly), so the
/// data cannot tell it from the mounting. An observation at u = x − p (IMU → point, mapping frame) moves by
/// δp(t) + δψ(t) × u. Each coefficient has a zero-mean prior of the σ below, per axis (the size of
/// the correction it makes at a strip's end). Nuisance blocks of the one adjustment, eliminated in
/// the mounting's covariance; what the polynomials absorb of the trajectory errors in time is then
/// no longer in their consider term (its Jacobians are the reduced ones, orthogonal to these
/// blocks), only what they cannot follow. Corrections need the sources' epochs
/// (AdjustmentProblem::setEpoch: every built-in method states them).
struct TrajectoryCorrections {
  int position_degree = 0;              ///< 0: the strip offset alone; 1: + linear drift; up to 3
  int attitude_degree = 0;              ///< 0: none; 1: linear attitude drift; up to 3
  double position_sigma_m = 0.05;       ///< prior of each position coefficient, per axis [m]
  double roll_pitch_sigma_deg = 0.005;  ///< prior of each attitude coefficient about x, y [deg]
  double heading_sigma_deg = 0.01;      ///< prior of each attitude coefficient about z [deg]
  /// The priors from the trajectory's stated accuracy (StochasticOptions::trajectory, its σ along
  /// time where given) instead of the three σ above: per strip and axis, the covariance of the
  /// Legendre coefficients that its stated Gauss–Markov error has over that strip's span
  /// (detail::legendreCoefficientCovariance) — a long strip or a short correlation time gives a
  /// drift room to bend, a short strip under a long correlation time little. Needs the trajectory
  /// errors on (TrajectoryAccuracy::any()).
  bool priors_from_accuracy = false;
  bool any() const { return position_degree > 0 || attitude_degree > 0; }
  /// Coefficients per strip: 3 d_p position, then 3 d_a attitude.
  int size() const { return 3 * position_degree + 3 * attitude_degree; }
  bool IsValid(std::string* error) const;
};

/// Velocity [m/s] and angular rate [rad/s] of the IMU in the mapping frame at a strip's time
/// (d/dt of p_m and R_mb = [ω]× R_mb); false when unknown.
using MotionFunction = std::function<bool(const std::string& strip_id, double time_s, Vec3* velocity_m_s, Vec3* rate_rad_s)>;

/// The stochastic model shared by every kind of observation.
struct StochasticOptions {
  /// Trajectory errors that stay nearly constant over a strip (GNSS, PPK) are modelled as
  /// one 3-D offset per strip, a random effect with this prior standard deviation per axis
  /// [m]. They are estimated with the mounting, so its covariance carries their uncertainty.
  /// 0 switches them off (strips then trusted exactly). With TrajectoryAccuracy on, state here
  /// the strip's bias *beyond* the drift stated there (the GNSS solution's offset from line to
  /// line): the drift's own strip-constant part is in TrajectoryAccuracy's term already, and
  /// stating it in both counts it twice — σ too large wherever few observations fix a strip's
  /// offset (the features method on the UAV preset: RMS of error/σ 0.35–0.56 with 2 cm here,
  /// 0.71–1.09 with the survey's 5 mm; docs/sigma-honesty.md).
  double strip_offset_sigma_m = 0.02;
  LossType loss = LossType::kTrivial;
  double loss_scale_m = 0.5;  ///< where the robust loss starts to bend [m]
  /// Per-point noise propagated into each observation's covariance (off by default).
  PulseNoise pulse_noise;
  /// Trajectory errors in time, in the mounting's covariance (on by default; see above). When
  /// PulseNoise's attitude random effect is on, the attitude is estimated instead and only the
  /// position part is considered here.
  TrajectoryAccuracy trajectory;
  /// Latency between the trajectory's and the scanner's clocks — a time offset δt: a point
  /// measured at t belongs to the pose at t + δt — as its prior σ [s]; 0 (default): not
  /// analysed. When set, δt's effect on the mounting enters σ as a consider parameter (as the
  /// trajectory errors do), and the data's own first-order estimate of δt, its σ and how far it
  /// would move the mounting are reported (Summary::time_offset_s, model_sensitivity). At one
  /// speed δt acts as an along-track lever arm (v·δt): the observability report says so. Needs
  /// the platform's motion (MountingAdjustment::setMotion; MountingCalibrator sets it from the
  /// trajectory; strips with per-point poses carry their own time and are left out).
  double time_offset_sigma_s = 0.0;
  /// With time_offset_sigma_s > 0: estimate δt in the solve (a parameter beside the mounting
  /// under that prior, eliminated in the mounting's covariance; Summary::time_offset_s is then
  /// the solved value) instead of only considering it. It does not change the mounting's model
  /// of the strips: δt moves every point by δt (v + ω × u).
  bool estimate_time_offset = false;
  /// Per-strip trajectory corrections in time (see above); off by default (the strip offsets).
  TrajectoryCorrections corrections;
  bool IsValid(std::string* error) const;
};

/// Levenberg–Marquardt and the re-matching loop of the matching methods.
struct SolverOptions {
  /// The paper's termination (seed step 8) is a cost change or a parameter change below a
  /// tolerance: function_tolerance and parameter_tolerance.
  int max_iterations = 100;
  double function_tolerance = 1e-10;   ///< relative cost change [-]
  double parameter_tolerance = 1e-10;  ///< relative parameter change [-]
  double gradient_tolerance = 1e-12;   ///< [-]
  double max_solver_time_s = 60.0;     ///< per solve [s]
  int num_threads = 1;
  /// Central-difference step, relative (Ceres NumericDiffOptions) [-].
  double numeric_diff_relative_step = 1e-6;
  /// Matching methods are re-matched at the new mounting and solved again until the mounting
  /// changes by less than these between two rounds, or this many rounds [-, m, rad]. 12: the
  /// dense correspondences' two stages take up to 6 matchings each (CorrespondenceOptions::dense);
  /// with 8 a noise-free VLP-16 survey whose per-laser offsets join at the third matching
  /// stopped 2.3e-4 deg off in heading, with 10 or more 1.7e-5 deg (2026-12-02).
  int max_rematch_rounds = 12;
  double rematch_tolerance_m = 1e-4;
  double rematch_tolerance_rad = 2e-7;
  /// …or by less than this fraction of each parameter's standard deviation [-].
  double rematch_sigma_fraction = 0.1;
  /// With re-matching sources: at most this many iterations per solve between matchings (the
  /// next matching moves the optimum anyway); the solve that ends the estimation is continued
  /// to convergence (up to max_iterations). 0: max_iterations in every solve [-].
  int max_iterations_per_matching = 0;
  bool IsValid(std::string* error) const;
};

/// What is computed after the solve.
struct AnalysisOptions {
  /// Observability by an absolute rule: a parameter is held (not estimated) only when the data
  /// do not determine it — its marginal standard deviation, every nuisance block eliminated
  /// and every other estimated parameter free, exceeds its physical bound below, or the reduced
  /// normal matrix is rank deficient along it. The most undetermined parameter (σ / bound) is
  /// held first and the rule applied again. Adding observations can only lower a marginal σ, so
  /// it never turns a determined parameter into a held one. A lever-arm component measured on
  /// the aircraft belongs in MountingBlockOptions::prior_sigma instead of being held.
  double undeterminable_sigma_m = 0.3;    ///< bound of a lever-arm component's σ [m]
  double undeterminable_sigma_deg = 1.0;  ///< bound of a boresight angle's σ [deg]
  /// An estimated lever-arm component that moves further than this from its used (measured)
  /// value makes the verdict doubtful: mountings are not mis-measured by that much, so the
  /// lever arm is more likely absorbing a model error (time offset, laser offsets) [m].
  double lever_arm_change_warning_m = 0.5;
  /// After the solve, MountingCalibrator solves once more from its estimate, with every
  /// observation that depends on the mounting selected again there (correspondences, plane
  /// points, feature targets, control). A mounting that then moves by more than 2σ has not
  /// settled — it depends on where the solve started — and the verdict says so (doubtful;
  /// beyond resolve_reject_sigma, reject).
  /// Costs a second solve when some method re-matches; nothing when none does.
  bool resolve_check = true;
  /// A re-solve that moves a parameter by more than this many σ rejects the calibration (exit 1):
  /// two solutions k σ apart, each self-consistent, say the parameter's true σ is k/√2 times the
  /// stated one or more, and 4.5/√2 = 3.2 is the factor at which σ₀² > 10 rejects (residuals
  /// over √10 times their stated σ). Between 2σ and this: doubtful [σ].
  double resolve_reject_sigma = 4.5;
  /// Eigenvalues of the bound-scaled reduced normal matrix below this fraction of the largest
  /// are a rank deficiency (infinite σ along their direction) [-].
  double rank_tolerance = 1e-12;
  /// Scale the covariance by the a-posteriori variance factor σ₀². Off by default: the
  /// covariance then follows the stated a-priori sigmas, and variance_factor tells how well
  /// they match the residuals (≈ 1 when they do). On, it takes the place of the check of a σ
  /// that a kind estimated at the start (ObservationSource::sigmaFromStart), not added to it.
  bool scale_covariance_by_variance_factor = false;
  /// An observation whose residual exceeds this many times the robust residual scale of its
  /// kind is flagged as an outlier [-].
  double outlier_factor = 4.0;
  bool IsValid(std::string* error) const;
};

/// Where the adjustment's trajectory model puts a strip's points beyond the mounting, as a solve
/// estimated it: the strip offset o, the trajectory corrections δp(t) + δψ(t) × u
/// (TrajectoryCorrections) and the time offset δt (v + ω × u). A matching source takes it in
/// ObservationSource::solved() and matches at these positions the next time, so that what it pairs
/// are the points the adjustment models (AdjustmentProblem::pointShifts()).
class PointShifts {
 public:
  /// One strip's estimated terms.
  struct Terms {
    Vec3 offset_m = Vec3::Zero();
    std::vector<double> coefficients;  ///< TrajectoryCorrections order; empty: none
    double t_mid_s = 0.0, half_span_s = 0.0;
  };
  /// One strip's shift as a function of a point's time and u = x − p (IMU → point, mapping frame).
  class Strip {
   public:
    /// The shift [m] of the strip's point seen at `time_s` with `u_m`; zero without terms.
    Vec3 at(double time_s, const Vec3& u_m) const;

   private:
    friend class PointShifts;
    const PointShifts* all_ = nullptr;
    const Terms* terms_ = nullptr;
    std::string id_;
  };
  /// The shift function of strip `strip_id` (zero for a strip the solve did not see).
  Strip strip(const std::string& strip_id) const;
  /// Nothing estimated: every shift is zero.
  bool empty() const { return strips_.empty() && time_offset_s_ == 0.0; }

 private:
  friend class AdjustmentProblem;
  std::map<std::string, Terms> strips_;
  int position_degree_ = 0, attitude_degree_ = 0;
  double time_offset_s_ = 0.0;
  MotionFunction motion_;
};

/// What a method sees while it adds its observations. Everything added is owned here.
class AdjustmentProblem {
 public:
  AdjustmentProblem(const std::array<double, 6>& mounting, double strip_offset_sigma_m, LossType loss, double loss_scale_m,
                    double numeric_diff_relative_step);
  ~AdjustmentProblem();
  AdjustmentProblem(const AdjustmentProblem&) = delete;
  AdjustmentProblem& operator=(const AdjustmentProblem&) = delete;

  /// The mounting block: (a_x, a_y, a_z [m], ω, φ, κ [rad]), MountingIndex order.
  double* mounting() { return mounting_; }
  std::array<double, 6> mountingValues() const {
    return {mounting_[0], mounting_[1], mounting_[2], mounting_[3], mounting_[4], mounting_[5]};
  }
  /// The 3-D offset block of a strip [m] (a random effect with the stochastic model's prior, or
  /// held at zero when that prior is off). Created on first use.
  double* stripOffset(const std::string& strip_id);
  /// A nuisance parameter block of `size` values starting at `initial`: estimated with the
  /// mounting, eliminated in the observability analysis. `manifold` (owned; may be null) for
  /// blocks such as unit normals. `schur_eliminable`: no residual block holds two such blocks.
  double* addNuisanceBlock(int size, const double* initial, ceres::Manifold* manifold = nullptr, bool schur_eliminable = true);
  /// Adds a residual block over `blocks` (the mounting, strip offsets and nuisance blocks of
  /// this problem) and takes ownership of `cost`. `loss_sigma_m` > 0 is the standard
  /// deviation [m] the residuals were divided by: the robust loss applies with scale
  /// loss_scale_m / loss_sigma_m. 0: never robust (priors). Returns the block's index.
  int addResidualBlock(ceres::CostFunction* cost, double loss_sigma_m, const std::vector<double*>& blocks);
  /// As above, with the robust loss bending at `loss_scale_m` instead of the options' scale
  /// (a matching source's coarse rounds, whose distances are still metres).
  int addResidualBlock(ceres::CostFunction* cost, double loss_sigma_m, const std::vector<double*>& blocks, double loss_scale_m);
  /// Central-difference step for the methods' numeric-diff cost functions [-].
  double numericDiffRelativeStep() const { return numeric_diff_relative_step_; }
  /// The per-point noise of the stochastic model, for the sources' observation covariances.
  const PulseNoise& pulseNoise() const { return pulse_noise_; }
  void setPulseNoise(const PulseNoise& noise) { pulse_noise_ = noise; }
  /// The platform's motion, for the epochs' velocity and angular rate (the time offset).
  void setMotion(MotionFunction motion) { motion_ = std::move(motion); }
  /// The attitude error δψ [rad] (rotation vector on the mapping axes) of a strip at `time_s`: a
  /// nuisance block, created on first use (observations within τ/20 share one). Once every
  /// source has added its blocks, the blocks of each strip are tied together in time by the
  /// Gauss–Markov priors of PulseNoise (σ_t, σ_t, σ_κ; τ = attitude_correlation_s). An
  /// observation at u = x − p (IMU → point, mapping frame) adds δψ × u to its point. Null when
  /// the stochastic model has no such random effect.
  double* attitudeError(const std::string& strip_id, double time_s);
  /// Adds the priors of the random effects created by the sources (called by the adjustment
  /// after every source's addBlocks).
  void addRandomEffectPriors();
  /// Trajectory corrections and the time offset to estimate (StochasticOptions), set before the
  /// sources add their blocks; they are attached to the residual blocks in commit().
  /// With TrajectoryCorrections::priors_from_accuracy the priors come from `accuracy` per strip.
  void setCorrections(const TrajectoryCorrections& corrections, double time_offset_sigma_s,
                      const TrajectoryAccuracy& accuracy = TrajectoryAccuracy::none());
  /// Hands every residual block to Ceres (called by the adjustment once the problem is complete).
  /// Blocks are kept until then, so that the trajectory corrections (StochasticOptions::
  /// corrections) and the time offset can be attached to those with epochs: their cost becomes
  /// the source's cost at the corrected strip offsets, with the correction blocks (one per strip,
  /// created here with their priors) and the time offset's block appended to their blocks.
  void commit();
  /// The per-strip correction block (TrajectoryCorrections order), its time span (centre, half
  /// width [s]); empty before commit() or without corrections.
  struct StripCorrection {
    std::string strip_id;
    double* values = nullptr;
    double t_mid_s = 0.0, half_span_s = 0.0;
    /// The prior's σ of the correction at the span's end (Σ_k c_k, P_k(1) = 1) per axis:
    /// position [m], attitude [rad].
    Vec3 prior_end_position_m = Vec3::Zero(), prior_end_attitude_rad = Vec3::Zero();
  };
  const std::vector<StripCorrection>& stripCorrections() const { return corrections_blocks_; }
  /// The trajectory corrections set by setCorrections (degrees 0: none beyond the strip offset).
  const TrajectoryCorrections& corrections() const { return corrections_; }
  /// The estimated time offset's block [s] (null unless estimated and some epoch moves).
  double* timeOffsetBlock() { return time_offset_block_; }
  /// The point shifts of the current estimates (strip offsets, corrections, time offset), for a
  /// matching source's next matching (PointShifts).
  PointShifts pointShifts() const;

  /// States when and where residual block `record` saw strip `strip_id` (whose offset block it
  /// holds): the pulse time [s] and u = x − p (IMU → point, mapping frame) [m]. The adjustment
  /// uses it for the trajectory errors in time (TrajectoryAccuracy); a block without it is
  /// taken as free of them. Call once per strip the block holds. `in_sigma`: the block's σ is
  /// estimated from the residuals (variance components), which already hold its own trajectory
  /// error — only its correlation with the other observations is added.
  void setEpoch(int record, const std::string& strip_id, double time_s, const Vec3& u_m, bool in_sigma = false);

  /// Asks the adjustment for nuisance block `block`'s covariance in the mounting's stochastic
  /// model — the formal part scaled as the mounting's, plus the trajectory errors in time
  /// (TrajectoryAccuracy) over the mounting and this block together — instead of a formal one
  /// that treats correlated observations as independent. `block` is one of this problem's
  /// nuisance blocks without a manifold; read the result in ObservationSource::finish with
  /// reportedCovariance(). The time offset's consider term is not in it (the mounting's only).
  /// `name` (e.g. "the per-laser offsets"), when given: the summary's model_sensitivity also
  /// states how far the mounting would move with the block held at 0 instead of estimated.
  void reportCovariance(const double* block, const std::string& name = "");
  /// The name given with a reported block ("" when none).
  std::string reportedName(const double* block) const;
  const std::vector<const double*>& reportedBlocks() const { return reported_; }
  /// The joint covariance of the mounting (rows and columns 0–5; NaN where a mounting parameter
  /// is held) and a block asked for by reportCovariance (6…), after the solve; empty when it was
  /// not asked for or could not be computed.
  const Eigen::MatrixXd& reportedCovariance(const double* block) const;
  /// Set by MountingAdjustment after the solve.
  void setReportedCovariance(const double* block, Eigen::MatrixXd covariance) { reported_covariance_[block] = std::move(covariance); }

  /// Residual vector of block `index` at the current parameter values (unweighted by loss).
  Eigen::VectorXd residual(int index) const;
  /// The leverage of records (indices as addResidualBlock returned them): for each the diagonal
  /// block H_rr = J_r N⁻¹ J_rᵀ of the whole adjustment's hat matrix at the current values, with
  /// N = Σ Jᵀ ρ′ J over every record, priors included (ρ′ the loss's weight at each residual, as
  /// in the solve's last step), in each block's tangent space, the mounting's held parameters
  /// left out (setEstimated). I − H_rr is the record's redundancy, its share of the degrees of
  /// freedom (over every record they sum to observations − unknowns): what a source's variance
  /// components divide by (Förstner: σ² = Σ e² / Σ redundancy), so that the parameters that fit
  /// its residuals — the mounting, strip offsets, laser offsets, not only its own — are counted.
  std::vector<Eigen::MatrixXd> leverage(const std::vector<int>& records) const;
  /// The covariance of a nuisance `block` (its tangent columns) with the listed records' share
  /// taken from their own leave-one-out residuals — a sandwich N⁻¹ B N⁻¹, B = Σ over the other
  /// records of Jᵀ J (their stated σ) + Σ over the listed ones of Jᵀ ẽ ẽᵀ J, ẽ = (I − H_rr)⁻¹ e
  /// the residual each would have without itself in the solve (the "HC3" estimator, MacKinnon
  /// & White 1985; leverage() for H). For parameters that few observations determine, whose
  /// fit hides their errors in small residuals. `formal` (optional): N⁻¹'s block from the same
  /// linearisation. Throws std::invalid_argument when `block` is not a variable block here.
  Eigen::MatrixXd leaveOneOutCovariance(const double* block, const std::vector<int>& records, Eigen::MatrixXd* formal = nullptr) const;
  /// Which mounting parameters the solve estimates (the others held): for leverage().
  void setEstimated(const std::array<bool, 6>& estimated) { estimated_ = estimated; }
  int residualBlockCount() const { return static_cast<int>(records_.size()); }
  /// Current values of a strip offset (zero when the strip has none) [m].
  Vec3 stripOffsetValue(const std::string& strip_id) const;

  // ---- used by MountingAdjustment -------------------------------------------------------
  struct Epoch {
    int block = 0;                   ///< index of the strip's offset in Record::blocks
    const double* offset = nullptr;  ///< the strip's offset block: names the strip
    double time_s = 0.0;
    Vec3 u_m = Vec3::Zero();
    bool in_sigma = false;  ///< its own variance is in the block's (estimated) σ already
    bool moving = false;    ///< the motion below is known (AdjustmentProblem::setMotion)
    Vec3 velocity_m_s = Vec3::Zero();
    Vec3 rate_rad_s = Vec3::Zero();
  };
  struct Record {
    ceres::CostFunction* cost = nullptr;
    std::vector<double*> blocks;
    int source = -1;
    double loss_sigma_m = 0.0;
    std::vector<Epoch> epochs;
    ceres::LossFunction* loss = nullptr;  ///< handed to Ceres with the cost in commit()
  };
  struct Block {
    double* values = nullptr;
    int size = 0;
    ceres::Manifold* manifold = nullptr;
    bool eliminable = true;
    bool constant = false;
  };
  void setSource(int source) { source_ = source; }
  const std::vector<Record>& records() const { return records_; }
  const std::vector<Block>& nuisanceBlocks() const { return nuisance_; }
  const std::map<std::string, double*>& stripOffsets() const { return offsets_; }
  ceres::Problem& ceresProblem() { return *problem_; }
  double stripOffsetSigma() const { return offset_sigma_m_; }

 private:
  /// Every block's values, at addresses in creation order (adjustment/block_arena.hpp); declared
  /// first, so that it outlives the Ceres problem that points into it.
  std::unique_ptr<detail::BlockArena> arena_;
  std::unique_ptr<ceres::Problem> problem_;
  double* mounting_ = nullptr;              ///< 6 values in arena_
  std::map<std::string, double*> offsets_;  ///< 3 values each in arena_
  std::vector<Block> nuisance_;
  std::vector<Record> records_;
  double offset_sigma_m_;
  LossType loss_;
  double loss_scale_m_;
  double numeric_diff_relative_step_;
  PulseNoise pulse_noise_;
  MotionFunction motion_;
  std::map<std::pair<std::string, long long>, double*> attitude_errors_;
  int source_ = -1;
  TrajectoryCorrections corrections_;
  TrajectoryAccuracy correction_accuracy_ = TrajectoryAccuracy::none();  ///< for priors_from_accuracy
  double time_offset_sigma_s_ = 0.0;                                     ///< > 0: the time offset is estimated
  std::vector<StripCorrection> corrections_blocks_;
  double* time_offset_block_ = nullptr;
  bool committed_ = false;
  std::array<bool, 6> estimated_{{true, true, true, true, true, true}};
  std::vector<const double*> reported_;
  std::map<const double*, std::string> reported_names_;
  std::map<const double*, Eigen::MatrixXd> reported_covariance_;
  void attachCorrections(bool corrections, bool time_offset);
  /// The prior covariance of one strip's correction coefficients over its span [t0, t1]
  /// (TrajectoryCorrections order): the stated σ, or the trajectory accuracy's Legendre covariance.
  Eigen::MatrixXd correctionPrior(double t0_s, double t1_s) const;
};

/// A kind of observation of the mounting (a method). A source never solves: it adds blocks.
class ObservationSource {
 public:
  virtual ~ObservationSource() = default;
  /// The kind's name in summaries ("ties", "planes", "correspondences", "control").
  virtual std::string kind() const = 0;
  /// Adds the residual blocks (and their nuisance blocks) at `mounting` (MountingIndex order
  /// [m, rad]). Called once per solve, each time with a fresh problem; a matching source
  /// re-matches here.
  virtual void addBlocks(const std::array<double, 6>& mounting, AdjustmentProblem* problem) = 0;
  /// True for sources whose blocks depend on the mounting they are built at (re-matched
  /// between solves until the mounting stops changing).
  virtual bool rematches() const { return false; }
  /// A matching source that is still in a coarse stage (its matches are not yet those it
  /// finishes with) returns false: the estimation goes on re-matching even if the mounting
  /// stopped changing.
  virtual bool settled() const { return true; }
  /// A σ of a distance that this kind estimated from the data where the calibration started —
  /// the mounting used and the nominal laser table — rather than one the user stated, with the
  /// least σ the kind allows (its floor) [m]; both 0 (the default) for stated σ. The adjustment
  /// checks it at the solution: where the kind's own σ₀² (its observations' residuals, not its
  /// priors) is below one half — the residuals scatter by less than 0.71 of that σ, clearly —
  /// the covariance is that of the estimate computed at the stated weights with the scatter the
  /// residuals show (a sandwich, N⁻¹ (Σ s_k N_k + the rest) N⁻¹, s_k = σ₀²_k, never below
  /// (floor/σ)²); the estimate itself is unchanged. An excess (σ₀²_k > 1) is left to the
  /// trajectory errors in time, which a strip's own fit cannot show.
  struct StartSigma {
    double sigma_m = 0.0;
    double floor_m = 0.0;
  };
  virtual StartSigma sigmaFromStart() const { return {}; }
  /// After each solve, while `problem` holds that solve's estimates (e.g. to carry nuisance
  /// values that persist across re-matchings into the next problem).
  virtual void solved(const AdjustmentProblem& problem) { (void)problem; }
  /// After the last solve, while `problem` holds the estimates: compute the kind's residual
  /// section (before at `mounting_used`, after at `mounting`).
  virtual void finish(const std::array<double, 6>& mounting_used, const std::array<double, 6>& mounting, const AdjustmentProblem& problem,
                      const AnalysisOptions& analysis) {
    (void)mounting_used, (void)mounting, (void)problem, (void)analysis;
  }
};

/// The method-independent part of a calibration's result.
struct AdjustmentSummary {
  using Mat6 = Eigen::Matrix<double, 6, 6>;
  TerminationType termination = TerminationType::kInvalidInput;
  std::string message;
  int iterations = 0;
  int rematch_rounds = 0;  ///< solves of the last estimation (1 when nothing re-matches), a restart's included
  /// The last estimation started again with the boresight first: its lever arm had moved more
  /// than AnalysisOptions::lever_arm_change_warning_m (re-matching sources only).
  bool boresight_first_restart = false;
  double initial_cost = 0.0;  ///< ½ Σ r², r normalised by σ [-]
  double final_cost = 0.0;
  double time_s = 0.0;               ///< wall time of the whole calibration [s]
  double construction_time_s = 0.0;  ///< of which: building the observations [s]
  double solve_time_s = 0.0;         ///< of which: Levenberg–Marquardt (all solves, matching included) [s]
  double analysis_time_s = 0.0;      ///< of which: observability and covariance [s]

  MountingParameters mounting_used;
  MountingParameters mounting;      ///< the complete mounting to use from now on
  std::array<bool, 6> estimated{};  ///< estimated (not fixed, not unobservable)
  std::array<double, 6> sigma{};    ///< std. deviation [m, rad]; NaN if not estimated
  /// The formal σ: observations taken as independent, no trajectory errors in time (what
  /// `sigma` was before TrajectoryAccuracy; equal to it when that is off) [m, rad].
  std::array<double, 6> formal_sigma{};
  /// What `sigma` contains: "formal" or "formal + trajectory errors in time".
  std::string sigma_model = "formal";
  Mat6 correlation = Mat6::Constant(std::nan(""));
  Mat6 covariance = Mat6::Constant(std::nan(""));  ///< of the estimated parameters [m, rad]
  /// "ceres::Covariance", or "reduced normal matrix" when Ceres could not compute it.
  std::string covariance_source;
  /// Normal matrix of the full mounting block once every nuisance block (tie positions,
  /// planes, strip offsets) is eliminated (Schur complement), at the estimate; unscaled.
  Mat6 reduced_normal_matrix = Mat6::Zero();
  double variance_factor = 1.0;  ///< σ₀² = 2·final_cost / degrees_of_freedom
  int degrees_of_freedom = 0;

  /// Parameters that were asked for but that the data cannot determine, and why.
  std::vector<std::string> unobservable;
  /// Column h (a parameter held by the observability rule, or fixed by the user): how far each
  /// estimated parameter moves per unit error of the held value (m/m, rad/m, m/rad or rad/rad;
  /// zero elsewhere). The estimated σ do not contain the held value's error: this says what it
  /// costs.
  Mat6 held_sensitivity = Mat6::Zero();
  std::string observability_report;
  double condition_number = 0.0;  ///< of the reduced normal matrix of the estimated block

  /// How far the mounting moves when a part of the model that the user switched on is switched
  /// off, against its σ (issue 26: "model-dependent" beyond 3σ). Today the one such part is a
  /// free lever arm (estimated without a prior): the boresight is re-solved, to first order,
  /// with the lever arm held at its used value — shift = −N_bb⁻¹ N_ba (a_used − â) from the
  /// reduced normal matrix.
  struct ModelSensitivity {
    std::string change;             ///< e.g. "the lever arm held at its used value"
    std::array<double, 6> shift{};  ///< of each estimated parameter [m, rad]; 0 elsewhere
    /// |shift| / σ, the σ the switched-off model states (conditional on the part switched off:
    /// the smaller of the two models' σ) [-]
    std::array<double, 6> shift_in_sigma{};
    /// How strongly the data reject the switched-off model: the largest |â − a_used| / σ of the
    /// parts switched off [-]. From 2 on (95 %) the data tell the two models apart: the shift is
    /// then the cost of a wrong model, not an ambiguity.
    double rejected_in_sigma = 0.0;
    /// The part switched off. kReported: a nuisance block a method reported
    /// (AdjustmentProblem::reportCovariance — the per-laser offsets).
    enum class Part { kLeverArm, kTimeOffset, kTrajectoryCorrections, kReported };
    Part part = Part::kReported;
    /// `shift` is first order with the same observations; a solve without the part matches and
    /// weighs again and can move further. For the per-laser offsets, when some first-order move
    /// reaches 1σ, MountingCalibrator solves again without them, started from the result:
    /// `solved` true and its moves here (0 where not estimated) [m, rad] and in σ [-].
    bool solved = false;
    std::array<double, 6> solved_shift{}, solved_shift_in_sigma{};
    /// Some |shift| (or solved shift) > 3σ while the data cannot tell the two models apart
    /// (rejected_in_sigma < 2) — or a solved shift > 3σ that the first order does not predict
    /// (unpredicted): rejected_in_sigma is a first-order test at the result, and a solve that
    /// lands elsewhere than the first order says has left it (Gravity Car's heading: 0.31° first
    /// order, 2.06° solved, 14.5σ; the mounting then depends on the model whatever the test says).
    bool model_dependent() const;
    /// Parameter j's solved shift is > 3σ and misses the first-order shift by more than half of
    /// itself and more than 3σ.
    bool unpredicted(int j) const;
    std::string text() const;  ///< one line for reports and the verdict
  };
  std::vector<ModelSensitivity> model_sensitivity;
  /// StochasticOptions::time_offset_sigma_s: the data's first-order estimate of the time offset
  /// (with its prior) and its σ [s]; NaN when not analysed. The mounting is not moved by it:
  /// model_sensitivity says how far it would move.
  double time_offset_s = std::numeric_limits<double>::quiet_NaN();
  double time_offset_sigma_s = std::numeric_limits<double>::quiet_NaN();
  /// True when the time offset above was estimated in the solve (StochasticOptions::
  /// estimate_time_offset), false when it is the first-order estimate beside it.
  bool time_offset_in_solve = false;
  /// StochasticOptions::corrections: each strip's estimated correction at the start and the end
  /// of its observations' time span (position [m] and attitude [rad], mapping axes) and the span.
  struct StripCorrection {
    std::string strip_id;
    double t_start_s = 0.0, t_end_s = 0.0;
    Vec3 position_start_m = Vec3::Zero(), position_end_m = Vec3::Zero();  ///< without the strip offset
    Vec3 attitude_start_rad = Vec3::Zero(), attitude_end_rad = Vec3::Zero();
    /// The prior's σ of the correction at the span's end, per axis (from the stated σ, or from
    /// the trajectory's accuracy: TrajectoryCorrections::priors_from_accuracy).
    Vec3 prior_end_position_m = Vec3::Zero(), prior_end_attitude_rad = Vec3::Zero();
  };
  std::vector<StripCorrection> strip_corrections;

  /// Residual blocks and residuals per kind of observation, in the order of the sources.
  struct KindCount {
    std::string kind;
    int blocks = 0;
    int residuals = 0;
    /// The kind's own σ₀² (Σ ρ(r²) over its observations / their redundancy), where its σ came
    /// from the data at the start (ObservationSource::sigmaFromStart); NaN otherwise.
    double variance_factor = std::nan("");
    /// The factor its normal-matrix share was given in the covariance (1: none; σ₀² below ½,
    /// not below the kind's floor).
    double covariance_scale = 1.0;
  };
  std::vector<KindCount> kinds;
  std::vector<std::pair<std::string, Vec3>> strip_offsets_m;  ///< estimated o_i [m]

  bool IsSolutionUsable() const { return termination == TerminationType::kConvergence; }
};

/// The adjustment: Ceres' Levenberg–Marquardt over the mounting, the strip offsets and every
/// source's blocks.
class MountingAdjustment {
 public:
  struct Options : MountingBlockOptions, StochasticOptions, SolverOptions, AnalysisOptions {
    /// False (with a message naming the group and field) when a value is out of range.
    bool IsValid(std::string* error) const;
  };
  using Summary = AdjustmentSummary;

  MountingAdjustment() = default;
  explicit MountingAdjustment(Options options) : options_(std::move(options)) {}
  const Options& options() const { return options_; }
  /// The platform's motion at a strip's time, for the time offset (StochasticOptions::
  /// time_offset_sigma_s); without it the time offset is not analysed.
  MountingAdjustment& setMotion(MotionFunction motion) {
    motion_ = std::move(motion);
    return *this;
  }

  /// Solves from `mounting_used`. Undeterminable parameters are named, held at their used
  /// values and the problem solved again. Numerical outcomes are in the summary (invalid
  /// options or no observation at all: kInvalidInput with a message). `sources` must outlive
  /// the call; each one's finish() is called before returning.
  /// `start` (optional, MountingIndex order [m, rad]): starting values of the estimated
  /// parameters (e.g. a closed-form answer); held ones stay at their used values.
  Summary solve(const MountingParameters& mounting_used, const std::vector<ObservationSource*>& sources,
                const std::array<double, 6>* start = nullptr) const;

 private:
  Options options_;
  MotionFunction motion_;
};

/// Robust scale of residual norms of one kind: 1.4826 · median / √(E χ²-median factor) — the
/// σ per axis of `dims`-dimensional Gaussian residuals whose norms have this median [-].
double robustScaleFromNorms(std::vector<double> norms, int dims);

}  // namespace mountcal
