#pragma once
/// \file methods/common/tie_observations.hpp
/// Virtual tie points (seed 000, SPEC §3) as observations of the one adjustment, and ground
/// control observed through virtual tie points on every strip that covers it.
///
/// Every tie observation (k, i) is one
/// `ceres::NumericDiffCostFunction<VtpResidual, ceres::CENTRAL, 3, 6, 3, 3>` with residual
/// `(P_ki(M) + o_i − X_k) / σ` — the central differences of seed eq. (10) — where X_k, the
/// tie's ground position, is a nuisance block and o_i the strip offset. At the optimum X_k is
/// the mean of seed eq. (7). A ground control point adds a prior on X_k.

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "mountcal/adjustment/mounting_adjustment.hpp"
#include "mountcal/data.hpp"
#include "mountcal/methods/common/virtual_tie_point.hpp"

namespace mountcal {

/// A rejected tie observation and why.
struct RejectedTie {
  std::string tie_id, strip_id;
  std::string reason;
};

/// One tie observation's residual before and after the adjustment (seed Table 1).
struct TieResidual {
  std::string tie_id, strip_id;
  Vec3 before_m = Vec3::Zero();  ///< P_ki(M_used) − mean_k, seed eq. (8) [m]
  Vec3 after_m = Vec3::Zero();   ///< P_ki(M̂) + o_i − X̂_k [m]
  bool outlier = false;          ///< flagged after the solve (AnalysisOptions::outlier_factor)
};

/// The stochastic model of a tie observation.
struct TieObservationOptions {
  /// A-priori standard deviation of a tie observation: horizontal (picking) and vertical
  /// (Rule 1 interpolation) [m].
  double tie_sigma_xy_m = 0.10;
  double tie_sigma_z_m = 0.05;
  /// Estimate the two σ above from the residuals instead of trusting them: variance component
  /// estimation (Förstner 1979) of the horizontal and the vertical component, each
  /// observation's redundancy taken as (k−1)/k for a tie seen on k strips; the solve is
  /// repeated with the new σ until they change by less than 1 % (at most
  /// SolverOptions::max_rematch_rounds solves). The mounting's covariance then follows the
  /// picking precision the data show, not the one stated.
  bool estimate_tie_sigma = false;
  bool IsValid(std::string* error) const;
};

/// What a module that picks virtual tie points needs (methods "vtpm" and "control"): the picks'
/// stochastic model and the virtual tie point's construction.
struct TiePickOptions : TieObservationOptions {
  VtpOptions vtp;
};

/// The residual section of the ties (or of the control points).
struct TieSection {
  int ties_used = 0;          ///< distinct ties in the adjustment
  int observations_used = 0;  ///< tie observations in the adjustment
  std::vector<RejectedTie> rejected;
  std::vector<TieResidual> residuals;
  Vec3 rms_before_m = Vec3::Zero();  ///< per axis [m]
  Vec3 rms_after_m = Vec3::Zero();
  /// The σ used in the last solve: the stated ones, or those estimated (estimate_tie_sigma) [m].
  double sigma_xy_m = 0.0, sigma_z_m = 0.0;
  bool sigma_estimated = false;
  /// Observations whose pick moves with its neighbourhood, an affine combination of its points
  /// (VtpMotion::kNeighbourhood: a multi-beam strip's), the others with their triangle [-].
  int neighbourhood_motion = 0;
  /// Observations flagged as outliers [-].
  int outlierCount() const {
    int n = 0;
    for (const TieResidual& r : residuals) n += r.outlier;
    return n;
  }
};

class VtpStrip;

/// Tie picks (kind "ties") or ground control points picked on every strip (kind "control").
class TieObservations final : public ObservationSource {
 public:
  /// Builds the virtual tie points of `picks` at `data.mounting_used`. GCPs whose id equals a
  /// tie's become priors on that tie's position. Throws InvalidInput for a pick naming a strip
  /// that is not in `data`.
  /// `threads`: the strips' k-d trees and the virtual tie points are built on this many
  /// threads (0: every core); the result does not depend on it.
  TieObservations(const CalibrationData& data, const std::vector<TieObservation>& picks, const std::vector<GroundControlPoint>& gcps,
                  const TieObservationOptions& options, const VtpOptions& vtp, std::string kind = "ties", int threads = 0);
  /// Ground control with any method: each GCP picked at its plan position on every strip whose
  /// points cover it (strips that do not are skipped, not rejected).
  static std::unique_ptr<TieObservations> control(const CalibrationData& data, const std::vector<GroundControlPoint>& gcps,
                                                  const TieObservationOptions& options, const VtpOptions& vtp, int threads = 0);
  ~TieObservations() override;

  std::string kind() const override { return kind_; }
  /// Control points are picked again at each new mounting; ties are not, but are solved again
  /// while their σ are being estimated.
  bool rematches() const override { return kind_ == "control" || estimatesSigma(); }
  bool settled() const override { return !estimatesSigma() || sigma_settled_; }
  void addBlocks(const std::array<double, 6>& mounting, AdjustmentProblem* problem) override;
  void solved(const AdjustmentProblem& problem) override;
  void finish(const std::array<double, 6>& mounting_used, const std::array<double, 6>& mounting, const AdjustmentProblem& problem,
              const AnalysisOptions& analysis) override;

  /// Observations usable in the adjustment (0: nothing to add).
  int observationCount() const { return section_.observations_used; }
  const TieSection& section() const { return section_; }
  const std::vector<VirtualTiePoint>& virtualTiePoints() const { return vtps_; }

 private:
  void build(const MountingParameters& reference);
  int threads_ = 0;
  bool estimatesSigma() const { return kind_ == "ties" && options_.estimate_tie_sigma; }
  struct Tie {
    std::string id;
    std::vector<int> obs;  // indices into vtps_
    const GroundControlPoint* gcp = nullptr;
    Vec3 mean_m = Vec3::Zero();  // seed eq. (7) at M_used
    double* X = nullptr;         // the nuisance block of the current problem
  };
  std::string kind_;
  TieObservationOptions options_;
  std::vector<GroundControlPoint> gcps_;
  std::vector<VirtualTiePoint> vtps_;
  std::vector<Tie> ties_;
  std::vector<int> blocks_;                    // residual block of each observation, in ties_ order
  std::vector<Mat3> whitening_;                // W of each observation (WᵀW = Σ⁻¹), in ties_ order
  std::vector<double> redundancy_;             // (k−1)/k of each observation, in ties_ order
  std::vector<Mat3> pick_cofactor_;            // J Jᵀ of each observation's plan pick (see pickCofactor), in ties_ order
  double sigma_xy_m_ = 0.0, sigma_z_m_ = 0.0;  // σ of the current solve [m]
  bool sigma_settled_ = false;
  TieSection section_;
  const CalibrationData* data_ = nullptr;
  std::vector<TieObservation> picks_;
  VtpOptions vtp_;
  std::array<double, 6> built_at_{};
};

}  // namespace mountcal
