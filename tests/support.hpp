#pragma once
// What several test files need, in one place: reading and writing whole files, running a command
// and keeping its exit code and output, the survey-grade noise and the simulated crossing field
// (simulated once per seed, noise and region size, for every test of the program).
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>

#include "mountcal/core/rotation.hpp"
#include "mountcal/methods/correspondence/correspondences.hpp"
#include "mountcal/mounting_calibrator.hpp"
#include "mountcal/simulation/survey.hpp"

namespace mountcal_tests {

inline constexpr double kDeg = mountcal::kPi / 180.0;

/// The simulator's per-laser error (LaserSpec) of each group in mountcal::kLaserGroups' order:
/// elevation, azimuth, range, vertical, horizontal — the truth of LaserCorrection's fields.
inline constexpr double mountcal::LaserSpec::*kLaserErrorFields[5] = {
    &mountcal::LaserSpec::elevation_rad, &mountcal::LaserSpec::azimuth_offset_rad, &mountcal::LaserSpec::range_offset_m,
    &mountcal::LaserSpec::vertical_offset_m, &mountcal::LaserSpec::horizontal_offset_m};

/// The whole file (empty when it cannot be read).
inline std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

inline void spit(const std::filesystem::path& path, const std::string& bytes) { std::ofstream(path, std::ios::binary) << bytes; }

/// A path in the temporary folder, unique to this process: "mountcal_<prefix>_<pid>_<name>".
inline std::string tempPath(const std::string& prefix, const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("mountcal_" + prefix + "_" + std::to_string(::getpid()) + "_" + name)).string();
}

/// A command's exit code (-1 when it did not exit) and what it printed.
struct CommandRun {
  int code = -1;
  std::string out, err;
};

/// Runs `program args` through the shell, keeping standard output and error apart.
inline CommandRun runCommand(const std::string& program, const std::string& args) {
  static std::atomic<int> counter{0};
  const std::string base =
      (std::filesystem::temp_directory_path() / ("mountcal_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++))).string();
  const int status = std::system((program + " " + args + " > " + base + ".out 2> " + base + ".err").c_str());
  CommandRun r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = slurp(base + ".out");
  r.err = slurp(base + ".err");
  std::filesystem::remove(base + ".out");
  std::filesystem::remove(base + ".err");
  return r;
}

/// The built command (`build/mountcal`).
inline CommandRun runCli(const std::string& args) { return runCommand(MOUNTCAL_CLI, args); }

/// The stated "realistic" noise of the calibration tests (survey-grade, post-processed): 2 cm
/// range, 0.001° scan-angle encoder, 5 mm strip-to-strip GNSS (Gauss–Markov, 100 s), 0.001° roll
/// and pitch and 0.002° heading noise (Gauss–Markov, 0.1 s), 3 cm tie picking.
inline mountcal::simulation::NoiseModel surveyGrade() {
  mountcal::simulation::NoiseModel n = mountcal::simulation::NoiseModel::realistic();
  n.gnss_sigma_m = 0.005;
  n.pick_sigma_m = 0.03;
  return n;
}

/// A preset survey (by default the paper's crossing field, seed 000 experiment 1: four strips at
/// 760 m and 1310 m, flat and gable roofs of four aspects, ground targets), with survey-grade noise
/// or none, points kept within `roi_radius_m` of the features. Simulated once per key.
inline const mountcal::simulation::SimulatedSurvey& crossingField(std::uint64_t seed, bool noise, double roi_radius_m,
                                                                  const std::string& preset = "paper-calibration-field") {
  using namespace mountcal::simulation;
  static std::map<std::string, std::unique_ptr<SimulatedSurvey>> cache;
  const std::string key = preset + "/" + std::to_string(seed) + (noise ? "n/" : "q/") + std::to_string(roi_radius_m);
  auto& slot = cache[key];
  if (!slot) {
    Scene scene;
    SurveyConfig c;
    makePreset(preset, seed, &c, &scene);
    c.noise = noise ? surveyGrade() : NoiseModel::none();
    c.roi_radius_m = roi_radius_m;
    slot = std::make_unique<SimulatedSurvey>(simulate(c, scene));
  }
  return *slot;
}

/// The VLP-16 preset's field flown by three of its passes (the centre line both ways at 50 m and
/// once at 80 m), 4 m around each target, with the true lever arm as the nominal one.
inline void uavThreePasses(std::uint64_t seed, mountcal::simulation::SurveyConfig* c, mountcal::simulation::Scene* scene) {
  mountcal::simulation::makePreset("uav-vlp16", seed, c, scene);
  c->nominal_mounting.a_b = c->true_mounting.a_b;
  c->roi_radius_m = 4.0;
  std::vector<mountcal::simulation::FlightLine> lines;
  for (const mountcal::simulation::FlightLine& l : c->lines)
    if (l.id == "1" || l.id == "2" || l.id == "4") lines.push_back(l);
  c->lines = lines;
}

/// The dense correspondences of the simulated UAV surveys (VLP-16 preset's field, three passes):
/// boresight only, no strip offsets and no trajectory errors in time (none are simulated), 0.3 m
/// neighbourhoods after a 1 m coarse stage, 1000 samples per pair; per-laser intrinsics off.
inline mountcal::MountingCalibrator::Options uavDenseOptions() {
  mountcal::MountingCalibrator::Options o;
  o.methods = {"correspondences"};
  o.estimate = {false, false, false, true, true, true};
  o.strip_offset_sigma_m = 0;
  o.trajectory = mountcal::TrajectoryAccuracy::none();
  mountcal::CorrespondenceOptions& c = o.method<mountcal::CorrespondenceOptions>();
  c.dense = true;
  c.radius_m = 0.3;
  c.coarse_radius_m = 1.0;
  c.max_neighbours = 10;
  c.budget = 1000;
  return o;
}

}  // namespace mountcal_tests
