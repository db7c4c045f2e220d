// One adjustment, many observation kinds (issue 8): plane patches (given regions and found
// automatically), automatic point-to-plane correspondences, ground control with any method,
// methods combined, the generic observability analysis — on simulated data with known truth.
#include <cstdio>
#include <gtest/gtest.h>

#include <ceres/ceres.h>

#include <map>
#include <memory>
#include <set>

#include "mountcal/mountcal.hpp"
#include "mountcal/core/error.hpp"
#include "mountcal/core/georeference_model.hpp"
#include "mountcal/mounting_calibrator.hpp"
#include "mountcal/simulation/survey.hpp"
#include "sanitizer_build.hpp"
#include "scatter.hpp"
#include "support.hpp"

using namespace mountcal_tests;
using namespace mountcal;
using namespace mountcal::simulation;

namespace {

/// The paper's crossing field (seed 000 experiment 1: four strips at 760 m and 1310 m, flat and
/// gable roofs of four aspects, ground targets), with points within 12 m of the features.
const SimulatedSurvey& denseField(std::uint64_t seed, bool noise) { return crossingField(seed, noise, 12.0); }

/// The crossing field (seed 3, survey-grade noise, points within 12 m of the features) flown with
/// a mounting far from the one used: boresight (0.25°, −0.30°, 0.40°) — at 1310 m the strips move
/// against each other by up to 15 m while a calibration brings them together.
const SimulatedSurvey& farMountingField() {
  static const SimulatedSurvey s = [] {
    Scene scene;
    SurveyConfig c;
    makePreset("paper-calibration-field", 3, &c, &scene);
    c.true_mounting = MountingParameters::fromDegrees(Vec3(0.10, -0.05, 0.20), Vec3(0.25, -0.30, 0.40));
    c.noise = surveyGrade();
    c.roi_radius_m = 12.0;
    return simulate(c, scene);
  }();
  return s;
}

/// The seeds of the "every estimate within 3σ" tests. The sanitizer build runs one of them: it
/// looks for memory errors and undefined behaviour on the same code, and the three noisy surveys
/// take minutes there.
std::vector<std::uint64_t> statisticalSeeds() {
#ifdef MOUNTCAL_SANITIZE_BUILD
  return {1};
#else
  return {1, 2, 4};
#endif
}

/// The survey with ground control at the tie features (the vertical lever arm needs it).
CalibrationData withControl(const SimulatedSurvey& s, double sigma_m = 0.01) {
  CalibrationData d = toCalibrationData(s);
  for (const FeaturePoint& f : s.gcps) d.gcps.push_back({f.id, f.x_m.x(), f.x_m.y(), f.x_m.z(), sigma_m, sigma_m});
  return d;
}

MountingCalibrator::Options methodOptions(std::vector<std::string> methods, bool automatic = false) {
  MountingCalibrator::Options o;
  o.methods = std::move(methods);
  o.method<PlaneOptions>().automatic = automatic;
  o.estimate.fill(true);
  return o;
}

/// The stochastic model of surveyGrade() for the calibrator.
MountingCalibrator::Options noisy(MountingCalibrator::Options o) {
  o.method<VtpmOptions>().tie_sigma_xy_m = 0.03;
  o.method<VtpmOptions>().tie_sigma_z_m = 0.03;
  o.method<ControlOptions>().tie_sigma_xy_m = 0.03;  // the control points are picked as the ties are
  o.method<ControlOptions>().tie_sigma_z_m = 0.03;
  o.strip_offset_sigma_m = 0.005;
  o.trajectory = TrajectoryAccuracy::none();  // the simulated trajectories carry no drift in time
  // These tests look at the estimate and its σ: no second solve from the result (the re-solve
  // check runs in tests/test_observability.cpp and on the Gravity sets).
  o.resolve_check = false;
  return o;
}

void expectRecovered(const MountingCalibrator::Summary& S, const MountingParameters& truth, double boresight_deg, double lever_m,
                     const std::string& what) {
  ASSERT_TRUE(S.IsSolutionUsable()) << what << "\n" << S.FullReport();
  EXPECT_TRUE(S.unobservable.empty()) << what << "\n" << S.observability_report;
  const auto e = S.mounting.toArray(), t = truth.toArray();
  for (int j : {kBoresightRoll, kBoresightPitch, kBoresightHeading})
    EXPECT_LT(std::abs(e[j] - t[j]), boresight_deg * kDeg) << what << " " << mountingParameterNames()[j];
  for (int j : {kLeverX, kLeverY}) EXPECT_LT(std::abs(e[j] - t[j]), lever_m) << what << " " << mountingParameterNames()[j];
}

/// The bound on one |error|/σ. These tests check 6 values per seed and up to 18 per test: at 3σ
/// an honest σ fails a test of 18 values one time in twenty (a Gaussian's 0.27 % each); at 3.5σ
/// one in a hundred (5e-4 each). Too small σ the scatter's upper bound sees (expectNotUnderstated);
/// too large ones its lower bound. (3σ held while the simulator's GNSS error started at 0, the
/// first lines quieter than stated; started stationary, seed 2's correspondences heading is 3.01σ.)
constexpr double kSigmaBound = 3.5;

/// |error| < kSigmaBound σ for every parameter; each error/σ also goes into `scatter` (its bounds).
void expectWithinSigmaBound(const MountingCalibrator::Summary& S, const MountingParameters& truth, const std::string& what,
                            mountcal_tests::ScatterOfErrors* scatter) {
  ASSERT_TRUE(S.IsSolutionUsable()) << what;
  const auto e = S.mounting.toArray(), t = truth.toArray();
  int estimated = 0;
  for (int j = 0; j < 6; ++j) {
    if (!S.estimated[j]) continue;
    ++estimated;
    EXPECT_LT(std::abs(e[j] - t[j]), kSigmaBound * S.sigma[j]) << what << " " << mountingParameterNames()[j] << "\n" << S.FullReport();
    scatter->add(e[j] - t[j], S.sigma[j]);
  }
  EXPECT_EQ(estimated, 6) << what << "\n" << S.observability_report;
}

}  // namespace

// ---- noise-free recovery ------------------------------------------------------------------------
// Tolerances of issue 26: boresight within 1e-4°, horizontal lever arm within 1 mm. Strip
// offsets off (the paper's model: noise-free data have none), ground control on the tie
// features so that all six parameters are estimated.

TEST(PlaneMethod, GivenRegionsRecoverTheTruthNoiseFree) {
  const SimulatedSurvey& s = denseField(1, false);
  CalibrationData d = withControl(s);
  ASSERT_GE(d.plane_regions.size(), 6u);  // two flat roofs, four gable faces
  auto o = methodOptions({"planes"});
  o.strip_offset_sigma_m = 0;
  const auto S = calibrate(d, o);
  expectRecovered(S, s.config.true_mounting, 1e-4, 0.001, "planes (regions)");
  EXPECT_NEAR(S.mounting.a_b.z(), s.config.true_mounting.a_b.z(), 0.001);
  EXPECT_GE(S.section<PlaneSection>().patches_used, 6);
  EXPECT_GT(S.section<PlaneSection>().rms_before_m, 0.1);  // the misalignment was real
  EXPECT_LT(S.section<PlaneSection>().rms_after_m, 0.002);
  EXPECT_GT(S.section<ControlSection>().observations_used, 50);
  // Every patch reports its points, strips and RMS before and after.
  for (const PatchResidual& p : S.section<PlaneSection>().patches) {
    EXPECT_GE(p.strips, 2) << p.patch_id;
    EXPECT_GT(p.points, 20) << p.patch_id;
    EXPECT_LT(p.rms_after_m, p.rms_before_m) << p.patch_id;
  }
  EXPECT_NE(S.FullReport().find("Planes (given regions)"), std::string::npos);
}

TEST(PlaneMethod, AutomaticPatchesRecoverTheTruthNoiseFree) {
  const SimulatedSurvey& s = denseField(1, false);
  CalibrationData d = withControl(s);
  d.plane_regions.clear();  // nothing given
  auto o = methodOptions({"planes"}, /*automatic=*/true);
  o.strip_offset_sigma_m = 0;
  const auto S = calibrate(d, o);
  expectRecovered(S, s.config.true_mounting, 1e-4, 0.001, "planes (auto)");
  // Patches of several orientations survive beside the flat ground: all four roof aspects.
  std::set<int> aspects;
  for (const PatchResidual& p : S.section<PlaneSection>().patches) {
    if (std::abs(p.normal.z()) > std::cos(10 * kDeg)) continue;
    const double aspect = std::fmod(std::atan2(p.normal.x(), p.normal.y()) / kDeg + 360.0, 360.0);
    aspects.insert(static_cast<int>(std::lround(aspect / 90.0)) % 4);
  }
  EXPECT_EQ(aspects.size(), 4u);
  EXPECT_TRUE(S.section<PlaneSection>().automatic);
}

TEST(CorrespondenceMethod, RecoversTheTruthNoiseFree) {
  const SimulatedSurvey& s = denseField(1, false);
  CalibrationData d = withControl(s);
  auto o = methodOptions({"correspondences"});
  o.strip_offset_sigma_m = 0;
  const auto S = calibrate(d, o);
  expectRecovered(S, s.config.true_mounting, 1e-4, 0.001, "correspondences");
  const CorrespondenceSection& c = S.section<CorrespondenceSection>();
  EXPECT_GE(c.rounds, 2);         // re-matched until the mounting stopped changing
  EXPECT_EQ(c.pairs.size(), 6u);  // four crossing strips: every pair overlaps
  EXPECT_LE(c.used, o.method<CorrespondenceOptions>().budget);
  EXPECT_GT(c.median_before_m, 0.05);
  EXPECT_LT(c.median_after_m, 0.002);
  for (const auto& p : c.pairs) EXPECT_GT(p.kept, 100) << p.strip_a << "/" << p.strip_b;
}

TEST(CorrespondenceMethod, LibraryCallReturnsCorrespondencesAndStatistics) {
  const SimulatedSurvey& s = denseField(1, false);
  const CalibrationData d = toCalibrationData(s);
  CorrespondenceOptions o;
  o.budget = 800;
  const CorrespondenceSet set = findCorrespondences(d, d.mounting_used.toArray(), o);
  ASSERT_EQ(set.pairs.size(), 6u);
  EXPECT_EQ(set.correspondences.size(), 800u);  // thinned to the budget
  int kept = 0, samples = 0, rejected = 0;
  for (const auto& p : set.pairs) {
    kept += p.kept;
    samples += p.samples;
    rejected += p.rejected_sparse + p.rejected_rough + p.rejected_far + p.rejected_normal + p.rejected_mad + p.rejected_budget;
  }
  EXPECT_EQ(kept, 800);
  EXPECT_EQ(kept + rejected, samples);  // every sample accounted for
  EXPECT_GT(set.radius_m, 0.5);
  EXPECT_GT(set.spacing_m, 0.3);
  EXPECT_GT(set.points_searched, 100000u);
  // Normal-space thinning keeps sloped roofs although level ground is most of the overlap.
  int sloped = 0;
  for (const Correspondence& c : set.correspondences) {
    EXPECT_GE(c.points_b.size(), static_cast<std::size_t>(o.min_neighbours));
    EXPECT_NE(c.strip_a, c.strip_b);
    sloped += std::abs(c.normal.z()) < std::cos(10 * kDeg);
  }
  EXPECT_GT(sloped, 40);
  EXPECT_GT(static_cast<double>(sloped) / 800.0, 3.0 * static_cast<double>(sloped) / static_cast<double>(samples));
  // Invalid settings are refused with a message naming the field.
  o.budget = 0;
  try {
    findCorrespondences(d, d.mounting_used.toArray(), o);
    FAIL() << "no exception";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("budget"), std::string::npos);
  }
}

// ---- survey-grade noise: honest σ -----------------------------------------------------------------

TEST(PlaneMethod, SurveyGradeNoiseEveryEstimateWithinItsSigmaBound) {
  mountcal_tests::ScatterOfErrors scatter;
  for (std::uint64_t seed : statisticalSeeds()) {
    const SimulatedSurvey& s = denseField(seed, true);
    const auto S = calibrate(withControl(s), noisy(methodOptions({"planes"})));
    expectWithinSigmaBound(S, s.config.true_mounting, "planes, seed " + std::to_string(seed), &scatter);
    EXPECT_GT(S.variance_factor, 0.5);
    EXPECT_LT(S.variance_factor, 2.0);
  }
  scatter.expectNotOverstated("planes");
  scatter.expectNotUnderstated("planes");
}

TEST(PlaneMethod, AutomaticSurveyGradeNoiseEveryEstimateWithinItsSigmaBound) {
  mountcal_tests::ScatterOfErrors scatter;
  for (std::uint64_t seed : statisticalSeeds()) {
    const SimulatedSurvey& s = denseField(seed, true);
    const auto S = calibrate(withControl(s), noisy(methodOptions({"planes"}, true)));
    expectWithinSigmaBound(S, s.config.true_mounting, "planes auto, seed " + std::to_string(seed), &scatter);
    EXPECT_GT(S.variance_factor, 0.5);
    EXPECT_LT(S.variance_factor, 2.0);
  }
  scatter.expectNotOverstated("planes auto");
  scatter.expectNotUnderstated("planes auto");
}

TEST(CorrespondenceMethod, SurveyGradeNoiseEveryEstimateWithinItsSigmaBound) {
  if (mountcal_tests::kSanitizerBuild)
    GTEST_SKIP() << "sanitizer build: the correspondences calibrate a noisy survey of this field under the sanitizers in "
                    "StripsMovingBeyondTheAprioriMisalignmentGrowItFromTheData (28 s here); the σ over three seeds in the Release suite";
  mountcal_tests::ScatterOfErrors scatter;
  for (std::uint64_t seed : statisticalSeeds()) {
    const SimulatedSurvey& s = denseField(seed, true);
    const auto S = calibrate(withControl(s), noisy(methodOptions({"correspondences"})));
    expectWithinSigmaBound(S, s.config.true_mounting, "correspondences, seed " + std::to_string(seed), &scatter);
    EXPECT_GT(S.variance_factor, 0.5);
    EXPECT_LT(S.variance_factor, 2.0);
  }
  scatter.expectNotOverstated("correspondences");
  scatter.expectNotUnderstated("correspondences");
}

// A mounting far from the one used (boresight 0.25°, −0.30°, 0.40°): during the calibration the
// strips move against each other by up to 15 m (1310 m lines), where the a-priori misalignment
// that the candidate neighbourhoods are found for is 1 m by default. Each matching checks that
// every sample's neighbours at its mounting lie inside what its candidates hold; here they do
// not, and the candidates are found again with the margin the data showed (24 m measured).
// Without that growth (max_misalignment_growths 0) those samples are refused, not matched on
// neighbourhoods cut short — before the check, the same survey (points within 25 m, lever z
// held, no control) ended 0.35° off in heading (0.05° against 0.40°, σ 0.02°) and said
// "doubtful" only through the re-solve check.
TEST(CorrespondenceMethod, StripsMovingBeyondTheAprioriMisalignmentGrowItFromTheData) {
  const SimulatedSurvey& s = farMountingField();
  const SurveyConfig& c = s.config;
  auto o = noisy(methodOptions({"correspondences"}));
  ASSERT_EQ(o.method<CorrespondenceOptions>().apriori_misalignment_m, 1.0);  // the default: no hand tuning
  const auto S = calibrate(withControl(s), o);
  mountcal_tests::ScatterOfErrors scatter;
  expectWithinSigmaBound(S, c.true_mounting, "correspondences, grown misalignment", &scatter);
  const CorrespondenceSection& cs = S.section<CorrespondenceSection>();
  EXPECT_GE(cs.misalignment_growths, 1);
  EXPECT_GT(cs.apriori_misalignment_m, 5.0);
  EXPECT_EQ(cs.rejectedMoved(), 0);  // the last matching's neighbourhoods are whole
  EXPECT_TRUE(cs.warnings().empty());
  EXPECT_NE(S.FullReport().find("candidates found again"), std::string::npos);
  // Without the growth the samples whose neighbours reach past their candidates are refused —
  // not matched on neighbourhoods cut short — and the section says what to raise.
  o.method<CorrespondenceOptions>().max_misalignment_growths = 0;
  const auto N = calibrate(withControl(s), o);
  const CorrespondenceSection& ns = N.section<CorrespondenceSection>();
  EXPECT_GT(ns.rejectedMoved(), 0);
  EXPECT_LT(ns.used, cs.used / 2);
  EXPECT_GT(ns.needed_misalignment_m, 5.0);
  ASSERT_EQ(ns.warnings().size(), 1u);
  EXPECT_NE(ns.warnings()[0].find("raise correspondences.apriori_misalignment_m"), std::string::npos) << ns.warnings()[0];
}

// The same far mounting with planes "auto" and every parameter estimated. At the mounting used
// the roofs' faces lie metres apart between strips: the first search keeps level patches only,
// which see the horizontal lever arm, pitch and heading only through the aircraft's attitude
// changes. Before the boresight stage and the second search (2026-12-05), eight of eight seeds
// ran to a self-consistent lever arm 4.4–5.3 m off at 49–99σ ("doubtful" only by the lever arm's
// move); the cost there was 1.6× the truth's. Now a lever arm that moves more than 0.5 m sends
// the estimation back to its start, where the boresight settles first with the lever arm held;
// the patches are found again where the strips meet — sloped roofs among them — and the lever
// arm joins: over twelve seeds every one "accept" (the RMS of error/σ over the seeds in
// docs/model-and-methods.md).
TEST(PlaneMethod, AutomaticPatchesFromAFarMountingAreFoundAgainWhereTheStripsMeet) {
  if (mountcal_tests::kSanitizerBuild)
    GTEST_SKIP() << "sanitizer build: a minute there for one calibration; the second search's code runs in the Release suite";
  const SimulatedSurvey& s = farMountingField();
  const CalibrationData d = withControl(s);
  auto o = noisy(methodOptions({"planes"}, /*automatic=*/true));
  int sloped_at_used = 0;
  for (const PlanarPatch& p : findPlanarPatches(d, o.method<PlaneOptions>()))
    sloped_at_used += std::abs(p.normal.z()) < std::cos(10 * kDeg);
  const auto S = calibrate(d, o);
  ASSERT_TRUE(S.IsSolutionUsable()) << S.FullReport();
  const PlaneSection& ps = S.section<PlaneSection>();
  EXPECT_GE(ps.patch_searches, 2);
  EXPECT_NE(S.FullReport().find("found again"), std::string::npos);
  EXPECT_TRUE(S.boresight_first_restart);  // the lever arm ran metres in the first loop
  EXPECT_GT(S.rematch_rounds, 2);          // both runs' solves counted
  int sloped = 0;
  for (const PatchResidual& p : ps.patches) sloped += std::abs(p.normal.z()) < std::cos(10 * kDeg);
  EXPECT_GE(sloped, 4) << S.FullReport();
  // The first search found two sloped regions, whose strips lay metres apart there (rejected).
  EXPECT_GE(sloped, 2 * sloped_at_used);
  const auto e = S.mounting.toArray(), t = s.config.true_mounting.toArray();
  for (int j = 0; j < 6; ++j) {
    ASSERT_TRUE(S.estimated[j]) << mountingParameterNames()[j] << "\n" << S.observability_report;
    EXPECT_LT(std::abs(e[j] - t[j]), kSigmaBound * S.sigma[j]) << mountingParameterNames()[j] << "\n" << S.FullReport();
  }
  EXPECT_LT(std::abs(e[kLeverX] - t[kLeverX]), 0.1);
  EXPECT_LT(std::abs(e[kLeverY] - t[kLeverY]), 0.1);
  for (int j : {kBoresightRoll, kBoresightPitch, kBoresightHeading}) EXPECT_LT(std::abs(e[j] - t[j]), 0.01 * kDeg);
  EXPECT_EQ(S.verdict().kind, MountingCalibrator::Verdict::Kind::kAccept) << S.FullReport();
}

// ---- the first paper's comparison: VTPM against the plane method ------------------------------

TEST(MethodComparison, FlatGroundLeavesPlanesWeakInPlanWhereFiveTiesAreNot) {
  if (mountcal_tests::kSanitizerBuild)
    GTEST_SKIP() << "sanitizer build: a statement about information (28 s there); its three calibrations' code runs under the "
                    "sanitizers in VtpmCalibration.*, PlaneMethod.* and Observability.*";
  const SimulatedSurvey& s = denseField(1, true);
  // VTPM with the paper's five ties (12 observations).
  CalibrationData ties = toCalibrationData(s);
  ties.ties = paperFiveTies(s);
  ASSERT_EQ(ties.ties.size(), 12u);
  auto ov = noisy(methodOptions({"vtpm"}));
  ov.estimate[kLeverZ] = false;
  const auto V = calibrate(ties, ov);
  ASSERT_TRUE(V.IsSolutionUsable()) << V.FullReport();
  for (int j : {kLeverX, kLeverY, kBoresightRoll, kBoresightPitch, kBoresightHeading}) EXPECT_TRUE(V.estimated[j]) << j;
  // Planes on flat ground only: nothing in plan can be seen.
  CalibrationData flat = toCalibrationData(s);
  flat.plane_regions = flatGroundRegions(s);
  ASSERT_GE(flat.plane_regions.size(), 10u);
  auto op = noisy(methodOptions({"planes"}));
  op.estimate[kLeverZ] = false;
  const auto F = calibrate(flat, op);
  ASSERT_TRUE(F.IsSolutionUsable()) << F.FullReport();
  // Weak in plan: each horizontal parameter is named undeterminable, or its σ is more than
  // twice that of the five ties (measured: 2.4–4×; lever x σ ≈ 0.9 m).
  for (int j : {kLeverX, kLeverY, kBoresightPitch, kBoresightHeading}) {
    EXPECT_TRUE(!F.estimated[j] || F.sigma[j] > 2 * V.sigma[j]) << mountingParameterNames()[j] << "\n" << F.FullReport();
  }
  EXPECT_TRUE(F.estimated[kBoresightRoll]);  // the vertical tilt across the swath is seen
  // Roofs of four aspects: the plane method is strong, stronger than five ties.
  auto R = calibrate(toCalibrationData(s), op);
  ASSERT_TRUE(R.IsSolutionUsable());
  EXPECT_TRUE(R.unobservable.empty()) << R.observability_report;
  for (int j : {kLeverX, kLeverY, kBoresightRoll, kBoresightPitch, kBoresightHeading}) {
    ASSERT_TRUE(R.estimated[j]) << j;
    EXPECT_LT(R.sigma[j], V.sigma[j]) << mountingParameterNames()[j];
  }
}

TEST(MethodComparison, CombiningTiesAndPlanesNeverWidensSigma) {
  const SimulatedSurvey& s = denseField(1, true);
  CalibrationData d = toCalibrationData(s);
  auto o = noisy(methodOptions({"vtpm"}));
  o.estimate[kLeverZ] = false;
  const auto T = calibrate(d, o);
  o.methods = {"planes"};
  const auto P = calibrate(d, o);
  o.methods = {"vtpm", "planes"};
  const auto B = calibrate(d, o);
  ASSERT_TRUE(T.IsSolutionUsable() && P.IsSolutionUsable() && B.IsSolutionUsable());
  ASSERT_EQ(B.kinds.size(), 2u);
  EXPECT_EQ(B.kinds[0].kind, "ties");
  EXPECT_EQ(B.kinds[1].kind, "planes");
  EXPECT_GT(B.section<VtpmSection>().observations_used, 0);
  EXPECT_GT(B.section<PlaneSection>().points_used, 0);
  for (int j = 0; j < 6; ++j) {
    if (!B.estimated[j]) continue;
    ASSERT_TRUE(T.estimated[j] && P.estimated[j]) << j;
    EXPECT_LE(B.sigma[j], T.sigma[j] * (1 + 1e-9)) << mountingParameterNames()[j];
    EXPECT_LE(B.sigma[j], P.sigma[j] * (1 + 1e-9)) << mountingParameterNames()[j];
  }
  EXPECT_NE(B.FullReport().find("Ties: RMS before"), std::string::npos);
  EXPECT_NE(B.FullReport().find("Planes (given regions)"), std::string::npos);
}

// ---- the adjustment core ----------------------------------------------------------------------

TEST(Adjustment, EliminatingPlaneParametersReproducesCeresCovariance) {
  // The reduced normal matrix (every plane, control and strip-offset block eliminated by a
  // Schur complement) inverted against ceres::Covariance on the mounting block.
  const SimulatedSurvey& s = denseField(2, true);
  auto o = noisy(methodOptions({"planes"}));
  const auto S = calibrate(withControl(s), o);
  ASSERT_TRUE(S.IsSolutionUsable());
  ASSERT_EQ(S.covariance_source, "ceres::Covariance");
  std::vector<int> idx;
  for (int j = 0; j < 6; ++j)
    if (S.estimated[j]) idx.push_back(j);
  ASSERT_EQ(idx.size(), 6u);
  const Eigen::Matrix<double, 6, 6> inv = S.reduced_normal_matrix.inverse();
  for (int a = 0; a < 6; ++a)
    for (int b = 0; b < 6; ++b)
      EXPECT_NEAR(inv(a, b), S.covariance(a, b), 1e-6 * std::sqrt(S.covariance(a, a) * S.covariance(b, b)))
          << mountingParameterNames()[a] << " / " << mountingParameterNames()[b];
}

TEST(Adjustment, PlanePointJacobiansMatchTheAnalyticDerivatives) {
  // ∂x/∂a_b = R_mb, ∂x/∂δ = −R_mb [R_bs r_s]× (first order), and r = n̂·(x + o − c)/σ − d/σ:
  // an independent check of the model, not of the differencing alone.
  const SimulatedSurvey& s = denseField(1, false);
  CalibrationData d = toCalibrationData(s);
  PlaneOptions po;
  PlaneObservations planes(d, po);
  ASSERT_FALSE(planes.patches().empty());
  const double sigma = planes.section().sigma_m;
  const std::array<std::array<double, 6>, 3> points = {
      {{0, 0, 0, 0, 0, 0}, {1e-8, -1e-8, 1e-8, 1e-8, -1e-8, 1e-8}, {0.1, -0.05, 0.2, 0.05 * kDeg, -0.08 * kDeg, 0.12 * kDeg}}};
  for (std::size_t pi = 0; pi < points.size(); ++pi) {
    const auto& m = points[pi];
    AdjustmentProblem P(m, 0.02, LossType::kTrivial, 0.5, 1e-6);
    planes.addBlocks(m, &P);
    ASSERT_GT(P.residualBlockCount(), 10);
    int checked = 0;
    for (const auto& rec : P.records()) {
      if (rec.cost->num_residuals() != 1 || rec.blocks.size() != 3) continue;  // a point-to-plane block
      const double* plane = rec.blocks[1];
      Vec3 n(plane[0], plane[1], plane[2]);
      n.normalize();
      // Find the point: the record order follows patches and points.
      const PlaneObservations::PatchPoint* pp = nullptr;
      int k = 0;
      for (const auto& patch : planes.patches())
        for (const auto& p : patch.points)
          if (k++ == checked) pp = &p;
      ASSERT_NE(pp, nullptr);
      double r;
      Eigen::Matrix<double, 1, 6, Eigen::RowMajor> J;
      Eigen::Matrix<double, 1, 4, Eigen::RowMajor> Jp;
      Eigen::Matrix<double, 1, 3, Eigen::RowMajor> Jo;
      const double* params[3] = {m.data(), plane, rec.blocks[2]};
      double* jac[3] = {J.data(), Jp.data(), Jo.data()};
      ASSERT_TRUE(rec.cost->Evaluate(params, &r, jac));
      // Lever arm and offset: exact.
      const Eigen::RowVector3d dr_da = n.transpose() * pp->R_mb / sigma;
      EXPECT_LT((J.leftCols<3>() - dr_da).norm(), 1e-6 * dr_da.norm());
      EXPECT_LT((Jo - n.transpose() / sigma).norm(), 1e-6 / sigma);
      // Boresight: the first-order form, exact at identity, within O(δ) at a realistic mounting.
      const MountingParameters M = d.mounting_used.withArray(m.data());
      const Vec3 v = M.R_bs() * pp->r_s;
      Mat3 vx;
      vx << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
      const Eigen::RowVector3d dr_dd = -n.transpose() * pp->R_mb * vx / sigma;
      const double tol = pi < 2 ? 1e-6 : 5e-3;
      EXPECT_LT((J.rightCols<3>() - dr_dd).norm(), tol * dr_dd.norm()) << "mounting " << pi;
      // …and the exact Euler-angle derivative, d/dω Rz Ry Rx(ω) etc., tight everywhere.
      const double w = m[3], p = m[4], h = m[5];
      auto dRx = [](double a) {
        Mat3 D;
        D << 0, 0, 0, 0, -std::sin(a), -std::cos(a), 0, std::cos(a), -std::sin(a);
        return D;
      };
      auto dRy = [](double a) {
        Mat3 D;
        D << -std::sin(a), 0, std::cos(a), 0, 0, 0, -std::cos(a), 0, -std::sin(a);
        return D;
      };
      auto dRz = [](double a) {
        Mat3 D;
        D << -std::sin(a), -std::cos(a), 0, std::cos(a), -std::sin(a), 0, 0, 0, 0;
        return D;
      };
      const Vec3 u = M.R_nom * pp->r_s;
      const Eigen::RowVector3d exact(n.dot(pp->R_mb * Rz(h) * Ry(p) * dRx(w) * u), n.dot(pp->R_mb * Rz(h) * dRy(p) * Rx(w) * u),
                                     n.dot(pp->R_mb * dRz(h) * Ry(p) * Rx(w) * u));
      EXPECT_LT((J.rightCols<3>() - exact / sigma).norm(), 1e-6 * exact.norm() / sigma) << "mounting " << pi;
      if (++checked == 25) break;
    }
    EXPECT_EQ(checked, 25);
  }
}

TEST(Adjustment, TheExactDifferentialFormEqualsGeoreferenceModel) {
  // The methods move a point by R_mb[(R_bs(M) − R_bs(M_used)) r_s + (a − a_used)] from its
  // position at M_used (SPEC §2 eq. 1 differenced): equal to GeoreferenceModel at M.
  const SimulatedSurvey& s = denseField(1, false);
  const CalibrationData d = toCalibrationData(s);
  PlaneObservations planes(d, PlaneOptions{});
  const MountingParameters M = d.mounting_used.withArray(std::array<double, 6>{0.3, -0.2, 0.1, 0.2 * kDeg, -0.3 * kDeg, 0.4 * kDeg}.data());
  const GeoreferenceModel model(d.trajectory, M);
  const StripData& strip = d.strips[0];
  int found = 0;
  for (const auto& patch : planes.patches()) {
    for (const auto& pp : patch.points) {
      if (pp.strip_id != strip.id) continue;
      for (std::size_t i = 0; i < strip.r_s.size(); ++i) {
        if ((strip.r_s[i] - pp.r_s).norm() > 1e-12) continue;
        const Vec3 exact = model.forward(strip.time_s[i], strip.r_s[i]);
        const Vec3 moved =
            patch.centre_m + pp.x0_rel + pp.R_mb * ((M.R_bs() - d.mounting_used.R_bs()) * pp.r_s + (M.a_b - d.mounting_used.a_b));
        EXPECT_LT((moved - exact).norm(), 1e-9);
        ++found;
        break;
      }
      if (found >= 20) break;
    }
    if (found >= 20) break;
  }
  EXPECT_EQ(found, 20);
}

TEST(Adjustment, OptionsGroupsValidateTheirFields) {
  std::string why;
  MountingCalibrator::Options o;
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o.strip_offset_sigma_m = -1;
  EXPECT_FALSE(static_cast<const StochasticOptions&>(o).IsValid(&why));
  EXPECT_NE(why.find("strip_offset_sigma_m"), std::string::npos);
  o = {};
  o.max_rematch_rounds = 0;
  EXPECT_FALSE(static_cast<const SolverOptions&>(o).IsValid(&why));
  o = {};
  o.rank_tolerance = 2;
  EXPECT_FALSE(static_cast<const AnalysisOptions&>(o).IsValid(&why));
  o = {};
  o.method<PlaneOptions>().max_points_per_strip = 1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_EQ(why.rfind("planes.max_points_per_strip", 0), 0u) << why;  // the method and its option
  o = {};
  o.method<CorrespondenceOptions>().max_normal_angle_deg = 95;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_EQ(why.rfind("correspondences.max_normal_angle_deg", 0), 0u) << why;
  o = {};
  o.methods.clear();
  EXPECT_FALSE(o.IsValid(&why));
  // Invalid options: no solve, a summary that says why.
  const auto S = calibrate(toCalibrationData(denseField(1, false)), o);
  EXPECT_EQ(S.termination, TerminationType::kInvalidInput);
  EXPECT_NE(S.message.find("methods"), std::string::npos);
}

TEST(PlaneMethod, RegionsThatCannotBeUsedAreRejectedWithAReason) {
  const SimulatedSurvey& s = denseField(1, false);
  CalibrationData d = withControl(s);
  const PlaneRegion good = d.plane_regions.front();
  d.plane_regions.push_back({"nowhere", 5000, 5000, 5010, 5010});                                               // no strip there
  d.plane_regions.push_back({"edge_of_data", good.xmin + 60, good.ymin + 60, good.xmin + 61, good.ymin + 61});  // a sliver
  auto o = methodOptions({"planes"});
  o.strip_offset_sigma_m = 0;
  const auto S = calibrate(d, o);
  ASSERT_TRUE(S.IsSolutionUsable());
  std::map<std::string, std::string> reasons;
  for (const RejectedPatch& r : S.section<PlaneSection>().rejected)
    if (r.strip_id.empty()) reasons[r.patch_id] = r.reason;
  EXPECT_EQ(reasons["nowhere"], "no strip has points in the region");
  bool sliver_rejected = false;
  for (const RejectedPatch& r : S.section<PlaneSection>().rejected) sliver_rejected |= r.patch_id == "edge_of_data";
  EXPECT_TRUE(sliver_rejected);
  for (const PatchResidual& p : S.section<PlaneSection>().patches) EXPECT_NE(p.patch_id, "nowhere");
  expectRecovered(S, s.config.true_mounting, 1e-4, 0.001, "planes with unusable regions");
}

TEST(Adjustment, CorrespondenceResidualEqualsGeoreferenceModel) {
  // The correspondence residual gathers its sums once (exact regrouping of SPEC §2 eq. 1
  // differenced); evaluated at any mounting it must equal n·(x_A(M) − x̄_B(M))/σ with every
  // point georeferenced by GeoreferenceModel.
  const SimulatedSurvey& s = denseField(1, false);
  const CalibrationData d = toCalibrationData(s);
  CorrespondenceObservations obs(d, CorrespondenceOptions{});
  const std::array<double, 6> m_match{0.05, -0.02, 0.1, 0.03 * kDeg, -0.05 * kDeg, 0.08 * kDeg};
  AdjustmentProblem P(m_match, 0.0, LossType::kTrivial, 0.5, 1e-6);
  obs.addBlocks(m_match, &P);
  const CorrespondenceSet& set = obs.lastMatching();
  ASSERT_GT(set.correspondences.size(), 1000u);
  const std::array<double, 6> m_eval{0.3, 0.1, -0.2, -0.2 * kDeg, 0.15 * kDeg, 0.3 * kDeg};
  const GeoreferenceModel model(d.trajectory, d.mounting_used.withArray(m_eval.data()));
  std::size_t k = 0, checked = 0;
  for (const auto& rec : P.records()) {
    if (rec.cost->num_residuals() != 1) continue;
    const Correspondence& c = set.correspondences[k++];
    if (k % 50 != 0) continue;
    double zero[3] = {0, 0, 0}, r = 0;
    const double* params[3] = {m_eval.data(), zero, zero};
    ASSERT_TRUE(rec.cost->Evaluate(params, &r, nullptr));
    const StripData& A = d.strips[static_cast<std::size_t>(c.strip_a)];
    const StripData& B = d.strips[static_cast<std::size_t>(c.strip_b)];
    const Vec3 xa = model.forward(A.time_s[c.point_a], A.r_s[c.point_a]);
    Vec3 xb = Vec3::Zero();
    for (std::size_t j : c.points_b) xb += model.forward(B.time_s[j], B.r_s[j]);
    xb /= static_cast<double>(c.points_b.size());
    EXPECT_NEAR(r * set.sigma_m, c.normal.dot(xa - xb), 1e-8) << "correspondence " << k;
    ++checked;
  }
  EXPECT_EQ(k, set.correspondences.size());
  EXPECT_GT(checked, 20u);
}

// ---- dense matching with per-laser elevation offsets, on simulated truth -------------------------
// A VLP-16 whose lasers are off their table's elevations (zero-mean, σ 0.1°: the size of the
// Gravity HDL-32E's estimated offsets), georeferenced with the table — as a driver with the
// manufacturer's calibration file writes the points — and a taped lever arm that is exact (a
// held lever arm 1 cm off moves the boresight by 0.006°, whatever the lasers). Dense
// correspondences with one elevation offset per laser recover each laser's error and the
// boresight; without them the boresight absorbs what it can of the lasers' errors and the passes
// stay apart. Noise-free, so the tolerances are issue 26's (1e-4°). Measured (2026-11-27): each
// laser within 1.4e-4°, the boresight within 2e-5°; without the offsets the boresight 0.017° off,
// passes 5 mm apart (the test prints both).
namespace {

struct PerLaserSurvey {
  SurveyConfig config;
  Scene scene;
  SimulatedSurvey survey;
};

const PerLaserSurvey& perLaserSurvey() {
  static const std::unique_ptr<PerLaserSurvey> s = [] {
    auto p = std::make_unique<PerLaserSurvey>();
    mountcal_tests::uavThreePasses(3, &p->config, &p->scene);
    p->config.noise = NoiseModel::none();
    p->config.multibeam.laser_errors = drawLaserErrors(p->config.multibeam.model.laserCount(), 11, deg2rad(0.1));
    p->survey = simulate(p->config, p->scene);
    return p;
  }();
  return *s;
}

MountingCalibrator::Summary denseCalibration(const PerLaserSurvey& s, double laser_sigma_deg) {
  MountingCalibrator::Options o = mountcal_tests::uavDenseOptions();
  o.method<CorrespondenceOptions>().laser_elevation_sigma_deg = laser_sigma_deg;
  return calibrate(toCalibrationData(s.survey), o);
}

}  // namespace

// The discrepancy breakdown (issue 28: where the tail is) singles out the one laser whose table
// entry is wrong. A noise-free VLP-16 survey with the true mounting, every laser as its table says
// except laser 5, 0.3° below its entry: by laser, laser 5's median discrepancy stands far above every
// other's; each grouping holds every used point once, and the range classes about a fifth of the
// examined points each (quintile bounds).
TEST(DiscrepancyBreakdown, BeforeAndAfterAreMatchedByClassLabel) {
  // The console, the result file and the report show the classes after a calibration, each
  // with its figures before: matched by label, in the after side's order; a class that had no
  // points before has none (NaN, null in the result file).
  auto cls = [](const char* label, double median) {
    DiscrepancyClass c;
    c.label = label;
    c.stats.queries = c.stats.used = 10;
    c.stats.median_m = median;
    return c;
  };
  DiscrepancyBreakdown before, after;
  before.by_laser = {cls("laser 3", 0.3), cls("laser 1", 0.1)};
  after.by_laser = {cls("laser 1", 0.01), cls("laser 2", 0.02), cls("laser 3", 0.03)};
  after.by_tilt = {cls("0-15 deg", 0.005)};
  const std::vector<DiscrepancyGroupChange> g = compareBreakdowns(before, after);
  ASSERT_EQ(g.size(), 4u);
  EXPECT_EQ(g[0].key, "by_laser");
  EXPECT_EQ(g[1].title, "place along the pass");
  EXPECT_EQ(g[3].key, "by_tilt");
  ASSERT_EQ(g[0].classes.size(), 3u);
  EXPECT_EQ(g[0].classes[0].label, "laser 1");
  EXPECT_TRUE(g[0].classes[0].in_before);
  EXPECT_EQ(g[0].classes[0].before.median_m, 0.1);
  EXPECT_EQ(g[0].classes[0].after.median_m, 0.01);
  EXPECT_FALSE(g[0].classes[1].in_before);
  EXPECT_TRUE(std::isnan(g[0].classes[1].before.median_m));
  EXPECT_EQ(g[0].classes[2].before.median_m, 0.3);
  EXPECT_TRUE(g[1].classes.empty());
  ASSERT_EQ(g[3].classes.size(), 1u);
  EXPECT_FALSE(g[3].classes[0].in_before);
}

TEST(DiscrepancyBreakdown, SinglesOutTheLaserWhoseTableEntryIsWrong) {
  SurveyConfig c;
  Scene scene;
  mountcal_tests::uavThreePasses(3, &c, &scene);
  c.noise = NoiseModel::none();
  c.nominal_mounting = c.true_mounting;
  c.multibeam.laser_errors.assign(static_cast<std::size_t>(c.multibeam.model.laserCount()), LaserSpec{});
  c.multibeam.laser_errors[5].elevation_rad = deg2rad(-0.3);
  const SimulatedSurvey s = simulate(c, scene);
  const CalibrationData d = toCalibrationData(s);
  const DiscrepancyReport r = discrepancyReport(d, c.true_mounting);
  const DiscrepancyBreakdown& b = r.breakdown;
  ASSERT_EQ(b.by_laser.size(), 16u);
  double worst_other = 0, laser5 = 0;
  for (const DiscrepancyClass& k : b.by_laser) {
    ASSERT_GT(k.stats.used, 50u) << k.label;
    if (k.label == "laser 5")
      laser5 = k.stats.median_m;
    else
      worst_other = std::max(worst_other, k.stats.median_m);
  }
  std::printf("median by laser: laser 5 %.4f m, worst other %.4f m\n", laser5, worst_other);
  EXPECT_GT(laser5, 5 * worst_other);
  EXPECT_GT(laser5, 0.02);
  auto sums = [](const std::vector<DiscrepancyClass>& v) {
    std::size_t q = 0, u = 0;
    for (const DiscrepancyClass& k : v) q += k.stats.queries, u += k.stats.used;
    return std::make_pair(q, u);
  };
  std::size_t queries = 0, used = 0;
  for (const PairDiscrepancy& p : r.pairs) queries += p.stats.queries, used += p.stats.used;
  EXPECT_EQ(sums(b.by_laser), std::make_pair(queries, used));
  EXPECT_EQ(sums(b.by_place), std::make_pair(queries, used));
  EXPECT_EQ(sums(b.by_range), std::make_pair(queries, used));
  EXPECT_EQ(sums(b.by_tilt).second, used);
  EXPECT_EQ(b.by_place.size(), 10u);
  ASSERT_EQ(b.by_range.size(), 5u);
  for (const DiscrepancyClass& k : b.by_range) {
    EXPECT_GT(k.stats.queries, queries * 15 / 100) << k.label;
    EXPECT_LT(k.stats.queries, queries * 25 / 100) << k.label;
  }
}

// The map of the discrepancy (issue 28: "a map of the residual discrepancy"), against a hand-built
// pair: a 20 m square of flat ground seen twice (every 0.1 m, and every 0.2 m at half a step), the
// second pass 5 cm high over one 4 m square. Per-point poses at the origin, a zero mounting: the
// laser vectors are the points. The cells over the raised square hold 0.05 m, the others 0.
TEST(DiscrepancyBreakdown, MapShowsWhereThePassesDisagree) {
  CalibrationData d;
  d.mounting_used = MountingParameters{};
  auto strip = [&](const std::string& id, double step, double shift, bool raised) {
    StripData s;
    s.id = id;
    for (double x = shift; x < 20.0; x += step)
      for (double y = shift; y < 20.0; y += step) {
        const bool bump = raised && x > 12 && x < 16 && y > 4 && y < 8;
        s.r_s.emplace_back(x, y, bump ? 0.05 : 0.0);
        s.time_s.push_back(static_cast<double>(s.time_s.size()) * 1e-4);
        s.poses.push_back(Pose{});
      }
    return s;
  };
  d.strips = {strip("ground", 0.1, 0.0, false), strip("raised", 0.2, 0.05, true)};
  const DiscrepancyMap& m = discrepancyReport(d, d.mounting_used).breakdown.map;
  ASSERT_FALSE(m.empty());
  EXPECT_LE(std::max(m.nx, m.ny), DiscrepancyMap::kMaxCells);
  EXPECT_NEAR(m.cell_m, 19.85 / DiscrepancyMap::kMaxCells, 0.01);
  EXPECT_EQ(m.median_m.size(), static_cast<std::size_t>(m.nx) * static_cast<std::size_t>(m.ny));
  EXPECT_NEAR(m.at(14.0, 6.0), 0.05, 1e-6);  // the raised square's middle
  EXPECT_NEAR(m.at(13.0, 5.0), 0.05, 1e-6);
  EXPECT_NEAR(m.at(5.0, 15.0), 0.0, 1e-6);  // level ground
  EXPECT_NEAR(m.at(18.0, 2.0), 0.0, 1e-6);
  EXPECT_TRUE(std::isnan(m.at(25.0, 5.0)));  // beyond the data
  EXPECT_NEAR(m.median_all_m, 0.0, 1e-6);    // most of the ground agrees
  int raised = 0;
  for (float v : m.median_m) raised += v > 0.04f;
  // The 4 m square in cells of ~0.25 m: about 16 × 16, less the cells its edges cut.
  EXPECT_GT(raised, 150);
  EXPECT_LT(raised, 290);
}

TEST(SimulatedLaserErrors, AreZeroMeanDrawnFromTheSeedAndRefusedWhenTheyDoNotFit) {
  const std::vector<LaserSpec> e = drawLaserErrors(16, 11, deg2rad(0.1), deg2rad(0.05), 0.002, 0.01);
  ASSERT_EQ(e.size(), 16u);
  double el = 0, az = 0, vz = 0, rms = 0;
  for (const LaserSpec& l : e)
    el += l.elevation_rad, az += l.azimuth_offset_rad, vz += l.vertical_offset_m, rms += l.elevation_rad * l.elevation_rad;
  EXPECT_NEAR(el, 0, 1e-15);
  EXPECT_NEAR(az, 0, 1e-15);
  EXPECT_NEAR(vz, 0, 1e-15);
  EXPECT_GT(std::sqrt(rms / 16), deg2rad(0.05));  // σ 0.1°: 16 draws are not all small
  EXPECT_EQ(drawLaserErrors(16, 11, deg2rad(0.1), deg2rad(0.05), 0.002, 0.01)[7].range_offset_m, e[7].range_offset_m);
  SurveyConfig c;
  Scene scene;
  makePreset("uav-vlp16", 1, &c, &scene);
  c.multibeam.laser_errors.resize(15);
  EXPECT_THROW(simulate(c, scene), InvalidInput);
  c.multibeam.laser_errors = e;
  c.multibeam.laser_errors[3].elevation_rad = 0.5;  // 29°: not an error of a laser table
  EXPECT_THROW(simulate(c, scene), InvalidInput);
}

TEST(CorrespondenceMethod, DenseMatchingRecoversEachLasersElevationErrorOnSimulatedTruth) {
  if (mountcal_tests::kSanitizerBuild)
    GTEST_SKIP() << "sanitizer build: the dense per-laser solve runs under the sanitizers on the Gravity passes "
                    "(Sets/GravityCalibration.*, 32 elevation offsets each; 52 s here for this survey); its recovery of "
                    "simulated truth is checked in the Release suite";
  const PerLaserSurvey& s = perLaserSurvey();
  const std::vector<LaserSpec>& truth = s.config.multibeam.laser_errors;
  const auto t = s.config.true_mounting.toArray();
  const auto with = denseCalibration(s, 0.5);
  ASSERT_TRUE(with.IsSolutionUsable()) << with.FullReport();
  const CorrespondenceSection& c = with.section<CorrespondenceSection>();
  ASSERT_EQ(c.laser_intrinsics.lasers.size(), truth.size());
  for (std::size_t i = 0; i < truth.size(); ++i) {
    EXPECT_NEAR(rad2deg(c.laser_intrinsics.lasers[i].elevation_rad), rad2deg(truth[i].elevation_rad), 5e-4)
        << "laser " << i;  // measured ≤ 1.4e-4°
    EXPECT_TRUE(std::isfinite(c.laser_intrinsics.sigma[i].elevation_rad)) << "laser " << i;
    EXPECT_GT(c.laser_intrinsics.points[i], 100) << "laser " << i;
  }
  const auto e = with.mounting.toArray();
  for (int j = 3; j < 6; ++j) EXPECT_NEAR(e[j], t[j], 1e-4 * kDeg) << mountingParameterNames()[j];
  EXPECT_LT(c.median_after_m, 2e-4);
  double worst_laser = 0, worst_angle = 0;
  for (std::size_t i = 0; i < truth.size(); ++i)
    worst_laser = std::max(worst_laser, std::abs(rad2deg(c.laser_intrinsics.lasers[i].elevation_rad - truth[i].elevation_rad)));
  for (int j = 3; j < 6; ++j) worst_angle = std::max(worst_angle, std::abs(e[j] - t[j]) / kDeg);
  std::printf("per-laser offsets: worst laser %.2e deg, worst boresight angle %.2e deg, median after %.2e m\n", worst_laser, worst_angle,
              c.median_after_m);
  // Without the lasers' offsets the same data give a boresight off by hundredths of a degree
  // and passes millimetres apart: the test can fail.
  const auto without = denseCalibration(s, 0.0);
  ASSERT_TRUE(without.IsSolutionUsable()) << without.FullReport();
  const auto e0 = without.mounting.toArray();
  double worst = 0;
  for (int j = 3; j < 6; ++j) worst = std::max(worst, std::abs(e0[j] - t[j]));
  EXPECT_GT(worst, 0.005 * kDeg);
  EXPECT_GT(without.section<CorrespondenceSection>().median_after_m, 10 * c.median_after_m);
  std::printf("without them: worst boresight angle %.4f deg, median after %.4f m\n", worst / kDeg,
              without.section<CorrespondenceSection>().median_after_m);
}
