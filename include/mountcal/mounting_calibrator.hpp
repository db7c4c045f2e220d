#pragma once
/// \file mounting_calibrator.hpp
/// Rigorous self-calibration of the six mounting parameters with the virtual tie point model
/// (seed 000 §2.2–2.4, SPEC §3), solved by Ceres' Levenberg–Marquardt trust region.
///
/// Unknowns: the mounting 6-vector (lever arm [m], boresight [rad]; any subset held fixed) and
/// each tie's ground position X_k. Every tie observation (k, i) is one
/// `ceres::NumericDiffCostFunction<VtpResidual, ceres::CENTRAL, 3, 6, 3, 3>` with residual
/// `(P_ki(M) + o_i − X_k) / σ` — the central differences of seed eq. (10) — where o_i is the
/// offset of strip i (a random effect with a prior, see Options::strip_offset_sigma_m; 0 and
/// held constant when switched off, which is the paper's model). At the optimum X_k is the mean
/// of seed eq. (7). Ground control points add a prior on X_k.
///
/// Two levels, as in small_gicp: the configurable class MountingCalibrator, and the one-call
/// mountcal::calibrate(); both return the same value-type Summary.

#include <memory>
#include <string>
#include <vector>

#include "mountcal/mounting.hpp"
#include "mountcal/observations.hpp"
#include "mountcal/trajectory.hpp"
#include "mountcal/virtual_tie_point.hpp"

namespace mountcal {

/// Everything a calibration needs: the delivered trajectory, the mounting the strips were
/// georeferenced with, the strips' raw observations, the tie picks, optional GCPs.
struct CalibrationData {
  std::shared_ptr<const Trajectory> trajectory;
  MountingParameters mounting_used;      ///< the reference mounting of the strips
  std::vector<StripData> strips;
  std::vector<TieObservation> ties;
  std::vector<GroundControlPoint> gcps;  ///< priors on the ties with the same id
};

/// How a calibration ended (after Ceres' TerminationType).
enum class TerminationType {
  kConvergence,     ///< a tolerance was met: the solution is usable
  kNoConvergence,   ///< iteration or time limit reached first: not usable
  kFailure,         ///< the solver failed (numerical trouble)
  kInvalidInput,    ///< options or data invalid; see Summary::message
};
const char* toString(TerminationType t);

/// Robust loss applied to the tie residuals.
enum class LossType { kTrivial, kHuber, kCauchy };

/// A rejected tie observation and why.
struct RejectedTie {
  std::string tie_id, strip_id;
  std::string reason;
};

/// One tie observation's residual before and after the adjustment (seed Table 1).
struct TieResidual {
  std::string tie_id, strip_id;
  Vec3 before_m = Vec3::Zero();  ///< P_ki(M_used) − mean_k, seed eq. (8) [m]
  Vec3 after_m = Vec3::Zero();   ///< P_ki(M̂) − X̂_k [m]
  bool outlier = false;          ///< flagged after the solve (see Options::outlier_factor)
};

class MountingCalibrator {
 public:
  struct Options {
    /// Which of the six parameters to estimate, in MountingIndex order. Default: all but the
    /// vertical lever arm, which flat ground and level flight cannot determine without GCPs.
    std::array<bool, 6> estimate{true, true, false, true, true, true};
    /// Optional priors on the mounting (MountingIndex order); a prior with sigma ≤ 0 or NaN is
    /// off. Values [m, rad]; sigmas [m, rad].
    std::array<double, 6> prior_value{0, 0, 0, 0, 0, 0};
    std::array<double, 6> prior_sigma{0, 0, 0, 0, 0, 0};
    /// A-priori standard deviation of a tie observation: horizontal (picking) and vertical
    /// (Rule 1 interpolation) [m].
    double tie_sigma_xy_m = 0.10;
    double tie_sigma_z_m = 0.05;
    /// Trajectory errors that stay nearly constant over a strip (GNSS, PPK) are modelled as
    /// one 3-D offset per strip, a random effect with this prior standard deviation per axis
    /// [m]. They are estimated with the mounting, so its covariance carries their uncertainty.
    /// 0 switches them off (strips then trusted exactly).
    double strip_offset_sigma_m = 0.02;
    LossType loss = LossType::kTrivial;
    double loss_scale_m = 0.5;  ///< where the robust loss starts to bend [m]
    /// Levenberg–Marquardt. The paper's termination (seed step 8) is a cost change or a
    /// parameter change below a tolerance: function_tolerance and parameter_tolerance.
    int max_iterations = 100;
    double function_tolerance = 1e-10;   ///< relative cost change [-]
    double parameter_tolerance = 1e-10;  ///< relative parameter change [-]
    double gradient_tolerance = 1e-12;   ///< [-]
    double max_solver_time_s = 60.0;     ///< [s]
    int num_threads = 1;
    /// Central-difference step, relative (Ceres NumericDiffOptions) [-].
    double numeric_diff_relative_step = 1e-6;
    /// A direction of the mounting that keeps less than this fraction of its information once
    /// the tie positions are eliminated cannot be determined by the data [-].
    double observability_threshold = 1e-3;
    /// Scale the covariance by the a-posteriori variance factor σ₀². Off by default: the
    /// covariance then follows the stated a-priori sigmas, and variance_factor tells how well
    /// they match the residuals (≈ 1 when they do).
    bool scale_covariance_by_variance_factor = false;
    /// An observation whose residual norm exceeds this many times the robust residual scale
    /// (1.4826 · median / 1.54 per axis) is flagged as an outlier [-].
    double outlier_factor = 4.0;
    VtpOptions vtp;

    /// False (with a message) when a value is out of range.
    bool IsValid(std::string* error) const;
  };

  struct Summary {
    TerminationType termination = TerminationType::kInvalidInput;
    std::string message;
    int iterations = 0;
    double initial_cost = 0.0;    ///< ½ Σ r², r normalised by σ [-]
    double final_cost = 0.0;
    double time_s = 0.0;          ///< wall time of the whole calibration [s]
    double construction_time_s = 0.0;  ///< of which: k-d trees and virtual tie points [s]
    double solve_time_s = 0.0;         ///< of which: Levenberg–Marquardt (all solves) [s]
    double analysis_time_s = 0.0;      ///< of which: observability and covariance [s]

    MountingParameters mounting_used;
    MountingParameters mounting;  ///< the complete mounting to use from now on
    std::array<bool, 6> estimated{};       ///< estimated (not fixed, not unobservable)
    std::array<double, 6> sigma{};         ///< std. deviation [m, rad]; NaN if not estimated
    Eigen::Matrix<double, 6, 6> correlation = Eigen::Matrix<double, 6, 6>::Constant(std::nan(""));
    double variance_factor = 1.0;          ///< σ₀² = 2·final_cost / (residuals − unknowns)
    int degrees_of_freedom = 0;

    /// Parameters that were asked for but that the data cannot determine, and why.
    std::vector<std::string> unobservable;
    std::string observability_report;
    double condition_number = 0.0;  ///< of the reduced normal matrix of the estimated block

    int ties_used = 0;               ///< distinct ties in the adjustment
    int observations_used = 0;       ///< tie observations in the adjustment
    std::vector<RejectedTie> rejected;
    std::vector<TieResidual> residuals;
    std::vector<std::pair<std::string, Vec3>> strip_offsets_m;  ///< estimated o_i [m]
    Vec3 rms_before_m = Vec3::Zero();  ///< per axis [m]
    Vec3 rms_after_m = Vec3::Zero();

    bool IsSolutionUsable() const { return termination == TerminationType::kConvergence; }
    std::string BriefReport() const;
    std::string FullReport() const;
  };

  MountingCalibrator() = default;
  explicit MountingCalibrator(Options options) : options_(std::move(options)) {}
  const Options& options() const { return options_; }

  /// Builds the virtual tie points and solves. Never throws for numerical outcomes (they are
  /// in the Summary); throws InvalidInput for structurally invalid data (no trajectory, a tie
  /// naming an unknown strip), TimeOutOfRange for a strip point outside the trajectory.
  Summary calibrate(const CalibrationData& data) const;

 private:
  Options options_;
};

/// One call: `MountingCalibrator(options).calibrate(data)`.
MountingCalibrator::Summary calibrate(const CalibrationData& data,
                                      const MountingCalibrator::Options& options = {});

}  // namespace mountcal
