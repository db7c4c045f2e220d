// The second paper's method (issue 10): `calibrate` with method "features" on the uav-vlp16
// preset (five strips, ten target regions), one core. Target: the whole call under 2 s. The
// figure is the whole calibrate() call; the counters split it into extraction (intensity, region
// growing, RANSAC), matching (ICP per pair and the closed form) and the rigorous adjustment
// (Levenberg–Marquardt with the re-selections, observability and covariance).
//   build/bench/bench_features
#include <benchmark/benchmark.h>

#include <chrono>

#include "mountcal/mountcal.hpp"

using namespace mountcal;
using namespace mountcal::simulation;

namespace {

const CalibrationData& uavData() {
  static const CalibrationData d = [] {
    Scene scene;
    SurveyConfig c;
    makePreset("uav-vlp16", 1, &c, &scene);
    return toCalibrationData(simulate(c, scene));
  }();
  return d;
}

void BM_FeaturesCalibrateUavVlp16(benchmark::State& state) {
  const CalibrationData& d = uavData();
  MountingCalibrator::Options o;
  o.methods = {"features"};
  o.estimate = {true, true, false, true, true, true};
  double extraction = 0, matching = 0, solve = 0;
  std::size_t points = 0;
  for (const StripData& s : d.strips) points += s.time_s.size();
  for (auto _ : state) {
    const auto S = calibrate(d, o);
    if (!S.IsSolutionUsable()) state.SkipWithError(S.message.c_str());
    extraction += S.section<FeatureSection>().extraction_time_s;
    matching += S.section<FeatureSection>().matching_time_s;
    solve += S.solve_time_s + S.analysis_time_s;
    benchmark::DoNotOptimize(S.mounting.boresight);
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["extraction_ms"] = 1e3 * extraction / n;
  state.counters["matching_ms"] = 1e3 * matching / n;
  state.counters["solve_ms"] = 1e3 * solve / n;
  state.counters["strip_points"] = static_cast<double>(points);
}
BENCHMARK(BM_FeaturesCalibrateUavVlp16)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
