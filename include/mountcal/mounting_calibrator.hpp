#pragma once
/// \file mounting_calibrator.hpp
/// Calibration of the six mounting parameters from overlapping strips: the registered methods
/// (methods/method.hpp) — virtual tie points (seed 000, SPEC §3), plane patches, automatic
/// point-to-plane correspondences, the second paper's targets, ground control — feeding one
/// adjustment (adjustment/mounting_adjustment.hpp), solved by Ceres' Levenberg–Marquardt.
///
/// Two levels, as in small_gicp: the configurable class MountingCalibrator, and the one-call
/// mountcal::calibrate(); both return the same value-type Summary: the method-independent core
/// (AdjustmentSummary) and one section per method that ran.

#include <array>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "mountcal/adjustment/mounting_adjustment.hpp"
#include "mountcal/data.hpp"
#include "mountcal/methods/method.hpp"
#include "mountcal/core/mounting.hpp"

namespace mountcal {

class MountingCalibrator {
 public:
  /// The adjustment's groups (mounting block, stochastic model, solver, analysis), the methods
  /// to run and each method's own options. Every field has its default and unit where it is
  /// declared.
  struct Options : MountingAdjustment::Options {
    /// The methods whose observations join the adjustment, by registered name ("vtpm",
    /// "planes", "correspondences", "features", …; `mountcal methods` lists them).
    std::vector<std::string> methods{"vtpm"};
    /// Each method's options, e.g. `options.method<PlaneOptions>().automatic = true`.
    MethodOptionsMap method_options;
    template <class T>
    T& method() {
      return method_options.get<T>();
    }
    template <class T>
    const T& method() const {
      return method_options.get<T>();
    }
    /// Worker threads for building the observations (the correspondence search and matchings);
    /// 0: every core. Results do not depend on it (each thread fills its own slots, combined in
    /// a fixed order). The solver's own threads are SolverOptions::num_threads.
    int threads = 0;
    /// False (with a message naming the method and option) when a value is out of range or a
    /// method is not registered.
    bool IsValid(std::string* error) const;
  };

  /// Whether a calibration should be used (issue 26): the verdict and its reasons, each a
  /// sentence a user can act on. Rules (Summary::verdict):
  ///  - reject: the solve is not usable; σ₀² above 10 (the residuals are
  ///    over three times the stated σ: outliers, a wrong model, or a wrong stochastic model);
  ///    nothing asked for could be determined;
  ///  - doubtful: a parameter asked for was held; σ₀² above 2 or below 0.3 (the σ do not match
  ///    the residuals — above 2, the stated σ are optimistic; below 0.3 not where every kind's σ
  ///    came from the data and its covariance takes the residuals' scatter,
  ///    ObservationSource::sigmaFromStart); fewer than 10 degrees of freedom
  ///    (none: nothing checks the result); more than 5 % of the observations flagged as outliers;
  ///    a model-dependent mounting (ModelSensitivity: switching off a free lever arm moves it by
  ///    over 3σ although the data cannot reject that); an estimated lever arm that moved further
  ///    than lever_arm_change_warning_m from its used value; a re-solve started from the result
  ///    (AnalysisOptions::resolve_check) that moves a parameter by more than 2σ, or fails —
  ///    reject beyond AnalysisOptions::resolve_reject_sigma (4.5σ by default);
  ///  - accept otherwise. A strong correlation is not a doubt by itself: the σ carry it (the
  ///    report's warnings name it).
  struct Verdict {
    enum class Kind { kAccept, kDoubtful, kReject };
    Kind kind = Kind::kAccept;
    std::vector<std::string> reasons;  ///< empty for kAccept; a reject's own reasons first
    const char* name() const { return kind == Kind::kAccept ? "accept" : kind == Kind::kDoubtful ? "doubtful" : "reject"; }
  };

  struct Summary : AdjustmentSummary {
    std::vector<std::string> methods;  ///< the methods that were run
    /// AnalysisOptions::lever_arm_change_warning_m of the run, for the verdict [m].
    double lever_arm_change_warning_m = 0.5;
    /// AnalysisOptions::resolve_check: a second solve started from this one's estimate, with
    /// every mounting-dependent observation selected again there.
    struct ResolveCheck {
      bool done = false;                       ///< false: switched off, the solve failed, or nothing re-matches
      bool usable = false;                     ///< the second solve converged
      MountingParameters mounting;             ///< its estimate
      std::array<double, 6> shift{};           ///< its estimate − this estimate [m, rad]; 0 where not estimated
      std::array<double, 6> shift_in_sigma{};  ///< |shift| / sigma [-]
      double time_s = 0.0;                     ///< its wall time (included in time_s) [s]
      /// The largest shift_in_sigma [-].
      double largestInSigma() const;
      /// More than 2σ, or the second solve failed: the result depends on where the solve started.
      bool unsettled() const { return done && (!usable || largestInSigma() > 2.0); }
      /// AnalysisOptions::resolve_reject_sigma of the run [σ].
      double reject_sigma = 4.5;
      /// A converged re-solve that moved some parameter by more than reject_sigma (a finite move).
      bool rejects() const {
        const double z = largestInSigma();
        return done && usable && std::isfinite(z) && z > reject_sigma;
      }
      std::string text() const;  ///< one line for reports and the verdict
    };
    ResolveCheck resolve;
    /// One section per module that ran (the named methods, and ground control when used), in
    /// registry order.
    std::vector<std::shared_ptr<const MethodSection>> sections;
    /// The section of a method, or null when it did not run.
    const MethodSection* section(const std::string& method) const;
    /// The first section of type T (e.g. PlaneSection), or null.
    template <class T>
    const T* find() const {
      for (const auto& s : sections)
        if (const T* t = dynamic_cast<const T*>(s.get())) return t;
      return nullptr;
    }
    /// The section of type T, or an empty one (zero counts) when its method did not run.
    template <class T>
    const T& section() const {
      static const T empty{};
      const T* t = find<T>();
      return t ? *t : empty;
    }
    bool uses(const std::string& method) const;
    /// Per-laser intrinsics a method estimated, by laser id (empty: none).
    LaserCorrections laserCorrections() const;
    std::string BriefReport() const;
    /// Ends with the verdict and its reasons.
    std::string FullReport() const;
    Verdict verdict() const;
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
MountingCalibrator::Summary calibrate(const CalibrationData& data, const MountingCalibrator::Options& options = {});

}  // namespace mountcal
