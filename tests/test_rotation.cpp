#include <gtest/gtest.h>

#include <random>

#include "mountcal/core/mounting.hpp"
#include "mountcal/core/rotation.hpp"

using namespace mountcal;

namespace {
void expectMatNear(const Mat3& a, const Mat3& b, double tol) {
  EXPECT_LT((a - b).cwiseAbs().maxCoeff(), tol) << "\n" << a << "\nvs\n" << b;
}
}  // namespace

TEST(Rotation, NinetyDegreeRotationsAreTheKnownMatrices) {
  Mat3 Rx90, Ry90, Rz90;
  Rx90 << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  Ry90 << 0, 0, 1, 0, 1, 0, -1, 0, 0;
  Rz90 << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  expectMatNear(Rx(kPi / 2), Rx90, 1e-15);
  expectMatNear(Ry(kPi / 2), Ry90, 1e-15);
  expectMatNear(Rz(kPi / 2), Rz90, 1e-15);
  // Active rotations: Rz(90°) turns +x into +y.
  EXPECT_NEAR((Rz(kPi / 2) * Vec3::UnitX() - Vec3::UnitY()).norm(), 0.0, 1e-15);
}

TEST(Rotation, LocalMappingFrameSwapsNorthEastAndFlipsDown) {
  // NED (1,0,0) = North → ENU (0,1,0); East → (1,0,0); Down → (0,0,-1).
  EXPECT_EQ(R_mn_local() * Vec3(1, 0, 0), Vec3(0, 1, 0));
  EXPECT_EQ(R_mn_local() * Vec3(0, 1, 0), Vec3(1, 0, 0));
  EXPECT_EQ(R_mn_local() * Vec3(0, 0, 1), Vec3(0, 0, -1));
  EXPECT_NEAR(R_mn_local().determinant(), 1.0, 1e-15);
}

TEST(Rotation, HeadingNinetyMapsBodyForwardToEast) {
  const Mat3 R_mb = R_mn_local() * R_nb(0.0, 0.0, deg2rad(90.0));
  EXPECT_NEAR((R_mb * Vec3::UnitX() - Vec3(1, 0, 0)).norm(), 0.0, 1e-15);   // forward → East
  EXPECT_NEAR((R_mb * Vec3::UnitY() - Vec3(0, -1, 0)).norm(), 0.0, 1e-15);  // right → South
}

TEST(Rotation, PositiveRollLowersTheRightWingAndPositivePitchRaisesTheNose) {
  // roll > 0: right wing down → body +y gains a +Down (n) component.
  EXPECT_GT((R_nb(deg2rad(10), 0, 0) * Vec3::UnitY()).z(), 0.0);
  // pitch > 0: nose up → body +x gains a −Down component.
  EXPECT_LT((R_nb(0, deg2rad(10), 0) * Vec3::UnitX()).z(), 0.0);
}

TEST(Rotation, RollPitchHeadingInvertsRnb) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.4, 1.4), h(-3.1, 3.1);
  for (int k = 0; k < 200; ++k) {
    const Vec3 rph(u(rng), u(rng), h(rng));
    const Vec3 back = rollPitchHeading(R_nb(rph.x(), rph.y(), rph.z()));
    EXPECT_LT((back - rph).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST(Rotation, QuaternionLogExpRoundTripAndSlerpMidpoint) {
  std::mt19937 rng(11);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int k = 0; k < 100; ++k) {
    const Vec3 v = Vec3(n(rng), n(rng), n(rng)).normalized() * (3.0 * (k + 1) / 101.0);
    EXPECT_LT((quatLog(quatExp(v)) - v).norm(), 1e-12);
  }
  EXPECT_LT((quatLog(quatExp(Vec3(1e-14, 0, 0))) - Vec3(1e-14, 0, 0)).norm(), 1e-20);
  const Quat q0(Rz(0.0)), q1(Rz(deg2rad(10.0)));
  expectMatNear(slerp(q0, q1, 0.5).toRotationMatrix(), Rz(deg2rad(5.0)), 1e-14);
  expectMatNear(slerp(q0, q1, 0.0).toRotationMatrix(), Rz(0.0), 1e-14);
  expectMatNear(slerp(q0, q1, 1.0).toRotationMatrix(), Rz(deg2rad(10.0)), 1e-14);
}

TEST(Mounting, BoresightIsZYXAndDegreeConversionIsAtTheEdgeOnly) {
  const auto m = MountingParameters::fromDegrees(Vec3(0.1, -0.05, 0.2), Vec3(0.05, -0.08, 0.12), Vec3(0, 0, 90));
  EXPECT_NEAR(m.boresight.x(), deg2rad(0.05), 1e-18);
  expectMatNear(m.R_bore(), Rz(deg2rad(0.12)) * Ry(deg2rad(-0.08)) * Rx(deg2rad(0.05)), 1e-15);
  expectMatNear(m.R_bs(), m.R_bore() * Rz(kPi / 2), 1e-15);
  const auto a = m.toArray();
  EXPECT_EQ(a[kLeverZ], 0.2);
  EXPECT_EQ(a[kBoresightHeading], m.boresight.z());
  const MountingParameters back = MountingParameters{}.withArray(a.data());
  EXPECT_EQ(back.a_b, m.a_b);
  EXPECT_EQ(back.boresight, m.boresight);
  EXPECT_EQ(mountingParameterNames()[kBoresightPitch], "boresight_pitch");
}
