#pragma once
// Internal (not installed): per-laser elevation offsets of a multi-beam scanner as one nuisance
// block of the adjustment, for the methods that take them from observations of their own kind
// (features, planes; the dense correspondences carry all five groups in their own block):
// the block, its priors, its values carried from solve to solve, its σ in the mounting's
// stochastic model, and the section's table and result-file entry.

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "mountcal/adjustment/mounting_adjustment.hpp"
#include "mountcal/core/error.hpp"
#include "mountcal/core/sensor_model.hpp"
#include "mountcal/data.hpp"

namespace mountcal::detail {

/// A section's table of per-laser elevation offsets: one line per laser id under `title`;
/// `points_label` heads the count column.
std::string laserElevationTable(const LaserElevationOffsets& e, const std::string& title, const std::string& points_label);
/// The same as an HTML table under an `<h3>` of `title`.
std::string laserElevationHtml(const LaserElevationOffsets& e, const std::string& title, const std::string& points_label);
/// The result file's `intrinsics` (apply and evaluate read them): offsets, σ and points by laser id (JSON text).
std::string laserElevationIntrinsics(const LaserElevationOffsets& e);

/// MethodSection::doubts() of a section's elevation offsets: laserPriorDoubts against their prior.
std::vector<std::string> laserElevationDoubts(const LaserElevationOffsets& e);

/// MethodSection::doubts() of per-laser intrinsics: the parameters of `lasers` estimated beyond
/// kLaserPriorDoubt times their group's prior σ (`prior_sigma`, 0 for a group not estimated; lasers
/// with `points[i] == 0` skipped) — empty, or one sentence naming up to four of them.
std::vector<std::string> laserPriorDoubts(const LaserCorrections& lasers, const std::vector<int>& points,
                                          const LaserCorrection& prior_sigma);

/// Per-laser elevation offsets δω_l as one block of the adjustment (exact turn of a laser vector:
/// r' = cos δω r + sin δω u, u = elevationTangent(r), LaserCorrector): each δω_l ~ N(0, σ), their
/// mean over the lasers the observations use held at 0 (a common offset is the boresight pitch's).
class LaserElevationBlock {
 public:
  /// The lasers of every strip (ids 0..max); throws InvalidInput naming the strip when one has no laser ids.
  void setUp(const CalibrationData& data, const std::string& method);
  int lasers() const { return static_cast<int>(values_.size()); }
  /// Adds the block and its priors; `seen[l]`: laser l has observations. Returns the block.
  double* add(AdjustmentProblem* problem, const std::vector<bool>& seen, double sigma_deg);
  double* block() const { return block_; }
  /// Keeps the solved values for the next round's block.
  void solved() {
    if (block_) std::copy(block_, block_ + lasers(), values_.begin());
  }
  /// The estimates, their σ (AdjustmentProblem::reportedCovariance), `points` per laser and the
  /// prior σ they were added with.
  LaserElevationOffsets finish(const AdjustmentProblem& adjustment, const std::vector<int>& points) const;

 private:
  std::vector<double> values_;  // carried from solve to solve [rad]
  double* block_ = nullptr;     // this round's block
  double prior_deg_ = 0.0;      // the priors' σ add() was given [deg]
};

/// A cost function of blocks (…, 1) seen as (…, L): its last block is element `index` of a
/// block of `size` values (one laser's offset in the block of all lasers). Owns `inner`.
class OneOfBlock final : public ceres::CostFunction {
 public:
  OneOfBlock(ceres::CostFunction* inner, int index, int size);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  std::unique_ptr<ceres::CostFunction> inner_;
  int index_, size_;
};

}  // namespace mountcal::detail
