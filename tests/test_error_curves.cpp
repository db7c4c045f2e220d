// The first paper's Figs 1–3 (SPEC §2, "The paper's error curves"): boresight ω = φ = κ = 0.1°,
// scan angles −45°…45°, ranges 500–2000 m, line scanner, level flight, zero lever arm.
#include <gtest/gtest.h>

#include <map>

#include "mountcal/report/error_curves.hpp"
#include "mountcal/core/mounting.hpp"

using namespace mountcal;

namespace {
constexpr double kDelta = deg2rad(0.1);
}  // namespace

// Outside the anonymous namespace: the TEST_F classes derive from it (GCC's -Wsubobject-linkage
// in the unity build of the tests).

struct Curves : ::testing::Test {
  void SetUp() override {
    for (int a = -45; a <= 45; ++a) angles.push_back(deg2rad(a));
    samples = boresightErrorCurves(Vec3(kDelta, kDelta, kDelta), angles, ranges);
    for (const auto& s : samples) by_range[s.range_m].push_back(s);
  }
  /// Second-order remainder bound: each factor of Rz·Ry·Rx deviates from I + [δ]× by at most
  /// δ²/2 and the cross terms add ωφ + ωκ + φκ, so |e − e₁| ≤ (ω+φ+κ)²/2 · ρ = 4.5 δ² ρ.
  static double remainder(double rho) { return 4.5 * kDelta * kDelta * rho * (1 + 1e-3); }

  std::vector<double> angles;
  const std::vector<double> ranges{500, 1000, 1500, 2000};
  std::vector<ErrorCurveSample> samples;
  std::map<double, std::vector<ErrorCurveSample>> by_range;
};

TEST_F(Curves, ExactGeoreferencingEqualsTheMatrixExpression) {
  const Mat3 R_bore = MountingParameters::fromDegrees(Vec3::Zero(), Vec3(0.1, 0.1, 0.1)).R_bore();
  ASSERT_EQ(samples.size(), angles.size() * ranges.size());
  for (const auto& s : samples) {
    const Vec3 r_s = s.range_m * Vec3(0, std::sin(s.scan_angle_rad), std::cos(s.scan_angle_rad));
    EXPECT_LT((s.exact_b - (R_bore - Mat3::Identity()) * r_s).norm(), 1e-9);
  }
}

TEST_F(Curves, FirstOrderFormHoldsWithinItsRemainder) {
  for (const auto& s : samples) {
    const double d = (s.exact_b - s.first_order_b).norm();
    EXPECT_LE(d, remainder(s.range_m));
    // The bound is tight enough to mean something: the error itself is ~δρ, 100× larger.
    EXPECT_GT(s.exact_b.norm(), 50 * remainder(s.range_m));
  }
}

TEST_F(Curves, AlongTrackErrorVanishesAtPlus45) {
  for (const auto& [rho, curve] : by_range) {
    std::size_t best = 0;
    for (std::size_t i = 0; i < curve.size(); ++i)
      if (std::abs(curve[i].exact_b.x()) < std::abs(curve[best].exact_b.x())) best = i;
    EXPECT_NEAR(rad2deg(curve[best].scan_angle_rad), 45.0, 1e-9) << rho;
    EXPECT_LE(std::abs(curve[best].exact_b.x()), remainder(rho));
    // ... and is largest at the other edge, −45° (the paper's +45°).
    EXPECT_NEAR(std::abs(curve.front().exact_b.x()), kDelta * rho * std::sqrt(2.0), remainder(rho));
  }
}

TEST_F(Curves, CrossTrackErrorIsLargestAtNadirAndFallsWithScanAngle) {
  for (const auto& [rho, curve] : by_range) {
    const std::size_t nadir = 45;
    ASSERT_NEAR(curve[nadir].scan_angle_rad, 0.0, 1e-15);
    EXPECT_NEAR(std::abs(curve[nadir].exact_b.y()), kDelta * rho, remainder(rho));
    for (std::size_t i = nadir + 1; i < curve.size(); ++i) {
      EXPECT_LT(std::abs(curve[i].exact_b.y()), std::abs(curve[i - 1].exact_b.y()));  // +θ side
      const std::size_t j = 2 * nadir - i;                                            // −θ side
      EXPECT_LT(std::abs(curve[j].exact_b.y()), std::abs(curve[j + 1].exact_b.y()));
    }
  }
}

TEST_F(Curves, VerticalErrorIsZeroAtNadirAndGrowsWithScanAngle) {
  for (const auto& [rho, curve] : by_range) {
    const std::size_t nadir = 45;
    EXPECT_LE(std::abs(curve[nadir].exact_b.z()), remainder(rho));
    for (std::size_t i = nadir + 1; i < curve.size(); ++i) {
      EXPECT_GT(std::abs(curve[i].exact_b.z()), std::abs(curve[i - 1].exact_b.z()));
      const std::size_t j = 2 * nadir - i;
      EXPECT_GT(std::abs(curve[j].exact_b.z()), std::abs(curve[j + 1].exact_b.z()));
    }
    EXPECT_NEAR(std::abs(curve.back().exact_b.z()), kDelta * rho * std::sqrt(0.5), remainder(rho));
  }
}

TEST_F(Curves, EveryErrorGrowsLinearlyWithRange) {
  const auto& base = by_range.at(500.0);
  for (const auto& [rho, curve] : by_range) {
    for (std::size_t i = 0; i < curve.size(); ++i) {
      EXPECT_LT((curve[i].exact_b - (rho / 500.0) * base[i].exact_b).norm(), 1e-9);
    }
  }
}

TEST_F(Curves, CsvAndSvgAreWellFormed) {
  const std::string csv = errorCurvesCsv(samples);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), static_cast<long>(samples.size() + 1));
  EXPECT_EQ(csv.rfind("range_m,scan_angle_deg,exact_x_m", 0), 0u);
  const std::string svg = errorCurveSvg(samples, 1, "Fig. 2");
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_EQ(std::count(svg.begin(), svg.end(), '\n') > 10, true);
  size_t polylines = 0;
  for (size_t p = svg.find("<polyline"); p != std::string::npos; p = svg.find("<polyline", p + 1)) ++polylines;
  EXPECT_EQ(polylines, ranges.size());
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
}

// The report's curves at a survey's own beams (issue 28: a drone's VLP-16 is not drawn as a line
// scanner's ±30°). A line scanner's beams, one per 1° bin at θ = k + 0.5°: the same errors as the
// curves above, which go through GeoreferenceModel (an independent path), and the first order
// within the same remainder.
TEST_F(Curves, BeamCurvesOfALineScannersBeamsAreThePapersCurves) {
  std::vector<Vec3> beams;
  std::vector<double> at;
  for (int k = -45; k < 45; ++k) {
    const double theta = deg2rad(k + 0.5);
    at.push_back(theta);
    beams.push_back(Vec3(0, std::sin(theta), std::cos(theta)) * 700.0);
  }
  const auto own = beamErrorCurves(Mat3::Identity(), R_zyx(Vec3(kDelta, kDelta, kDelta)), beams, ranges, 1.0, 1);
  const auto paper = boresightErrorCurves(Vec3(kDelta, kDelta, kDelta), at, ranges);
  ASSERT_EQ(own.size(), paper.size());
  for (std::size_t i = 0; i < own.size(); ++i) {
    EXPECT_NEAR(own[i].scan_angle_rad, paper[i].scan_angle_rad, 1e-12);
    EXPECT_EQ(own[i].range_m, paper[i].range_m);
    EXPECT_LT((own[i].exact_b - paper[i].exact_b).norm(), 1e-9 * own[i].range_m) << i;
    EXPECT_LT((own[i].first_order_b - own[i].exact_b).norm(), remainder(own[i].range_m)) << i;
  }
  EXPECT_TRUE(beamErrorCurves(Mat3::Identity(), Mat3::Identity(), {Vec3::Zero()}, ranges).empty());
}

// A multi-beam scanner on its side (spin axis along the body's forward axis, lasers at ±10°
// elevation in pairs): drawn over the whole turn it scans, and each 2° bin's error is the line
// scanner's at the bin's angle times cos 10° (the pair's mean direction; the bin's 2° mean
// shortens it by sin 1°/1°, under 1e-4).
TEST_F(Curves, BeamCurvesOfASpinningScannerOnItsSideCoverItsTurn) {
  const Mat3 R_nom = R_zyx(Vec3(0, kPi / 2, 0));  // scanner z (spin axis) → body x
  std::vector<Vec3> beams;
  for (int a = 0; a < 1440; ++a) {
    const double az = deg2rad(0.25 * a + 0.125);
    for (double el : {deg2rad(10.0), deg2rad(-10.0)})
      beams.push_back(30.0 * Vec3(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)));
  }
  const Mat3 R_new = R_zyx(Vec3(kDelta, kDelta, kDelta)) * R_nom;
  const std::vector<double> r{30.0};
  const auto own = beamErrorCurves(R_nom, R_new, beams, r);
  ASSERT_EQ(own.size(), 180u);
  EXPECT_LT(own.front().scan_angle_rad, deg2rad(-178.0));
  EXPECT_GT(own.back().scan_angle_rad, deg2rad(178.0));
  std::vector<double> angles;
  for (const auto& e : own) angles.push_back(e.scan_angle_rad);
  const auto paper = boresightErrorCurves(Vec3(kDelta, kDelta, kDelta), angles, r);
  for (std::size_t i = 0; i < own.size(); ++i) {
    const Vec3 want = std::cos(deg2rad(10.0)) * paper[i].exact_b;
    EXPECT_LT((own[i].exact_b - want).norm(), 1e-4 * paper[i].exact_b.norm() + 1e-12) << i;
  }
}
