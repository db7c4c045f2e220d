// The Gravity HDL-32E calibrations (issue "Real UAV data"): reading the job's LAS file and
// calibrating, one core, per set — the figure the "under 1 s" is about. Needs
// ../shared/data/gravity beside the repository; the pass-to-pass discrepancy after each run is
// reported as a counter (median, m).
#include <benchmark/benchmark.h>

#include <filesystem>

#include "mountcal/mountcal.hpp"
#include "mountcal/report/evaluation.hpp"
#include "mountcal/job/load.hpp"
#include "mountcal/job/result.hpp"
#include "mountcal/mounting_calibrator.hpp"

using namespace mountcal;

namespace {

void calibrateSet(benchmark::State& state, const char* name) {
  const std::string path = std::string(MOUNTCAL_SOURCE_DIR) + "/examples/gravity/" + name + ".json";
  const Job job = readJob(path);
  if (!std::filesystem::exists(job.strips.front().path)) {
    state.SkipWithError(("data not found: " + job.strips.front().path).c_str());
    return;
  }
  MountingCalibrator::Summary S;
  for (auto _ : state) {
    const LoadedJob L = loadJob(job);  // reading included
    S = MountingCalibrator(job.options).calibrate(L.data);
    benchmark::DoNotOptimize(S.mounting);
  }
  CalibrationData d = loadJob(job).data;
  applyLaserCorrections(&d, S.laserCorrections());
  state.counters["median_after_m"] = pooledDiscrepancy(d, S.mounting).median_m;
  state.counters["matchings"] = S.section<CorrespondenceSection>().rounds;
}

}  // namespace

BENCHMARK_CAPTURE(calibrateSet, truck, "truck")->Unit(benchmark::kMillisecond)->Repetitions(3)->Iterations(1);
BENCHMARK_CAPTURE(calibrateSet, car, "car")->Unit(benchmark::kMillisecond)->Repetitions(3)->Iterations(1);
BENCHMARK_CAPTURE(calibrateSet, tent, "tent")->Unit(benchmark::kMillisecond)->Repetitions(3)->Iterations(1);

BENCHMARK_MAIN();
