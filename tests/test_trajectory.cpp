#include <gtest/gtest.h>

#include <random>

#include "mountcal/core/error.hpp"
#include "mountcal/core/trajectory.hpp"

using namespace mountcal;

namespace {
std::vector<TrajectorySample> line(int n, double dt) {
  std::vector<TrajectorySample> s(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    s[i].time_s = 1000.0 + i * dt;
    s[i].p_m = Vec3(10.0 * i * dt, 0.0, 500.0);
    s[i].heading = deg2rad(90.0);
  }
  return s;
}
}  // namespace

TEST(Trajectory, RejectsBadSamplesWithTheSampleNamed) {
  EXPECT_THROW(Trajectory(line(1, 0.1)), InvalidInput);
  auto dup = line(5, 0.1);
  dup[3].time_s = dup[2].time_s;
  try {
    Trajectory t(dup);
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("sample 3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("duplicate"), std::string::npos) << e.what();
  }
  auto unsorted = line(5, 0.1);
  std::swap(unsorted[1].time_s, unsorted[2].time_s);
  EXPECT_THROW(Trajectory{unsorted}, InvalidInput);
  auto nan = line(5, 0.1);
  nan[4].roll = std::nan("");
  EXPECT_THROW(Trajectory{nan}, InvalidInput);
  auto inf = line(5, 0.1);
  inf[0].p_m.x() = HUGE_VAL;
  EXPECT_THROW(Trajectory{inf}, InvalidInput);
}

TEST(Trajectory, NeverExtrapolates) {
  const Trajectory t(line(5, 0.1));
  EXPECT_NO_THROW(t.pose(1000.0));
  EXPECT_NO_THROW(t.pose(1000.4));
  EXPECT_THROW(t.pose(999.9999), TimeOutOfRange);
  EXPECT_THROW(t.pose(1000.4001), TimeOutOfRange);
  EXPECT_THROW(t.pose(std::nan("")), TimeOutOfRange);
}

TEST(Trajectory, LinearPositionAndSlerpAttitude) {
  std::vector<TrajectorySample> s(2);
  s[0].time_s = 0;
  s[1].time_s = 2;
  s[1].p_m = Vec3(2, 4, 6);
  s[1].heading = deg2rad(20);
  s[1].roll = deg2rad(4);
  const Trajectory t(s);
  const Pose p = t.pose(0.5);
  EXPECT_LT((p.p_m - Vec3(0.5, 1, 1.5)).norm(), 1e-15);
  // Slerp between identity and R1 at a quarter of the way is the quarter rotation.
  const Mat3 R1 = R_nb(s[1].roll, s[1].pitch, s[1].heading);
  const Eigen::AngleAxisd aa(R1);
  const Mat3 expected = R_mn_local() * Eigen::AngleAxisd(0.25 * aa.angle(), aa.axis()).toRotationMatrix();
  EXPECT_LT((p.R_mb - expected).cwiseAbs().maxCoeff(), 1e-14);
}

TEST(Trajectory, CubicIsExactForQuadraticMotionInsideAndLinearAtTheEnds) {
  std::vector<TrajectorySample> s(8);
  const double times[8] = {0.0, 0.1, 0.25, 0.3, 0.5, 0.55, 0.8, 1.0};  // uneven spacing
  auto p = [](double t) { return Vec3(3 * t * t + 2 * t, -t * t, 100 + 0.5 * t); };
  for (int i = 0; i < 8; ++i) {
    s[i].time_s = times[i];
    s[i].p_m = p(times[i]);
  }
  const Trajectory cubic(s, PositionInterpolation::kCubic);
  // Interior intervals have exact velocities at both ends → the Hermite cubic is exact.
  for (double t = 0.1; t <= 0.8; t += 0.01) {
    EXPECT_LT((cubic.pose(t).p_m - p(t)).norm(), 1e-12) << t;
  }
  // Linear interpolation is not exact for the same motion: the test can tell them apart.
  const Trajectory linear(s, PositionInterpolation::kLinear);
  EXPECT_GT((linear.pose(0.4).p_m - p(0.4)).norm(), 1e-3);
}

TEST(Trajectory, CursorGivesTheSameAnswerForSortedAndUnsortedQueries) {
  const Trajectory t(line(200, 0.005), PositionInterpolation::kCubic);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(t.startTime(), t.endTime());
  std::size_t cursor = 0;
  for (int k = 0; k < 2000; ++k) {
    const double time = (k < 1000) ? t.startTime() + k * (t.endTime() - t.startTime()) / 999.0 : u(rng);
    const Pose a = t.pose(time, &cursor);
    const Pose b = t.pose(time);
    EXPECT_LT((a.p_m - b.p_m).norm(), 1e-12);
    EXPECT_LT((a.R_mb - b.R_mb).norm(), 1e-14);
  }
}

TEST(Trajectory, HeadingWrapTakesTheShortArc) {
  std::vector<TrajectorySample> s(2);
  s[0].time_s = 0;
  s[1].time_s = 1;
  s[0].heading = deg2rad(179);
  s[1].heading = deg2rad(-179);
  const Trajectory t(s);
  const Vec3 rph = rollPitchHeading(R_mn_local().transpose() * t.pose(0.5).R_mb);
  EXPECT_NEAR(std::abs(rad2deg(rph.z())), 180.0, 1e-9);
}
