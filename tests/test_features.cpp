// The second paper's method (issue 10): high-intensity targets extracted, matched by ICP between
// strips, the closed form of SPEC §2 (seed 002 eqs. 8–10), and the rigorous adjustment of the
// targets' centroids — on the uav-vlp16 preset (VLP-16 on its side, R_nom = Ry(90°), the paper's
// flight plan) with known truth.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <sstream>

#include <nlohmann/json.hpp>

#include "mountcal/mountcal.hpp"
#include "mountcal/core/georeference_model.hpp"
#include "mountcal/mounting_calibrator.hpp"
#include "methods/features/feature_laser_terms.hpp"
#include "mountcal/simulation/survey.hpp"
#include "sanitizer_build.hpp"
#include "scatter.hpp"
#include "support.hpp"

using namespace mountcal_tests;
using namespace mountcal;
using namespace mountcal::simulation;
namespace fs = std::filesystem;

namespace {

struct Uav {
  SurveyConfig config;
  Scene scene;
  SimulatedSurvey survey;
};

/// The preset, simulated once per (seed, noise, heights).
const Uav& uav(std::uint64_t seed, bool noise, bool one_height = false) {
  static std::map<std::string, std::unique_ptr<Uav>> cache;
  auto& slot = cache[std::to_string(seed) + (noise ? "n" : "q") + (one_height ? "1" : "2")];
  if (!slot) {
    slot = std::make_unique<Uav>();
    makePreset("uav-vlp16", seed, &slot->config, &slot->scene);
    if (!noise) slot->config.noise = NoiseModel::none();
    if (one_height) keepOneHeight(&slot->config);
    slot->survey = simulate(slot->config, slot->scene);
  }
  return *slot;
}

MountingCalibrator::Options featureOptions(bool lever_arm_xy) {
  MountingCalibrator::Options o;
  o.methods = {"features"};
  o.estimate = {lever_arm_xy, lever_arm_xy, false, true, true, true};
  o.trajectory = TrajectoryAccuracy::none();  // the simulated trajectories carry no drift in time
  return o;
}

double angleError(const MountingParameters& est, const MountingParameters& truth, int a) {
  return std::abs(est.boresight(a) - truth.boresight(a)) / kDeg;
}

}  // namespace

TEST(FeatureIcp, RecoversAKnownOffsetBetweenTwoCopiesOfATargetWithinAMillimetre) {
  // A 1.5 m board tilted 30°, sampled at random (spacing ≈ 6 cm), and a copy shifted by 21 cm
  // along, 16 cm across and 5 cm off the board — several point spacings: ICP started from no
  // offset has to walk there through wrong neighbours. The expected value is the shift given.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.75, 0.75);
  const Vec3 e1(1, 0, 0), e2(0, std::cos(30 * kDeg), std::sin(30 * kDeg));
  const Vec3 centre(312.4, -87.1, 12.3);
  const Vec3 shift(0.21, -0.16, 0.05);
  std::vector<Vec3> a, b;
  for (int i = 0; i < 600; ++i) {
    a.push_back(centre + u(rng) * e1 + u(rng) * e2);
    b.push_back(a.back() + shift);
  }
  const Vec3 normal = e1.cross(e2);
  const Vec3 zero = Vec3::Zero();
  const IcpResult r = matchTranslation(a, b, normal, 0.003, 0.02, 200, 1e-9, &zero);
  EXPECT_TRUE(r.converged);
  EXPECT_GT(r.iterations, 2);
  EXPECT_LT((r.translation_m + shift).norm(), 0.001) << r.translation_m.transpose();
  EXPECT_LT(r.rms_m, 1e-6);
  // Started from the centroid difference (the default) it is there at once.
  const IcpResult c = matchTranslation(a, b, normal, 0.003, 0.02);
  EXPECT_LT((c.translation_m + shift).norm(), 1e-9);
  // The covariance is the one stated: σ_n along the normal, σ_t across.
  EXPECT_NEAR(std::sqrt(normal.dot(r.covariance * normal)), 0.003, 1e-12);
  EXPECT_NEAR(std::sqrt(e1.dot(r.covariance * e1)), 0.02, 1e-12);
}

TEST(FeatureClosedForm, SpecFormsGiveBackTheAnglesAndTheLeverArm) {
  // Offsets written with SPEC §2's closed forms (seed 002 eqs. 8–10) for known ε and η, by hand:
  //   opposite, one line at height H:       Δ = (2(ε_φ H + η_x), 2(η_y − ε_ω H), 2 ε_ω y_A)
  //   same direction, B offset D to the right: Δ_along = −ε_κ D, Δ_down = ε_ω D (Δ_cross = 0)
  const double er = 0.0012, ep = -0.0021, ek = 0.0034, hx = 0.05, hy = -0.03;  // [rad], [m]
  auto pair = [](const std::string& rel, double H, double yA, double yB, const Vec3& d) {
    FeaturePairOffset p;
    p.relation = rel;
    p.height_m = p.height_b_m = H;
    p.lateral_a_m = yA;
    p.lateral_b_m = yB;
    p.line_offset_m = yA - yB;
    p.offset_afd_m = d;
    p.covariance_afd = Mat3::Identity() * 1e-4;
    return p;
  };
  std::vector<FeaturePairOffset> pairs;
  for (double H : {50.0, 80.0})
    for (double y : {-20.0, 15.0}) pairs.push_back(pair("opposite", H, y, -y, Vec3(2 * (ep * H + hx), 2 * (hy - er * H), 2 * er * y)));
  for (double y : {-20.0, 15.0}) pairs.push_back(pair("same", 50.0, y, y - 50.0, Vec3(-ek * 50.0, 0.0, er * 50.0)));
  MountingParameters used = MountingParameters::fromDegrees(Vec3(0.1, 0.2, 0.3), Vec3(1, 2, 3), Vec3(0, 90, 0));
  FeatureOptions o;
  const FeatureClosedForm C = closedFormBoresight(pairs, used, o);
  ASSERT_TRUE(C.valid) << C.message;
  EXPECT_TRUE(C.lever_arm_estimated);
  EXPECT_NEAR(C.boresight_correction_rad.x(), er, 1e-12);
  EXPECT_NEAR(C.boresight_correction_rad.y(), ep, 1e-12);
  EXPECT_NEAR(C.boresight_correction_rad.z(), ek, 1e-12);
  EXPECT_NEAR(C.lever_arm_correction_m.x(), hx, 1e-10);
  EXPECT_NEAR(C.lever_arm_correction_m.y(), hy, 1e-10);
  // The corrected mounting is the used one minus ε (and η).
  EXPECT_NEAR(C.mounting.boresight.y(), used.boresight.y() - ep, 1e-12);
  EXPECT_NEAR(C.mounting.a_b.x(), 0.1 - hx, 1e-10);
  // One height: the lever arm is held and the coupling named; the pitch then absorbs η_x / H.
  pairs.erase(std::remove_if(pairs.begin(), pairs.end(), [](const FeaturePairOffset& p) { return p.height_m > 60; }), pairs.end());
  const FeatureClosedForm one = closedFormBoresight(pairs, used, o);
  ASSERT_TRUE(one.valid);
  EXPECT_TRUE(one.pitch_lever_arm_coupled);
  EXPECT_NEAR(one.boresight_correction_rad.y(), ep + hx / 50.0, 1e-9);
  // Only crossing pairs: nothing determined, said so.
  std::vector<FeaturePairOffset> crossing = {pair("crossing", 50, 10, 10, Vec3::Zero())};
  EXPECT_FALSE(closedFormBoresight(crossing, used, o).valid);
}

TEST(FeatureMethod, NoiseFreeClosedFormAndRigorousRecoverTheBoresight) {
  // The issue asks for the closed form within 0.05° (met: ≤ 0.019° on seeds 1–2, with and without
  // noise) and the rigorous solution within 0.005° (missed on pitch and heading): a VLP-16 at 50 m
  // samples a 1.5 m target in rows 0.5 m apart (5 m/s, 10 Hz), so a target's position in one
  // strip is uncertain by 1–5 cm even without noise (measured: the mean of the true hit points lies
  // 0.5–11 cm from the centre). Measured: rigorous roll ≤ 0.003°, pitch ≤ 0.032° (σ 0.02–0.04°,
  // correlated with the along-track lever arm), heading ≤ 0.04° (σ 0.024–0.03°); σ₀² 0.8–1.1.
  const Uav& s = uav(1, false);
  const CalibrationData data = toCalibrationData(s.survey);
  ASSERT_FALSE(data.target_regions.empty());
  const auto S = calibrate(data, featureOptions(true));
  ASSERT_TRUE(S.IsSolutionUsable()) << S.message;
  const FeatureSection& F = S.section<FeatureSection>();
  EXPECT_GE(F.targets_used, 9);
  const FeatureClosedForm& C = F.closed_form;
  ASSERT_TRUE(C.valid) << C.message;
  EXPECT_TRUE(C.lever_arm_estimated) << "two heights flown: the closed form separates pitch from the along-track lever arm";
  const MountingParameters& truth = s.config.true_mounting;
  const double rigorous[3] = {0.005, 0.03, 0.06};
  for (int a = 0; a < 3; ++a) {
    EXPECT_LT(angleError(C.mounting, truth, a), 0.05) << "closed form, angle " << a << "\n" << S.FullReport();
    EXPECT_LT(angleError(S.mounting, truth, a), rigorous[a]) << "rigorous, angle " << a << "\n" << S.FullReport();
    EXPECT_LT(angleError(S.mounting, truth, a) * kDeg, 3 * S.sigma[3 + a]) << "rigorous within 3 sigma, angle " << a;
  }
  EXPECT_NEAR(S.variance_factor, 1.0, 0.5) << "the centres' sigma are estimated from the residuals";
  for (int k = 0; k < 2; ++k) EXPECT_LT(std::abs(S.mounting.a_b(k) - truth.a_b(k)), 0.03) << "lever arm " << k;
  // The pairs are read from the trajectory: opposite, same direction offset by D = 50 m.
  int opposite = 0, same = 0;
  for (const FeaturePairOffset& p : F.pairs) {
    if (p.relation == "opposite") ++opposite;
    if (p.relation == "same" && std::abs(std::abs(p.line_offset_m) - 50.0) < 2.0) ++same;
  }
  EXPECT_GT(opposite, 0);
  EXPECT_GT(same, 0);
}

// The in-plane σ of a view's centre is estimated per axis, along the viewing strip's track and
// across it: without noise a centre's error is the sampling of the target's outline (the VLP-16's
// rows against its scan lines), and the two differ. Against the truth — each view's outline
// centre at the true mounting minus the scene's target centre, no mountcal estimate involved — over
// three noise-free surveys (129 views; measured: true RMS along 0.0195 m, across 0.0144 m;
// estimated 0.0184 m, 0.0148 m): each estimated component within 10 % of the true RMS on its axis.
// One isotropic σ (their RMS, 0.0171 m) would miss the along-track RMS by 12 % and the across-track
// by 19 %: the test asserts that too, so it cannot pass with one σ for the plane.
TEST(FeatureMethod, InPlaneSigmasAlongAndAcrossTheTrackFollowTheTrueCentreErrors) {
  double ss_true[2] = {0, 0}, ss_est[2] = {0, 0};
  int views = 0, solves = 0;
  const std::uint64_t seeds = mountcal_tests::seedsFor(3, 1);
  for (std::uint64_t seed = 1; seed <= seeds; ++seed) {
    const Uav& s = uav(seed, false);
    CalibrationData data = toCalibrationData(s.survey);
    data.mounting_used = s.config.true_mounting;       // the views' centroids at the truth: the points
    for (StripData& st : data.strips) st.x_m.clear();  // georeferenced again from the beams
    const auto S = calibrate(data, featureOptions(true));
    ASSERT_TRUE(S.IsSolutionUsable()) << "seed " << seed << ": " << S.message;
    const FeatureSection& F = S.section<FeatureSection>();
    ASSERT_TRUE(F.sigma_estimated);
    for (std::size_t k = 0; k < F.target_ids.size(); ++k) {
      const auto& fp = s.scene.features();
      const auto it = std::find_if(fp.begin(), fp.end(), [&](const FeaturePoint& f) { return f.id == F.target_ids[k]; });
      ASSERT_NE(it, fp.end()) << F.target_ids[k];
      for (const FeatureView& v : F.views[k]) {
        const Vec3 n = v.normal.normalized();
        const Vec3 a = (v.forward - n * n.dot(v.forward)).normalized(), c = n.cross(a);
        const Vec3 e = v.centroid_m - it->x_m;
        ss_true[0] += std::pow(a.dot(e), 2);
        ss_true[1] += std::pow(c.dot(e), 2);
        ++views;
      }
    }
    ss_est[0] += std::pow(F.sigma_along_track_m, 2);
    ss_est[1] += std::pow(F.sigma_across_track_m, 2);
    ++solves;
  }
  if (mountcal_tests::kSanitizerBuild)
    GTEST_SKIP() << "sanitizer build: one survey, for memory errors; the σ against the true errors over three in the Release suite";
  ASSERT_GT(views, 60);
  const double along = std::sqrt(ss_true[0] / views), across = std::sqrt(ss_true[1] / views);
  const double est_along = std::sqrt(ss_est[0] / solves), est_across = std::sqrt(ss_est[1] / solves);
  std::printf("true centre error RMS: along %.4f m, across %.4f m; estimated sigma: along %.4f m, across %.4f m (%d views)\n", along,
              across, est_along, est_across, views);
  EXPECT_GT(std::max(along, across) / std::min(along, across), 1.25) << "the sampling is anisotropic on this preset";
  EXPECT_NEAR(est_along / along, 1.0, 0.1);
  EXPECT_NEAR(est_across / across, 1.0, 0.1);
  const double isotropic = std::sqrt(0.5 * (along * along + across * across));
  EXPECT_GT(std::max(std::abs(isotropic / along - 1), std::abs(isotropic / across - 1)), 0.1)
      << "one in-plane σ would pass these bounds: the test would not discriminate";
}

TEST(FeatureMethod, OneHeightNamesThePitchLeverArmCouplingTwoHeightsDetermineBoth) {
  const Uav& one = uav(1, false, true);
  const auto S1 = calibrate(toCalibrationData(one.survey), featureOptions(true));
  ASSERT_EQ(one.survey.strips.size(), 3u);
  EXPECT_TRUE(S1.section<FeatureSection>().closed_form.pitch_lever_arm_coupled);
  EXPECT_NE(S1.section<FeatureSection>().closed_form.message.find("coupled"), std::string::npos)
      << S1.section<FeatureSection>().closed_form.message;
  const Uav& two = uav(1, false);
  const auto S2 = calibrate(toCalibrationData(two.survey), featureOptions(true));
  ASSERT_TRUE(S2.IsSolutionUsable());
  // One height: the closed form cannot separate lever x from pitch (above), but the rigorous
  // adjustment still can, through the targets' spread in range and beam elevation: lever x is
  // determined (an absolute rule holds only what the data do not determine), with less
  // information than from two heights and a σ that covers its error — or it is held.
  const bool lever_x_named = std::find(S1.unobservable.begin(), S1.unobservable.end(), "lever_arm_x") != S1.unobservable.end();
  if (!lever_x_named) {
    EXPECT_GT(S1.formal_sigma[0], S2.formal_sigma[0]) << S1.FullReport();
    EXPECT_LT(std::abs(S1.mounting.a_b.x() - one.config.true_mounting.a_b.x()), 3 * S1.sigma[0]) << S1.FullReport();
  }
  EXPECT_FALSE(S2.section<FeatureSection>().closed_form.pitch_lever_arm_coupled);
  EXPECT_TRUE(S2.unobservable.empty()) << S2.FullReport();
  EXPECT_TRUE(S2.estimated[0] && S2.estimated[4]);
  EXPECT_LT(std::abs(S2.correlation(0, 4)), 0.99);
}

TEST(FeatureMethod, UnusableRegionsAreRejectedWithTheirReasonsTheRestStillUsed) {
#ifdef MOUNTCAL_SANITIZE_BUILD
  const bool one_height = true;  // three strips: the whole pipeline in a third of the time
#else
  const bool one_height = false;
#endif
  const Uav& s = uav(1, false, one_height);
  CalibrationData data = toCalibrationData(s.survey);
  const std::size_t n_regions = data.target_regions.size();
  // (a) bare ground only; (b) one box over two boards; (c) target_1 hidden from strip 3.
  const Vec3 t1 = [&] {
    for (const FeaturePoint& f : s.scene.features())
      if (f.id == "target_2") return f.x_m;
    return Vec3(Vec3::Zero());
  }();
  data.target_regions.push_back({"bare_ground", t1.x() - 1.2, t1.y() + 2.3, t1.x() + 1.2, t1.y() + 3.6});
  data.target_regions.push_back({"two_boards", -13, 86, 33, 124});
  PlaneRegion hidden;
  for (const PlaneRegion& r : data.target_regions)
    if (r.id == "target_1") hidden = r;
  ASSERT_EQ(hidden.id, "target_1");
  std::string hidden_strip;
  for (StripData& strip : data.strips) {
    int dimmed = 0;
    for (std::size_t i = 0; i < strip.x_m.size(); ++i) {
      const Vec3& x = strip.x_m[i];
      if (x.x() >= hidden.xmin && x.x() <= hidden.xmax && x.y() >= hidden.ymin && x.y() <= hidden.ymax) strip.intensity[i] = 35, ++dimmed;
    }
    if (dimmed > 0) {
      hidden_strip = strip.id;
      break;  // the first strip that covers it
    }
  }
  ASSERT_FALSE(hidden_strip.empty());
  const auto S = calibrate(data, featureOptions(!one_height));
  ASSERT_TRUE(S.IsSolutionUsable()) << S.message;
  auto reasonFor = [&](const std::string& target, const std::string& strip) {
    for (const RejectedFeature& r : S.section<FeatureSection>().rejected)
      if (r.target_id == target && r.strip_id == strip) return r.reason;
    return std::string();
  };
  EXPECT_NE(reasonFor("bare_ground", "").find("no high-intensity points"), std::string::npos) << reasonFor("bare_ground", "");
  EXPECT_NE(reasonFor("two_boards", "").find("more than one target"), std::string::npos) << reasonFor("two_boards", "");
  EXPECT_NE(reasonFor("target_1", hidden_strip).find("does not see the target"), std::string::npos) << reasonFor("target_1", hidden_strip);
  // target_1 is still used with its other strips, and every preset target is used.
  EXPECT_NE(std::find(S.section<FeatureSection>().target_ids.begin(), S.section<FeatureSection>().target_ids.end(), "target_1"),
            S.section<FeatureSection>().target_ids.end());
  // target_3 of the preset lies on the road's centre line: the bright stripe runs through its
  // region on every strip, and the region is refused for it.
  EXPECT_NE(reasonFor("target_3", "1").find("run to the region's edge"), std::string::npos) << reasonFor("target_3", "1");
  EXPECT_EQ(S.section<FeatureSection>().targets_used, static_cast<int>(n_regions) - 1);
  const MountingParameters& truth = s.config.true_mounting;
  const double bound[3] = {0.005, 0.03, 0.06};
  for (int a = 0; a < 3; ++a) EXPECT_LT(angleError(S.mounting, truth, a), bound[a]);
}

TEST(FeatureMethod, SurveyGradeNoiseEveryRigorousEstimateWithinThreeSigma) {
  const std::vector<std::uint64_t> seeds = {3, 4, 5};
  mountcal_tests::ScatterOfErrors scatter;
  for (std::uint64_t seed : seeds) {
    const Uav& s = uav(seed, true);
    const auto S = calibrate(toCalibrationData(s.survey), featureOptions(true));
    ASSERT_TRUE(S.IsSolutionUsable()) << S.message;
    const auto truth = s.config.true_mounting.toArray(), est = S.mounting.toArray();
    for (int j = 0; j < 6; ++j) {
      if (!S.estimated[j]) continue;
      EXPECT_LT(std::abs(est[j] - truth[j]), 3 * S.sigma[j]) << "seed " << seed << " parameter " << j << "\n" << S.FullReport();
      scatter.add(est[j] - truth[j], S.sigma[j]);
    }
  }
  scatter.expectNotOverstated("features (rigorous)");
}

TEST(FeatureMethod, HouseCornersAfterCorrectionWithinTenCentimetres) {
  // The paper's check (seed 002 Tables 1–2): eave corners of the gable-roof houses, surveyed, against
  // where each strip puts them. The strip georeferences a corner from the pulse that hit it: the
  // raw vector that the true trajectory and mounting send to the corner, at the moment the
  // scanner's cross-track plane passes it, georeferenced with the delivered trajectory and the
  // mounting under test.
  const Uav& s = uav(3, true);
  const auto S = calibrate(toCalibrationData(s.survey), featureOptions(true));
  ASSERT_TRUE(S.IsSolutionUsable()) << S.message;
  const GeoreferenceModel truth(s.survey.true_trajectory, s.config.true_mounting);
  const GeoreferenceModel before(s.survey.measured_trajectory, s.config.nominal_mounting);
  const GeoreferenceModel after(s.survey.measured_trajectory, S.mounting);
  const GeoreferenceModel at_truth(s.survey.measured_trajectory, s.config.true_mounting);
  int corners = 0;
  double worst_before = 0, worst_after = 0, worst_truth = 0, ss_after = 0, ss_truth = 0;
  for (const FeaturePoint& f : s.scene.features()) {
    if (f.id.find("_corner") == std::string::npos) continue;
    for (const SimulatedStrip& strip : s.survey.strips) {
      // The time the platform passes abeam of the corner (bisection on the along-track distance).
      double t0 = strip.pulses.front().time_s, t1 = strip.pulses.back().time_s;
      auto along = [&](double t) {
        const Pose p = s.survey.true_trajectory->pose(t);
        return Vec3(p.R_mb.col(0)).dot(f.x_m - p.p_m);
      };
      if (along(t0) * along(t1) > 0) continue;
      for (int it = 0; it < 60; ++it) {
        const double tm = 0.5 * (t0 + t1);
        (along(t0) * along(tm) <= 0 ? t1 : t0) = tm;
      }
      const double t = 0.5 * (t0 + t1);
      const Pose p = s.survey.true_trajectory->pose(t);
      if ((f.x_m - p.p_m).norm() > s.config.multibeam.max_range_m) continue;
      const Vec3 r_s = truth.inverse(t, f.x_m);
      if (std::getenv("MOUNTCAL_DEBUG_CORNERS")) {
        std::printf("%s strip %s range %.1f: before %.3f after %.3f at truth %.3f\n", f.id.c_str(), strip.id.c_str(),
                    (f.x_m - p.p_m).norm(), (before.forward(t, r_s) - f.x_m).norm(), (after.forward(t, r_s) - f.x_m).norm(),
                    (at_truth.forward(t, r_s) - f.x_m).norm());
      }
      worst_before = std::max(worst_before, (before.forward(t, r_s) - f.x_m).norm());
      const double e_after = (after.forward(t, r_s) - f.x_m).norm(), e_truth = (at_truth.forward(t, r_s) - f.x_m).norm();
      worst_after = std::max(worst_after, e_after);
      worst_truth = std::max(worst_truth, e_truth);
      ss_after += e_after * e_after;
      ss_truth += e_truth * e_truth;
      ++corners;
    }
  }
  ASSERT_GE(corners, 16);
  const double rms_after = std::sqrt(ss_after / corners), rms_truth = std::sqrt(ss_truth / corners);
  EXPECT_GT(worst_before, 0.5) << "the nominal mounting puts the corners far off";
  // The paper's check: every corner within 10 cm (measured, seed 3: worst 0.066 m after, 0.079 m
  // at the true mounting — corners 60–90 m away carry the trajectory's own noise).
  EXPECT_LT(rms_after, 0.10) << "RMS of the corners after the correction";
  EXPECT_LT(rms_after, 2.0 * rms_truth) << "at most twice what the true mounting leaves (" << rms_truth << " m)";
  EXPECT_LT(worst_after, 0.10) << "worst corner after the correction; at the true mounting " << worst_truth << " m";
}

namespace {

/// The command's exit code; its standard output and error, together, in `out`.
int runCliLog(const std::string& args, std::string* out) {
  const CommandRun r = runCli(args);
  *out = r.out + r.err;
  return r.code;
}

}  // namespace

TEST(FeatureMethod, CommandRunsTheSimulatedJobAndAJobWrittenByHand) {
  const fs::path dir = fs::temp_directory_path() / ("mountcal_features_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  std::string out;
  ASSERT_EQ(runCliLog("simulate --preset uav-vlp16 --seed 2 --out " + dir.string(), &out), 0) << out;
  ASSERT_TRUE(fs::exists(dir / "job_features.json"));
  ASSERT_EQ(runCliLog("calibrate " + (dir / "job_features.json").string(), &out), 0) << out;
  EXPECT_NE(out.find("Closed form"), std::string::npos) << out;
  nlohmann::json truth = nlohmann::json::parse(std::ifstream(dir / "truth.json"));
  auto check = [&](const fs::path& result_path, const std::string& what, int min_targets) {
    const nlohmann::json r = nlohmann::json::parse(std::ifstream(result_path));
    ASSERT_TRUE(r.contains("features")) << what;
    const auto& f = r["features"];
    EXPECT_GE(f["targets_used"].get<int>(), min_targets) << what;
    EXPECT_TRUE(f["closed_form"]["valid"].get<bool>()) << what;
    EXPECT_FALSE(f["pairs"].empty()) << what;
    for (int a = 0; a < 3; ++a) {
      const double t = truth["mounting"]["boresight_deg"][a].get<double>();
      EXPECT_NEAR(r["mounting"]["boresight_deg"][a].get<double>(), t, a == 0 ? 0.01 : 0.08) << what << " rigorous angle " << a;
      EXPECT_NEAR(f["closed_form"]["mounting"]["boresight_deg"][a].get<double>(), t, 0.08) << what << " closed form angle " << a;
    }
  };
  check(dir / "result_features.json", "simulated job", 9);

  // A job written by another program to SPEC §4: its own field order, a targets CSV it wrote
  // itself (boxes of 5–6 m around where the operator saw the targets).
  std::ofstream(dir / "my_targets.csv") << "plane_id,xmin,ymin,xmax,ymax\n"
                                           "T1,-22.5,37.5,-17.5,42.5\nT2,7.5,57.5,12.5,62.5\nT4,37.5,137.5,42.5,142.5\n"
                                           "T6,-7.5,167.5,-2.5,172.5\nT8,12.5,197.5,17.5,202.5\nB1,27,117,33,123\nB2,-13,87,-7,93\n";
  std::ofstream(dir / "my_job.json") << R"({
  "strips": [{"id": "1", "path": "strip_1.las"}, {"id": "2", "path": "strip_2.las"}, {"id": "3", "path": "strip_3.las"},
             {"id": "4", "path": "strip_4.las"}, {"id": "5", "path": "strip_5.las"}],
  "method": "features",
  "targets": "my_targets.csv",
  "features": {"min_points": 15, "ransac_threshold_m": 0.3},
  "mounting_used": {"boresight_deg": [0, 0, 0], "lever_arm_m": [0.11, -0.06, 0.19]},
  "estimate": {"lever_arm": [true, true, false], "boresight": [true, true, true]},
  "sensor": {"type": "multibeam", "model": "VLP-16", "nominal_rotation_deg": [0, 90, 0]},
  "trajectory": {"path": "trajectory.csv"},
  "frame": {"type": "local"},
  "output": {"result": "my_result.json"}
})";
  const fs::path result = dir / "my_result.json";
  ASSERT_EQ(runCliLog("calibrate " + (dir / "my_job.json").string(), &out), 0) << out;
  check(result, "job written by hand", 7);
  fs::remove_all(dir);
}

// Issue 28: the features method takes per-laser elevation offsets. A noise-free VLP-16 survey whose
// lasers fire 0.1° (σ) off their table. Nine 1.5 m targets seen by two or three lasers each barely
// determine sixteen offsets: measured (2026-11-28) σ 0.02–0.17° per laser (NaN for the three
// lasers no target view holds), every offset within 0.15° of the truth (about the seen lasers'
// mean), the boresight within 3σ, its worst error 0.0082° with the offsets against 0.0054° without
// (2026-12-06) — no gain on this survey, where the dense correspondences recover the same errors to
// 1e-4°. Their σ: worst |error|/σ 1.7, RMS 0.7 since they take the views' leave-one-out residuals
// (3.7 and 1.4 with the formal σ; 5.2 and 1.9 before the features' redundancy came from the
// leverage) — over many seeds in PerLaserElevationSigmasAreHonestOverSeeds.
TEST(FeatureMethod, PerLaserElevationOffsetsAreEstimatedWithTheBoresight) {
  auto s = std::make_unique<Uav>();
  makePreset("uav-vlp16", 1, &s->config, &s->scene);
  s->config.noise = NoiseModel::none();
  s->config.multibeam.laser_errors = drawLaserErrors(16, 11, deg2rad(0.1));
  s->survey = simulate(s->config, s->scene);
  const CalibrationData data = toCalibrationData(s->survey);
  const MountingParameters& truth = s->config.true_mounting;
  MountingCalibrator::Options o = featureOptions(true);
  o.method<FeatureOptions>().laser_elevation_sigma_deg = 0.2;
  const auto with = calibrate(data, o);
  ASSERT_TRUE(with.IsSolutionUsable()) << with.FullReport();
  const FeatureSection& F = with.section<FeatureSection>();
  ASSERT_EQ(F.laser_intrinsics.lasers.size(), 16u);
  ASSERT_EQ(with.laserCorrections().size(), 16u);  // what apply and evaluate take
  // The offsets are estimated about their mean over the lasers the views hold: the truth likewise.
  int seen = 0;
  double mean = 0, worst_ratio = 0, sum_ratio2 = 0;
  for (std::size_t i = 0; i < 16; ++i)
    if (F.laser_intrinsics.points[i] > 0) mean += s->config.multibeam.laser_errors[i].elevation_rad / kDeg, ++seen;
  mean /= std::max(seen, 1);
  for (std::size_t i = 0; i < 16; ++i) {
    const double t = s->config.multibeam.laser_errors[i].elevation_rad / kDeg - mean, e = F.laser_intrinsics.lasers[i].elevation_rad / kDeg;
    if (F.laser_intrinsics.points[i] == 0) {
      EXPECT_TRUE(std::isnan((F.laser_intrinsics.sigma[i].elevation_rad / kDeg))) << "laser " << i;
      continue;
    }
    EXPECT_GT((F.laser_intrinsics.sigma[i].elevation_rad / kDeg), 0.005) << "laser " << i;
    const double ratio = std::abs(e - t) / (F.laser_intrinsics.sigma[i].elevation_rad / kDeg);
    worst_ratio = std::max(worst_ratio, ratio);
    sum_ratio2 += ratio * ratio;
    EXPECT_LT(std::abs(e - t), 0.15) << "laser " << i;  // within the truth's own spread (0.1° σ, 0.16° the largest)
  }
  std::printf("features: per-laser offsets, worst |error|/sigma %.1f, RMS %.1f over %d lasers\n", worst_ratio, std::sqrt(sum_ratio2 / seen),
              seen);
  EXPECT_GE(seen, 10);
  for (int a = 0; a < 3; ++a) EXPECT_LT(angleError(with.mounting, truth, a) * kDeg, 3 * with.sigma[3 + a]) << "angle " << a;
  EXPECT_NE(with.FullReport().find("Per-laser elevation offsets"), std::string::npos);
  MOUNTCAL_STATISTICS_IN_RELEASE_ONLY("the comparison with the solve without the offsets");
  const auto without = calibrate(data, featureOptions(true));
  double worst_without = 0, worst_with = 0;
  for (int a = 0; a < 3; ++a) {
    worst_without = std::max(worst_without, angleError(without.mounting, truth, a));
    worst_with = std::max(worst_with, angleError(with.mounting, truth, a));
  }
  std::printf("features, lasers 0.1 deg off: boresight worst %.4f deg without the offsets, %.4f deg with\n", worst_without, worst_with);
  EXPECT_LT(worst_with, 0.03);  // the rigorous method's noise-free limit on this survey (pitch, above)
}

// The per-laser elevation offsets' σ over many surveys with the preset's noise and lasers 0.1°
// off their table (issue 28 with issue 26's honest-σ rule: RMS of error/σ within [0.7, 1.4], at
// least 85 % within 2σ): their σ take the views' share from the views' leave-one-out residuals
// (AdjustmentProblem::leaveOneOutCovariance) — with the formal σ the RMS was 1.55–1.62 (seeds
// 1–60 and 61–120), 76–83 % within 2σ. The boresight keeps its formal σ and stays honest. The
// truth is compared about its mean over the lasers the views see, as the offsets are estimated.
// Measured 2026-12-06: see the printed line. About 15 s in Release; 2 seeds under the sanitizers.
TEST(FeatureMethod, PerLaserElevationSigmasAreHonestOverSeeds) {
  const int seeds = mountcal_tests::seedsFor(40, 2);
  double z2 = 0, bz2[3] = {0, 0, 0};
  int n = 0, within = 0, usable = 0;
  for (int seed = 1; seed <= seeds; ++seed) {
    auto s = std::make_unique<Uav>();
    makePreset("uav-vlp16", static_cast<std::uint64_t>(seed), &s->config, &s->scene);
    s->config.multibeam.laser_errors = drawLaserErrors(16, static_cast<std::uint64_t>(10 + seed), deg2rad(0.1));
    s->survey = simulate(s->config, s->scene);
    MountingCalibrator::Options o = featureOptions(true);
    o.method<FeatureOptions>().laser_elevation_sigma_deg = 0.1;
    const auto S = calibrate(toCalibrationData(s->survey), o);
    ASSERT_TRUE(S.IsSolutionUsable()) << "seed " << seed << S.FullReport();
    ++usable;
    const FeatureSection& F = S.section<FeatureSection>();
    double mean = 0;
    int seen = 0;
    for (std::size_t i = 0; i < 16; ++i)
      if (F.laser_intrinsics.points[i] > 0) mean += s->config.multibeam.laser_errors[i].elevation_rad, ++seen;
    mean /= std::max(seen, 1);
    for (std::size_t i = 0; i < 16; ++i) {
      if (F.laser_intrinsics.points[i] == 0) continue;
      const double z = (F.laser_intrinsics.lasers[i].elevation_rad - (s->config.multibeam.laser_errors[i].elevation_rad - mean)) /
                       F.laser_intrinsics.sigma[i].elevation_rad;
      ASSERT_TRUE(std::isfinite(z)) << "seed " << seed << " laser " << i;
      z2 += z * z, within += std::abs(z) < 2, ++n;
    }
    for (int a = 0; a < 3; ++a) bz2[a] += std::pow(angleError(S.mounting, s->config.true_mounting, a) * kDeg / S.sigma[3 + a], 2);
  }
  MOUNTCAL_STATISTICS_IN_RELEASE_ONLY("σ honesty over 40 seeds");
  const double rms = std::sqrt(z2 / n), share = static_cast<double>(within) / n;
  std::printf(
      "features, per-laser elevation offsets over %d seeds: %d offsets, RMS of error/sigma %.2f, %.1f %% within 2 sigma; "
      "boresight RMS of error/sigma %.2f %.2f %.2f\n",
      usable, n, rms, 100 * share, std::sqrt(bz2[0] / usable), std::sqrt(bz2[1] / usable), std::sqrt(bz2[2] / usable));
  EXPECT_GE(rms, 0.7) << "σ too large";
  EXPECT_LE(rms, 1.4) << "σ too small";
  EXPECT_GE(share, 0.85);
  for (int a = 0; a < 3; ++a) {
    EXPECT_GE(std::sqrt(bz2[a] / usable), 0.6) << "angle " << a;
    EXPECT_LE(std::sqrt(bz2[a] / usable), 1.4) << "angle " << a;
  }
}

// Issue 28's full per-laser model in the features method: a view's centre with every group of a
// laser's correction, as the linear terms of detail::addFeatureLaserTerms give it, against the
// points corrected one by one by LaserCorrector (the one home of the model, SPEC §2 extended) —
// random weights, attitudes, beams and corrections well beyond a working sensor's (1°, 5 cm), so
// that no second-order term hides: Σ_j W_j R_mb,j R_bs (r'_j − r_j) to 1e-12 of its size.
TEST(FeatureMethod, LaserTermsOfEveryGroupEqualThePointsCorrectedOneByOne) {
  std::mt19937 rng(7);
  std::normal_distribution<double> n01;
  auto rot = [&] {
    return Mat3(Eigen::AngleAxisd(n01(rng), Vec3::UnitZ()) * Eigen::AngleAxisd(0.3 * n01(rng), Vec3::UnitY()) *
                Eigen::AngleAxisd(0.3 * n01(rng), Vec3::UnitX()));
  };
  for (int trial = 0; trial < 20; ++trial) {
    const LaserCorrection c{deg2rad(n01(rng)), deg2rad(n01(rng)), 0.05 * n01(rng), 0.05 * n01(rng), 0.05 * n01(rng)};
    const Mat3 R_bs = rot();
    detail::FeatureLaserTerms K;
    Vec3 by_points = Vec3::Zero();
    for (int j = 0; j < 12; ++j) {
      const double omega = deg2rad(-15 + 2 * (j % 16)), alpha = 2 * kPi * j / 12.0, rho = 20 + 40 * std::abs(n01(rng));
      const Vec3 r = rho * Vec3(std::cos(omega) * std::sin(alpha), std::cos(omega) * std::cos(alpha), std::sin(omega));
      Mat3 W = Mat3::Identity() / 12.0;
      W(0, 1) = W(1, 0) = 0.01 * n01(rng);
      const Mat3 WR = W * rot();
      detail::addFeatureLaserTerms(WR, LaserRay(r), &K);
      by_points += WR * R_bs * (LaserCorrector(c)(r) - r);
    }
    const Eigen::Map<const Eigen::Matrix<double, 9, 1>> vecR(R_bs.data());
    const Vec3 by_terms = detail::featureLaserTermMatrix(K, c) * vecR;
    EXPECT_LT((by_terms - by_points).norm(), 1e-12 * std::max(1.0, by_points.norm())) << "trial " << trial;
    // No correction: no share.
    EXPECT_LT((detail::featureLaserTermMatrix(K, LaserCorrection{}) * vecR).norm(), 1e-12) << "trial " << trial;
  }
}

namespace {

/// A uav-vlp16 survey flown with per-laser errors of every group (the "VLP-16" preset's σ, each
/// group's mean over the lasers removed where a calibration holds it), calibrated by the features
/// with all five groups under priors of those σ; per group Σ (error/σ)², the count and the share
/// within 2σ over the lasers the targets' views hold (the truth of elevation, azimuth and vertical
/// about its mean over those lasers, as they are estimated).
struct FeatureIntrinsicsRun {
  std::array<double, 5> sum_z2{};
  std::array<int, 5> count{}, within2{};
  double worst_z = 0;
  std::array<double, 3> boresight_z{};
  double worst_boresight_deg = 0;
  bool usable = false;
  std::string report;
};

FeatureIntrinsicsRun featureIntrinsicsRun(std::uint64_t seed, bool noise) {
  auto s = std::make_unique<Uav>();
  makePreset("uav-vlp16", seed, &s->config, &s->scene);
  if (!noise) s->config.noise = NoiseModel::none();
  const LaserErrorSigmas sig = laserErrorPreset("VLP-16");
  s->config.multibeam.laser_errors =
      drawLaserErrors(16, 100 + seed, sig.elevation_rad, sig.azimuth_rad, sig.vertical_m, sig.range_m, sig.horizontal_m);
  s->survey = simulate(s->config, s->scene);
  MountingCalibrator::Options o = featureOptions(true);
  FeatureOptions& f = o.method<FeatureOptions>();
  f.laser_elevation_sigma_deg = sig.elevation_rad / kDeg;
  f.laser_azimuth_sigma_deg = sig.azimuth_rad / kDeg;
  f.laser_range_sigma_m = sig.range_m;
  f.laser_vertical_sigma_m = sig.vertical_m;
  f.laser_horizontal_sigma_m = sig.horizontal_m;
  const auto S = calibrate(toCalibrationData(s->survey), o);
  FeatureIntrinsicsRun r;
  r.report = S.FullReport();
  r.usable = S.IsSolutionUsable();
  if (!r.usable) return r;
  const LaserIntrinsicEstimates& L = S.section<FeatureSection>().laser_intrinsics;
  const std::vector<LaserSpec>& truth = s->config.multibeam.laser_errors;
  for (std::size_t g = 0; g < 5; ++g) {
    double LaserCorrection::*const est = kLaserGroups[g].field;
    double LaserSpec::*const tru = kLaserErrorFields[g];
    double mean = 0;
    int seen = 0;
    for (std::size_t i = 0; i < 16; ++i)
      if (L.points[i] > 0) mean += truth[i].*tru, ++seen;
    mean = (g == 2 || g == 4) ? 0.0 : mean / std::max(seen, 1);  // range and horizontal keep their common part
    for (std::size_t i = 0; i < 16; ++i) {
      if (L.points[i] == 0) continue;
      const double z = (L.lasers[i].*est - (truth[i].*tru - mean)) / (L.sigma[i].*est);
      r.sum_z2[g] += z * z, ++r.count[g], r.within2[g] += std::abs(z) < 2;
      r.worst_z = std::max(r.worst_z, std::isfinite(z) ? std::abs(z) : 1e9);
    }
  }
  // The azimuth offsets' mean over the seen lasers is held at 0: the truth's is a turn about the
  // spin axis, which the boresight carries — R_bore,true R_nom R_z(δᾱ) R_nomᵀ (R_z as
  // LaserCorrector turns a beam) is the boresight to compare with.
  double azimuth_mean = 0;
  int seen = 0;
  for (std::size_t i = 0; i < 16; ++i)
    if (L.points[i] > 0) azimuth_mean += truth[i].azimuth_offset_rad, ++seen;
  azimuth_mean /= std::max(seen, 1);
  const LaserCorrector turn(LaserCorrection{0, azimuth_mean, 0, 0, 0});
  Mat3 Rz;
  for (int c = 0; c < 3; ++c) Rz.col(c) = turn(Vec3::Unit(c));
  MountingParameters truth_mounting = s->config.true_mounting;
  const Mat3& R_nom = truth_mounting.R_nom;
  truth_mounting.boresight = rollPitchHeading(truth_mounting.R_bore() * R_nom * Rz * R_nom.transpose());
  for (int a = 0; a < 3; ++a) {
    r.boresight_z[static_cast<std::size_t>(a)] = angleError(S.mounting, truth_mounting, a) * kDeg / S.sigma[3 + a];
    r.worst_boresight_deg = std::max(r.worst_boresight_deg, angleError(S.mounting, truth_mounting, a));
  }
  return r;
}

}  // namespace

// Issue 28, the features with every group (not only the elevation): a noise-free survey with
// the VLP-16 preset's errors in all five groups (0.05°, 10 mm range, 5 mm origins), estimated under
// priors of those σ. Nine targets barely determine 80 parameters, so the priors decide most of
// them, and noise-free the targets' sampling (a 1.5 m board in rows 0.5 m apart) still places
// each view's centre to 1–5 cm: what is asked is that the σ cover the errors — their RMS of
// error/σ within [0.5, 1.5], none beyond 4σ (55 parameters; over 30 such surveys 95–97 % lie
// within 2σ per group, RMS 0.89–1.00) —, the boresight within 3σ and within the method's
// noise-free limit (0.03°), and the summary's table titled for the groups. Measured
// (2026-12-06): worst 3.58σ, boresight worst 0.017°.
TEST(FeatureMethod, PerLaserIntrinsicsOfEveryGroupAreEstimatedNoiseFree) {
  const FeatureIntrinsicsRun r = featureIntrinsicsRun(1, false);
  ASSERT_TRUE(r.usable) << r.report;
  int n = 0;
  double z2 = 0;
  for (std::size_t g = 0; g < 5; ++g) n += r.count[g], z2 += r.sum_z2[g];
  std::printf(
      "features, every laser group noise-free: %d parameters, RMS of error/sigma %.2f, worst %.2f; boresight worst %.4f deg "
      "(%.2f %.2f %.2f sigma)\n",
      n, std::sqrt(z2 / std::max(n, 1)), r.worst_z, r.worst_boresight_deg, r.boresight_z[0], r.boresight_z[1], r.boresight_z[2]);
  for (std::size_t g = 0; g < 5; ++g) EXPECT_GE(r.count[g], 10) << "group " << g;
  EXPECT_GE(std::sqrt(z2 / n), 0.5);
  EXPECT_LE(std::sqrt(z2 / n), 1.5);
  EXPECT_LE(r.worst_z, 4.0);
  for (double z : r.boresight_z) EXPECT_LE(z, 3.0);
  EXPECT_LT(r.worst_boresight_deg, 0.03);
  EXPECT_NE(r.report.find("Per-laser intrinsics"), std::string::npos);
}

// The σ of every group over many surveys with the preset's noise (issue 28 with issue 26's
// honest-σ rule: per group RMS of error/σ within [0.7, 1.4], at least 85 % within 2σ), the
// boresight's within [0.6, 1.4] against the truth in the calibration's convention (the seen
// lasers' mean azimuth in the boresight; compared with the raw truth roll's RMS was 1.53).
// Measured (2026-12-06, seeds 1–30): elevation 1.04, azimuth 1.11, range 1.06, vertical 0.93,
// horizontal 0.99 (92.6–96.4 % within 2σ); the boresight 1.14 / 0.75 / 0.84. About 32 s in
// Release; 2 seeds under the sanitizers.
TEST(FeatureMethod, PerLaserIntrinsicsOfEveryGroupSigmasAreHonestOverSeeds) {
  const int seeds = mountcal_tests::seedsFor(30, 2);
  std::array<double, 5> z2{};
  std::array<int, 5> n{}, within{};
  std::array<double, 3> bz2{};
  int usable = 0;
  for (int seed = 1; seed <= seeds; ++seed) {
    const FeatureIntrinsicsRun r = featureIntrinsicsRun(static_cast<std::uint64_t>(seed), true);
    ASSERT_TRUE(r.usable) << "seed " << seed << r.report;
    ++usable;
    for (std::size_t g = 0; g < 5; ++g) z2[g] += r.sum_z2[g], n[g] += r.count[g], within[g] += r.within2[g];
    for (std::size_t a = 0; a < 3; ++a) bz2[a] += r.boresight_z[a] * r.boresight_z[a];
  }
  MOUNTCAL_STATISTICS_IN_RELEASE_ONLY("σ honesty over 30 seeds");
  const char* const names[5] = {"elevation", "azimuth", "range", "vertical", "horizontal"};
  for (std::size_t g = 0; g < 5; ++g) {
    const double rms = std::sqrt(z2[g] / n[g]), share = static_cast<double>(within[g]) / n[g];
    std::printf("features, every laser group over %d seeds: %s %d parameters, RMS of error/sigma %.2f, %.1f %% within 2 sigma\n", usable,
                names[g], n[g], rms, 100 * share);
    EXPECT_GE(rms, 0.7) << names[g] << ": σ too large";
    EXPECT_LE(rms, 1.4) << names[g] << ": σ too small";
    EXPECT_GE(share, 0.85) << names[g];
  }
  std::printf("features, every laser group: boresight RMS of error/sigma %.2f %.2f %.2f\n", std::sqrt(bz2[0] / usable),
              std::sqrt(bz2[1] / usable), std::sqrt(bz2[2] / usable));
  for (std::size_t a = 0; a < 3; ++a) {
    EXPECT_GE(std::sqrt(bz2[a] / usable), 0.6) << "angle " << a;
    EXPECT_LE(std::sqrt(bz2[a] / usable), 1.4) << "angle " << a;
  }
}
