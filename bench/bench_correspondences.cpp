// Automatic correspondences (issue "One adjustment, many observation kinds"). Target on one
// core: the whole calibrate() with method "correspondences" on the crossing-field preset
// (paper-calibration-field as `mountcal simulate` writes it: four strips, ≈ 360,000 points,
// no ties) under 3 s. Also: the throughput of one correspondence search in strip points per
// second (points in the overlap hulls), and the peak memory of a calibration (in a forked child,
// so that the figure is the calibration's own: the simulated survey is made before the fork).
//   build/bench/bench_correspondences
#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include "mountcal/mountcal.hpp"

using namespace mountcal;
using namespace mountcal::simulation;

namespace {

const CalibrationData& fieldData() {
  static const CalibrationData d = [] {
    Scene scene;
    SurveyConfig c;
    makePreset("paper-calibration-field", 1, &c, &scene);  // the preset as written, realistic noise
    const SimulatedSurvey s = simulate(c, scene);
    CalibrationData data = toCalibrationData(s);
    data.ties.clear();
    return data;
  }();
  return d;
}

MountingCalibrator::Options correspondenceOptions() {
  MountingCalibrator::Options o;
  o.methods = {"correspondences"};
  return o;
}

void BM_CalibrateWithCorrespondences(benchmark::State& state) {
  const CalibrationData& d = fieldData();
  std::size_t points = 0;
  for (const auto& s : d.strips) points += s.time_s.size();
  MountingCalibrator::Summary S;
  for (auto _ : state) {
    S = calibrate(d, correspondenceOptions());
    benchmark::DoNotOptimize(S.final_cost);
  }
  state.counters["strip_points"] = static_cast<double>(points);
  state.counters["correspondences"] = S.section<CorrespondenceSection>().used;
  state.counters["matchings"] = S.section<CorrespondenceSection>().rounds;
  state.counters["search_s"] = S.section<CorrespondenceSection>().search_time_s;
  state.counters["construction_s"] = S.construction_time_s;  // matchings included
  state.counters["solve_s"] = S.solve_time_s;
  state.counters["analysis_s"] = S.analysis_time_s;
  state.counters["usable"] = S.IsSolutionUsable();
}
BENCHMARK(BM_CalibrateWithCorrespondences)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_CorrespondenceSearch(benchmark::State& state) {
  const CalibrationData& d = fieldData();
  CorrespondenceSet set;
  for (auto _ : state) {
    set = findCorrespondences(d, d.mounting_used.toArray(), CorrespondenceOptions{});
    benchmark::DoNotOptimize(set.correspondences.size());
  }
  // Throughput in strip points (those in the overlap hulls) per second; each search includes
  // the reference points, voxel hulls, samples, poses and the k-d trees.
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(set.points_searched));
  state.counters["points_in_overlap"] = static_cast<double>(set.points_searched);
  state.counters["correspondences"] = static_cast<double>(set.correspondences.size());
}
BENCHMARK(BM_CorrespondenceSearch)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_CalibrationPeakMemory(benchmark::State& state) {
  const CalibrationData& d = fieldData();
  long before_kb = 0, peak_kb = 0;
  {
    rusage ru{};
    ::getrusage(RUSAGE_SELF, &ru);
    before_kb = ru.ru_maxrss;
  }
  for (auto _ : state) {
    const pid_t pid = ::fork();
    if (pid == 0) {
      const auto S = calibrate(d, correspondenceOptions());
      ::_exit(S.IsSolutionUsable() ? 0 : 1);
    }
    int status = 0;
    ::waitpid(pid, &status, 0);
    rusage ru{};
    ::getrusage(RUSAGE_CHILDREN, &ru);
    peak_kb = ru.ru_maxrss;
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) state.SkipWithError("calibration failed");
  }
  state.counters["data_MiB"] = static_cast<double>(before_kb) / 1024.0;
  state.counters["peak_rss_MiB"] = static_cast<double>(peak_kb) / 1024.0;
}
BENCHMARK(BM_CalibrationPeakMemory)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
