// Trajectory errors in time (TrajectoryAccuracy): the consider term of the mounting's
// covariance against closed forms — the variance of a mean of Gauss–Markov-correlated samples.
#include <gtest/gtest.h>

#include <ceres/sized_cost_function.h>

#include <cmath>
#include <string>
#include <vector>

#include "mountcal/adjustment/mounting_adjustment.hpp"
#include "mountcal/core/rotation.hpp"
#include "mountcal/mountcal.hpp"
#include "sanitizer_build.hpp"

namespace mountcal {
namespace {

/// r = (a_x + o_x − y) / σ: each observation measures the lever arm's x through its strip's
/// offset (held at zero), at a time and an IMU → point vector u.
class MeanResidual final : public ceres::SizedCostFunction<1, 6, 3> {
 public:
  MeanResidual(double y, double sigma) : y_(y), w_(1.0 / sigma) {}
  bool Evaluate(double const* const* p, double* r, double** J) const override {
    r[0] = (p[0][0] + p[1][0] - y_) * w_;
    if (J && J[0]) {
      for (int k = 0; k < 6; ++k) J[0][k] = k == 0 ? w_ : 0.0;
    }
    if (J && J[1]) {
      for (int k = 0; k < 3; ++k) J[1][k] = k == 0 ? w_ : 0.0;
    }
    return true;
  }

 private:
  double y_, w_;
};

struct Sample {
  std::string strip;
  double time_s;
  Vec3 u_m;
  double y = 0.0;  ///< the observed value [m]
};

class MeanSource final : public ObservationSource {
 public:
  MeanSource(std::vector<Sample> samples, double sigma) : samples_(std::move(samples)), sigma_(sigma) {}
  std::string kind() const override { return "mean"; }
  void addBlocks(const std::array<double, 6>& /*mounting*/, AdjustmentProblem* problem) override {
    for (const Sample& s : samples_) {
      const int k = problem->addResidualBlock(new MeanResidual(s.y, sigma_), sigma_, {problem->mounting(), problem->stripOffset(s.strip)});
      problem->setEpoch(k, s.strip, s.time_s, s.u_m);
    }
  }

 private:
  std::vector<Sample> samples_;
  double sigma_;
};

MountingAdjustment::Options meanOptions(const TrajectoryAccuracy& accuracy) {
  MountingAdjustment::Options o;
  o.estimate = {true, false, false, false, false, false};
  o.strip_offset_sigma_m = 0.0;  // offsets held: the closed form below has no nuisance
  o.trajectory = accuracy;
  return o;
}

/// Σ_ij exp(−|t_i − t_j| / τ) over the samples of one strip.
double correlationSum(const std::vector<Sample>& s, const std::string& strip, double tau) {
  double sum = 0;
  for (const Sample& a : s)
    for (const Sample& b : s)
      if (a.strip == strip && b.strip == strip) sum += std::exp(-std::abs(a.time_s - b.time_s) / tau);
  return sum;
}

TEST(TrajectoryErrors, PositionDriftGivesTheVarianceOfAMeanOfCorrelatedSamples) {
  // n samples, 0.3 s apart, of two strips: Var(â) = σ²/n + σ_p²/n² Σ_strips Σ_ij exp(−|t_i − t_j|/τ)
  // (hand derivation: â is the mean; the strips' drifts are independent).
  std::vector<Sample> s;
  for (int k = 0; k < 40; ++k) s.push_back({"1", 100.0 + 0.3 * k, Vec3(0, 0, -100)});
  for (int k = 0; k < 20; ++k) s.push_back({"2", 500.0 + 0.3 * k, Vec3(0, 0, -100)});
  const double sigma = 0.01, tau = 2.0;
  TrajectoryAccuracy acc = TrajectoryAccuracy::none();
  acc.position_sigma_m = 0.02;
  acc.position_correlation_s = tau;
  MeanSource source(s, sigma);
  const auto S = MountingAdjustment(meanOptions(acc)).solve(MountingParameters{}, {&source});
  ASSERT_TRUE(S.IsSolutionUsable()) << S.message;
  const double n = static_cast<double>(s.size());
  const double formal = sigma * sigma / n;
  const double drift = 0.02 * 0.02 / (n * n) * (correlationSum(s, "1", tau) + correlationSum(s, "2", tau));
  EXPECT_NEAR(S.formal_sigma[0], std::sqrt(formal), 1e-9);
  EXPECT_NEAR(S.sigma[0], std::sqrt(formal + drift), 1e-6 * std::sqrt(formal + drift));
  EXPECT_EQ(S.sigma_model, "formal + trajectory errors in time");
  EXPECT_GT(S.sigma[0], 2.0 * S.formal_sigma[0]);  // the drift dominates here
}

TEST(TrajectoryErrors, AttitudeDriftMovesAPointByTheRotationTimesItsArm) {
  // δx = δψ × u. With u = (0, 0, −H) only pitch moves x: δx = −H δψ_y (σ_t); with u = (0, L, 0)
  // only heading: δx = −L δψ_z (σ_κ). Var(â) = σ²/n + σ_t² H²/n² Σρ + σ_κ² L²/n² Σρ.
  const double H = 120.0, L = 40.0, tau = 1.0;
  std::vector<Sample> s;
  for (int k = 0; k < 30; ++k) s.push_back({"a", 0.1 * k, k % 2 ? Vec3(0, 0, -H) : Vec3(0, L, 0)});
  TrajectoryAccuracy acc = TrajectoryAccuracy::none();
  acc.roll_pitch_sigma_deg = 0.003;
  acc.heading_sigma_deg = 0.01;
  acc.attitude_correlation_s = tau;
  MeanSource source(s, 0.005);
  const auto S = MountingAdjustment(meanOptions(acc)).solve(MountingParameters{}, {&source});
  ASSERT_TRUE(S.IsSolutionUsable()) << S.message;
  const double n = static_cast<double>(s.size()), st = deg2rad(0.003), sk = deg2rad(0.01);
  // Pitch and heading errors are independent axes: only pitch×pitch and heading×heading pairs.
  double sum_pitch = 0, sum_heading = 0;
  for (std::size_t i = 0; i < s.size(); ++i)
    for (std::size_t j = 0; j < s.size(); ++j) {
      const double rho = std::exp(-std::abs(s[i].time_s - s[j].time_s) / tau);
      const bool pi = s[i].u_m.z() != 0, pj = s[j].u_m.z() != 0;
      if (pi && pj) sum_pitch += rho;
      if (!pi && !pj) sum_heading += rho;
    }
  const double expected = 0.005 * 0.005 / n + (st * st * H * H * sum_pitch + sk * sk * L * L * sum_heading) / (n * n);
  EXPECT_NEAR(S.sigma[0], std::sqrt(expected), 1e-6 * std::sqrt(expected));
}

// ---- the time offset (StochasticOptions::time_offset_sigma_s) -----------------------------------

/// Level, straight flight along x: strip "fast" at 60 m/s, "slow" at 40 m/s, no rotation.
MotionFunction straightFlight() {
  return [](const std::string& strip, double, Vec3* v, Vec3* w) {
    *v = Vec3(strip == "slow" ? 40.0 : 60.0, 0, 0);
    *w = Vec3::Zero();
    return true;
  };
}

TEST(TimeOffset, AtOneSpeedItIsAnAlongTrackLeverArm) {
  // Hand derivation: the residual (a_x + o_x − y)/σ moves with δt by v δt/σ (∂x/∂δt = v): the
  // lever arm's column times v. As a consider parameter Var(â_x) gains v² σ_t²; estimated beside
  // a_x it keeps its prior σ exactly, and the two cannot be told apart.
  std::vector<Sample> s;
  for (int k = 0; k < 40; ++k) s.push_back({"fast", 100.0 + 0.3 * k, Vec3(0, 0, -100)});
  MountingAdjustment::Options o = meanOptions(TrajectoryAccuracy::none());
  o.time_offset_sigma_s = 0.002;
  MeanSource source(s, 0.01);
  const auto S = MountingAdjustment(o).setMotion(straightFlight()).solve(MountingParameters{}, {&source});
  ASSERT_TRUE(S.IsSolutionUsable()) << S.message;
  const double formal = 0.01 * 0.01 / 40.0;
  EXPECT_NEAR(S.formal_sigma[0], std::sqrt(formal), 1e-9);
  EXPECT_NEAR(S.sigma[0] * S.sigma[0], formal + 60.0 * 60.0 * 0.002 * 0.002, 1e-9);
  EXPECT_EQ(S.sigma_model, "formal + time offset");
  EXPECT_NEAR(S.time_offset_sigma_s, 0.002, 1e-9);
  EXPECT_NEAR(S.time_offset_s, 0.0, 1e-9);
  EXPECT_NE(S.observability_report.find("The time offset is not determined"), std::string::npos) << S.observability_report;
  EXPECT_NE(S.observability_report.find("it can hardly be told from lever_arm_x"), std::string::npos) << S.observability_report;
  // Without the motion (per-point poses) nothing is analysed, and the report says so.
  const auto N = MountingAdjustment(o).solve(MountingParameters{}, {&source});
  EXPECT_TRUE(std::isnan(N.time_offset_s));
  EXPECT_EQ(N.sigma_model, "formal");
  EXPECT_NE(N.observability_report.find("The time offset is not analysed"), std::string::npos);
}

TEST(TimeOffset, TwoSpeedsSeparateItAndTheFirstOrderEstimateIsTheTruth) {
  // y = a + v δ at 60 and 40 m/s: solved with δt = 0 the lever arm takes the mean, a + 50 δ;
  // one Gauss–Newton step with δt (linear here: exact, up to its weak prior) gives δ back and
  // moves a_x to a. The data reject δt = 0 (|δ̂|/σ ≫ 2): a model error, not an ambiguity.
  const double a = 0.3, delta = 0.004;
  std::vector<Sample> s;
  for (int k = 0; k < 40; ++k) s.push_back({"fast", 100.0 + 0.3 * k, Vec3(0, 0, -100), a + 60.0 * delta});
  for (int k = 0; k < 40; ++k) s.push_back({"slow", 300.0 + 0.3 * k, Vec3(0, 0, -100), a + 40.0 * delta});
  MountingAdjustment::Options o = meanOptions(TrajectoryAccuracy::none());
  o.time_offset_sigma_s = 1.0;  // a weak prior
  MeanSource source(s, 0.01);
  const auto S = MountingAdjustment(o).setMotion(straightFlight()).solve(MountingParameters{}, {&source});
  ASSERT_TRUE(S.IsSolutionUsable()) << S.message;
  EXPECT_NEAR(S.mounting.a_b.x(), a + 50.0 * delta, 1e-8);
  EXPECT_NEAR(S.time_offset_s, delta, 1e-7);
  // σ of δ from the two means' difference: σ √(1/40 + 1/40) / (60 − 40).
  EXPECT_NEAR(S.time_offset_sigma_s, 0.01 * std::sqrt(2.0 / 40.0) / 20.0, 1e-8);
  EXPECT_EQ(S.observability_report.find("not determined"), std::string::npos) << S.observability_report;
  ASSERT_EQ(S.model_sensitivity.size(), 1u);
  const auto& ms = S.model_sensitivity[0];
  EXPECT_NE(ms.change.find("the time offset estimated"), std::string::npos);
  EXPECT_NEAR(S.mounting.a_b.x() + ms.shift[0], a, 1e-6);
  EXPECT_GT(ms.rejected_in_sigma, 10.0);
  EXPECT_FALSE(ms.model_dependent());
}

TEST(TimeOffset, FromTheTrajectoryOnTheCrossingField) {
  // The calibrator's motion comes from the trajectory (central differences). Every line of the
  // crossing field is flown at 60 m/s: δt adds (60 m/s · σ_t)² to lever x's variance (the
  // closed form above, within the attitude oscillation's share) and barely changes the
  // boresight's.
  simulation::Scene scene;
  simulation::SurveyConfig c;
  simulation::makePreset("paper-calibration-field", 1, &c, &scene);
  c.noise = simulation::NoiseModel::none();
  c.roi_radius_m = 8.0;
  const CalibrationData data = simulation::toCalibrationData(simulation::simulate(c, scene));
  MountingCalibrator::Options o;
  o.estimate = {true, true, false, true, true, true};
  o.strip_offset_sigma_m = 0;
  o.trajectory = TrajectoryAccuracy::none();
  const auto S0 = calibrate(data, o);
  o.time_offset_sigma_s = 0.005;
  const auto S1 = calibrate(data, o);
  ASSERT_TRUE(S0.IsSolutionUsable() && S1.IsSolutionUsable());
  const double added = 60.0 * 60.0 * 0.005 * 0.005;
  EXPECT_NEAR(S1.sigma[kLeverX] * S1.sigma[kLeverX] - S0.sigma[kLeverX] * S0.sigma[kLeverX], added, 0.1 * added);
  for (int j : {kBoresightRoll, kBoresightPitch, kBoresightHeading}) EXPECT_NEAR(S1.sigma[j], S0.sigma[j], 0.1 * S0.sigma[j]) << j;
  // The 0.2–0.3° attitude oscillation turns at up to 0.2°/s with 0.8–1.3 km arms (ω × u): that
  // separates part of δt from lever x — measured σ 2.2 ms against the 5 ms prior.
  EXPECT_GT(S1.time_offset_sigma_s, 0.2 * 0.005);
  EXPECT_LT(S1.time_offset_sigma_s, 0.7 * 0.005) << S1.FullReport();
  EXPECT_EQ(S1.observability_report.find("time offset is not determined"), std::string::npos);
  EXPECT_LT(std::abs(S1.time_offset_s), 1e-4) << "noise-free, no latency simulated";
  EXPECT_NE(S1.FullReport().find("Time offset (first order, not applied)"), std::string::npos);
}

TEST(TrajectoryErrors, NoneLeavesTheFormalSigma) {
  std::vector<Sample> s;
  for (int k = 0; k < 10; ++k) s.push_back({"1", 0.5 * k, Vec3(0, 0, -100)});
  MeanSource source(s, 0.01);
  const auto S = MountingAdjustment(meanOptions(TrajectoryAccuracy::none())).solve(MountingParameters{}, {&source});
  ASSERT_TRUE(S.IsSolutionUsable());
  EXPECT_EQ(S.sigma_model, "formal");
  EXPECT_DOUBLE_EQ(S.sigma[0], S.formal_sigma[0]);
  EXPECT_NEAR(S.sigma[0], 0.01 / std::sqrt(10.0), 1e-9);
}

TEST(TrajectoryErrors, InvalidAccuracyIsRefusedWithTheField) {
  TrajectoryAccuracy acc;
  acc.position_correlation_s = 0.0;
  std::string why;
  EXPECT_FALSE(acc.IsValid(&why));
  EXPECT_NE(why.find("position_correlation_s"), std::string::npos) << why;
  acc = TrajectoryAccuracy();
  acc.heading_sigma_deg = -1.0;
  EXPECT_FALSE(acc.IsValid(&why));
  EXPECT_NE(why.find("heading_sigma_deg"), std::string::npos) << why;
}

// ---- model sensitivity: a free lever arm --------------------------------------------------------

/// r = (a_x + h · pitch − y) / σ: the along-track lever arm and the pitch seen alike through
/// heights h that hardly differ — the one-height coupling, linear.
class CoupledResidual final : public ceres::SizedCostFunction<1, 6> {
 public:
  CoupledResidual(double h, double y, double sigma) : h_(h), y_(y), w_(1.0 / sigma) {}
  bool Evaluate(double const* const* p, double* r, double** J) const override {
    r[0] = (p[0][0] + h_ * p[0][4] - y_) * w_;
    if (J && J[0]) {
      for (int k = 0; k < 6; ++k) J[0][k] = k == 0 ? w_ : k == 4 ? h_ * w_ : 0.0;
    }
    return true;
  }

 private:
  double h_, y_, w_;
};

class CoupledSource final : public ObservationSource {
 public:
  std::string kind() const override { return "coupled"; }
  void addBlocks(const std::array<double, 6>& /*mounting*/, AdjustmentProblem* problem) override {
    for (int k = 0; k < 20; ++k) {
      const double h = k % 2 ? 101.0 : 100.0;
      problem->addResidualBlock(new CoupledResidual(h, 0.1, 0.005), 0.005, {problem->mounting()});  // truth a_x 0.1 m, pitch 0
    }
  }
};

TEST(ModelSensitivity, AFreeLeverArmTheDataCannotRejectButThatMovesThePitchIsModelDependent) {
  // By hand (n = 20, h alternating 100 / 101, σ = 5 mm, noise-free y = 0.1): â = 0.1 m;
  // N = [n Σh; Σh Σh²]/σ² with Σh = 2010, Σh² = 202010, det·σ⁴ = 100 → σ_a = σ √(Σh²/100) = 0.2247 m,
  // so the used 0 is 0.45σ away (not rejected). Held at 0, pitch moves by â Σh / Σh² = 9.950e-4
  // rad, and the held model states σ_pitch = σ / √Σh² = 1.112e-5 rad: 89σ.
  CoupledSource source;
  MountingAdjustment::Options o;
  o.estimate = {true, false, false, false, true, false};
  o.trajectory = TrajectoryAccuracy::none();
  const auto S = MountingAdjustment(o).solve(MountingParameters{}, {&source});
  ASSERT_TRUE(S.IsSolutionUsable()) << S.message;
  EXPECT_NEAR(S.mounting.a_b.x(), 0.1, 1e-9);
  EXPECT_NEAR(S.sigma[0], 0.005 * std::sqrt(202010.0 / 100.0), 1e-6);
  ASSERT_EQ(S.model_sensitivity.size(), 1u);
  const auto& ms = S.model_sensitivity[0];
  EXPECT_NEAR(ms.shift[4], 0.1 * 2010.0 / 202010.0, 1e-9);
  EXPECT_NEAR(ms.shift_in_sigma[4], (0.1 * 2010.0 / 202010.0) / (0.005 / std::sqrt(202010.0)), 1e-3);
  EXPECT_NEAR(ms.rejected_in_sigma, 0.1 / S.sigma[0], 1e-9);
  EXPECT_TRUE(ms.model_dependent()) << ms.text();
  EXPECT_NE(ms.text().find("model-dependent"), std::string::npos) << ms.text();
}

TEST(ModelSensitivity, ALeverArmTheDataRejectIsNotAnAmbiguity) {
  // The same with heights 100 and 200: the lever arm is determined (σ_a ≈ 2 mm), the used 0 is
  // rejected at ≈ 50σ, and holding it is a wrong model, not an alternative one.
  class Separated final : public ObservationSource {
   public:
    std::string kind() const override { return "separated"; }
    void addBlocks(const std::array<double, 6>& /*mounting*/, AdjustmentProblem* problem) override {
      for (int k = 0; k < 20; ++k)
        problem->addResidualBlock(new CoupledResidual(k % 2 ? 200.0 : 100.0, 0.1, 0.005), 0.005, {problem->mounting()});
    }
  } source;
  MountingAdjustment::Options o;
  o.estimate = {true, false, false, false, true, false};
  o.trajectory = TrajectoryAccuracy::none();
  const auto S = MountingAdjustment(o).solve(MountingParameters{}, {&source});
  ASSERT_EQ(S.model_sensitivity.size(), 1u);
  EXPECT_GT(S.model_sensitivity[0].rejected_in_sigma, 3.0);
  EXPECT_FALSE(S.model_sensitivity[0].model_dependent()) << S.model_sensitivity[0].text();
}

// ---- statistical: σ under navigation drift ----------------------------------------------------

struct Honesty {
  std::array<double, 6> z2_total{}, z2_formal{};
  std::array<int, 6> within{}, counted{};
};

/// `planes` on the crossing field over `seeds` surveys with navigation drift in time (band-limited
/// sinusoids: a form the calibrator does not model), as examples/sigma_honesty does.
Honesty planesUnderDrift(int seeds) {
  Honesty h;
  for (int seed = 1; seed <= seeds; ++seed) {
    simulation::Scene scene;
    simulation::SurveyConfig c;
    simulation::makePreset("paper-calibration-field", static_cast<std::uint64_t>(seed), &c, &scene);
    c.noise = simulation::NoiseModel::withNavigationDrift();
    c.noise.gnss_sigma_m = 0.005;
    c.roi_radius_m = 12.0;
    const simulation::SimulatedSurvey s = simulation::simulate(c, scene);
    MountingCalibrator::Options o;
    o.methods = {"planes"};
    o.strip_offset_sigma_m = 0.02;
    o.estimate = {true, true, false, true, true, true};
    const auto S = calibrate(simulation::toCalibrationData(s), o);
    EXPECT_TRUE(S.IsSolutionUsable()) << "seed " << seed;
    const auto e = S.mounting.toArray(), t = c.true_mounting.toArray();
    for (std::size_t j = 0; j < 6; ++j) {
      if (!S.estimated[j]) continue;
      const double z = (e[j] - t[j]) / S.sigma[j], zf = (e[j] - t[j]) / S.formal_sigma[j];
      h.z2_total[j] += z * z;
      h.z2_formal[j] += zf * zf;
      h.within[j] += std::abs(z) <= 2.0;
      ++h.counted[j];
    }
  }
  return h;
}

// Issue 26's criterion on the plane method: over 30 surveys with navigation drift, RMS of
// error/σ within [0.7, 1.4] for every estimated parameter and at least 85 % within 2σ (26 of 30:
// 2.3 binomial σ below 95.4 %); the formal σ fail it (their RMS was 2.0–3.3). Measured
// (2026-11-26): RMS 0.99–1.33, 87–97 % within 2σ. About 25 s in Release; the sanitizer build
// runs 2 seeds for memory errors only.
TEST(TrajectoryErrors, PlaneSigmasAreHonestUnderNavigationDrift) {
  const int seeds = mountcal_tests::seedsFor(30, 2);
  const Honesty h = planesUnderDrift(seeds);
  MOUNTCAL_STATISTICS_IN_RELEASE_ONLY("σ honesty over 30 seeds");
  bool formal_fails = false;
  for (std::size_t j = 0; j < 6; ++j) {
    if (h.counted[j] == 0) continue;
    EXPECT_EQ(h.counted[j], seeds);
    const double rms = std::sqrt(h.z2_total[j] / h.counted[j]), rms_formal = std::sqrt(h.z2_formal[j] / h.counted[j]);
    const double frac = static_cast<double>(h.within[j]) / h.counted[j];
    std::printf("%-20s RMS of error/sigma %.2f (formal %.2f), %.0f %% within 2 sigma\n", mountingParameterNames()[j].c_str(), rms,
                rms_formal, 100 * frac);
    formal_fails |= rms_formal > 1.4;
    EXPECT_GE(rms, 0.7) << mountingParameterNames()[j] << ": σ too large";
    EXPECT_LE(rms, 1.4) << mountingParameterNames()[j] << ": σ too small";
    EXPECT_GE(frac, 0.85) << mountingParameterNames()[j];
  }
  EXPECT_TRUE(formal_fails) << "the formal σ should fail this test: it would not discriminate";
}

}  // namespace
}  // namespace mountcal
