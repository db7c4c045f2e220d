// VTPM self-calibration on simulated data with known truth (issue: VTPM self-calibration).
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <map>
#include <memory>
#include <random>
#include <set>

#include "mountcal/mountcal.hpp"
#include "mountcal/core/error.hpp"

#include "methods/common/vtp_cost.hpp"
#include "mountcal/report/evaluation.hpp"
#include "mountcal/mounting_calibrator.hpp"
#include "mountcal/simulation/survey.hpp"
#include "sanitizer_build.hpp"
#include "scatter.hpp"
#include "support.hpp"

using namespace mountcal_tests;
using namespace mountcal;
using namespace mountcal::simulation;

namespace {

/// Calibrator options that state the same stochastic model.
MountingCalibrator::Options surveyGradeOptions() {
  MountingCalibrator::Options o;
  o.method<VtpmOptions>().tie_sigma_xy_m = 0.03;
  o.method<VtpmOptions>().tie_sigma_z_m = 0.03;
  o.strip_offset_sigma_m = 0.005;
  return o;
}

/// The crossing field with points kept within 8 m of the tie features (what VTPM picks from).
const SimulatedSurvey& tieField(std::uint64_t seed, bool noise, const std::string& preset = "paper-calibration-field") {
  return crossingField(seed, noise, 8.0, preset);
}

}  // namespace

TEST(VtpmCalibration, NoiseFreeCrossingFieldRecoversTheTruth) {
  // All six parameters, from zero; ground control at the tie features makes the vertical lever
  // arm observable (without it, it is held, and its 0.2 m leaks ~2e-4° into the heading
  // through the attitude oscillation — see VerticalLeverArmNeedsGroundControl).
  const SimulatedSurvey& s = tieField(1, false);
  CalibrationData d = toCalibrationData(s);
  for (const FeaturePoint& f : s.gcps) d.gcps.push_back({f.id, f.x_m.x(), f.x_m.y(), f.x_m.z(), 0.01, 0.01});
  MountingCalibrator::Options o;
  o.estimate.fill(true);
  const auto S = calibrate(d, o);
  ASSERT_TRUE(S.IsSolutionUsable()) << S.FullReport();
  EXPECT_TRUE(S.unobservable.empty()) << S.observability_report;
  const auto e = S.mounting.toArray(), t = s.config.true_mounting.toArray();
  for (int j : {kBoresightRoll, kBoresightPitch, kBoresightHeading}) EXPECT_LT(std::abs(e[j] - t[j]), 1e-4 * kDeg) << j;
  for (int j : {kLeverX, kLeverY, kLeverZ}) EXPECT_LT(std::abs(e[j] - t[j]), 1e-3) << j;
  EXPECT_LT(S.section<VtpmSection>().rms_after_m.maxCoeff(), 0.005);
  EXPECT_GT(S.section<VtpmSection>().rms_before_m.head<2>().minCoeff(), 0.5);  // the misalignment was real
  // Without ground control and with the default estimate (lever z held at its used value),
  // the boresight is still within 3e-4° and the horizontal lever arm within 1 mm.
  const auto H = calibrate(toCalibrationData(s));
  ASSERT_TRUE(H.IsSolutionUsable());
  EXPECT_FALSE(H.estimated[kLeverZ]);
  const auto h = H.mounting.toArray();
  for (int j : {kBoresightRoll, kBoresightPitch, kBoresightHeading}) EXPECT_LT(std::abs(h[j] - t[j]), 3e-4 * kDeg) << j;
  for (int j : {kLeverX, kLeverY}) EXPECT_LT(std::abs(h[j] - t[j]), 1e-3) << j;
}

TEST(VtpmCalibration, SurveyGradeNoiseWithinToleranceAndHonestSigmas) {
  mountcal_tests::ScatterOfErrors scatter;
  for (std::uint64_t seed : {1, 2, 3}) {
    const SimulatedSurvey& s = tieField(seed, true);
    // The data have no navigation drift in time: stated so (the default TrajectoryAccuracy
    // assumes a real GNSS/INS solution's and would overstate σ here, which the scatter bound sees:
    // RMS of error/σ 0.26 over these 15 values with it, 2026-11-26).
    MountingCalibrator::Options o = surveyGradeOptions();
    o.trajectory = TrajectoryAccuracy::none();
    const auto S = calibrate(toCalibrationData(s), o);
    ASSERT_TRUE(S.IsSolutionUsable()) << S.FullReport();
    const auto e = S.mounting.toArray(), t = s.config.true_mounting.toArray();
    for (int j : {kBoresightRoll, kBoresightPitch, kBoresightHeading}) {
      EXPECT_LT(std::abs(e[j] - t[j]), 0.003 * kDeg) << "seed " << seed << " param " << j;
      EXPECT_LT(std::abs(e[j] - t[j]), 3 * S.sigma[j]) << "seed " << seed << " param " << j;
      scatter.add(e[j] - t[j], S.sigma[j]);
    }
    for (int j : {kLeverX, kLeverY}) {
      EXPECT_LT(std::abs(e[j] - t[j]), 0.05) << "seed " << seed << " param " << j;
      EXPECT_LT(std::abs(e[j] - t[j]), 3 * S.sigma[j]) << "seed " << seed << " param " << j;
      scatter.add(e[j] - t[j], S.sigma[j]);
    }
    // The stated stochastic model matches the residuals: σ₀² near 1.
    EXPECT_GT(S.variance_factor, 0.5) << seed;
    EXPECT_LT(S.variance_factor, 2.0) << seed;
  }
  scatter.expectNotOverstated("vtpm");
}

TEST(VtpmCalibration, MultiBeamPicksMoveWithTheMeanOfTheirNeighbourhood) {
  // The uav-vlp16 preset noise-free (VLP-16 on its side, 40-60 m, a-priori boresight error 0.5°,
  // −0.8°, 1.2°): each pick is the target's place at the mounting used, where sixteen lasers
  // tilted ±15° along the track each put it elsewhere. Moved with its enclosing triangle (one
  // laser's pulses) the pick follows that laser; moved with the mean displacement of the points
  // around it, each laser weighing the same (VtpMotion::kNeighbourhood, the default on strips with
  // laser ids), the lasers' displacements cancel to first order. Measured (2026-12-05, seeds 1-8):
  // heading error RMS 0.022° with the plain mean displacement, 0.0086° since the pick is an affine
  // combination of its neighbourhood that reproduces it in plan (on the true surface at the true
  // mounting), against 0.047° with the triangle. Noise-free but not zero: the pick is the scan
  // plane's ray and the neighbourhood holds 3-12 of the 16 lasers (the ROI's time windows) — within
  // the noisy surveys' σ (heading 0.04°, pitch 0.05°, lever x 0.07 m).
  const int seeds = mountcal_tests::seedsFor(8, 1);
  double z2_nb = 0, z2_tri = 0;
  for (int seed = 1; seed <= seeds; ++seed) {
    SurveyConfig c;
    Scene scene;
    makePreset("uav-vlp16", static_cast<std::uint64_t>(seed), &c, &scene);
    c.noise = NoiseModel::none();
    const SimulatedSurvey s = simulate(c, scene);
    const CalibrationData d = toCalibrationData(s);
    ASSERT_FALSE(d.strips[0].laser.empty());
    const auto t = c.true_mounting.toArray();
    for (VtpMotion motion : {VtpMotion::kAuto, VtpMotion::kTriangle}) {
      MountingCalibrator::Options o;
      o.estimate = {true, true, false, true, true, true};
      o.trajectory = TrajectoryAccuracy::none();
      o.method<VtpmOptions>().vtp.motion = motion;
      const auto S = calibrate(d, o);
      ASSERT_TRUE(S.IsSolutionUsable()) << S.FullReport();
      const auto e = S.mounting.toArray();
      const double heading = std::abs(e[kBoresightHeading] - t[kBoresightHeading]);
      (motion == VtpMotion::kAuto ? z2_nb : z2_tri) += heading * heading;
      if (motion != VtpMotion::kAuto) continue;
      EXPECT_EQ(S.section<VtpmSection>().neighbourhood_motion, S.section<VtpmSection>().observations_used);
      for (int j : {kBoresightRoll, kBoresightPitch, kBoresightHeading}) EXPECT_LT(std::abs(e[j] - t[j]), 0.06 * kDeg) << seed << " " << j;
      for (int j : {kLeverX, kLeverY}) EXPECT_LT(std::abs(e[j] - t[j]), 0.08) << seed << " " << j;  // lever x 0.065 m at worst (seed 5)
    }
  }
  MOUNTCAL_STATISTICS_IN_RELEASE_ONLY("the RMS heading error over 8 noise-free surveys");
  std::printf("RMS heading error: neighbourhood %.4f°, triangle %.4f°\n", std::sqrt(z2_nb / seeds) / kDeg,
              std::sqrt(z2_tri / seeds) / kDeg);
  EXPECT_LT(z2_nb, 0.16 * z2_tri);  // RMS below 0.4 of the triangle's (0.18 measured)
}

TEST(VtpmCalibration, MultiBeamSigmasAreHonestWithALargeAprioriBoresightError) {
  // The uav-vlp16 preset with its noise (picks 5 cm, the preset's navigation and range noise) and
  // its job's settings, seeds 1-12: with the picks moved by their triangles (before upright
  // triangles were refused) the heading's RMS of error/σ was 3.4 over these seeds (10.6σ at worst,
  // every error negative but one); now every parameter's RMS is 0.71-0.86 (2026-12-05; over 30
  // seeds scripts/experiments/uav-vtpm). Bound: 1.5, about the 99 % point of √(χ²₁₂/12) (1.48) for an honest σ.
  const int seeds = mountcal_tests::seedsFor(12, 1);
  std::array<double, 6> z2{};
  for (int seed = 1; seed <= seeds; ++seed) {
    SurveyConfig c;
    Scene scene;
    makePreset("uav-vlp16", static_cast<std::uint64_t>(seed), &c, &scene);
    const SimulatedSurvey s = simulate(c, scene);
    MountingCalibrator::Options o;
    o.estimate = {true, true, false, true, true, true};
    const auto S = calibrate(toCalibrationData(s), o);
    ASSERT_TRUE(S.IsSolutionUsable()) << seed << "\n" << S.FullReport();
    EXPECT_EQ(S.section<VtpmSection>().neighbourhood_motion, S.section<VtpmSection>().observations_used);
    const auto e = S.mounting.toArray(), t = c.true_mounting.toArray();
    for (int j : {kLeverX, kLeverY, kBoresightRoll, kBoresightPitch, kBoresightHeading}) z2[j] += std::pow((e[j] - t[j]) / S.sigma[j], 2);
  }
  MOUNTCAL_STATISTICS_IN_RELEASE_ONLY("the RMS of error/σ over 12 seeds");
  for (int j : {kLeverX, kLeverY, kBoresightRoll, kBoresightPitch, kBoresightHeading}) {
    const double rms = std::sqrt(z2[j] / seeds);
    std::printf("%s RMS of error/sigma %.2f\n", mountingParameterNames()[j].c_str(), rms);
    EXPECT_LT(rms, 1.5) << mountingParameterNames()[j];
  }
}

TEST(VtpmCalibration, VerticalLeverArmNeedsGroundControl) {
  const SimulatedSurvey& s = tieField(1, false);
  MountingCalibrator::Options o;
  o.estimate.fill(true);
  const auto S = calibrate(toCalibrationData(s), o);
  ASSERT_TRUE(S.IsSolutionUsable());
  ASSERT_EQ(S.unobservable.size(), 1u) << S.observability_report;
  EXPECT_EQ(S.unobservable[0], "lever_arm_z");
  EXPECT_TRUE(std::isnan(S.sigma[kLeverZ]));
  EXPECT_NE(S.observability_report.find("lever_arm_z cannot be determined"), std::string::npos);
  EXPECT_NE(S.FullReport().find("undeterminable"), std::string::npos);
  // With ground control at the tie features the vertical lever arm is recovered.
  CalibrationData d = toCalibrationData(s);
  for (const FeaturePoint& f : s.gcps) d.gcps.push_back({f.id, f.x_m.x(), f.x_m.y(), f.x_m.z(), 0.01, 0.01});
  const auto G = calibrate(d, o);
  ASSERT_TRUE(G.IsSolutionUsable());
  EXPECT_TRUE(G.unobservable.empty()) << G.observability_report;
  EXPECT_NEAR(G.mounting.a_b.z(), s.config.true_mounting.a_b.z(), 2e-3);
  EXPECT_LT(G.sigma[kLeverZ], 0.05);
}

TEST(VtpmCalibration, CorrectingTheCheckBlockShrinksCheckPointErrorsTenfold) {
  const SimulatedSurvey& f = tieField(1, true);
  const auto S = calibrate(toCalibrationData(f), surveyGradeOptions());
  ASSERT_TRUE(S.IsSolutionUsable());
  const SimulatedSurvey& block = tieField(1, true, "paper-check-block");
  const CalibrationData check = toCalibrationData(block, /*use_check_points=*/true);
  ASSERT_GE(check.ties.size(), 14u);
  const auto before = evaluateCheckPoints(check, block.config.nominal_mounting);
  const auto after = evaluateCheckPoints(check, S.mounting);
  ASSERT_EQ(before.residuals.size(), after.residuals.size());
  EXPECT_GE(before.residuals.size(), 12u);
  EXPECT_LT(after.rms_m.norm() * 10, before.rms_m.norm()) << before.rms_m.transpose() << " -> " << after.rms_m.transpose();
  std::vector<PlaneRegion> planes;
  for (const auto& p : block.check_planes) planes.push_back({p.id, p.xmin, p.ymin, p.xmax, p.ymax});
  const auto pb = evaluateCheckPlanes(check, planes, block.config.nominal_mounting);
  const auto pa = evaluateCheckPlanes(check, planes, S.mounting);
  ASSERT_EQ(pb.size(), 2u);
  for (std::size_t i = 0; i < pb.size(); ++i) {
    EXPECT_GT(pb[i].points, 50);
    EXPECT_LT(pa[i].rms_m, pb[i].rms_m) << pb[i].plane_id;
  }
}

TEST(VtpmCalibration, DegenerateParallelFlightNamesWhatCannotBeSeparated) {
  Scene scene;
  SurveyConfig c;
  makePreset("paper-calibration-field", 5, &c, &scene);
  c.noise = NoiseModel::none();
  c.roi_radius_m = 6.0;
  c.lines = {{"1", -700, 0, deg2rad(90), 1400, 760, 60},
             {"2", -700, 150, deg2rad(90), 1400, 760, 60},
             {"3", -700, -150, deg2rad(90), 1400, 760, 60}};
  const SimulatedSurvey s = simulate(c, scene);
  MountingCalibrator::Options o;
  o.estimate.fill(true);
  const auto S = calibrate(toCalibrationData(s), o);
  // One height, parallel lines: the lever arm has no observation of its own (its σ would be
  // metres) and is held; pitch is then determined — given the held along-track lever arm, which
  // it cannot be separated from: the summary says how far each held value's error moves it.
  std::set<std::string> un(S.unobservable.begin(), S.unobservable.end());
  for (const char* name : {"lever_arm_x", "lever_arm_y", "lever_arm_z"})
    EXPECT_TRUE(un.count(name)) << name << "\n" << S.observability_report;
  for (const char* name : {"boresight_roll", "boresight_pitch", "boresight_heading"}) EXPECT_FALSE(un.count(name)) << name;
  for (int j : {kLeverX, kLeverY, kLeverZ}) EXPECT_TRUE(std::isnan(S.sigma[j])) << j;
  EXPECT_NE(S.observability_report.find("held lever_arm_x moves boresight_pitch"), std::string::npos) << S.observability_report;
  // The sensitivities predict the errors the held values cause (noise-free: nothing else): a
  // hand check of −N_ee⁻¹ N_eh against the truth.
  const auto e = S.mounting.toArray(), t = c.true_mounting.toArray(), u = S.mounting_used.toArray();
  for (int j : {kBoresightRoll, kBoresightPitch, kBoresightHeading}) {
    double predicted = 0;
    for (int h : {kLeverX, kLeverY, kLeverZ}) predicted += S.held_sensitivity(j, h) * (u[h] - t[h]);
    EXPECT_NEAR(e[j] - t[j], predicted, 0.0003 * kDeg + 0.05 * std::abs(predicted)) << j;
  }
  EXPECT_GT(std::abs(S.held_sensitivity(kBoresightPitch, kLeverX)), 0.5 * kDeg / 10.0) << "pitch moves ≥ 0.05°/m of lever x at 760 m";
  // Roll and heading are still recovered from the parallel offsets (SPEC §2 closed form), to
  // within what the held parameters' true values (0.1 m, 0.08°) leak into them.
  EXPECT_LT(std::abs(e[kBoresightRoll] - t[kBoresightRoll]), 0.002 * kDeg);
  EXPECT_LT(std::abs(e[kBoresightHeading] - t[kBoresightHeading]), 0.002 * kDeg);
}

TEST(VtpmCalibration, UnbuildableTiesAreRejectedWithAReason) {
  const SimulatedSurvey& s = tieField(1, false);
  CalibrationData d = toCalibrationData(s);
  std::size_t b = 0;
  while (d.ties[b].tie_id.rfind("ring_", 0) != 0) ++b;  // a ground target: data is centred on it
  const TieObservation base = d.ties[b];
  TieObservation far = base;
  far.tie_id = "far_away";
  far.x_m += 500;
  TieObservation far2 = far;
  far2.strip_id = d.ties.back().strip_id;
  // Just past the edge of the simulated data around the feature (ROI 8 m + 3 m margin).
  TieObservation edge = base;
  edge.tie_id = "edge";
  edge.x_m += 11.3;
  TieObservation edge2 = edge;
  edge2.strip_id = d.ties[b + 1].strip_id;
  d.ties.insert(d.ties.end(), {far, far2, edge, edge2});
  const auto S = calibrate(d);
  ASSERT_TRUE(S.IsSolutionUsable());
  std::map<std::string, std::string> reasons;
  for (const RejectedTie& r : S.section<VtpmSection>().rejected) reasons[r.tie_id + "/" + r.strip_id] = r.reason;
  EXPECT_EQ(reasons[far.tie_id + "/" + far.strip_id].rfind("too few points", 0), 0u) << reasons[far.tie_id + "/" + far.strip_id];
  bool outside = false;
  for (const auto& [k, r] : reasons) outside |= k.rfind("edge/", 0) == 0 && r.rfind("outside the hull", 0) == 0;
  EXPECT_TRUE(outside) << "edge picks: " << reasons[edge.tie_id + "/" + edge.strip_id] << " | "
                       << reasons[edge2.tie_id + "/" + edge2.strip_id];
  // Unknown strips are bad input, not a silent drop.
  CalibrationData bad = toCalibrationData(s);
  bad.ties[0].strip_id = "no-such-strip";
  EXPECT_THROW(calibrate(bad), InvalidInput);
}

TEST(VtpmCalibration, MisPickedTieUnderRobustLossIsFlaggedAndHarmless) {
  const SimulatedSurvey& s = tieField(2, true);
  CalibrationData d = toCalibrationData(s);
  std::map<std::string, int> count;
  for (const auto& t : d.ties) ++count[t.tie_id];
  std::size_t victim = 0;
  while (count[d.ties[victim].tie_id] < 4 || d.ties[victim].tie_id.rfind("ring", 0) != 0) ++victim;
  d.ties[victim].x_m += 5.0;  // 5 m mis-pick, still on flat ground
  for (LossType loss : {LossType::kHuber, LossType::kCauchy}) {
    auto o = surveyGradeOptions();
    o.loss = loss;
    o.loss_scale_m = 0.1;
    const auto S = calibrate(d, o);
    ASSERT_TRUE(S.IsSolutionUsable());
    const auto e = S.mounting.toArray(), t = s.config.true_mounting.toArray();
    for (int j : {kBoresightRoll, kBoresightPitch, kBoresightHeading}) EXPECT_LT(std::abs(e[j] - t[j]), 0.003 * kDeg) << j;
    for (int j : {kLeverX, kLeverY}) EXPECT_LT(std::abs(e[j] - t[j]), 0.05) << j;
    int flagged = 0, found = 0;
    for (const TieResidual& r : S.section<VtpmSection>().residuals) {
      if (r.tie_id == d.ties[victim].tie_id && r.strip_id == d.ties[victim].strip_id) {
        ++found;
        EXPECT_TRUE(r.outlier);
      }
      flagged += r.outlier;
    }
    EXPECT_EQ(found, 1) << "the mis-picked tie must be in the residuals for its flag to be checked";
    EXPECT_LE(flagged, 3);
  }
}

TEST(VtpmCalibration, NumericJacobianAgreesWithAnIndependentReference) {
  const SimulatedSurvey& s = tieField(1, false);
  const CalibrationData d = toCalibrationData(s);
  const StripData* strip = nullptr;
  for (const auto& st : d.strips)
    if (st.id == d.ties[0].strip_id) strip = &st;
  ASSERT_NE(strip, nullptr);
  VtpStrip vs(*strip, d.trajectory, d.mounting_used);
  VirtualTiePoint vtp;
  std::string why;
  ASSERT_TRUE(vs.build(d.ties[0], VtpOptions{}, &vtp, &why)) << why;
  std::unique_ptr<ceres::CostFunction> cost(detail::makeVtpCostFunction(&vtp, Vec3(1, 1, 1)));
  // At identity, near identity (1e-8) and at a realistic mounting (manif-style).
  const std::array<std::array<double, 6>, 3> points = {
      {{0, 0, 0, 0, 0, 0}, {1e-8, -1e-8, 1e-8, 1e-8, -1e-8, 1e-8}, {0.1, -0.05, 0.2, 0.05 * kDeg, -0.08 * kDeg, 0.12 * kDeg}}};
  for (const auto& m : points) {
    double X[3] = {0, 0, 0}, o[3] = {0, 0, 0}, r[3];
    Eigen::Matrix<double, 3, 6, Eigen::RowMajor> J;
    Eigen::Matrix<double, 3, 3, Eigen::RowMajor> JX, Jo;
    const double* params[3] = {m.data(), X, o};
    double* jac[3] = {J.data(), JX.data(), Jo.data()};
    ASSERT_TRUE(cost->Evaluate(params, r, jac));
    // Reference: 5-point stencil with its own step, O(h⁴).
    for (int j = 0; j < 6; ++j) {
      const double h = j < 3 ? 1e-3 : 1e-5;
      auto at = [&](double dx) {
        auto mm = m;
        mm[j] += dx;
        return vtp.position(mm.data());
      };
      const Vec3 ref = (-at(2 * h) + 8 * at(h) - 8 * at(-h) + at(-2 * h)) / (12 * h);
      EXPECT_LT((J.col(j) - ref).norm(), 1e-6 * std::max(1.0, ref.norm())) << "param " << j << "\n"
                                                                           << J.col(j).transpose() << "\n"
                                                                           << ref.transpose();
    }
    EXPECT_LT((JX + Mat3::Identity()).norm(), 1e-12);
    EXPECT_LT((Jo - Mat3::Identity()).norm(), 1e-12);
  }
  // A boresight column is about ρ ≈ 760 m per radian: the Jacobian is not trivially small.
  EXPECT_GT(std::abs(vtp.position(std::array<double, 6>{0, 0, 0, 1e-4, 0, 0}.data()).y() - vtp.referencePosition().y()), 0.01);
}

TEST(VirtualTiePoint, RuleOneIsSeedEquationFiveAndRuleTwoIsRigid) {
  // seed eq. (5) on a known plane z = 2 + 0.1 x − 0.2 y.
  auto plane = [](double x, double y) { return 2 + 0.1 * x - 0.2 * y; };
  const Vec3 p1(0, 0, plane(0, 0)), p2(1, 0.2, plane(1, 0.2)), p3(0.3, 1, plane(0.3, 1));
  EXPECT_NEAR(interpolateHeight(p1, p2, p3, 0.4, 0.3), plane(0.4, 0.3), 1e-12);
  // Kabsch recovers a known rigid motion exactly.
  const Mat3 R = R_zyx(Vec3(0.01, -0.02, 0.3));
  const Vec3 t(5, -3, 2);
  const Vec3 p[3] = {p1, p2, p3};
  const Vec3 q[3] = {R * p1 + t, R * p2 + t, R * p3 + t};
  Mat3 R_est;
  Vec3 t_est;
  fitRigidTransform(p, q, 3, &R_est, &t_est);
  EXPECT_LT((R_est - R).norm(), 1e-12);
  EXPECT_LT((t_est - t).norm(), 1e-12);
}

TEST(VirtualTiePoint, NeighbourhoodMotionIsAnAffineCombinationOfItsPointsAtThePick) {
  // Twelve pulses of four lasers with their own poses and laser vectors, georeferenced at M₀ and
  // again at M by georeference() (SPEC §2, the public forward model). The weights must be the
  // solution of min Σ (w_i − u_i)² / u_i subject to each laser's share and Σ w_i x_i = pick in plan
  // — here from the whole KKT system solved densely, not the code's Lagrange closed form — and
  // P(M) = Σ w_i x_i(M) at every mounting: at M₀ the pick's plan position.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  MountingParameters m0;
  m0.a_b = Vec3(0.1, -0.05, 0.2);
  m0.boresight = Vec3(0.5, -0.8, 1.2) * kDeg;
  m0.R_nom = R_zyx(Vec3(0, 90 * kDeg, 0));  // a VLP-16 on its side
  MountingParameters m = m0;
  m.a_b += Vec3(0.03, -0.02, 0.01);
  m.boresight = Vec3(0.55, -0.7, 0.9) * kDeg;
  std::vector<LaserFootprint> pts(12);
  std::vector<double> w(12);
  std::vector<int> laser(12);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    pts[i].pose.p_m = Vec3(500 + 20 * u(rng), -300 + 20 * u(rng), 50 + u(rng));
    pts[i].pose.R_mb = R_zyx(Vec3(0.02 * u(rng), 0.02 * u(rng), 0.3 + 0.05 * u(rng)));
    pts[i].r_s = Vec3(10 * u(rng), 15 * u(rng), 45 + 5 * u(rng));
    pts[i].x0_m = georeference(pts[i].pose, m0.R_bs(), m0.a_b, pts[i].r_s);
    pts[i].index = i;
    w[i] = 1 + static_cast<double>(i % 3);
    laser[i] = static_cast<int>(i % 4);
  }
  const double pick_x = pts[0].x0_m.x() + 0.1, pick_y = pts[0].x0_m.y() + 0.05;
  VirtualTiePoint v("t", "s", pick_x, pick_y, {pts[0], pts[1], pts[2]}, m0);
  v.setMotionSupport(pts, w, laser);
  // The KKT system of the weights' change δ: [2 U⁻¹ Cᵀ; C 0] [δ; μ] = [0; b], C the four lasers'
  // indicator rows and the plan coordinates, b = 0 for the shares and pick − Σ u_i x_i in plan.
  const int n = 12, c = 6;
  double wsum = 0;
  for (double x : w) wsum += x;
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(n + c, n + c);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(n + c);
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (int i = 0; i < n; ++i) {
    const double ui = w[static_cast<std::size_t>(i)] / wsum;
    K(i, i) = 2.0 / ui;
    const int rows[3] = {n + laser[static_cast<std::size_t>(i)], n + 4, n + 5};
    const double vals[3] = {1.0, pts[static_cast<std::size_t>(i)].x0_m.x(), pts[static_cast<std::size_t>(i)].x0_m.y()};
    for (int r = 0; r < 3; ++r) K(rows[r], i) = K(i, rows[r]) = vals[r];
    centroid += ui * pts[static_cast<std::size_t>(i)].x0_m.head<2>();
  }
  b(n + 4) = pick_x - centroid.x();
  b(n + 5) = pick_y - centroid.y();
  const Eigen::VectorXd sol = K.fullPivLu().solve(b);
  ASSERT_EQ(v.motionWeights().size(), pts.size());
  Vec3 at_m = Vec3::Zero(), at_m0 = Vec3::Zero();
  for (std::size_t i = 0; i < pts.size(); ++i) {
    EXPECT_NEAR(v.motionWeights()[i], w[i] / wsum + sol(static_cast<Eigen::Index>(i)), 1e-12) << i;
    at_m += v.motionWeights()[i] * georeference(pts[i].pose, m.R_bs(), m.a_b, pts[i].r_s);
    at_m0 += v.motionWeights()[i] * pts[i].x0_m;
  }
  EXPECT_LT((v.position(m) - at_m).norm(), 1e-9);
  EXPECT_LT((v.position(m0) - at_m0).norm(), 1e-9);
  EXPECT_LT((v.referencePosition() - at_m0).norm(), 1e-9);
  EXPECT_LT(std::hypot(v.position(m0).x() - pick_x, v.position(m0).y() - pick_y), 1e-9);  // the pick, in plan
  // One group: the same with only the shares' sum, and the plain weighted mean's displacement is
  // not what a pick away from the points' centroid gets.
  VirtualTiePoint one("t", "s", pick_x, pick_y, {pts[0], pts[1], pts[2]}, m0);
  one.setMotionSupport(pts, w);
  EXPECT_LT(std::hypot(one.position(m0).x() - pick_x, one.position(m0).y() - pick_y), 1e-9);
  Vec3 mean_shift = Vec3::Zero();
  for (std::size_t i = 0; i < pts.size(); ++i)
    mean_shift += w[i] / wsum * (georeference(pts[i].pose, m.R_bs(), m.a_b, pts[i].r_s) - pts[i].x0_m);
  EXPECT_GT((one.position(m) - one.position(m0) - mean_shift).norm(), 1e-4);
  w[4] = -1;
  EXPECT_THROW(v.setMotionSupport(pts, w), InvalidInput);
  EXPECT_THROW(v.setMotionSupport(pts, {}, std::vector<int>(3, 0)), InvalidInput);
  // A strip whose laser ids are not one per point is refused before any pick reads them.
  StripData strip;
  strip.id = "s";
  for (const LaserFootprint& f : pts) {
    strip.time_s.push_back(0.0);
    strip.r_s.push_back(f.r_s);
    strip.x_m.push_back(f.x0_m);
    strip.poses.push_back(f.pose);
    strip.laser.push_back(static_cast<std::uint16_t>(f.index % 4));
  }
  EXPECT_NO_THROW(VtpStrip(strip, nullptr, m0));
  strip.laser.pop_back();
  EXPECT_THROW(VtpStrip(strip, nullptr, m0), InvalidInput);
  EXPECT_THROW(v.setMotionSupport(pts, std::vector<double>(3, 1.0)), InvalidInput);
  EXPECT_THROW(v.setMotionSupport({}), InvalidInput);
}

TEST(VirtualTiePoint, ATriangleStandingUprightInPlanIsRefused) {
  // A roof sloping 10° along x, scanned in rows 1 cm apart along the slope with pulses 10 cm apart
  // across it; alternate rows lie 2 cm above and below the roof (within the RANSAC threshold of
  // 5 cm). Every triangle of the TIN joins two rows: its plane holds the row's direction and a
  // step of 1 cm along the roof and 4 cm across it, so it stands nearly upright (86°) — a sliver
  // in plan from which Rule 1 would extrapolate the pick's height. Without the ±2 cm the same
  // triangles lie in the roof (10°) and the pick is built, on the roof.
  const double slope = 10 * kDeg;
  const Vec3 along(std::cos(slope), 0, std::sin(slope)), up(-std::sin(slope), 0, std::cos(slope));
  auto strip = [&](double offset_m) {
    StripData d;
    d.id = "s";
    for (int row = 0; row < 60; ++row)
      for (int k = 0; k < 13; ++k) {
        d.x_m.push_back(Vec3(100, 200 + 0.1 * k, 30) + 0.01 * row * along + (row % 2 ? offset_m : -offset_m) * up);
        d.time_s.push_back(0.0);
        d.r_s.push_back(Vec3(0, 0, 30));
        d.poses.push_back(Pose{});
      }
    return d;
  };
  const TieObservation pick{"t", "s", 100 + 0.30 * std::cos(slope) + 0.0013, 200.63, 0};
  VirtualTiePoint vtp;
  std::string reason;
  const VtpStrip upright(strip(0.02), nullptr, MountingParameters{});
  EXPECT_FALSE(upright.build(pick, VtpOptions{}, &vtp, &reason));
  EXPECT_NE(reason.find("degenerate triangle: its plane is 8"), std::string::npos) << reason;
  EXPECT_NE(reason.find("steep (a sliver in plan)"), std::string::npos) << reason;
  const VtpStrip flat(strip(0.0), nullptr, MountingParameters{});
  ASSERT_TRUE(flat.build(pick, VtpOptions{}, &vtp, &reason)) << reason;
  EXPECT_NEAR(vtp.referencePosition().z(), 30 + (pick.x_m - 100) * std::tan(slope), 1e-9);
}

// σ honesty over many seeds (issue 12). The survey's noise differs from what the calibrator is
// told: the GNSS error drifts within a strip (Gauss–Markov, 20 s; the calibrator assumes one
// offset per strip), the picks scatter 4 cm where 3 cm is stated (the calibrator estimates the
// tie σ from the residuals: variance components), the range noise is per pulse while a virtual
// tie point is modelled with its barycentric weights. The navigation and scanner noise are
// stated (PulseNoise) as the simulator's. The checks, per estimated parameter over the seeds:
//  - the fraction of errors within 2σ at least 0.85 (0.954 for an honest σ);
//  - the RMS of e/σ within the 99 % range of √(χ²_n / n) for n seeds — the two-sided test of
//    the same claim (the upper bound of 0.99 on the fraction is not a sound test with
//    30 seeds: an honest σ puts all 30 within 2σ in 24 % of the runs);
//  - the mean σ₀² within the 99 % range of χ² for the pooled redundancy.
namespace {

struct HonestyResult {
  std::array<int, 6> within{}, counted{};
  std::array<double, 6> z2{};
  double variance_factor_sum = 0, redundancy_sum = 0;
  int seeds = 0;
  int accepted = 0;                 // verdict accept
  std::vector<std::string> doubts;  // the reasons of the others
};

/// `model_attitude_correlation_s` > 0: the attitude as PulseNoise's random effect with that τ;
/// `consider_attitude_s` > 0: as TrajectoryAccuracy's attitude errors in time with that τ.
HonestyResult honestyOverSeeds(int first_seed, int seeds, double attitude_correlation_s, double model_attitude_correlation_s,
                               double consider_attitude_s = 0.0) {
  HonestyResult h;
  h.seeds = seeds;
  for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
    Scene scene;
    SurveyConfig c;
    makePreset("paper-calibration-field", static_cast<std::uint64_t>(seed), &c, &scene);
    c.noise = surveyGrade();
    c.noise.gnss_correlation_s = 20.0;
    c.noise.pick_sigma_m = 0.04;
    c.noise.attitude_correlation_s = attitude_correlation_s;
    c.roi_radius_m = 8.0;
    const SimulatedSurvey s = simulate(c, scene);
    MountingCalibrator::Options o = surveyGradeOptions();  // picks 3 cm
    o.method<VtpmOptions>().tie_sigma_z_m = 0.01;
    o.method<VtpmOptions>().estimate_tie_sigma = true;
    o.pulse_noise.range_m = c.noise.range_sigma_m;
    o.pulse_noise.beam_deg = rad2deg(c.noise.scan_angle_sigma_rad);
    o.pulse_noise.roll_pitch_deg = rad2deg(c.noise.attitude_sigma_rad);
    o.pulse_noise.heading_deg = 2 * rad2deg(c.noise.attitude_sigma_rad);
    o.pulse_noise.attitude_correlation_s = model_attitude_correlation_s;
    o.trajectory = TrajectoryAccuracy::none();  // no drift in time simulated: the formal σ must be honest
    if (consider_attitude_s > 0) {
      o.pulse_noise.roll_pitch_deg = o.pulse_noise.heading_deg = 0.0;
      o.trajectory.roll_pitch_sigma_deg = rad2deg(c.noise.attitude_sigma_rad);
      o.trajectory.heading_sigma_deg = 2 * rad2deg(c.noise.attitude_sigma_rad);
      o.trajectory.attitude_correlation_s = consider_attitude_s;
    }
    const auto S = calibrate(toCalibrationData(s), o);
    EXPECT_TRUE(S.IsSolutionUsable()) << "seed " << seed << "\n" << S.FullReport();
    if (!S.IsSolutionUsable()) continue;
    const auto e = S.mounting.toArray(), t = s.config.true_mounting.toArray();
    for (std::size_t j = 0; j < 6; ++j) {
      if (!S.estimated[j] || !(S.sigma[j] > 0)) continue;
      const double z = (e[j] - t[j]) / S.sigma[j];
      ++h.counted[j];
      h.within[j] += std::abs(z) <= 2.0;
      h.z2[j] += z * z;
    }
    h.variance_factor_sum += S.variance_factor;
    h.redundancy_sum += S.degrees_of_freedom;
    const auto verdict = S.verdict();
    h.accepted += verdict.kind == MountingCalibrator::Verdict::Kind::kAccept;
    for (const std::string& r : verdict.reasons) h.doubts.push_back("seed " + std::to_string(seed) + ": " + r);
  }
  return h;
}

void expectHonest(const HonestyResult& h) {
  // √(χ²_n/n) 99 % range for n = 30: χ²_30 quantiles 13.79 and 53.67.
  ASSERT_EQ(h.seeds, 30);
  const double rms_lo = std::sqrt(13.79 / 30), rms_hi = std::sqrt(53.67 / 30);
  for (std::size_t j = 0; j < 6; ++j) {
    if (h.counted[j] == 0) continue;
    EXPECT_EQ(h.counted[j], h.seeds) << "parameter " << j;
    const double frac = static_cast<double>(h.within[j]) / h.counted[j];
    const double rms = std::sqrt(h.z2[j] / h.counted[j]);
    std::printf("%-20s %d of %d within 2 sigma (%.2f), RMS of error/sigma %.2f\n", mountingParameterNames()[j].c_str(), h.within[j],
                h.counted[j], frac, rms);
    EXPECT_GE(frac, 0.85) << mountingParameterNames()[j].c_str();
    EXPECT_GE(rms, rms_lo) << mountingParameterNames()[j].c_str() << ": sigma overstated";
    EXPECT_LE(rms, rms_hi) << mountingParameterNames()[j].c_str() << ": sigma understated";
  }
  const double vf = h.variance_factor_sum / h.seeds;
  const double band = 2.576 * std::sqrt(2.0 / h.redundancy_sum);  // σ₀² of the pooled redundancy
  std::printf("mean variance factor %.4f (chi-square 99 %% range 1 +- %.4f), mean redundancy %.1f\n", vf, band, h.redundancy_sum / h.seeds);
  EXPECT_NEAR(vf, 1.0, band);
  // A survey whose σ are honest is accepted: the verdict's doubts are not raised by chance.
  std::string doubts;
  for (const std::string& d : h.doubts) doubts += d + "\n";
  EXPECT_EQ(h.accepted, h.seeds) << doubts;
}

}  // namespace

// White attitude noise (the simulator's 0.001°/0.002° redrawn every 5 ms), stated as such.
// Measured (2026-11-22, seeds 101–130): fractions 0.93–1.00, RMS of e/σ 0.87–1.03, σ₀² 1.010
// (other blocks of 30 seeds: 131–160 RMS 0.80–1.11, σ₀² 1.001; 161–190 RMS 0.86–1.16, σ₀² 1.013).
// About 60 s in Release; the sanitizer build runs 2 seeds for memory errors only.
TEST(VtpmCalibration, SigmasAreHonestOverThirtySeeds) {
  const HonestyResult h = honestyOverSeeds(101, mountcal_tests::seedsFor(30, 2), 0.005, 0.0);
  MOUNTCAL_STATISTICS_IN_RELEASE_ONLY("σ honesty over 30 seeds");
  expectHonest(h);
}

// Attitude noise correlated over 0.1 s (an INS: Gauss–Markov), stated to the calibrator as
// trajectory errors in time (TrajectoryAccuracy, the same σ and τ), in the covariance as consider
// parameters. This was issue 12's disabled test: with the attitude as PulseNoise's estimated
// random effect instead, the boresight heading stayed too confident (0.83–0.90 within 2σ, RMS of
// e/σ 1.25–1.33, 2026-11-22). Measured with the consider term (2026-11-26, seeds 101–130): lever
// x, y, roll, pitch 30 of 30 within 2σ (RMS 0.84, 0.72, 0.69, 0.88), heading 28 of 30 (RMS 1.11);
// σ₀² 1.013. About 20 s in Release; the sanitizer build runs 2 seeds for memory errors only.
TEST(VtpmCalibration, SigmasAreHonestUnderCorrelatedAttitudeNoise) {
  const HonestyResult h = honestyOverSeeds(101, mountcal_tests::seedsFor(30, 2), 0.1, 0.0, 0.1);
  MOUNTCAL_STATISTICS_IN_RELEASE_ONLY("σ honesty over 30 seeds");
  expectHonest(h);
}

// The pulse noise's point covariance against a hand derivation: a point H = 1000 m below the
// IMU — tilts t move it by H·t horizontally, heading not at all, range along the beam (z),
// pointing β across it (ρβ); a point 300 m to the side — heading κ moves it by 300·κ along y.
TEST(StochasticModel, PulseNoiseCovarianceIsTheHandDerivation) {
  PulseNoise n;
  n.roll_pitch_deg = 0.001;
  n.heading_deg = 0.002;
  n.range_m = 0.02;
  n.beam_deg = 0.003;
  const double t = deg2rad(0.001), k = deg2rad(0.002), b = deg2rad(0.003);
  const Vec3 below(0, 0, -1000);
  Mat3 expected = Mat3::Zero();
  expected(0, 0) = expected(1, 1) = std::pow(1000 * t, 2) + std::pow(1000 * b, 2);
  expected(2, 2) = 0.02 * 0.02;
  EXPECT_LT((n.pointCovariance(below, below) - expected).norm(), 1e-15);
  // Interpolated from pulses with Σ w² = 0.4: range and pointing scale, attitude does not.
  Mat3 expected_w = Mat3::Zero();
  expected_w(0, 0) = expected_w(1, 1) = std::pow(1000 * t, 2) + 0.4 * std::pow(1000 * b, 2);
  expected_w(2, 2) = 0.4 * 0.02 * 0.02;
  EXPECT_LT((n.pointCovariance(below, below, 0.4) - expected_w).norm(), 1e-15);
  PulseNoise heading_only;
  heading_only.heading_deg = 0.002;
  const Mat3 side = heading_only.pointCovariance(Vec3(300, 0, -1000), Vec3(300, 0, -1000));
  EXPECT_NEAR(side(1, 1), std::pow(300 * k, 2), 1e-18);
  EXPECT_NEAR(side(0, 0), 0.0, 1e-18);
  EXPECT_NEAR(side(2, 2), 0.0, 1e-18);
  // As a random effect (correlation time > 0) the attitude leaves Σ_x.
  heading_only.attitude_correlation_s = 0.1;
  EXPECT_LT(heading_only.pointCovariance(Vec3(300, 0, -1000), Vec3(300, 0, -1000)).norm(), 1e-20);
  std::string why;
  PulseNoise bad;
  bad.range_m = -1;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(why.find("range_m"), std::string::npos);
}

// Variance components recover the picking precision the data show, whatever was stated:
// picks scatter 4 cm, the job states 2 cm.
TEST(VtpmCalibration, EstimatedTieSigmaIsThePickingPrecision) {
  Scene scene;
  SurveyConfig c;
  makePreset("paper-calibration-field", 7, &c, &scene);
  c.noise = surveyGrade();
  c.noise.pick_sigma_m = 0.04;
  c.noise.attitude_correlation_s = 0.005;
  c.roi_radius_m = 8.0;
  const SimulatedSurvey s = simulate(c, scene);
  MountingCalibrator::Options o = surveyGradeOptions();
  o.method<VtpmOptions>().tie_sigma_xy_m = 0.02;
  o.method<VtpmOptions>().tie_sigma_z_m = 0.01;
  o.pulse_noise.range_m = c.noise.range_sigma_m;
  o.pulse_noise.beam_deg = rad2deg(c.noise.scan_angle_sigma_rad);
  o.pulse_noise.roll_pitch_deg = rad2deg(c.noise.attitude_sigma_rad);
  o.pulse_noise.heading_deg = 2 * rad2deg(c.noise.attitude_sigma_rad);
  const auto stated = calibrate(toCalibrationData(s), o);
  o.method<VtpmOptions>().estimate_tie_sigma = true;
  const auto S = calibrate(toCalibrationData(s), o);
  ASSERT_TRUE(S.IsSolutionUsable()) << S.FullReport();
  EXPECT_TRUE(S.section<VtpmSection>().sigma_estimated);
  EXPECT_FALSE(stated.section<VtpmSection>().sigma_estimated);
  EXPECT_DOUBLE_EQ(stated.section<VtpmSection>().sigma_xy_m, 0.02);
  // ≈ 500 observations: the estimate is good to a few per cent; 10 % allowed.
  EXPECT_NEAR(S.section<VtpmSection>().sigma_xy_m, 0.04, 0.004) << S.FullReport();
  // With the σ the data show, σ₀² is 1; with the stated 2 cm it was 1.76 (the horizontal
  // residuals (4/2)² = 4 times their variance, diluted by the vertical ones and the pulse noise).
  EXPECT_GT(stated.variance_factor, 1.5);
  EXPECT_NEAR(S.variance_factor, 1.0, 0.15);
  EXPECT_GT(S.rematch_rounds, 1);
  EXPECT_NE(S.FullReport().find("estimated from the residuals"), std::string::npos);
}

// `evaluate`'s pass-to-pass discrepancy on airborne strips (the crossing field at 760 m and
// 1310 m, about 0.5 m spacing): it used to find no point within its UAV-sized gates ("no strips
// overlap"). Noise-free, with the mounting the strips were georeferenced with, the roofs and the
// ground of two strips disagree; with the true mounting they coincide.
TEST(VtpmCalibration, PassDiscrepancyWorksOnAirborneStrips) {
  const SimulatedSurvey& s = tieField(1, false);
  const CalibrationData d = toCalibrationData(s);
  const std::vector<PairDiscrepancy> before = passDiscrepancies(d, s.config.nominal_mounting);
  const std::vector<PairDiscrepancy> after = passDiscrepancies(d, s.config.true_mounting);
  ASSERT_GE(before.size(), 4u);
  ASSERT_EQ(after.size(), before.size());
  for (std::size_t p = 0; p < after.size(); ++p) {
    EXPECT_GT(after[p].stats.used, 100u) << after[p].query << "/" << after[p].reference;
    EXPECT_LT(after[p].stats.median_m, 0.01) << after[p].query << "/" << after[p].reference;
    EXPECT_GT(before[p].stats.median_m, 5 * after[p].stats.median_m) << before[p].query << "/" << before[p].reference;
  }
}
