#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "mountcal/core/error.hpp"
#include "mountcal/core/geodesy.hpp"
#include "mountcal/core/georeference_model.hpp"
#include "core/sincos_batch.hpp"  // internal (src/)

using namespace mountcal;

namespace {

std::shared_ptr<const Trajectory> levelTrajectory(const Vec3& p, double heading_rad) {
  std::vector<TrajectorySample> s(2);
  s[0].time_s = 0;
  s[1].time_s = 1;
  s[0].p_m = s[1].p_m = p;
  s[0].heading = s[1].heading = heading_rad;
  return std::make_shared<const Trajectory>(s);
}

/// A 10 s trajectory at 200 Hz with random slow attitude and a UTM-sized position.
std::shared_ptr<const Trajectory> randomTrajectory(std::mt19937& rng, PositionInterpolation interp) {
  std::uniform_real_distribution<double> u(-1, 1);
  const double h0 = kPi * u(rng), r0 = 0.05 * u(rng), p0 = 0.05 * u(rng);
  std::vector<TrajectorySample> s(2001);
  for (std::size_t i = 0; i < s.size(); ++i) {
    const double t = 0.005 * static_cast<double>(i);
    s[i].time_s = 350000.0 + t;
    s[i].p_m = Vec3(500000 + 60 * t * std::sin(h0), 4100000 + 60 * t * std::cos(h0), 1200 + 2 * std::sin(0.3 * t));
    s[i].roll = r0 + 0.004 * std::sin(0.7 * t);
    s[i].pitch = p0 + 0.003 * std::cos(0.5 * t);
    s[i].heading = h0 + 0.002 * std::sin(0.2 * t);
  }
  return std::make_shared<const Trajectory>(s, interp);
}

}  // namespace

TEST(Georeference, ZeroMountingIdentityAttitudeNadir) {
  const Vec3 p(1000, 2000, 800);
  const GeoreferenceModel model(levelTrajectory(p, 0.0), MountingParameters{});
  // Level, heading 0: body x = North, y = East, z = Down. Nadir 800 m → ground at z = 0.
  EXPECT_LT((model.forward(0.3, Vec3(0, 0, 800)) - Vec3(1000, 2000, 0)).norm(), 1e-12);
  // Body +y (starboard) of a northbound flight is East (+x mapping).
  EXPECT_LT((model.forward(0.3, Vec3(0, 50, 0)) - Vec3(1050, 2000, 800)).norm(), 1e-12);
  EXPECT_LT((model.forward(0.3, Vec3(50, 0, 0)) - Vec3(1000, 2050, 800)).norm(), 1e-12);
}

TEST(Georeference, HeadingNinetyMapsBodyForwardToEast) {
  const Vec3 p(0, 0, 0);
  const GeoreferenceModel model(levelTrajectory(p, deg2rad(90)), MountingParameters{});
  EXPECT_LT((model.forward(0.5, Vec3(100, 0, 0)) - Vec3(100, 0, 0)).norm(), 1e-12);
  EXPECT_LT((model.forward(0.5, Vec3(0, 100, 0)) - Vec3(0, -100, 0)).norm(), 1e-12);
}

TEST(Georeference, PureLeverArmShiftsByRmbTimesA) {
  std::mt19937 rng(1);
  const auto traj = randomTrajectory(rng, PositionInterpolation::kLinear);
  MountingParameters with;
  with.a_b = Vec3(0.4, -0.2, 1.3);
  const GeoreferenceModel a(traj, with), b(traj, MountingParameters{});
  for (double t : {350000.0, 350003.21, 350010.0}) {
    const Vec3 r_s(3, -40, 900);
    const Mat3 R_mb = traj->pose(t).R_mb;
    EXPECT_LT((a.forward(t, r_s) - b.forward(t, r_s) - R_mb * with.a_b).norm(), 1e-9);
  }
}

TEST(Georeference, BoresightAndNominalRotationCompose) {
  MountingParameters m = MountingParameters::fromDegrees(Vec3::Zero(), Vec3(0, 0, 0), Vec3(0, 0, 90));
  const GeoreferenceModel model(levelTrajectory(Vec3::Zero(), 0.0), m);
  // R_nom = Rz(90°) turns scanner +x into body +y (starboard) = East.
  EXPECT_LT((model.forward(0.5, Vec3(10, 0, 0)) - Vec3(10, 0, 0)).norm(), 1e-12);
}

TEST(Georeference, RandomRoundTripsWithinANanometre) {
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> u(-1, 1);
  const MultiBeamModel vlp = MultiBeamModel::VLP16(), hdl = MultiBeamModel::HDL32E();
  const LineScannerModel line;
  double worst = 0;
  for (int trial = 0; trial < 20; ++trial) {
    const auto traj = randomTrajectory(rng, trial % 2 ? PositionInterpolation::kCubic : PositionInterpolation::kLinear);
    const auto m = MountingParameters::fromDegrees(Vec3(u(rng), u(rng), u(rng)), Vec3(u(rng), u(rng), u(rng)),
                                                   Vec3(180 * u(rng), 90 * u(rng), 180 * u(rng)));
    const GeoreferenceModel model(traj, m);
    std::uniform_real_distribution<double> t(traj->startTime(), traj->endTime());
    for (int k = 0; k < 200; ++k) {
      Vec3 r_s;
      switch (k % 4) {
        case 0:
          r_s = line.vector(1.2 * u(rng), 200 + 3000 * std::abs(u(rng)));
          break;
        case 1:
          r_s = vlp.vector(k % 16, kPi * (1 + u(rng)), 100 * std::abs(u(rng)) + 1);
          break;
        case 2:
          r_s = hdl.vector(k % 32, kPi * (1 + u(rng)), 100 * std::abs(u(rng)) + 1);
          break;
        default:
          r_s = Vec3(500 * u(rng), 500 * u(rng), 500 * u(rng));
      }
      const double time = t(rng);
      const Vec3 back = model.inverse(time, model.forward(time, r_s));
      worst = std::max(worst, (back - r_s).norm());
    }
  }
  EXPECT_LT(worst, 1e-9);
}

TEST(Georeference, BatchEqualsSingleAndRoundTrips) {
  std::mt19937 rng(9);
  const auto traj = randomTrajectory(rng, PositionInterpolation::kCubic);
  const auto m = MountingParameters::fromDegrees(Vec3(0.1, 0.2, -0.3), Vec3(0.1, -0.2, 0.3));
  const GeoreferenceModel model(traj, m);
  const std::size_t n = 5000;
  std::vector<double> t(n), theta(n), rho(n), r_s(3 * n), x_m(3 * n), x_line(3 * n), back(3 * n);
  const LineScannerModel line;
  for (std::size_t k = 0; k < n; ++k) {
    t[k] = traj->startTime() + (traj->endTime() - traj->startTime()) * static_cast<double>(k) / (n - 1);
    theta[k] = 0.6 * std::sin(0.01 * static_cast<double>(k));
    rho[k] = 900 + static_cast<double>(k % 97);
    Eigen::Map<Vec3>{&r_s[3 * k]} = line.vector(theta[k], rho[k]);
  }
  std::swap(t[10], t[4000]);  // unsorted times are handled too
  std::swap(theta[10], theta[4000]);
  std::swap(rho[10], rho[4000]);
  for (std::size_t k : {std::size_t{10}, std::size_t{4000}}) Eigen::Map<Vec3>{&r_s[3 * k]} = line.vector(theta[k], rho[k]);
  model.forward(t.data(), r_s.data(), x_m.data(), n);
  model.forwardLineScan(line, t.data(), theta.data(), rho.data(), x_line.data(), n);
  model.inverse(t.data(), x_m.data(), back.data(), n);
  for (std::size_t k = 0; k < n; ++k) {
    const Vec3 single = model.forward(t[k], Eigen::Map<const Vec3>(&r_s[3 * k]));
    EXPECT_LT((Eigen::Map<const Vec3>(&x_m[3 * k]) - single).norm(), 1e-9);
    EXPECT_LT((Eigen::Map<const Vec3>(&x_line[3 * k]) - single).norm(), 1e-9);
    EXPECT_LT((Eigen::Map<const Vec3>(&back[3 * k]) - Eigen::Map<const Vec3>(&r_s[3 * k])).norm(), 1e-9);
  }
}

TEST(Georeference, TimesOutsideTheTrajectoryThrow) {
  const GeoreferenceModel model(levelTrajectory(Vec3::Zero(), 0.0), MountingParameters{});
  EXPECT_THROW(model.forward(1.5, Vec3(0, 0, 1)), TimeOutOfRange);
  const double t[2] = {0.5, -1.0};
  const double r[6] = {0, 0, 1, 0, 0, 1};
  double x[6];
  EXPECT_THROW(model.forward(t, r, x, 2), TimeOutOfRange);
  EXPECT_THROW(GeoreferenceModel(std::shared_ptr<const Trajectory>(), MountingParameters{}), InvalidInput);
}

// A committed fixture with every angle and the lever arm non-zero, derived outside mountcal:
// SPEC §2 eq. (1), x_m = p_m + R_mn R_nb (R_bore R_nom r_s + a_b), evaluated with
// R_mn = [[0,1,0],[1,0,0],[0,0,-1]], R_nb = Rz(135°) Ry(−1.5°) Rx(2.5°),
// R_bore = Rz(0.5°) Ry(−0.2°) Rx(0.3°), R_nom = I, a_b = (0.12, −0.35, 0.80) m,
// r_s = (12, −150, 790) m, p_m = (500, 1200, 800) m, by a separate 20-line Python script of
// plain 3×3 products (math.cos/sin only). mountcal must reproduce it and invert it.
TEST(Georeference, CommittedFixtureWithEveryAngleNonZero) {
  std::vector<TrajectorySample> s(2);
  for (int i = 0; i < 2; ++i) {
    s[static_cast<std::size_t>(i)].time_s = i;
    s[static_cast<std::size_t>(i)].p_m = Vec3(500.0, 1200.0, 800.0);
    s[static_cast<std::size_t>(i)].roll = deg2rad(2.5);
    s[static_cast<std::size_t>(i)].pitch = deg2rad(-1.5);
    s[static_cast<std::size_t>(i)].heading = deg2rad(135.0);
  }
  const GeoreferenceModel model(std::make_shared<const Trajectory>(s),
                                MountingParameters::fromDegrees(Vec3(0.12, -0.35, 0.80), Vec3(0.3, -0.2, 0.5)));
  const Vec3 expected(626.524880988322, 1340.354124179978, 17.433637571924);
  const Vec3 r_s(12.0, -150.0, 790.0);
  EXPECT_LT((model.forward(0.5, r_s) - expected).norm(), 1e-9);
  EXPECT_LT((model.inverse(0.5, expected) - r_s).norm(), 1e-9);
}

// Meridian convergence in a geodetic job: east of the project origin in the northern
// hemisphere, local north leans west (towards the origin's meridian) by Δλ·sin φ — here
// 1° · sin 45° = 0.7071° (Lambert; the exact angle on the ellipsoid differs in the 4th digit).
TEST(Georeference, MeridianConvergenceLeansNorthTowardsTheOrigin) {
  const LocalTangentFrame frame({deg2rad(45.0), 0.0, 0.0});
  const Vec3 north_east = frame.R_mn(deg2rad(45.0), deg2rad(1.0)) * Vec3::UnitX();  // NED north at 1° E
  const Vec3 north_west = frame.R_mn(deg2rad(45.0), deg2rad(-1.0)) * Vec3::UnitX();
  const double gamma_east = rad2deg(std::atan2(north_east.x(), north_east.y()));  // clockwise from grid north
  const double gamma_west = rad2deg(std::atan2(north_west.x(), north_west.y()));
  EXPECT_LT(gamma_east, 0.0);
  EXPECT_GT(gamma_west, 0.0);
  EXPECT_NEAR(gamma_east, -0.7071, 0.002);
  EXPECT_NEAR(gamma_west, 0.7071, 0.002);
}

// The batch paths expand the attitude once per trajectory interval (a 4th-order series of the
// slerp, issue 13): they must equal the pulse-by-pulse slerp within 1e-9 m at ranges up to
// 3 km — for ordinary dynamics (the series) and for intervals turning fast (the exact path).
TEST(Georeference, BatchIntervalExpansionEqualsExactSlerp) {
  std::vector<TrajectorySample> s;
  for (int i = 0; i <= 4000; ++i) {  // 20 s at 200 Hz; from 12 s on, a 60°/s turn
    const double t = i / 200.0;
    TrajectorySample x;
    x.time_s = 5000.0 + t;
    x.p_m = Vec3(70 * t, 3 * std::sin(0.4 * t), 900 + std::cos(0.3 * t));
    x.roll = deg2rad(3.0) * std::sin(2 * kPi * t / 5.0);
    x.pitch = deg2rad(2.0) * std::cos(2 * kPi * t / 7.0);
    x.heading = deg2rad(30.0) + (t > 12 ? deg2rad(60.0) * (t - 12) : 0.0);
    s.push_back(x);
  }
  for (PositionInterpolation interp : {PositionInterpolation::kLinear, PositionInterpolation::kCubic}) {
    const auto T = std::make_shared<const Trajectory>(s, interp);
    const GeoreferenceModel model(T, MountingParameters::fromDegrees(Vec3(0.3, -0.2, 0.5), Vec3(0.4, -0.3, 1.2)));
    const std::size_t n = 20000;
    std::vector<double> t(n), r(3 * n), x(3 * n), back(3 * n), theta(n), rho(n), xl(3 * n);
    const LineScannerModel line;
    for (std::size_t k = 0; k < n; ++k) {
      t[k] = 5000.0 + 19.99 * static_cast<double>(k) / n;
      theta[k] = deg2rad(35.0) * std::sin(0.37 * static_cast<double>(k));
      rho[k] = 300.0 + 2700.0 * (0.5 + 0.5 * std::cos(0.11 * static_cast<double>(k)));  // 300 m – 3 km
      Eigen::Map<Vec3>{&r[3 * k]} = line.vector(theta[k], rho[k]);
    }
    model.forward(t.data(), r.data(), x.data(), n);
    model.inverse(t.data(), x.data(), back.data(), n);
    model.forwardLineScan(line, t.data(), theta.data(), rho.data(), xl.data(), n);
    double worst_fwd = 0, worst_inv = 0, worst_line = 0;
    for (std::size_t k = 0; k < n; ++k) {
      const Vec3 rk(r[3 * k], r[3 * k + 1], r[3 * k + 2]);
      const Vec3 exact = model.forward(t[k], rk);  // pulse by pulse: the trajectory's own slerp
      worst_fwd = std::max(worst_fwd, (Vec3(x[3 * k], x[3 * k + 1], x[3 * k + 2]) - exact).norm());
      worst_line = std::max(worst_line, (Vec3(xl[3 * k], xl[3 * k + 1], xl[3 * k + 2]) - exact).norm());
      worst_inv = std::max(worst_inv, (Vec3(back[3 * k], back[3 * k + 1], back[3 * k + 2]) - model.inverse(t[k], exact)).norm());
    }
    EXPECT_LT(worst_fwd, 1e-9);
    EXPECT_LT(worst_line, 1e-9);
    EXPECT_LT(worst_inv, 1e-9);
  }
  // Both paths were taken: slow intervals turn < 0.004 rad, the 60°/s turn 0.0052 rad.
  const Trajectory T(s);
  Mat3 R;
  Vec3 w_slow, w_fast;
  T.intervalAttitude(100, &R, &w_slow);
  T.intervalAttitude(3000, &R, &w_fast);
  EXPECT_LT(w_slow.norm(), 0.004);
  EXPECT_GT(w_fast.norm(), 0.004);
}

// The batch line scan takes sin and cos of its scan angles from a vectorised series
// (src/sincos_batch.hpp); the reference is the C library's sin and cos.
TEST(Georeference, SinCosBatchAgreesWithTheCLibrary) {
  std::vector<double> theta;
  for (int k = -4000; k <= 4000; ++k) theta.push_back(k * 1.0e-3 * kPi);  // ±4π, every quadrant
  for (int q = -16; q <= 16; ++q) {                                       // the quadrant boundaries and either side of them
    for (double d : {0.0, 1e-17, -1e-17, 1e-9, -1e-9}) theta.push_back(q * kPi / 4 + d);
  }
  for (double x : {0.0, -0.0, 1e-300, 12345.678, -99999.9, 1e5, -1e5}) theta.push_back(x);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1e5, 1e5);
  for (int k = 0; k < 20000; ++k) theta.push_back(u(rng));
  std::vector<double> s(theta.size()), c(theta.size());
  mountcal::detail::sinCosBatch(theta.data(), s.data(), c.data(), theta.size());
  double worst = 0;
  for (std::size_t k = 0; k < theta.size(); ++k) {
    worst = std::max({worst, std::fabs(s[k] - std::sin(theta[k])), std::fabs(c[k] - std::cos(theta[k]))});
  }
  EXPECT_LE(worst, 4e-16);
  // Beyond ±1e5 rad, infinities and NaN: the C library's values (the whole batch takes them).
  const double big[] = {1.5e5, -3e12, 0.7, std::numeric_limits<double>::infinity(), std::numeric_limits<double>::quiet_NaN()};
  double sb[5], cb[5];
  mountcal::detail::sinCosBatch(big, sb, cb, 5);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(sb[k], std::sin(big[k]));
    EXPECT_EQ(cb[k], std::cos(big[k]));
  }
  EXPECT_TRUE(std::isnan(sb[3]) && std::isnan(cb[3]) && std::isnan(sb[4]) && std::isnan(cb[4]));
}

// The batch line scan forms the laser vectors itself: with a calibrated scanner (range offset,
// angle scale and offset) and a batch that is not a whole number of its blocks it equals the
// scanner's own vector() pulse by pulse.
TEST(Georeference, BatchLineScanAppliesTheScannerCalibration) {
  std::mt19937 rng(11);
  const auto T = randomTrajectory(rng, PositionInterpolation::kCubic);
  const GeoreferenceModel model(T, MountingParameters::fromDegrees(Vec3(0.1, 0.2, -0.3), Vec3(-0.2, 0.1, 0.4)));
  LineScannerModel line;
  line.range_offset_m = 0.043;
  line.scan_angle_scale = 1.0007;
  line.scan_angle_offset_rad = deg2rad(0.02);
  for (std::size_t n : {std::size_t{1}, std::size_t{511}, std::size_t{1537}}) {
    std::vector<double> t(n), theta(n), rho(n), x(3 * n);
    for (std::size_t k = 0; k < n; ++k) {
      t[k] = T->startTime() + 9.0 * static_cast<double>(k) / static_cast<double>(n);
      theta[k] = deg2rad(75.0) * std::sin(0.013 * static_cast<double>(k) + 0.3);
      rho[k] = 50.0 + 0.7 * static_cast<double>(k % 997);
    }
    model.forwardLineScan(line, t.data(), theta.data(), rho.data(), x.data(), n);
    double worst = 0;
    for (std::size_t k = 0; k < n; ++k) {
      const Vec3 exact = model.forward(t[k], line.vector(theta[k], rho[k]));
      worst = std::max(worst, (Vec3(x[3 * k], x[3 * k + 1], x[3 * k + 2]) - exact).norm());
    }
    EXPECT_LT(worst, 1e-9) << n << " pulses";
  }
}
