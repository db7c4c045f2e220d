// Observability by an absolute rule (issue 26, item 4): a parameter is held only when the data
// do not determine it; adding observations never turns a determined parameter into a held one;
// a measured lever arm enters as a prior observation instead of a hard hold.
#include <gtest/gtest.h>

#include <set>
#include <string>
#include <vector>

#include "mountcal/mountcal.hpp"

namespace mountcal {
namespace {

using namespace simulation;

constexpr double kDeg = kPi / 180.0;

/// The crossing field at two heights, noise-free, with the picks and the roof regions.
const SimulatedSurvey& noiseFreeField(SurveyConfig* config_out = nullptr) {
  static SurveyConfig config;
  static const SimulatedSurvey survey = [] {
    Scene scene;
    makePreset("paper-calibration-field", 3, &config, &scene);
    config.noise = NoiseModel::none();
    config.roi_radius_m = 10.0;
    return simulate(config, scene);
  }();
  if (config_out) *config_out = config;
  return survey;
}

MountingCalibrator::Summary run(const std::vector<std::string>& methods) {
  MountingCalibrator::Options options;
  options.methods = methods;
  options.estimate = {true, true, false, true, true, true};
  return calibrate(toCalibrationData(noiseFreeField()), options);
}

std::set<std::string> held(const MountingCalibrator::Summary& s) { return {s.unobservable.begin(), s.unobservable.end()}; }

// A test per pair of methods: what either component determines, the combination determines.
class CombinationKeepsWhatAComponentDetermines : public ::testing::TestWithParam<std::pair<const char*, const char*>> {};

TEST_P(CombinationKeepsWhatAComponentDetermines, NoParameterAComponentDeterminesIsHeld) {
  const auto [a, b] = GetParam();
  const auto only_a = run({a}), only_b = run({b}), both = run({a, b});
  ASSERT_TRUE(only_a.IsSolutionUsable() && only_b.IsSolutionUsable() && both.IsSolutionUsable());
  for (const std::string& name : held(both)) {
    EXPECT_TRUE(held(only_a).count(name)) << name << " is held in " << a << "+" << b << " but determined by " << a << "\n"
                                          << both.observability_report;
    EXPECT_TRUE(held(only_b).count(name)) << name << " is held in " << a << "+" << b << " but determined by " << b << "\n"
                                          << both.observability_report;
  }
  // Information only grows: no formal σ of the combination above its components' (1 % for
  // rounding and the re-matched sets of the automatic methods). The σ with trajectory errors in
  // time may grow: observations weighted as independent that share a trajectory error are not
  // combined optimally — what that costs is what those σ state.
  for (int j = 0; j < 6; ++j) {
    if (!both.estimated[j]) continue;
    for (const auto* one : {&only_a, &only_b})
      if (one->estimated[j]) {
        EXPECT_LE(both.formal_sigma[j], 1.01 * one->formal_sigma[j]) << mountingParameterNames()[j];
      }
  }
}

INSTANTIATE_TEST_SUITE_P(Pairs, CombinationKeepsWhatAComponentDetermines,
                         ::testing::Values(std::make_pair("vtpm", "planes"), std::make_pair("vtpm", "correspondences"),
                                           std::make_pair("planes", "correspondences")),
                         [](const auto& info) { return std::string(info.param.first) + "_" + info.param.second; });

TEST(Observability, VtpmDeterminesTheAlongTrackLeverArmAndPlanesDoNotTakeItAway) {
  // The case measured in issue 26: vtpm alone determined lever_arm_x; with planes added the
  // old relative rule held it, and pitch absorbed its error.
  SurveyConfig config;
  noiseFreeField(&config);
  const auto vtpm = run({"vtpm"}), both = run({"vtpm", "planes"});
  ASSERT_TRUE(vtpm.estimated[kLeverX]) << vtpm.observability_report;
  ASSERT_TRUE(both.estimated[kLeverX]) << both.observability_report;
  const auto t = config.true_mounting.toArray(), e = both.mounting.toArray();
  EXPECT_LT(std::abs(e[kLeverX] - t[kLeverX]), 0.02);
  EXPECT_LT(std::abs(e[kBoresightPitch] - t[kBoresightPitch]), 0.002 * kDeg);
}

TEST(Observability, AMeasuredLeverArmIsAPriorNotAHold) {
  // Flat ground only: the horizontal lever arm is seen only through the aircraft's small roll
  // and pitch (σ of decimetres). Against a bound of 5 cm it is held; with the taped value's σ
  // it is estimated, its σ no larger than the tape's, and no held-value sensitivity is left.
  const SimulatedSurvey& s = noiseFreeField();
  CalibrationData data = toCalibrationData(s);
  data.plane_regions = flatGroundRegions(s);
  MountingCalibrator::Options options;
  options.methods = {"planes"};
  options.estimate = {true, true, false, true, true, true};
  options.undeterminable_sigma_m = 0.05;
  const auto free = calibrate(data, options);
  ASSERT_FALSE(free.estimated[kLeverX]) << free.FullReport();
  EXPECT_FALSE(free.held_sensitivity.col(kLeverX).isZero()) << "the held lever arm moves the boresight";
  for (int j : {kLeverX, kLeverY}) {
    options.prior_value[static_cast<std::size_t>(j)] = data.mounting_used.toArray()[static_cast<std::size_t>(j)];
    options.prior_sigma[static_cast<std::size_t>(j)] = 0.02;
  }
  const auto taped = calibrate(data, options);
  EXPECT_TRUE(taped.unobservable.empty()) << taped.observability_report;
  for (int j : {kLeverX, kLeverY}) {
    ASSERT_TRUE(taped.estimated[j]);
    EXPECT_LE(taped.formal_sigma[j], 0.02 * 1.0001);  // the tape's information, and the data's on top
    // Trajectory errors in time (2 cm vertical drift) pull the flat-ground estimate through the
    // aircraft's small pitch and roll: the σ that include them say so.
    EXPECT_GT(taped.sigma[j], taped.formal_sigma[j]);
  }
  EXPECT_GT(taped.formal_sigma[kLeverX], 0.02 * 0.5);  // flat ground adds little to the tape along x
  EXPECT_TRUE(taped.held_sensitivity.isZero());
}

// The verdict's reject over seeds: picks that scatter 3 cm stated as 1 mm give σ₀² far above
// 10 in every seed, and the verdict says so (the accept side: VtpmCalibration.
// SigmasAreHonestOverThirtySeeds accepts all 30 honest surveys).
TEST(Verdict, StatedSigmasFarTooSmallAreRejectedInEverySeed) {
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    Scene scene;
    SurveyConfig c;
    makePreset("paper-calibration-field", seed, &c, &scene);
    c.noise = NoiseModel::realistic();
    c.noise.pick_sigma_m = 0.03;
    c.roi_radius_m = 8.0;
    const SimulatedSurvey s = simulate(c, scene);
    MountingCalibrator::Options options;
    options.method<VtpmOptions>().tie_sigma_xy_m = 0.001;
    options.method<VtpmOptions>().tie_sigma_z_m = 0.001;
    const auto summary = calibrate(toCalibrationData(s), options);
    ASSERT_TRUE(summary.IsSolutionUsable());
    const auto verdict = summary.verdict();
    EXPECT_EQ(verdict.kind, MountingCalibrator::Verdict::Kind::kReject) << "seed " << seed << ": σ₀² " << summary.variance_factor;
    ASSERT_FALSE(verdict.reasons.empty());
    EXPECT_NE(verdict.reasons[0].find("σ₀²"), std::string::npos) << verdict.reasons[0];
    EXPECT_NE(summary.FullReport().find("Verdict: reject"), std::string::npos);
  }
}

}  // namespace
}  // namespace mountcal
