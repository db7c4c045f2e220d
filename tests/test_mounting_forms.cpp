// The mounting in other programs' forms (mounting_forms.hpp), checked against hand-derived
// values and against the definition of a change of body axes.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "mountcal/mountcal.hpp"

using namespace mountcal;

TEST(MountingForms, ForwardLeftUpAnglesOfTheIssuesExampleByHand) {
  // A new user needed an hour for this: mountcal's (+1.362, +1.087, −2.252)° in a
  // forward-left-up program is (+1.362, −1.087, +2.252)° (a half turn about x: roll kept,
  // pitch and heading reversed); the lever arm's y and z change sign.
  const MountingParameters m = MountingParameters::fromDegrees(Vec3(0.10, 0.20, 0.30), Vec3(1.362, 1.087, -2.252));
  const MountingForm frd = mountingForm(m, BodyAxes::kForwardRightDown), flu = mountingForm(m, BodyAxes::kForwardLeftUp);
  const Vec3 frd_deg = frd.boresight_rad * 180.0 / kPi, flu_deg = flu.boresight_rad * 180.0 / kPi;
  EXPECT_NEAR(frd_deg.x(), 1.362, 1e-12);
  EXPECT_NEAR(frd_deg.y(), 1.087, 1e-12);
  EXPECT_NEAR(frd_deg.z(), -2.252, 1e-12);
  EXPECT_NEAR(flu_deg.x(), 1.362, 1e-12);
  EXPECT_NEAR(flu_deg.y(), -1.087, 1e-12);
  EXPECT_NEAR(flu_deg.z(), 2.252, 1e-12);
  EXPECT_NEAR((flu.lever_arm_m - Vec3(0.10, -0.20, -0.30)).norm(), 0.0, 1e-15);
  // A quarter turn in heading by hand: q = (cos 45°, 0, 0, sin 45°), in FLU (cos 45°, 0, 0, −sin 45°).
  const MountingParameters quarter = MountingParameters::fromDegrees(Vec3::Zero(), Vec3(0, 0, 90));
  const MountingForm qf = mountingForm(quarter, BodyAxes::kForwardRightDown), ql = mountingForm(quarter, BodyAxes::kForwardLeftUp);
  const double h = std::sqrt(0.5);
  EXPECT_NEAR((qf.q_bore.coeffs() - Eigen::Vector4d(0, 0, h, h)).norm(), 0.0, 1e-15);  // coeffs(): x, y, z, w
  EXPECT_NEAR((ql.q_bore.coeffs() - Eigen::Vector4d(0, 0, -h, h)).norm(), 0.0, 1e-15);
}

TEST(MountingForms, EveryFormDescribesTheSameRotationOfTheSameVectors) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> angle(-3.0, 3.0), len(-2.0, 2.0);
  const Mat3 T = Vec3(1, -1, -1).asDiagonal();  // FRD axes → FLU axes
  for (int trial = 0; trial < 200; ++trial) {
    // Small boresights as well as large installation angles (pitch within ±90°).
    const double k = trial < 100 ? 0.01 : 1.0;
    MountingParameters m = MountingParameters::fromDegrees(Vec3(len(rng), len(rng), len(rng)),
                                                           Vec3(k * angle(rng) * 30, k * angle(rng) * 25, k * angle(rng) * 60),
                                                           Vec3(0, trial % 2 ? 90.0 : 0.0, 0));
    for (BodyAxes axes : {BodyAxes::kForwardRightDown, BodyAxes::kForwardLeftUp}) {
      const MountingForm f = mountingForm(m, axes);
      const Mat3 to = axes == BodyAxes::kForwardRightDown ? Mat3::Identity() : T;
      // The angles recompose the matrix (Rz·Ry·Rx), the quaternions are the matrices.
      EXPECT_LT((R_zyx(f.boresight_rad) - f.R_bore).norm(), 1e-12);
      EXPECT_LT((f.q_bore.toRotationMatrix() - f.R_bore).norm(), 1e-12);
      EXPECT_LT((f.q_bs.toRotationMatrix() - f.R_bs).norm(), 1e-12);
      EXPECT_GE(f.q_bore.w(), 0.0);
      // A scanner vector lands on the same physical body vector, written in these axes.
      const Vec3 r_s(len(rng), len(rng), len(rng));
      EXPECT_LT((f.R_bs * r_s + f.lever_arm_m - to * (m.R_bs() * r_s + m.a_b)).norm(), 1e-12);
      // The boresight acts on body vectors written in these axes.
      const Vec3 v(len(rng), len(rng), len(rng));
      EXPECT_LT((f.R_bore * (to * v) - to * (m.R_bore() * v)).norm(), 1e-12);
    }
  }
}

TEST(MountingForms, TextAndJsonNameTheConventions) {
  const MountingParameters m = MountingParameters::fromDegrees(Vec3(0.1, 0.2, 0.3), Vec3(1.362, 1.087, -2.252));
  LaserCorrections lasers(2);
  lasers[0].elevation_rad = deg2rad(0.1);
  lasers[1].elevation_rad = deg2rad(-0.2);
  lasers[1].range_m = 0.0125;
  const std::string text = mountingFormsText(m, lasers);
  EXPECT_NE(text.find("Rz(heading) * Ry(pitch) * Rx(roll)"), std::string::npos);
  EXPECT_NE(text.find("forward-left-up"), std::string::npos);
  EXPECT_NE(text.find("+1.362000 -1.087000 +2.252000 deg"), std::string::npos) << text;
  EXPECT_NE(text.find("      1         -0.20000       +0.00000    +0.0125"), std::string::npos) << text;
  const std::string json = mountingFormsJson(m);
  EXPECT_NE(json.find("\"forward-left-up\""), std::string::npos);
  EXPECT_NE(json.find("\"q_bore\""), std::string::npos);
}

TEST(MountingForms, CommandWritesAResultsMountingInEveryForm) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("mountcal_forms_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string result = (dir / "result.json").string(), out = (dir / "forms.json").string(), err = (dir / "err.txt").string();
  std::ofstream(result) << R"({"mounting": {"lever_arm_m": [0.1, 0.2, 0.3], "boresight_deg": [1.362, 1.087, -2.252]},
                              "intrinsics": {"laser_elevation_offset_deg": [0.1, -0.2]}})";
  ASSERT_EQ(std::system((std::string(MOUNTCAL_CLI) + " mounting --json " + result + " > " + out).c_str()), 0);
  std::ifstream in(out);
  const nlohmann::json j = nlohmann::json::parse(in);
  const auto& flu = j["forward-left-up"];
  EXPECT_NEAR(flu["boresight_deg"][1].get<double>(), -1.087, 1e-12);
  EXPECT_NEAR(flu["boresight_deg"][2].get<double>(), 2.252, 1e-12);
  EXPECT_NEAR(flu["lever_arm_m"][2].get<double>(), -0.3, 1e-15);
  EXPECT_NEAR(j["laser_elevation_offset_deg"][1].get<double>(), -0.2, 1e-12);
  // A result without a mounting is bad input: exit 2, one line naming the file.
  std::ofstream(result) << R"({"sigma": {}})";
  const int status = std::system((std::string(MOUNTCAL_CLI) + " mounting " + result + " > /dev/null 2> " + err).c_str());
  EXPECT_EQ(WEXITSTATUS(status), 2);
  std::ifstream e(err);
  std::string line;
  std::getline(e, line);
  EXPECT_NE(line.find(result), std::string::npos) << line;
  fs::remove_all(dir);
}
