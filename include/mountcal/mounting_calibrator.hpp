#pragma once
/// \file mounting_calibrator.hpp
/// Calibration of the six mounting parameters from overlapping strips: the methods of
/// DESIGN.md — virtual tie points (seed 000, SPEC §3), plane patches, automatic point-to-plane
/// correspondences, ground control — feeding one adjustment (adjustment/mounting_adjustment.hpp),
/// solved by Ceres' Levenberg–Marquardt trust region.
///
/// Two levels, as in small_gicp: the configurable class MountingCalibrator, and the one-call
/// mountcal::calibrate(); both return the same value-type Summary: the method-independent core
/// (AdjustmentSummary) and one residual section per kind of observation.

#include <memory>
#include <string>
#include <vector>

#include "mountcal/adjustment/mounting_adjustment.hpp"
#include "mountcal/data.hpp"
#include "mountcal/methods/correspondence/correspondences.hpp"
#include "mountcal/methods/features/feature_observations.hpp"
#include "mountcal/methods/planes/plane_observations.hpp"
#include "mountcal/methods/vtpm/tie_observations.hpp"
#include "mountcal/mounting.hpp"
#include "mountcal/virtual_tie_point.hpp"

namespace mountcal {

/// The calibration methods (SPEC §4 "method"); any combination joins one adjustment.
enum class CalibrationMethod { kVtpm, kPlanes, kCorrespondences, kFeatures };
const char* toString(CalibrationMethod m);  ///< "vtpm", "planes", "correspondences", "features"

class MountingCalibrator {
 public:
  /// The adjustment's groups (mounting block, stochastic model, solver, analysis) and one group
  /// per method. Every field has its default and unit where it is declared.
  struct Options : MountingAdjustment::Options, TieObservationOptions {
    std::vector<CalibrationMethod> methods{CalibrationMethod::kVtpm};
    VtpOptions vtp;
    PlaneOptions planes;
    CorrespondenceOptions correspondence;
    FeatureOptions features;
    /// Worker threads for building the observations (the correspondence search and matchings);
    /// 0: every core. Results do not depend on it (each thread fills its own slots, combined in
    /// a fixed order). The solver's own threads are SolverOptions::num_threads.
    int threads = 0;
    /// False (with a message) when a value is out of range.
    bool IsValid(std::string* error) const;
  };

  struct Summary : AdjustmentSummary {
    std::vector<std::string> methods;  ///< the methods that were run
    // ---- the ties' section (method "vtpm"; seed Table 1) --------------------------------
    int ties_used = 0;               ///< distinct ties in the adjustment
    int observations_used = 0;       ///< tie observations in the adjustment
    std::vector<RejectedTie> rejected;
    std::vector<TieResidual> residuals;
    Vec3 rms_before_m = Vec3::Zero();  ///< per axis [m]
    Vec3 rms_after_m = Vec3::Zero();
    /// The tie σ of the last solve: as stated, or estimated (TieObservationOptions::estimate_tie_sigma) [m].
    double tie_sigma_xy_m = 0.0, tie_sigma_z_m = 0.0;
    bool tie_sigma_estimated = false;
    // ---- the other kinds --------------------------------------------------------------------
    TieSection control;                       ///< GCPs observed on every strip (non-VTPM methods)
    PlaneSection planes;                      ///< method "planes"
    CorrespondenceSection correspondences;    ///< method "correspondences"
    /// Method "features": targets, per-pair offsets and the paper's closed form (the rigorous
    /// estimate is the summary's mounting; the adjustment starts from the closed form).
    FeatureSection features;

    bool uses(CalibrationMethod m) const;
    std::string BriefReport() const;
    std::string FullReport() const;
  };

  MountingCalibrator() = default;
  explicit MountingCalibrator(Options options) : options_(std::move(options)) {}
  const Options& options() const { return options_; }

  /// Builds every method's observations and solves. Never throws for numerical outcomes (they
  /// are in the Summary); throws InvalidInput for structurally invalid data (no trajectory, a
  /// tie naming an unknown strip), TimeOutOfRange for a strip point outside the trajectory.
  Summary calibrate(const CalibrationData& data) const;

 private:
  Options options_;
};

/// One call: `MountingCalibrator(options).calibrate(data)`.
MountingCalibrator::Summary calibrate(const CalibrationData& data,
                                      const MountingCalibrator::Options& options = {});

}  // namespace mountcal
