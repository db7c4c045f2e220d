// Survey simulator tests (issue: survey simulator).
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <map>

#include "mountcal/core/error.hpp"
#include "mountcal/core/georeference_model.hpp"
#include "mountcal/simulation/survey.hpp"
#include "core/normal_batch.hpp"  // internal (src/)

#include <cmath>
#include <random>

using namespace mountcal;
using namespace mountcal::simulation;

namespace {

/// Calibration-field preset with no noise and a small ROI: quick to simulate.
SurveyConfig quietField(Scene* scene, std::uint64_t seed = 3) {
  SurveyConfig c;
  makePreset("paper-calibration-field", seed, &c, scene);
  c.noise = NoiseModel::none();
  c.roi_radius_m = 3.0;
  return c;
}

}  // namespace

TEST(Simulator, PointsGeoreferencedWithTheTruthLieOnTheSurfaceTheyHit) {
  Scene scene;
  SurveyConfig c = quietField(&scene);
  const SimulatedSurvey s = simulate(c, scene);
  const GeoreferenceModel truth(s.true_trajectory, c.true_mounting);
  std::size_t n = 0, ground = 0;
  for (const SimulatedStrip& strip : s.strips) {
    ASSERT_EQ(strip.pulses.size(), strip.points_m.size());
    for (std::size_t k = 0; k < strip.pulses.size(); k += 7) {
      const Vec3 x = truth.forward(strip.pulses[k].time_s, strip.pulses[k].r_s);
      EXPECT_LT((x - strip.true_points_m[k]).norm(), 1e-6);
      if (strip.kinds[k] == SurfaceKind::kGround || strip.kinds[k] == SurfaceKind::kMarking) {
        EXPECT_NEAR(x.z(), scene.groundHeight(x.x(), x.y()), 1e-6);
        ++ground;
      }
      ++n;
    }
  }
  EXPECT_GT(n, 1000u);
  EXPECT_GT(ground, 500u);
}

TEST(Simulator, WithNominalEqualToTruthAndNoNoiseEveryTiesPicksCoincide) {
  Scene scene;
  SurveyConfig c = quietField(&scene);
  c.nominal_mounting = c.true_mounting;
  const SimulatedSurvey s = simulate(c, scene);
  ASSERT_GT(s.ties.size(), 40u);
  std::map<std::string, std::vector<const TiePick*>> by_tie;
  for (const TiePick& p : s.ties) by_tie[p.tie_id].push_back(&p);
  for (const auto& [id, picks] : by_tie) {
    ASSERT_GE(picks.size(), 2u) << id;
    for (const TiePick* p : picks) {
      EXPECT_LT(std::hypot(p->x_m - picks[0]->x_m, p->y_m - picks[0]->y_m), 1e-6) << id;
      EXPECT_LT((p->apparent_m - p->true_m).norm(), 1e-6) << id;
    }
  }
}

TEST(Simulator, PicksSpreadAsTheFirstOrderStripOffsetFormulasPredict) {
  // SPEC §2 closed form: level flight at height H, A and B opposite over one line, C in A's
  // direction displaced by D to A's right. ε = δ_used − δ, η = a_used − a.
  Scene scene;
  scene.setGround(0.0, 0.0, 0.0);
  for (int k = 0; k < 7; ++k) {
    const double y = 40.0 * k - 120.0;  // cross-track offsets of the targets (x is East)
    scene.addGroundTarget("t" + std::to_string(k), 150 + y, 300.0 + 50 * k, 3.0, 0.0);
  }
  scene.build();
  SurveyConfig c;
  c.name = "closed-form";
  c.dynamics = AttitudeDynamics{0, 0, 0, 9, 13, 21};
  c.noise = NoiseModel::none();
  c.roi_radius_m = 2.0;
  const double H = 500, D = 100;
  c.lines = {{"A", 150, 0, 0.0, 800, H, 60}, {"B", 150, 800, kPi, 800, H, 60}, {"C", 150 + D, 0, 0.0, 800, H, 60}};
  c.nominal_mounting = MountingParameters{};
  c.true_mounting = MountingParameters::fromDegrees(Vec3(0.10, -0.05, 0.20), Vec3(0.05, -0.08, 0.12));
  const SimulatedSurvey s = simulate(c, scene);
  const Vec3 eps = c.nominal_mounting.boresight - c.true_mounting.boresight;
  const Vec3 eta = c.nominal_mounting.a_b - c.true_mounting.a_b;
  std::map<std::string, std::map<std::string, const TiePick*>> picks;
  for (const TiePick& p : s.ties) picks[p.tie_id][p.strip_id] = &p;
  // Strip A's axes in the mapping frame: along = North, cross (right) = East, down = −Up.
  auto inA = [](const Vec3& d) { return Vec3(d.y(), d.x(), -d.z()); };
  const double tol = 5e-3;  // O(δ²ρ) ≈ 2 mm here, and the 0.5 m vertical undulation of the flight
  int checked = 0;
  for (const auto& [id, by_strip] : picks) {
    ASSERT_TRUE(by_strip.count("A") && by_strip.count("B")) << id;
    const Vec3 x_A = by_strip.at("A")->apparent_m, true_m = by_strip.at("A")->true_m;
    const double y_A = true_m.x() - 150.0;
    const double H_A = H + 0.5;  // the flight undulates by ±0.5 m; allow for it in the tolerance
    const Vec3 dAB = inA(x_A - by_strip.at("B")->apparent_m);
    EXPECT_NEAR(dAB.x(), 2 * (eps.y() * H_A + eta.x()), tol + 2 * std::abs(eps.y()) * 1.0) << id;
    EXPECT_NEAR(dAB.y(), 2 * (eta.y() - eps.x() * H_A), tol + 2 * std::abs(eps.x()) * 1.0) << id;
    EXPECT_NEAR(dAB.z(), 2 * eps.x() * y_A, tol) << id;
    if (by_strip.count("C")) {
      const Vec3 dAC = inA(x_A - by_strip.at("C")->apparent_m);
      EXPECT_NEAR(dAC.x(), -eps.z() * D, tol) << id;
      EXPECT_NEAR(dAC.z(), eps.x() * D, tol) << id;
    }
    ++checked;
  }
  EXPECT_EQ(checked, 7);
  // The spread is real: pitch error of 0.08° at 500 m moves picks by 1.4 m between A and B.
  EXPECT_GT(std::abs(2 * eps.y() * H), 1.0);
}

TEST(Simulator, PointSpacingOfThe760mPresetIsHalfAMetre) {
  Scene scene;
  SurveyConfig c;
  makePreset("paper-calibration-field", 1, &c, &scene);
  c.roi_radius_m = 0;  // whole strip
  c.lines.resize(1);
  c.lines[0].x0_m = -150;
  c.lines[0].length_m = 300;
  const SimulatedSurvey s = simulate(c, scene);
  const auto& pts = s.strips[0].true_points_m;
  // Count ground returns in a 100 m window across the whole swath (mean density).
  std::size_t n = 0;
  double ymin = 1e9, ymax = -1e9;
  for (const Vec3& p : pts) {
    if (p.x() < -50 || p.x() > 50) continue;
    ++n;
    ymin = std::min(ymin, p.y());
    ymax = std::max(ymax, p.y());
  }
  const double spacing = std::sqrt(100.0 * (ymax - ymin) / static_cast<double>(n));
  EXPECT_NEAR(spacing, 0.5, 0.1) << n << " points over " << ymax - ymin << " m";
}

TEST(Simulator, SameSeedSameOutputOtherSeedOtherNoise) {
  Scene scene;
  SurveyConfig c;
  makePreset("paper-calibration-field", 42, &c, &scene);
  c.roi_radius_m = 2.0;
  const SimulatedSurvey a = simulate(c, scene), b = simulate(c, scene);
  ASSERT_EQ(a.strips.size(), b.strips.size());
  for (std::size_t k = 0; k < a.strips.size(); ++k) {
    ASSERT_EQ(a.strips[k].points_m.size(), b.strips[k].points_m.size());
    for (std::size_t i = 0; i < a.strips[k].points_m.size(); ++i) ASSERT_EQ(a.strips[k].points_m[i], b.strips[k].points_m[i]);
  }
  ASSERT_EQ(a.ties.size(), b.ties.size());
  for (std::size_t i = 0; i < a.ties.size(); ++i) ASSERT_EQ(a.ties[i].x_m, b.ties[i].x_m);
  c.seed = 43;
  const SimulatedSurvey d = simulate(c, scene);
  EXPECT_NE(a.ties[0].x_m, d.ties[0].x_m);
}

// The pulse loop's noise comes from detail::BufferedNormals (src/normal_batch.hpp): Rng::normal()'s
// stream drawn in batches, with a logarithm of its own. References: the C library's log, and
// Rng::normal() itself.
TEST(Simulator, BatchedNormalsFollowTheRngStream) {
  std::vector<double> x;
  for (int k = 1; k <= 4096; ++k) x.push_back(k / 4096.0);  // (0, 1]: q of the polar method
  for (double v : {1e-300, 2.2250738585072014e-308, 0.7071067811865475, 0.7071067811865476, 1.4142135623730951, 1.4142135623730950,
                   1.0 - 1e-16, 1.0 + 2.2e-16, 2.0, 3.0, 1e300})
    x.push_back(v);
  std::mt19937 gen(5);
  std::uniform_real_distribution<double> e(-700, 700);
  for (int k = 0; k < 20000; ++k) x.push_back(std::exp(e(gen)));
  std::vector<double> ln(x.size());
  detail::logBatch(x.data(), ln.data(), x.size());
  double worst_ulp = 0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    const double ref = std::log(x[k]);
    const double ulp = ref == 0 ? 5e-324 : std::nextafter(std::fabs(ref), INFINITY) - std::fabs(ref);
    worst_ulp = std::max(worst_ulp, std::fabs(ln[k] - ref) / ulp);
  }
  EXPECT_LE(worst_ulp, 2.0);

  detail::Rng a(77), b(77);
  detail::BufferedNormals batched(&b);
  double worst = 0, sum = 0, sum2 = 0;
  const int n = 100000;  // several batches
  for (int k = 0; k < n; ++k) {
    const double ref = a.normal(), got = batched.next();
    worst = std::max(worst, std::fabs(got - ref) / std::max(1.0, std::fabs(ref)));
    sum += got;
    sum2 += got * got;
  }
  EXPECT_LE(worst, 1e-15);
  EXPECT_NEAR(sum / n, 0.0, 0.02);  // 6 standard errors
  EXPECT_NEAR(sum2 / n, 1.0, 0.03);
}

// The line scanner's noisy laser vector is formed from the block's sin θ, cos θ by the angle sum;
// it must still be the scanner model's vector of the recorded (noisy) angle and range.
TEST(Simulator, NoisyLineScannerVectorsAreTheModelsVectorOfTheRecordedAngleAndRange) {
  Scene scene;
  SurveyConfig c;
  makePreset("paper-calibration-field", 9, &c, &scene);
  c.noise.scan_angle_sigma_rad = deg2rad(0.01);
  c.roi_radius_m = 2.0;
  const SimulatedSurvey s = simulate(c, scene);
  std::size_t n = 0;
  double worst = 0;
  for (const SimulatedStrip& strip : s.strips) {
    for (const RawPulse& p : strip.pulses) {
      worst = std::max(worst, (p.r_s - LineScannerModel{}.vector(p.angle_rad, p.range_m)).norm());
      ++n;
    }
  }
  ASSERT_GT(n, 10000u);
  EXPECT_LE(worst, 1e-12);  // 1e-15 relative at ranges under 1.5 km
}

TEST(Simulator, MultiBeamPresetScansTheGroundAroundTheTargets) {
  Scene scene;
  SurveyConfig c;
  makePreset("uav-vlp16", 1, &c, &scene);
  c.noise = NoiseModel::none();
  c.roi_radius_m = 1.5;
  const std::size_t strips = 5, ties = 16;  // three lines at 50 m, the centre line twice at 80 m
  const SimulatedSurvey s = simulate(c, scene);
  ASSERT_EQ(s.strips.size(), strips);
  const GeoreferenceModel truth(s.true_trajectory, c.true_mounting);
  std::size_t n = 0;
  for (const SimulatedStrip& strip : s.strips) {
    for (std::size_t k = 0; k < strip.pulses.size(); k += 11) {
      const RawPulse& p = strip.pulses[k];
      const Vec3 r_s = c.multibeam.model.vector(p.laser_id, p.angle_rad, p.range_m);
      EXPECT_LT((truth.forward(p.time_s, r_s) - strip.true_points_m[k]).norm(), 1e-6);
      ++n;
    }
  }
  EXPECT_GT(n, 100u);
  EXPECT_GE(s.ties.size(), ties);
}

// Per-laser errors (issue 28): the rays are cast with the table plus the errors, the points are
// georeferenced with the table. Through the true trajectory and mounting, the vector of the table
// plus the errors reaches the surface hit exactly; the table's own vector misses it.
TEST(Simulator, PerLaserErrorsAreCastWhileThePointsUseTheTable) {
  Scene scene;
  SurveyConfig c;
  makePreset("uav-vlp16", 1, &c, &scene);
  c.noise = NoiseModel::none();
  c.roi_radius_m = 1.5;
  c.lines.resize(1);  // one line: each pulse is checked
  c.multibeam.laser_errors = drawLaserErrors(c.multibeam.model.laserCount(), 5, deg2rad(0.1), deg2rad(0.05), 0.005, 0.01);
  const MultiBeamModel real = firedModel(c.multibeam);
  ASSERT_EQ(real.laser(3).elevation_rad, c.multibeam.model.laser(3).elevation_rad + c.multibeam.laser_errors[3].elevation_rad);
  ASSERT_EQ(real.laser(3).range_offset_m, c.multibeam.model.laser(3).range_offset_m + c.multibeam.laser_errors[3].range_offset_m);
  const SimulatedSurvey s = simulate(c, scene);
  const GeoreferenceModel truth(s.true_trajectory, c.true_mounting);
  std::size_t n = 0, off = 0;
  for (const SimulatedStrip& strip : s.strips) {
    for (std::size_t k = 0; k < strip.pulses.size(); k += 11) {
      const RawPulse& p = strip.pulses[k];
      EXPECT_LT((p.r_s - c.multibeam.model.vector(p.laser_id, p.angle_rad, p.range_m)).norm(), 1e-9);  // the table's vector
      EXPECT_LT((truth.forward(p.time_s, real.vector(p.laser_id, p.angle_rad, p.range_m)) - strip.true_points_m[k]).norm(), 1e-6);
      off += (truth.forward(p.time_s, p.r_s) - strip.true_points_m[k]).norm() > 1e-3;
      ++n;
    }
  }
  EXPECT_GT(n, 100u);
  EXPECT_GT(off, n * 9 / 10);  // errors of 0.1°, 5 mm and 1 cm move nearly every point by over 1 mm
}

// The azimuth gate (MultiBeamConfig::azimuth_gate) sets up only the firing sequences that can
// reach an ROI window: the strips are the ungated simulator's to the last bit — the VLP-16 preset
// (spin axis horizontal, rolling and pitching by 1°) and an HDL-32E, both with survey noise and
// per-laser errors of every group (azimuth and horizontal offsets widen the gate), ROI radius 1.5 m,
// the centre line at both heights.
TEST(Simulator, AzimuthGateKeepsEveryPulseTheRoiKeeps) {
  for (const bool hdl : {false, true}) {
    Scene scene;
    SurveyConfig c;
    makePreset("uav-vlp16", 3, &c, &scene);
    if (hdl) c.multibeam.model = MultiBeamModel::HDL32E();
    c.roi_radius_m = 1.5;
    c.lines = {c.lines[0], c.lines[3]};  // the centre line at 50 m and at 80 m
    c.multibeam.laser_errors = drawLaserErrors(c.multibeam.model.laserCount(), 7, deg2rad(0.1), deg2rad(0.3), 0.005, 0.01, 0.02);
    SurveyConfig ungated = c;
    ungated.multibeam.azimuth_gate = false;
    const SimulatedSurvey a = simulate(c, scene), b = simulate(ungated, scene);
    ASSERT_EQ(a.strips.size(), b.strips.size());
    std::size_t n = 0;
    for (std::size_t i = 0; i < a.strips.size(); ++i) {
      const SimulatedStrip &x = a.strips[i], &y = b.strips[i];
      ASSERT_EQ(x.pulses.size(), y.pulses.size()) << "strip " << x.id << (hdl ? " HDL-32E" : " VLP-16");
      for (std::size_t k = 0; k < x.pulses.size(); ++k) {
        ASSERT_EQ(x.pulses[k].time_s, y.pulses[k].time_s) << k;
        ASSERT_EQ(x.pulses[k].laser_id, y.pulses[k].laser_id) << k;
        ASSERT_EQ(x.pulses[k].range_m, y.pulses[k].range_m) << k;
        ASSERT_EQ(x.points_m[k], y.points_m[k]) << k;
      }
      n += x.pulses.size();
    }
    EXPECT_GT(n, 10000u);
    EXPECT_EQ(a.ties.size(), b.ties.size());
  }
}

TEST(Simulator, RejectsInconsistentConfigurationsAndUnknownPresets) {
  Scene scene;
  SurveyConfig c;
  EXPECT_THROW(makePreset("no-such-preset", 1, &c, &scene), InvalidInput);
  makePreset("paper-check-block", 1, &c, &scene);
  c.lines[0].speed_mps = 0;
  EXPECT_THROW(simulate(c, scene), InvalidInput);
  c.lines.clear();
  EXPECT_THROW(simulate(c, scene), InvalidInput);
}

namespace mountcal::simulation {
namespace {

/// Measured − true trajectory in x, sampled at the trajectory's rate over every line of the
/// crossing field (both share their sample times) with only navigation drift of `form`: the
/// sample RMS, and the RMS of the 1 s difference over the RMS.
struct DriftStatistics {
  double rms = 0.0, one_second_change = 0.0;
};
DriftStatistics driftStatistics(NoiseModel::DriftForm form) {
  Scene scene;
  SurveyConfig c;
  makePreset("paper-calibration-field", 4, &c, &scene);
  c.noise = NoiseModel::none();
  c.noise.drift_position_sigma_m = 0.02;
  c.noise.drift_attitude_sigma_rad = deg2rad(0.002);
  c.noise.drift_form = form;
  c.roi_radius_m = 1.0;
  const SimulatedSurvey s = simulate(c, scene);
  const auto& measured = s.measured_trajectory->samples();
  const auto& truth = s.true_trajectory->samples();
  EXPECT_EQ(measured.size(), truth.size());
  std::vector<double> dx, times;
  for (std::size_t i = 0; i < measured.size(); ++i) {
    dx.push_back(measured[i].p_m.x() - truth[i].p_m.x());
    times.push_back(measured[i].time_s);
  }
  EXPECT_GT(dx.size(), 1000u);
  double ss = 0;
  for (double v : dx) ss += v * v;
  DriftStatistics out;
  out.rms = std::sqrt(ss / static_cast<double>(dx.size()));
  const std::size_t lag = static_cast<std::size_t>(std::lround(c.trajectory_rate_hz));
  double diff2 = 0;
  std::size_t n = 0;
  for (std::size_t i = lag; i < dx.size(); ++i) {
    if (times[i] - times[i - lag] > 1.01) continue;  // across a line gap
    diff2 += (dx[i] - dx[i - lag]) * (dx[i] - dx[i - lag]);
    ++n;
  }
  EXPECT_GT(n, 100u);
  out.one_second_change = std::sqrt(diff2 / static_cast<double>(n)) / out.rms;
  return out;
}

// Issue 26: navigation drift of realistic spectra, in a form unlike the calibrator's models.
TEST(SimulationNoise, NavigationDriftHasItsRmsAndItsPeriods) {
  const DriftStatistics d = driftStatistics(NoiseModel::DriftForm::kBandLimited);
  EXPECT_GT(d.rms, 0.02 * 0.5);  // eight sinusoids per line: the sample RMS scatters about σ
  EXPECT_LT(d.rms, 0.02 * 1.6);
  // Smooth over a second (periods ≥ 10 s): for a sinusoid of period P, RMS of the 1 s
  // difference / RMS = 2 sin(π/P) ≤ 0.63 at P = 10 s, ≥ 2 sin(π/100) = 0.06: not constant.
  EXPECT_LT(d.one_second_change, 0.63);
  EXPECT_GT(d.one_second_change, 0.06);
}

// The Gauss–Markov form (issue 26's words): correlation times 10–100 s drawn per line and axis.
// For a first-order process of correlation time τ the 1 s difference has RMS √(2(1 − e^(−1/τ)))
// times the process's: 0.14 (τ = 100 s) to 0.44 (τ = 10 s).
TEST(SimulationNoise, GaussMarkovDriftHasItsRmsAndCorrelationTimes) {
  const DriftStatistics d = driftStatistics(NoiseModel::DriftForm::kGaussMarkov);
  EXPECT_GT(d.rms, 0.02 * 0.5);  // a few lines of a few correlation times: the sample RMS scatters
  EXPECT_LT(d.rms, 0.02 * 1.6);
  EXPECT_GT(d.one_second_change, 0.14 * 0.8);
  EXPECT_LT(d.one_second_change, 0.44 * 1.2);
}

TEST(SimulationNoise, WithoutDriftTheSurveyIsUnchanged) {
  Scene scene;
  SurveyConfig c;
  makePreset("paper-calibration-field", 4, &c, &scene);
  c.noise = NoiseModel::realistic();
  c.roi_radius_m = 1.0;
  const SimulatedSurvey a = simulate(c, scene);
  c.noise.drift_position_period_max_s = 50;  // a setting of a drift that is off: no effect
  const SimulatedSurvey b = simulate(c, scene);
  ASSERT_EQ(a.measured_trajectory->samples().size(), b.measured_trajectory->samples().size());
  for (std::size_t i = 0; i < a.measured_trajectory->samples().size(); i += 97)
    EXPECT_EQ(a.measured_trajectory->samples()[i].p_m, b.measured_trajectory->samples()[i].p_m);
}

}  // namespace
}  // namespace mountcal::simulation

// The scenario key "laser_errors" draws the errors for a multi-beam preset, and is refused for a
// line scanner with the file and the field named.
TEST(Scenario, LaserErrorsAreDrawnForAMultiBeamPresetAndRefusedForALineScanner) {
  const std::string path = testing::TempDir() + "mountcal_scenario_lasers.json";
  std::ofstream(path) << R"({"preset": "uav-vlp16", "laser_errors": {"elevation_sigma_deg": 0.1, "range_sigma_m": 0.01, "seed": 4}})";
  SurveyConfig c;
  Scene scene;
  loadScenario(path, &c, &scene);
  const std::vector<LaserSpec> want = drawLaserErrors(16, 4, deg2rad(0.1), 0.0, 0.0, 0.01);
  ASSERT_EQ(c.multibeam.laser_errors.size(), 16u);
  for (std::size_t i = 0; i < want.size(); ++i) {
    EXPECT_EQ(c.multibeam.laser_errors[i].elevation_rad, want[i].elevation_rad);
    EXPECT_EQ(c.multibeam.laser_errors[i].range_offset_m, want[i].range_offset_m);
    EXPECT_EQ(c.multibeam.laser_errors[i].azimuth_offset_rad, 0.0);
  }
  std::ofstream(path) << R"({"preset": "paper-calibration-field", "laser_errors": {"elevation_sigma_deg": 0.1}})";
  try {
    loadScenario(path, &c, &scene);
    FAIL() << "a line scanner has no lasers to be off";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("laser_errors"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  std::ofstream(path) << R"({"preset": "uav-vlp16", "laser_errors": {"elevation_sigma_deg": 5}})";
  EXPECT_THROW(loadScenario(path, &c, &scene), FileError);  // 5°: not an error of a laser table
  // The sensor's error preset: every group drawn with laserErrorPreset's σ, a key overriding one.
  std::ofstream(path) << R"({"preset": "uav-vlp16", "laser_errors": {"preset": "VLP-16", "range_sigma_m": 0.02, "seed": 4}})";
  loadScenario(path, &c, &scene);
  const LaserErrorSigmas p = laserErrorPreset("VLP-16");
  const std::vector<LaserSpec> all = drawLaserErrors(16, 4, p.elevation_rad, p.azimuth_rad, p.vertical_m, 0.02, p.horizontal_m);
  ASSERT_EQ(c.multibeam.laser_errors.size(), 16u);
  for (std::size_t i = 0; i < all.size(); ++i) {
    EXPECT_EQ(c.multibeam.laser_errors[i].range_offset_m, all[i].range_offset_m);
    EXPECT_EQ(c.multibeam.laser_errors[i].horizontal_offset_m, all[i].horizontal_offset_m);
    EXPECT_NE(all[i].horizontal_offset_m, 0.0);
  }
  std::ofstream(path) << R"({"preset": "uav-vlp16", "laser_errors": {"preset": "VLP-32"}})";
  try {
    loadScenario(path, &c, &scene);
    FAIL() << "no such error preset";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("laser_errors.preset"), std::string::npos) << e.what();
  }
  std::remove(path.c_str());
}

// The drift's form from a scenario: named, as a field of the noise object, and refused with the
// file and the field when it is neither form.
TEST(Scenario, DriftFormIsReadByNameAndFieldAndAnUnknownOneRefused) {
  const std::string path = testing::TempDir() + "mountcal_scenario_drift.json";
  SurveyConfig c;
  Scene scene;
  std::ofstream(path) << R"({"preset": "uav-vlp16", "noise": "navigation_drift_gauss_markov"})";
  loadScenario(path, &c, &scene);
  EXPECT_EQ(c.noise.drift_form, NoiseModel::DriftForm::kGaussMarkov);
  EXPECT_EQ(c.noise.drift_position_sigma_m, 0.02);
  std::ofstream(path) << R"({"preset": "uav-vlp16", "noise": {"drift_position_sigma_m": 0.03, "drift_form": "gauss_markov"}})";
  loadScenario(path, &c, &scene);
  EXPECT_EQ(c.noise.drift_form, NoiseModel::DriftForm::kGaussMarkov);
  std::ofstream(path) << R"({"preset": "uav-vlp16", "noise": {"drift_form": "pink"}})";
  try {
    loadScenario(path, &c, &scene);
    FAIL() << "an unknown drift form";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("drift_form"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  std::remove(path.c_str());
}
