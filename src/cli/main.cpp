// mountcal — the command-line tool. Exit codes (SPEC §4): 0 success; 1 the solve ran but is
// not usable; 2 bad input, with one line on stderr naming the file and where it went wrong.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <string>

#include "mountcal/error.hpp"
#include "mountcal/io/atomic_file.hpp"
#include "mountcal/job.hpp"
#include "mountcal/report.hpp"
#include "mountcal/simulation/survey.hpp"
#include "mountcal/version.hpp"

namespace {

int runSimulate(const std::string& scenario, const std::string& preset, std::uint64_t seed,
                const std::string& out, bool no_noise) {
  using namespace mountcal::simulation;
  SurveyConfig config;
  Scene scene;
  if (!scenario.empty()) {
    loadScenario(scenario, &config, &scene);
  } else {
    makePreset(preset, seed, &config, &scene);
  }
  if (no_noise) config.noise = NoiseModel::none();
  const auto t0 = std::chrono::steady_clock::now();
  const SimulatedSurvey survey = simulate(config, scene);
  writeSurvey(survey, out);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::size_t points = 0;
  for (const auto& s : survey.strips) points += s.points_m.size();
  std::printf("%s: %zu strips, %zu points, %zu tie observations, %zu check-point observations in %.1f s\n",
              config.name.c_str(), survey.strips.size(), points, survey.ties.size(),
              survey.check_points.size(), secs);
  std::printf("wrote %s/job.json and truth.json; run: mountcal calibrate %s/job.json\n", out.c_str(), out.c_str());
  return 0;
}

int runCalibrate(const std::string& job_path, bool quiet) {
  using namespace mountcal;
  const Job job = readJob(job_path);
  const CalibrationData data = loadJobData(job);
  const MountingCalibrator::Summary S = MountingCalibrator(job.options).calibrate(data);
  ResultEvaluation ev;
  bool any_eval = false;
  const std::vector<TieObservation> checks = loadCheckPoints(job);
  const std::vector<PlaneRegion> planes = loadCheckPlanes(job);
  if (!checks.empty() || !planes.empty()) {
    any_eval = true;
    CalibrationData check = data;
    check.ties = checks;
    if (!checks.empty()) {
      ev.has_check_points = true;
      ev.check_points_before = evaluateCheckPoints(check, data.mounting_used, job.options.vtp);
      ev.check_points_after = evaluateCheckPoints(check, S.mounting, job.options.vtp);
    }
    if (!planes.empty()) {
      ev.check_planes_before = evaluateCheckPlanes(check, planes, data.mounting_used);
      ev.check_planes_after = evaluateCheckPlanes(check, planes, S.mounting);
    }
  }
  if (!job.result_path.empty()) io::writeFileAtomically(job.result_path, resultJson(S, any_eval ? &ev : nullptr));
  if (!job.report_path.empty()) {
    io::writeFileAtomically(job.report_path, htmlReport(S, any_eval ? &ev : nullptr, "mountcal calibration — " + job_path));
  }
  if (!quiet) std::printf("%s", S.FullReport().c_str());
  if (!job.result_path.empty() && !quiet) std::printf("wrote %s\n", job.result_path.c_str());
  if (!S.IsSolutionUsable()) {
    std::fprintf(stderr, "mountcal calibrate: the solve is not usable: %s (%s)\n", toString(S.termination), S.message.c_str());
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mountcal " MOUNTCAL_VERSION_STRING
               " — LiDAR mounting (lever arm and boresight) calibration from overlapping strips"};
  app.require_subcommand(1);

  std::string scenario, preset, out;
  std::uint64_t seed = 1;
  bool no_noise = false;
  CLI::App* sim = app.add_subcommand("simulate", "Simulate a survey with known mounting truth (SPEC §4)");
  sim->add_option("scenario", scenario, "Scenario JSON file (a preset with overrides)");
  sim->add_option("--preset", preset, "Preset: paper-calibration-field, paper-check-block, uav-vlp16");
  sim->add_option("--seed", seed, "Random seed for the noise")->capture_default_str();
  sim->add_option("--out", out, "Output folder")->required();
  sim->add_flag("--no-noise", no_noise, "Switch every noise source off");

  std::string job_path;
  bool quiet = false;
  CLI::App* cal = app.add_subcommand("calibrate", "Calibrate the mounting from a job file (SPEC §4); writes the result file");
  cal->add_option("job", job_path, "Job JSON file")->required();
  cal->add_flag("--quiet", quiet, "Print nothing on success");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  try {
    if (sim->parsed()) {
      if (scenario.empty() == preset.empty()) {
        std::fprintf(stderr, "mountcal simulate: give either a SCENARIO file or --preset NAME\n");
        return 2;
      }
      return runSimulate(scenario, preset, seed, out, no_noise);
    }
    if (cal->parsed()) return runCalibrate(job_path, quiet);
  } catch (const mountcal::Error& e) {
    std::fprintf(stderr, "mountcal: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mountcal: internal error: %s\n", e.what());
    return 3;
  }
  return 0;
}
