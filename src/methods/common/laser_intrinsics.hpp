#pragma once
// Internal (not installed): per-laser intrinsics of a multi-beam scanner (LaserCorrection's five
// groups) as one nuisance block of the adjustment, shared by the methods that estimate them
// (dense correspondences, planes, features): where each value sits in the block, its priors, its
// σ and correlation screening in the mounting's stochastic model, and the section's table,
// result-file entry, doubts and warnings.

#include <ceres/ceres.h>

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "mountcal/adjustment/mounting_adjustment.hpp"
#include "mountcal/core/sensor_model.hpp"
#include "mountcal/data.hpp"
#include "mountcal/methods/common/laser_priors.hpp"
#include "mountcal/methods/method.hpp"

namespace mountcal::detail {

/// `t` with the five job options of LaserIntrinsicsPriors added (T derives from it), each row's
/// meaning after `context` ("dense mode: ", "multi-beam strips with laser ids: ").
template <class T>
OptionTable<T> laserPriorOptions(OptionTable<T> t, const std::string& context) {
  t.number(
      "laser_elevation_sigma_deg", [](T& o) -> double& { return o.laser_elevation_sigma_deg; }, "deg", 0, 10,
      context + "prior sigma of per-laser elevation offsets (mean held at 0); 0: not estimated");
  t.number(
      "laser_azimuth_sigma_deg", [](T& o) -> double& { return o.laser_azimuth_sigma_deg; }, "deg", 0, 10,
      context + "prior sigma of per-laser azimuth offsets (mean held at 0); 0: not estimated");
  t.number(
      "laser_range_sigma_m", [](T& o) -> double& { return o.laser_range_sigma_m; }, "m", 0, 1,
      context + "prior sigma of per-laser range offsets; 0: not estimated");
  t.number(
      "laser_vertical_sigma_m", [](T& o) -> double& { return o.laser_vertical_sigma_m; }, "m", 0, 1,
      context + "prior sigma of per-laser vertical origin offsets (mean held at 0); 0: not estimated");
  t.number(
      "laser_horizontal_sigma_m", [](T& o) -> double& { return o.laser_horizontal_sigma_m; }, "m", 0, 1,
      context + "prior sigma of per-laser horizontal origin offsets; 0: not estimated");
  return t;
}

/// Where the per-laser intrinsics sit in their parameter block: the estimated groups in
/// LaserCorrection's order (elevation, azimuth, range, vertical, horizontal), each one value per
/// laser (group g's value of laser l at offset[g] + l).
struct LaserLayout {
  int lasers = 0;
  std::array<int, 5> offset{{-1, -1, -1, -1, -1}};  // −1: the group is not estimated
  int size = 0;
  LaserLayout() = default;
  /// The groups whose prior σ in `prior` is positive, for `laser_count` lasers.
  LaserLayout(int laser_count, const LaserCorrection& prior);
  bool empty() const { return size == 0; }
  bool elevationOnly() const { return size > 0 && size == lasers && offset[0] == 0; }
  LaserCorrection correction(const double* block, int laser) const;
  LaserCorrections corrections(const double* block) const;
};

/// The priors of a block laid out by `layout`: each value N(0, its group's σ in `prior`), and the
/// means of elevation (the boresight pitch's direction, by convention), azimuth (a boresight
/// rotation about the spin axis) and vertical offsets (the lever arm along it) over the lasers
/// `seen` held at 0 (a laser no observation sees keeps its prior alone, and does not carry the
/// others' mean). Range and horizontal offsets keep their common part.
void addLaserPriors(AdjustmentProblem* problem, double* block, const LaserLayout& layout, const LaserCorrection& prior,
                    const std::vector<bool>& seen);

/// The estimates of a block laid out by `layout`, their σ and correlation screening from the joint
/// covariance of the mounting and the block in the mounting's stochastic model
/// (AdjustmentProblem::reportCovariance), with `points` per laser and the priors they had.
/// `block_change` (optional, the block's size square): added to the block's own covariance (a
/// method whose formal part it replaces, AdjustmentProblem::leaveOneOutCovariance).
LaserIntrinsicEstimates laserEstimates(const AdjustmentProblem& adjustment, const double* block, const LaserLayout& layout,
                                       const LaserCorrection& prior, const std::vector<int>& points,
                                       const Eigen::MatrixXd& block_change = Eigen::MatrixXd());

/// A section's text table of the estimated groups (value and σ each), each laser's largest
/// |correlation| with the boresight and its `points_label` count, under `title`, and the
/// correlation screening's line.
std::string laserIntrinsicsText(const LaserIntrinsicEstimates& e, const std::string& title, const std::string& points_label);
/// The same as an HTML table under an `<h3>` of `title`.
std::string laserIntrinsicsHtml(const LaserIntrinsicEstimates& e, const std::string& title, const std::string& points_label);
/// The result file's `intrinsics` (apply and evaluate read them): per group
/// `laser_<group>_offset_<unit>` and `_sigma_<unit>`, the boresight correlations, the points and
/// the screening (JSON text).
std::string laserIntrinsicsJson(const LaserIntrinsicEstimates& e);
/// MethodSection::doubts() of per-laser intrinsics: laserPriorDoubts against their priors.
std::vector<std::string> laserIntrinsicsDoubts(const LaserIntrinsicEstimates& e);
/// Warnings for intrinsics beyond a working sensor's (range 0.10 m, origin 0.05 m, angles 1°).
std::vector<std::string> laserImplausibleWarnings(const LaserCorrections& lasers);

/// MethodSection::doubts() of per-laser intrinsics: the parameters of `lasers` estimated beyond
/// kLaserPriorDoubt times their group's prior σ (`prior_sigma`, 0 for a group not estimated; lasers
/// with `points[i] == 0` skipped) — empty, or one sentence naming up to four of them.
std::vector<std::string> laserPriorDoubts(const LaserCorrections& lasers, const std::vector<int>& points,
                                          const LaserCorrection& prior_sigma);

/// Per-laser intrinsics as one block of the adjustment, for the methods that add it to
/// observations of their own kind (planes, features): the values carried from solve to solve,
/// the priors (addLaserPriors) and the estimates (laserEstimates).
class LaserIntrinsicsBlock {
 public:
  /// The lasers of every strip (ids 0..max) and the groups of `prior` (σ > 0); throws InvalidInput
  /// naming the strip when one has no laser ids.
  void setUp(const CalibrationData& data, const std::string& method, const LaserCorrection& prior);
  int lasers() const { return layout_.lasers; }
  const LaserLayout& layout() const { return layout_; }
  /// Adds the block and its priors; `seen[l]`: laser l has observations. Returns the block.
  double* add(AdjustmentProblem* problem, const std::vector<bool>& seen);
  double* block() const { return block_; }
  /// Keeps the solved values for the next round's block.
  void solved() {
    if (block_) std::copy(block_, block_ + layout_.size, values_.begin());
  }
  /// The estimates, their σ and screening, with `points` per laser.
  LaserIntrinsicEstimates finish(const AdjustmentProblem& adjustment, const std::vector<int>& points,
                                 const Eigen::MatrixXd& block_change = Eigen::MatrixXd()) const;

 private:
  LaserLayout layout_;
  LaserCorrection prior_;
  std::vector<double> values_;  // carried from solve to solve [rad, m]
  double* block_ = nullptr;     // this round's block
};

/// A cost function of blocks (…, 5) seen as (…, layout.size): its last block is one laser's five
/// groups (LaserCorrection's order), taken from the block of every laser's estimated groups
/// (LaserLayout; a group not estimated is 0 and has no column). Owns `inner`.
class OneLaserOfBlock final : public ceres::CostFunction {
 public:
  OneLaserOfBlock(ceres::CostFunction* inner, const LaserLayout& layout, int laser);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  std::unique_ptr<ceres::CostFunction> inner_;
  std::array<int, 5> index_;  // the group's column in the whole block, −1: not estimated
  int size_;
};

}  // namespace mountcal::detail
