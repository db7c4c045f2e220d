#pragma once
/// \file plan/planner.hpp
/// The flight-plan observability planner (`mountcal plan PLAN.json`): before anyone flies,
/// which mounting parameters a planned calibration flight determines, how well (σ, correlations,
/// condition number), and — for the weakest parameter — which line or ground feature to add.
///
/// A prediction simulates the planned survey without noise, with the true mounting equal to the
/// nominal one, and builds the one adjustment (adjustment/mounting_adjustment.hpp) at that truth
/// with the plan's stochastic model: the covariance of the mounting is then the a-priori one, the
/// σ a calibration with that noise would report (its scatter over repeated flights; a test checks
/// it against 30+ simulated calibrations with independent noise).

#include <array>
#include <string>
#include <vector>

#include "mountcal/mounting_calibrator.hpp"
#include "mountcal/simulation/scene.hpp"
#include "mountcal/simulation/survey.hpp"

namespace mountcal::plan {

/// A planned line: flown from `start` to `end` (plan coordinates [m]) at a height above the
/// ground datum and a ground speed.
struct PlannedLine {
  std::string id;
  double x0_m = 0, y0_m = 0, x1_m = 0, y1_m = 0;
  double height_m = 0;
  double speed_mps = 0;
};

/// A ground control point: a feature of the ground (a target's centre or corner, a roof point)
/// whose coordinates are surveyed, with its σ.
struct PlannedGcp {
  std::string feature_id;
  double sigma_xy_m = 0.02, sigma_z_m = 0.02;
};

/// Everything a plan file holds, ready to simulate.
struct Plan {
  std::string name = "plan";
  std::string path;  ///< the plan file readPlan() read (named in errors); empty for a plan built in code
  std::vector<PlannedLine> lines;
  /// Sensor, noise, mounting (nominal = truth), ROI and attitude dynamics; `lines` is filled
  /// from `Plan::lines` by surveyConfig().
  simulation::SurveyConfig survey;
  /// What the ground offers: flat or sloped ground, gable or monopitch roofs of given slope and aspect,
  /// square ground targets (buildScene() makes the scene to simulate).
  struct Roof {
    std::string id;
    double x_m = 0, y_m = 0, slope_deg = 30, aspect_deg = 0, size_m = 12, eave_height_m = 6;
    /// Gable (faces towards aspect and aspect + 180°) or monopitch (one face towards aspect, its
    /// low eave at eave_height_m).
    bool monopitch = false;
  };
  struct Target {
    std::string id;
    double x_m = 0, y_m = 0, size_m = 1.5;
  };
  double ground_z_m = 0, ground_gx = 0, ground_gy = 0;
  std::vector<Roof> roofs;
  std::vector<Target> targets;
  std::vector<PlannedGcp> gcps;
  /// Methods and the stochastic model (σ of ties, planes, strip offsets, per-pulse noise): set
  /// from the plan's noise unless the file states them.
  MountingCalibrator::Options options;

  /// The survey configuration with the plan's lines.
  simulation::SurveyConfig surveyConfig() const;
  /// The scene: the ground, each roof as a gable house whose faces look towards aspect_deg and
  /// aspect_deg + 180°, each target as a square ground target (centre and corners are features).
  simulation::Scene buildScene() const;
  /// The mean flying height of the lines [m].
  double meanHeight() const;
};

/// The side-to-side width a line flown `height_m` above flat ground covers [m]: 2 h tan(half
/// FOV) for a line scanner; for a multi-beam scanner the chord of 0.7 × its maximum range
/// (returns near the limit are sparse), or h when that range does not reach the ground.
double swathWidth(const simulation::SurveyConfig& config, double height_m);

/// Reads a plan file (format in the README, "Planning a calibration flight"). Throws FileError
/// naming the file and the field for anything missing, of the wrong type or out of range.
Plan readPlan(const std::string& path);

/// What a plan determines.
struct Prediction {
  std::array<bool, 6> determined{};  ///< estimated (not undeterminable)
  std::array<double, 6> sigma{};     ///< predicted σ [m, rad]; NaN if not determined
  Eigen::Matrix<double, 6, 6> correlation = Eigen::Matrix<double, 6, 6>::Constant(std::nan(""));
  double condition_number = 0.0;            ///< of the reduced normal matrix of the determined block
  std::vector<std::string> undeterminable;  ///< parameter names, with the reasons in `observability`
  std::string observability;
  /// Ground features (targets, roof faces' points) that fewer than two lines see, so no tie:
  /// hidden under a roof or behind a wall from the lines, or outside their swaths.
  std::vector<std::string> untied;
  int strips = 0;        ///< strips simulated
  int observations = 0;  ///< residual blocks in the adjustment
  double seconds = 0.0;  ///< wall time of the prediction [s]
  /// The parameter that most needs help: the first undeterminable one, else the one whose σ
  /// moves the ground most (lever arm σ [m], boresight σ × mean flying height [m]). -1: none.
  int weakest = -1;
  /// The weakest parameter's σ in metres on the ground (infinite when undeterminable).
  double weakest_ground_sigma_m = 0.0;
};

/// Predicts what `plan` determines (simulation without noise + the adjustment at the truth).
/// Throws InvalidInput when the plan cannot be simulated (no line sees any feature).
Prediction predict(const Plan& plan);

/// A candidate addition to the plan and what it would give.
struct Suggestion {
  std::string kind;         ///< "second height", "offset line", "crossing line", "ground control"
  std::string description;  ///< what to fly or survey, with coordinates
  Plan plan;                ///< the plan with the addition
  Prediction prediction;
  /// σ of the weakest parameter of the base plan with this addition [m, rad]; infinite while
  /// still undeterminable.
  double weakest_sigma = 0.0;
};

struct PlannerOptions {
  double second_height_factor = 1.5;  ///< a second height: the first line again at this × its height [-]
  /// A same-direction line offset sideways by this fraction of the first line's swath width [-].
  double offset_fraction = 0.5;
  bool try_candidates = true;  ///< false: the prediction only
};

/// The prediction of the plan and, when some parameter is weak or undeterminable, the candidate
/// additions (a second height, a same-direction line offset sideways, a crossing line, a ground
/// control point) ranked by the σ they give the weakest parameter (best first).
struct PlanAnalysis {
  Prediction base;
  std::vector<Suggestion> suggestions;
  double seconds = 0.0;
  std::string text() const;  ///< the planner's text output
};

PlanAnalysis analysePlan(const Plan& plan, const PlannerOptions& options = {});

/// HTML report of a plan analysis: plan view of the lines, footprints and ground features, the
/// σ and correlation heat map, the ranked suggestions (self-contained, inline SVG).
std::string planReportHtml(const Plan& plan, const PlanAnalysis& analysis);

}  // namespace mountcal::plan
