// Simulator throughput (issue: survey simulator; target ≥ 5 M pulses/s on one core for the
// line scanner over the calibration field) and memory per pulse.
//   build/bench/bench_simulator
#include <benchmark/benchmark.h>

#include "mountcal/simulation/survey.hpp"

using namespace mountcal;
using namespace mountcal::simulation;

namespace {

void BM_SimulateLineScannerFullStrip(benchmark::State& state) {
  Scene scene;
  SurveyConfig c;
  makePreset("paper-calibration-field", 1, &c, &scene);
  c.roi_radius_m = 0;  // whole strip: every pulse is ray-cast
  c.lines.resize(1);   // 1400 m at 760 m, 150 kHz: 3.5 M pulses
  std::size_t pulses = 0, returns = 0, bytes = 0;
  for (auto _ : state) {
    const SimulatedSurvey s = simulate(c, scene);
    returns = s.strips[0].pulses.size();
    pulses = static_cast<std::size_t>(c.lines[0].length_m / c.lines[0].speed_mps * c.line.prf_hz);
    bytes = returns * (sizeof(RawPulse) + 2 * sizeof(Vec3) + sizeof(SurfaceKind));
    benchmark::DoNotOptimize(s.strips.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * pulses));
  state.counters["pulses"] = static_cast<double>(pulses);
  state.counters["bytes_per_pulse"] = static_cast<double>(bytes) / static_cast<double>(returns);
  state.counters["triangles"] = static_cast<double>(scene.triangleCount());
}
BENCHMARK(BM_SimulateLineScannerFullStrip)->Unit(benchmark::kMillisecond)->Iterations(3);

// Issue 13: a survey of several lines on 1 and 2 threads (the four lines of the calibration
// field within 12 m of its features, as the preset is written), measured in the same run.
void BM_SimulateFourLinesThreads(benchmark::State& state) {
  Scene scene;
  SurveyConfig c;
  makePreset("paper-calibration-field", 1, &c, &scene);
  c.threads = static_cast<int>(state.range(0));
  std::size_t returns = 0;
  for (auto _ : state) {
    const SimulatedSurvey s = simulate(c, scene);
    returns = 0;
    for (const auto& st : s.strips) returns += st.pulses.size();
    benchmark::DoNotOptimize(s.strips.data());
  }
  state.counters["threads"] = static_cast<double>(c.threads);
  state.counters["returns"] = static_cast<double>(returns);
}
BENCHMARK(BM_SimulateFourLinesThreads)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(3)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
