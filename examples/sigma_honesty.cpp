// Are the stated σ honest? Simulates a survey over many seeds, calibrates each with one method
// (or a combination) and prints, per estimated parameter, the RMS of error/σ (1 for an honest
// σ) and the share of errors within 2σ (95.4 % for an honest σ) — issue 26's table.
//
//   sigma_honesty [--method vtpm|planes|planes_auto|correspondences|features|vtpm+planes]
//                 [--seeds N] [--first-seed S] [--noise realistic|navigation_drift|navigation_drift_gauss_markov]
//                 [--model-attitude-drift]   (state the attitude drift as PulseNoise's random effect)
//                 [--corrections P,A]        (estimate per-strip trajectory corrections: position
//                                             degree P, attitude degree A; StochasticOptions::corrections)
//                 [--priors-from-accuracy]   (the corrections' priors from the stated trajectory
//                                             accuracy: TrajectoryCorrections::priors_from_accuracy)
//                 [--per-seed]               (each seed's errors, σ and strip offsets against the truth)
//                 [--offset-sigma M]         (the strip offsets' σ; default 0.005, the survey's strip-
//                                             to-strip GNSS bias — the drift is TrajectoryAccuracy's)
//                 [--resolve-check]          (run the re-solve check and the verdict, and count how
//                                             often they doubt or reject surveys whose truth is known)
//
// The field is the first paper's crossing field (two heights, roofs of several aspects; pulses
// cast within 12 m of every feature), or the VLP-16 UAV preset for `features`. Noise
// `navigation_drift` adds band-limited position (2 cm, 10–100 s) and attitude (0.002°, 1–30 s)
// drift within every strip: a form the calibrator does not model; `navigation_drift_gauss_markov`
// the same magnitudes as Gauss–Markov processes whose correlation times are drawn per line and
// axis from 10–100 s (position) and 1–30 s (attitude), against the calibrator's single τ. A σ
// of 0 counts as an error beyond 2σ (and is named).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "mountcal/mountcal.hpp"

using namespace mountcal;
using namespace mountcal::simulation;

/// One seed's detail (--per-seed): each estimated parameter's error, σ and error/σ, σ₀², and per
/// strip the trajectory's true mean position error (measured − true over the strip's pulses)
/// beside the estimated strip offset.
void printSeed(int seed, const SimulatedSurvey& s, const MountingCalibrator::Summary& summary, const std::array<double, 6>& e,
               const std::array<double, 6>& t) {
  std::printf("seed %d: σ₀² %.2f\n", seed, summary.variance_factor);
  for (std::size_t j = 0; j < 6; ++j)
    if (summary.estimated[j])
      std::printf("  %-18s error %+.5f σ %.5f %s  error/σ %+.2f\n", mountingParameterNames()[j].c_str(),
                  j < 3 ? e[j] - t[j] : rad2deg(e[j] - t[j]), j < 3 ? summary.sigma[j] : rad2deg(summary.sigma[j]), j < 3 ? "m" : "deg",
                  (e[j] - t[j]) / summary.sigma[j]);
  for (const auto& st : s.strips) {
    Vec3 d = Vec3::Zero();
    double n = 0;
    for (std::size_t q = 0; q < st.pulses.size(); q += 1000, n += 1)
      d += s.measured_trajectory->pose(st.pulses[q].time_s).p_m - s.true_trajectory->pose(st.pulses[q].time_s).p_m;
    if (n > 0) d /= n;
    Vec3 est = Vec3::Zero();
    for (const auto& [id, o] : summary.strip_offsets_m)
      if (id == st.id) est = o;
    std::printf("  strip %-4s true mean error %+.4f %+.4f %+.4f m, estimated offset %+.4f %+.4f %+.4f m\n", st.id.c_str(), d.x(), d.y(),
                d.z(), est.x(), est.y(), est.z());
  }
}

int main(int argc, char** argv) {
  std::string method = "vtpm", noise = "navigation_drift_gauss_markov";
  int seeds = 10, first_seed = 1;
  bool model_drift = false, trajectory_none = false, per_seed = false, priors_from_accuracy = false, offsets_within_drift = false;
  bool resolve_check = false;
  double offset_sigma = 0.005;  // the simulated survey's strip-to-strip GNSS bias (gnss_sigma_m below)
  int corr_position = 0, corr_attitude = 0;
  double attitude_tau = TrajectoryAccuracy().attitude_correlation_s, position_tau = TrajectoryAccuracy().position_correlation_s;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--method" && i + 1 < argc)
      method = argv[++i];
    else if (a == "--seeds" && i + 1 < argc)
      seeds = std::atoi(argv[++i]);
    else if (a == "--first-seed" && i + 1 < argc)
      first_seed = std::atoi(argv[++i]);
    else if (a == "--noise" && i + 1 < argc)
      noise = argv[++i];
    else if (a == "--model-attitude-drift")
      model_drift = true;
    else if (a == "--trajectory-none")
      trajectory_none = true;
    else if (a == "--per-seed")
      per_seed = true;
    else if (a == "--priors-from-accuracy")
      priors_from_accuracy = true;
    else if (a == "--attitude-tau" && i + 1 < argc)
      attitude_tau = std::atof(argv[++i]);
    else if (a == "--position-tau" && i + 1 < argc)
      position_tau = std::atof(argv[++i]);
    else if (a == "--offset-sigma" && i + 1 < argc)
      offset_sigma = std::atof(argv[++i]);
    else if (a == "--offsets-within-drift")  // the offsets' prior as the drift's constant part
      offsets_within_drift = true;
    else if (a == "--resolve-check")
      resolve_check = true;
    else if (a == "--corrections" && i + 1 < argc && std::sscanf(argv[i + 1], "%d,%d", &corr_position, &corr_attitude) == 2)
      ++i;
    else {
      std::fprintf(
          stderr,
          "usage: %s [--method M] [--seeds N] [--first-seed S] [--noise realistic|navigation_drift|navigation_drift_gauss_markov] "
          "[--model-attitude-drift] [--trajectory-none] [--per-seed] [--priors-from-accuracy] [--attitude-tau S] [--position-tau S] "
          "[--offset-sigma M] [--offsets-within-drift] [--corrections P,A] [--resolve-check]\n",
          argv[0]);
      return 2;
    }
  }
  if (seeds < 1 || (noise != "realistic" && noise != "navigation_drift" && noise != "navigation_drift_gauss_markov")) {
    std::fprintf(stderr, "sigma_honesty: --seeds must be ≥ 1 and --noise realistic, navigation_drift or navigation_drift_gauss_markov\n");
    return 2;
  }
  std::vector<std::string> methods;
  bool automatic = false;
  {
    std::stringstream ss(method);
    for (std::string m; std::getline(ss, m, '+');) {
      if (m == "planes_auto") {
        automatic = true;
        m = "planes";
      }
      methods.push_back(m);
    }
  }
  const bool uav = method == "features";
  std::array<double, 6> z2{}, e2{};
  std::array<int, 6> within{}, counted{}, zero_sigma{};
  double vf = 0;
  int used = 0;
  // --resolve-check: each seed's largest re-solve move [σ], the checks that doubt (unsettled) or
  // reject (the calibrator's own bounds), and the verdicts.
  std::vector<double> moves;
  int unsettled = 0, rejects = 0;
  std::array<int, 3> verdicts{};
  std::printf("%s, %s noise, seeds %d–%d\n", method.c_str(), noise.c_str(), first_seed, first_seed + seeds - 1);
  for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
    Scene scene;
    SurveyConfig c;
    makePreset(uav ? "uav-vlp16" : "paper-calibration-field", static_cast<std::uint64_t>(seed), &c, &scene);
    c.noise = noise == "realistic"          ? NoiseModel::realistic()
              : noise == "navigation_drift" ? NoiseModel::withNavigationDrift()
                                            : NoiseModel::withNavigationDrift(NoiseModel::DriftForm::kGaussMarkov);
    c.noise.gnss_sigma_m = 0.005;  // strip-to-strip GNSS, survey grade
    c.noise.pick_sigma_m = 0.03;
    if (!uav) c.roi_radius_m = 12.0;
    const SimulatedSurvey s = simulate(c, scene);
    MountingCalibrator::Options o;
    o.methods = methods;
    o.method<VtpmOptions>().tie_sigma_xy_m = 0.03;
    o.method<VtpmOptions>().tie_sigma_z_m = 0.01;  // picks are 2-D; a tie's height comes from its triangle
    o.method<VtpmOptions>().estimate_tie_sigma = true;
    o.method<PlaneOptions>().automatic = automatic;
    o.strip_offset_sigma_m = offset_sigma;
    o.estimate = {true, true, false, true, true, true};
    o.resolve_check = resolve_check;  // off by default: the estimate and its σ are what is measured
    o.trajectory.attitude_correlation_s = attitude_tau;
    o.trajectory.position_correlation_s = position_tau;
    o.trajectory.offsets_within_drift = offsets_within_drift;
    if (trajectory_none) o.trajectory = TrajectoryAccuracy::none();
    o.corrections.position_degree = corr_position;
    o.corrections.attitude_degree = corr_attitude;
    o.corrections.priors_from_accuracy = priors_from_accuracy;
    if (model_drift) {  // the attitude drift as the calibrator's random effect (ties only, today)
      o.pulse_noise.roll_pitch_deg = rad2deg(c.noise.drift_attitude_sigma_rad);
      o.pulse_noise.heading_deg = 2 * rad2deg(c.noise.drift_attitude_sigma_rad);
      o.pulse_noise.attitude_correlation_s = 5.0;
    }
    const auto summary = calibrate(toCalibrationData(s), o);
    if (!summary.IsSolutionUsable()) {
      std::printf("seed %d: not usable (%s)\n", seed, summary.message.c_str());
      continue;
    }
    ++used;
    vf += summary.variance_factor;
    const auto e = summary.mounting.toArray(), t = c.true_mounting.toArray();
    if (per_seed) printSeed(seed, s, summary, e, t);
    if (resolve_check) {
      const MountingCalibrator::Verdict v = summary.verdict();
      ++verdicts[static_cast<std::size_t>(v.kind)];
      if (summary.resolve.done) moves.push_back(summary.resolve.usable ? summary.resolve.largestInSigma() : 1e9);
      unsettled += summary.resolve.unsettled();
      rejects += summary.resolve.rejects();
      if (per_seed || v.kind != MountingCalibrator::Verdict::Kind::kAccept) {
        std::printf("seed %d: %s; %s\n", seed, v.name(), summary.resolve.text().c_str());
        for (const std::string& r : v.reasons) std::printf("    %s\n", r.c_str());
      }
    }
    for (std::size_t j = 0; j < 6; ++j) {
      if (!summary.estimated[j]) continue;
      // A σ of 0 (or not a number) claims what no survey gives: counted, as an error beyond 2σ.
      const bool stated = summary.sigma[j] > 0;
      zero_sigma[j] += !stated;
      const double z = stated ? (e[j] - t[j]) / summary.sigma[j] : 1e3;
      z2[j] += z * z;
      e2[j] += (e[j] - t[j]) * (e[j] - t[j]);
      within[j] += std::abs(z) <= 2.0;
      ++counted[j];
    }
  }
  std::printf("%-20s %14s %12s %16s\n", "parameter", "RMS error/σ", "within 2σ", "RMS error");
  for (std::size_t j = 0; j < 6; ++j) {
    if (counted[j] == 0) continue;
    const double rms = std::sqrt(e2[j] / counted[j]);
    std::printf("%-20s %14.2f %11.0f%% %12.4g %s", mountingParameterNames()[j].c_str(), std::sqrt(z2[j] / counted[j]),
                100.0 * within[j] / counted[j], j < 3 ? rms : rad2deg(rms), j < 3 ? "m" : "deg");
    if (zero_sigma[j] > 0) std::printf("  (σ = 0 in %d solves)", zero_sigma[j]);
    std::printf("\n");
  }
  std::printf("mean variance factor %.2f over %d usable solves\n", used ? vf / used : 0.0, used);
  if (resolve_check) {
    std::sort(moves.begin(), moves.end());
    std::printf(
        "re-solve check in %zu solves: largest move median %.2fσ, largest %.2fσ; unsettled (over 2σ or not converged) in %d, "
        "rejecting in %d\n",
        moves.size(), moves.empty() ? 0.0 : moves[moves.size() / 2], moves.empty() ? 0.0 : moves.back(), unsettled, rejects);
    std::printf("verdicts: accept %d, doubtful %d, reject %d\n", verdicts[0], verdicts[1], verdicts[2]);
  }
  return used == seeds ? 0 : 1;
}
