// A block with automatic correspondences (issue 13): how the whole calibrate() grows with the
// number of strips (4, 8, 16, 32 strips of the simulated block; one thread), the throughput of
// the correspondence search in strip points per second, and the same calibration on 1 and 2
// threads (measured in the same run). The pair jobs of a workflow (`mountcal match`) are timed
// as `findPairCandidates` per pair.
//   build/bench/bench_block
#include <benchmark/benchmark.h>

#include <map>

#include "mountcal/mountcal.hpp"

using namespace mountcal;
using namespace mountcal::simulation;

namespace {

const CalibrationData& blockData(int strips, BlockLayout layout = BlockLayout::kCrossing) {
  static std::map<std::pair<int, int>, CalibrationData> cache;
  const std::pair<int, int> key{strips, static_cast<int>(layout)};
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  Scene scene;
  SurveyConfig c;
  makeBlock(strips, 1, &c, &scene, layout);
  return cache.emplace(key, toCalibrationData(simulate(c, scene))).first->second;
}

MountingCalibrator::Options options(int threads) {
  MountingCalibrator::Options o;
  o.methods = {"correspondences"};
  o.estimate = {false, true, false, true, true, true};  // one height: lever x and z not determined
  o.threads = threads;
  return o;
}

void BM_BlockCalibrate(benchmark::State& state) {
  const int strips = static_cast<int>(state.range(0)), threads = static_cast<int>(state.range(1));
  const CalibrationData& d = blockData(strips);
  std::size_t points = 0;
  for (const auto& s : d.strips) points += s.time_s.size();
  MountingCalibrator::Summary S;
  for (auto _ : state) {
    S = calibrate(d, options(threads));
    benchmark::DoNotOptimize(S.final_cost);
  }
  int overlapping = 0;
  for (const auto& p : S.section<CorrespondenceSection>().pairs) overlapping += p.samples > 0;
  state.counters["strips"] = strips;
  state.counters["threads"] = threads;
  state.counters["points"] = static_cast<double>(points);
  state.counters["pairs"] = overlapping;
  state.counters["matchings"] = S.section<CorrespondenceSection>().rounds;
  state.counters["construction_s"] = S.construction_time_s;  // the pairs' candidates and every matching
  state.counters["solve_s"] = S.solve_time_s;
  state.counters["s_per_pair"] = S.time_s / std::max(overlapping, 1);
  state.counters["usable"] = S.IsSolutionUsable();
}
BENCHMARK(BM_BlockCalibrate)
    ->Args({4, 1})
    ->Args({8, 1})
    ->Args({16, 1})
    ->Args({32, 1})
    ->Args({12, 1})
    ->Args({12, 2})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(3)
    ->ReportAggregatesOnly(true);

// Issue 26's cost target: per-strip trajectory corrections (a linear position and attitude drift
// per strip: 6 more values per strip, 192 on 32 strips) against the same block's
// calibrate() without them, both timed in each iteration of this run; at most 2×. `sparse`: the
// solve uses Ceres' sparse solver (over 120 values not eliminated first).
void BM_BlockTrajectoryCorrectionsCost(benchmark::State& state) {
  const int strips = static_cast<int>(state.range(0));
  const CalibrationData& d = blockData(strips);
  MountingCalibrator::Options with = options(1);
  with.corrections.position_degree = 1;
  with.corrections.attitude_degree = 1;
  double base_s = 0, corr_s = 0;
  MountingCalibrator::Summary S0, S1;
  for (auto _ : state) {
    S0 = calibrate(d, options(1));
    S1 = calibrate(d, with);
    base_s += S0.time_s;
    corr_s += S1.time_s;
    benchmark::DoNotOptimize(S1.final_cost);
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["strips"] = strips;
  state.counters["baseline_s"] = base_s / n;
  state.counters["corrections_s"] = corr_s / n;
  state.counters["ratio"] = corr_s / base_s;
  state.counters["corrected_strips"] = static_cast<double>(S1.strip_corrections.size());
  state.counters["usable"] = S0.IsSolutionUsable() && S1.IsSolutionUsable();
}
BENCHMARK(BM_BlockTrajectoryCorrectionsCost)->Arg(32)->Unit(benchmark::kMillisecond)->Iterations(1)->Repetitions(3);

// The same with parallel lines of one length (BlockLayout::kParallel): pairs, and each pair's
// size, grow linearly with the strips — the time should too.
void BM_ParallelBlockCalibrate(benchmark::State& state) {
  const int strips = static_cast<int>(state.range(0));
  const CalibrationData& d = blockData(strips, BlockLayout::kParallel);
  std::size_t points = 0;
  for (const auto& s : d.strips) points += s.time_s.size();
  MountingCalibrator::Summary S;
  for (auto _ : state) {
    S = calibrate(d, options(1));
    benchmark::DoNotOptimize(S.final_cost);
  }
  int overlapping = 0;
  for (const auto& p : S.section<CorrespondenceSection>().pairs) overlapping += p.samples > 0;
  state.counters["strips"] = strips;
  state.counters["points"] = static_cast<double>(points);
  state.counters["pairs"] = overlapping;
  state.counters["matchings"] = S.section<CorrespondenceSection>().rounds;
  state.counters["construction_s"] = S.construction_time_s;
  state.counters["s_per_pair"] = S.time_s / std::max(overlapping, 1);
  state.counters["usable"] = S.IsSolutionUsable();
}
BENCHMARK(BM_ParallelBlockCalibrate)
    ->Arg(4)
    ->Arg(8)
    ->Arg(16)
    ->Arg(32)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(3)
    ->ReportAggregatesOnly(true);

// One matching from scratch on the 12-strip block (candidates of every pair, then the matching):
// strip points in the overlaps per second, on 1 and 2 threads.
void BM_BlockCorrespondenceSearch(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(0));
  const CalibrationData& d = blockData(12);
  CorrespondenceSet set;
  for (auto _ : state) {
    set = findCorrespondences(d, d.mounting_used.toArray(), CorrespondenceOptions{}, true, threads);
    benchmark::DoNotOptimize(set.correspondences.size());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(set.points_searched));
  state.counters["threads"] = threads;
  state.counters["points_in_overlaps"] = static_cast<double>(set.points_searched);
}
BENCHMARK(BM_BlockCorrespondenceSearch)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(3);

// A workflow's match job for each pair, in memory (no file): the candidates of one pair from its
// two strips.
void BM_BlockPairCandidates(benchmark::State& state) {
  const CalibrationData& d = blockData(12);
  const auto pairs = candidateStripPairs(d, CorrespondenceOptions{});
  std::size_t samples = 0, points_b = 0;
  for (auto _ : state) {
    samples = points_b = 0;
    for (const auto& [a, b] : pairs) {
      const PairCandidates p = findPairCandidates(d, a, b, CorrespondenceOptions{});
      samples += p.samples_a.size();
      points_b += p.points_b.size();
    }
  }
  state.counters["pairs"] = static_cast<double>(pairs.size());
  state.counters["samples"] = static_cast<double>(samples);
  state.counters["points_of_B_kept"] = static_cast<double>(points_b);
  state.counters["file_MB"] = static_cast<double>(samples * (64 + 32) + points_b * 64) / 1e6;
}
BENCHMARK(BM_BlockPairCandidates)->Unit(benchmark::kMillisecond)->Iterations(1);

// Swath QC (issue 29) of the block, before and after one mounting (both georeferenced, every
// pair's dZ): its time against BM_BlockCalibrate's on the same block in the same run (the issue:
// under the calibration's time), and its growth with the points (4 … 32 strips: linear).
void BM_BlockSwathQc(benchmark::State& state) {
  const int strips = static_cast<int>(state.range(0));
  const CalibrationData& d = blockData(strips);
  std::size_t points = 0;
  for (const auto& s : d.strips) points += s.time_s.size();
  SwathQcResult qc;
  for (auto _ : state) {
    qc = swathQc(d, d.mounting_used, d.mounting_used);
    benchmark::DoNotOptimize(qc.overall_after.rmsdz_m);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(points));
  state.counters["strips"] = strips;
  state.counters["points"] = static_cast<double>(points);
  state.counters["pairs"] = static_cast<double>(qc.pairs.size());
  state.counters["cells"] = static_cast<double>(qc.overall_after.cells);
  state.counters["cell_m"] = qc.cell_size_m;
}
BENCHMARK(BM_BlockSwathQc)
    ->Arg(4)
    ->Arg(8)
    ->Arg(12)
    ->Arg(16)
    ->Arg(32)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(3)
    ->ReportAggregatesOnly(true);

}  // namespace

BENCHMARK_MAIN();
