// Calibration benchmarks (issue: VTPM self-calibration). Targets on one core:
//   solve with 12 observations < 20 ms; with 10,000 observations < 2 s;
//   VTPM construction of 1,000 ties on a 1 M-point strip, k-d tree included, < 2 s.
// The solve benchmarks report the Levenberg–Marquardt time (Summary::solve_time_s, manual
// time) as their figure, and the whole calibrate() call — k-d trees and virtual tie points,
// observability analysis and covariance included — as the counter total_ms.
//   build/bench/bench_calibration
#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <random>

#include "methods/common/vtp_strip.hpp"
#include "mountcal/mountcal.hpp"

using namespace mountcal;
using namespace mountcal::simulation;

namespace {

const SimulatedSurvey& fieldSurvey() {
  static const SimulatedSurvey s = [] {
    Scene scene;
    SurveyConfig c;
    makePreset("paper-calibration-field", 1, &c, &scene);
    return simulate(c, scene);
  }();
  return s;
}

/// A flat field with 2,500 tie features on a 20 m grid, crossed by the preset's four strips:
/// 10,000 tie observations.
const SimulatedSurvey& bigSurvey() {
  static const SimulatedSurvey s = [] {
    Scene scene;
    SurveyConfig c;
    makePreset("paper-calibration-field", 2, &c, &scene);
    Scene flat;
    flat.setGround(0.0, 0.001, -0.0015);
    for (int i = 0; i < 50; ++i)
      for (int j = 0; j < 50; ++j)
        flat.addFeature(
            {"g" + std::to_string(i) + "_" + std::to_string(j), Vec3(-245 + 10.0 * i, -245 + 10.0 * j, 0.0), SurfaceKind::kGround, 3.0});
    for (auto& f : const_cast<std::vector<FeaturePoint>&>(flat.features())) f.x_m.z() = flat.groundHeight(f.x_m.x(), f.x_m.y());
    flat.build();
    c.roi_radius_m = 3.0;
    return simulate(c, flat);
  }();
  return s;
}

void BM_Calibrate12Observations(benchmark::State& state) {
  const SimulatedSurvey& s = fieldSurvey();
  CalibrationData d = toCalibrationData(s);
  // Five ties, twelve observations (as in the paper's Table 1).
  // Three ties on two strips and two on three: 12 observations.
  std::map<std::string, std::vector<TieObservation>> by_tie;
  for (const auto& t : d.ties) by_tie[t.tie_id].push_back(t);
  std::vector<TieObservation> ties;
  int n_ties = 0;
  for (const auto& [id, obs] : by_tie) {
    if (obs.size() < 3 || id.rfind("ring_", 0) != 0) continue;
    const std::size_t take = n_ties < 3 ? 2 : 3;
    ties.insert(ties.end(), obs.begin(), obs.begin() + static_cast<long>(take));
    if (++n_ties == 5) break;
  }
  d.ties = ties;
  for (auto _ : state) {
    const auto S = calibrate(d);
    benchmark::DoNotOptimize(S.mounting);
    state.SetIterationTime(S.solve_time_s);
    state.counters["observations"] = S.section<VtpmSection>().observations_used;
    state.counters["total_ms"] = 1e3 * S.time_s;
    state.counters["construction_ms"] = 1e3 * S.construction_time_s;
  }
}
BENCHMARK(BM_Calibrate12Observations)->Unit(benchmark::kMillisecond)->Iterations(20)->UseManualTime();

void BM_Calibrate10000Observations(benchmark::State& state) {
  const CalibrationData d = toCalibrationData(bigSurvey());
  for (auto _ : state) {
    const auto S = calibrate(d);
    benchmark::DoNotOptimize(S.mounting);
    state.SetIterationTime(S.solve_time_s);
    state.counters["observations"] = S.section<VtpmSection>().observations_used;
    state.counters["total_ms"] = 1e3 * S.time_s;
    state.counters["construction_ms"] = 1e3 * S.construction_time_s;
    state.counters["analysis_ms"] = 1e3 * S.analysis_time_s;
  }
}
BENCHMARK(BM_Calibrate10000Observations)->Unit(benchmark::kMillisecond)->Iterations(3)->UseManualTime();

void BM_VtpConstruction1000TiesOn1MPointStrip(benchmark::State& state) {
  static const SimulatedSurvey s = [] {
    Scene scene;
    SurveyConfig c;
    makePreset("paper-calibration-field", 3, &c, &scene);
    c.roi_radius_m = 0;
    c.lines.resize(1);
    c.lines[0].x0_m = -200;
    c.lines[0].length_m = 400;
    return simulate(c, scene);
  }();
  const CalibrationData d = toCalibrationData(s);
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> ux(-150, 150), uy(-200, 200);
  std::vector<TieObservation> picks;
  for (int k = 0; k < 1000; ++k) picks.push_back({"t" + std::to_string(k), d.strips[0].id, ux(rng), uy(rng), 0});
  int built = 0;
  for (auto _ : state) {
    VtpStrip strip(d.strips[0], d.trajectory, d.mounting_used);  // k-d tree included
    built = 0;
    for (const auto& p : picks) {
      VirtualTiePoint v;
      std::string why;
      built += strip.build(p, VtpOptions{}, &v, &why);
    }
    benchmark::DoNotOptimize(built);
  }
  state.counters["strip_points"] = static_cast<double>(d.strips[0].time_s.size());
  state.counters["ties_built"] = built;
}
BENCHMARK(BM_VtpConstruction1000TiesOn1MPointStrip)->Unit(benchmark::kMillisecond)->Iterations(3);

// Issue 13: the VTPM construction of the 10,000-observation survey (4 strips' k-d trees, then
// every virtual tie point) on 1 and 2 threads, measured in the same run.
void BM_VtpmConstructionThreads(benchmark::State& state) {
  const CalibrationData d = toCalibrationData(bigSurvey());
  MountingCalibrator::Options o;
  const int threads = static_cast<int>(state.range(0));
  std::size_t built = 0;
  for (auto _ : state) {
    const TieObservations ties(d, d.ties, d.gcps, o.method<VtpmOptions>(), o.method<VtpmOptions>().vtp, "ties", threads);
    built = ties.virtualTiePoints().size();
    benchmark::DoNotOptimize(built);
  }
  state.counters["threads"] = threads;
  state.counters["observations"] = static_cast<double>(d.ties.size());
  state.counters["built"] = static_cast<double>(built);
}
BENCHMARK(BM_VtpmConstructionThreads)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(3)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
