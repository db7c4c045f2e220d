#include <gtest/gtest.h>

#include <random>

#include "mountcal/core/error.hpp"
#include "mountcal/core/sensor_model.hpp"
#include "mountcal/job/load.hpp"

using namespace mountcal;

TEST(LineScanner, HandValues) {
  const LineScannerModel m;
  EXPECT_LT((m.vector(0.0, 800.0) - Vec3(0, 0, 800)).norm(), 1e-12);  // nadir: straight down
  // θ = +30° points to starboard (+y body) and down.
  EXPECT_LT((m.vector(deg2rad(30), 1000.0) - Vec3(0, 500, 1000 * std::sqrt(3) / 2)).norm(), 1e-9);
  EXPECT_LT((m.vector(deg2rad(-30), 1000.0) - Vec3(0, -500, 1000 * std::sqrt(3) / 2)).norm(), 1e-9);
  LineScannerModel biased;
  biased.range_offset_m = 0.5;
  biased.scan_angle_scale = 1.001;
  biased.scan_angle_offset_rad = deg2rad(0.01);
  const Vec3 v = biased.vector(deg2rad(20), 700.0);
  const double th = 1.001 * deg2rad(20) + deg2rad(0.01);
  EXPECT_LT((v - 700.5 * Vec3(0, std::sin(th), std::cos(th))).norm(), 1e-9);
  double theta = 0, rho = 0;
  biased.inverse(v, &theta, &rho);
  EXPECT_NEAR(theta, deg2rad(20), 1e-14);
  EXPECT_NEAR(rho, 700.0, 1e-10);
}

TEST(MultiBeam, VLP16HandValues) {
  const MultiBeamModel vlp = MultiBeamModel::VLP16();
  ASSERT_EQ(vlp.laserCount(), 16);
  // Laser 0: −15°, +11.2 mm; azimuth 0 looks along +y.
  const double rho = 10.0;
  EXPECT_LT((vlp.vector(0, 0.0, rho) - Vec3(0, rho * std::cos(deg2rad(15)), -rho * std::sin(deg2rad(15)) + 0.0112)).norm(), 1e-12);
  // Laser 1: +1°, −0.7 mm; azimuth 90° (clockwise from +y) looks along +x.
  EXPECT_LT((vlp.vector(1, deg2rad(90), rho) - Vec3(rho * std::cos(deg2rad(1)), 0, rho * std::sin(deg2rad(1)) - 0.0007)).norm(), 1e-12);
  // Laser 15: +15°, −11.2 mm; azimuth 180° looks along −y.
  EXPECT_LT((vlp.vector(15, kPi, rho) - Vec3(0, -rho * std::cos(deg2rad(15)), rho * std::sin(deg2rad(15)) - 0.0112)).norm(), 1e-12);
  EXPECT_NEAR(rad2deg(vlp.laser(14).elevation_rad), -1.0, 1e-12);
  EXPECT_NEAR(vlp.firingTime(15, 2), 2 * 55.296e-6 + 15 * 2.304e-6, 1e-15);
  EXPECT_THROW(vlp.laser(16), InvalidInput);
  EXPECT_THROW(vlp.vector(-1, 0, 1), InvalidInput);
}

TEST(MultiBeam, HDL32EHandValues) {
  const MultiBeamModel hdl = MultiBeamModel::HDL32E();
  ASSERT_EQ(hdl.laserCount(), 32);
  EXPECT_NEAR(rad2deg(hdl.laser(0).elevation_rad), -30.67, 1e-12);
  EXPECT_NEAR(rad2deg(hdl.laser(31).elevation_rad), 10.67, 1e-12);
  EXPECT_NEAR(rad2deg(hdl.laser(15).elevation_rad), 0.0, 1e-12);
  // The 32 elevations are −30.67 … +10.67 in 1.333° steps (the manual rounds each to 0.01°,
  // so a step is 1.33 or 1.34).
  std::vector<double> el;
  for (const auto& l : hdl.lasers()) el.push_back(rad2deg(l.elevation_rad));
  std::sort(el.begin(), el.end());
  for (std::size_t i = 1; i < el.size(); ++i) EXPECT_NEAR(el[i] - el[i - 1], 1.3335, 0.0066);
  const double rho = 20.0, c = std::cos(deg2rad(30.67)), s = std::sin(deg2rad(30.67));
  EXPECT_LT((hdl.vector(0, deg2rad(270), rho) - Vec3(-rho * c, 0, -rho * s)).norm(), 1e-12);
  EXPECT_NEAR(hdl.firingTime(31, 1), 46.08e-6 + 31 * 1.152e-6, 1e-15);
}

TEST(MultiBeam, CustomTablesAreValidated) {
  EXPECT_THROW(MultiBeamModel("empty", {}, 1e-5), InvalidInput);
  LaserSpec bad;
  bad.elevation_rad = std::nan("");
  EXPECT_THROW(MultiBeamModel("bad", {bad}, 1e-5), InvalidInput);
  LaserSpec l;
  l.elevation_rad = deg2rad(-2);
  l.azimuth_offset_rad = deg2rad(1.5);
  l.range_offset_m = 0.03;
  const MultiBeamModel m("one", {l}, 1e-5);
  const Vec3 v = m.vector(0, deg2rad(10), 5.0);
  EXPECT_NEAR(v.norm(), 5.03, 1e-12);
  EXPECT_NEAR(std::atan2(v.x(), v.y()), deg2rad(11.5), 1e-12);
}

TEST(SensorModel, RawToVectorRoundTripsForEveryKind) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> az(0.0, 2 * kPi - 1e-9), th(-1.2, 1.2), r(1.0, 3000.0);
  const SensorModel sensors[] = {SensorModel::lineScanner(), SensorModel::multiBeam(MultiBeamModel::VLP16()),
                                 SensorModel::multiBeam(MultiBeamModel::HDL32E()), SensorModel::vectorSensor()};
  for (const SensorModel& sensor : sensors) {
    for (int k = 0; k < 500; ++k) {
      RawPulse p;
      p.range_m = r(rng);
      p.laser_id = sensor.type == SensorType::kMultiBeam ? k % sensor.multibeam.laserCount() : 0;
      p.angle_rad = sensor.type == SensorType::kMultiBeam ? az(rng) : th(rng);
      p.r_s = Vec3(r(rng), -r(rng), r(rng));
      const Vec3 v = sensor.vector(p);
      RawPulse back;
      back.laser_id = p.laser_id;
      sensor.inverse(v, &back);
      EXPECT_LT((sensor.vector(back) - v).norm(), 1e-9);
      if (sensor.type != SensorType::kVector) {
        EXPECT_NEAR(back.range_m, p.range_m, 1e-9);
        EXPECT_NEAR(back.angle_rad, p.angle_rad, 1e-12);
      }
    }
  }
}

// checkLaserTable (issue 28 item 5) by hand: each VLP-16 laser's vectors over a full turn of
// azimuth, made by the model (vertical offsets included), deviate by 0 from the table; tilted by
// δ = 1° about x the elevation of a vector at azimuth α changes by about δ cos α, so over a full
// turn the median stays within δ; turned 180° about y (upside down), laser i reads −ω_i: the
// worst deviation is 2 × 15° = 30° (lasers 0 and 15).
TEST(MultiBeam, LaserTableCheckByHand) {
  const MultiBeamModel m = MultiBeamModel::VLP16();
  auto data = [&](const Mat3& R) {
    CalibrationData d;
    StripData s;
    for (int id = 0; id < m.laserCount(); ++id)
      for (int k = 0; k < 360; ++k) {
        s.r_s.push_back(R * m.vector(id, k * M_PI / 180, 20.0));
        s.laser.push_back(static_cast<std::uint16_t>(id));
      }
    d.strips.push_back(s);
    return d;
  };
  const LaserTableCheck level = checkLaserTable(data(Mat3::Identity()), m);
  ASSERT_EQ(level.lasers.size(), 16u);
  EXPECT_LT(level.worst_abs_deviation_deg, 1e-9);
  const LaserTableCheck tilted = checkLaserTable(data(Eigen::AngleAxisd(M_PI / 180, Vec3::UnitX()).toRotationMatrix()), m);
  EXPECT_LT(tilted.worst_abs_deviation_deg, 1.0);
  const LaserTableCheck upside_down = checkLaserTable(data(Eigen::AngleAxisd(M_PI, Vec3::UnitY()).toRotationMatrix()), m);
  EXPECT_NEAR(upside_down.worst_abs_deviation_deg, 30.0, 0.1);
  EXPECT_EQ(upside_down.beyond(5.0), 14);  // all but the ±1° lasers (2 × 1° = 2°)
}
