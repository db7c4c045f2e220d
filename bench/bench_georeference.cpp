// Batch georeferencing throughput (issue 2 target: ≥ 15 M points/s on one core; issue 13:
// ≥ 40 M pulses/s and ≥ 2.5× the plain loop, BM_PlainLoopLineScan, measured in the same run).
// A line scanner at 150 kHz over a 200 Hz trajectory, 10 M pulses with sorted times.
//   build/bench/bench_georeference [--benchmark_filter=...]
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <vector>

#include "mountcal/core/georeference_model.hpp"

using namespace mountcal;

namespace {

struct Survey {
  std::shared_ptr<const Trajectory> trajectory;
  std::vector<double> t, theta, rho, r_s, x_m;
};

const Survey& survey() {
  static const Survey s = [] {
    Survey out;
    const std::size_t n = 10'000'000;
    const double prf = 150e3, duration = static_cast<double>(n) / prf + 0.01;
    std::vector<TrajectorySample> samples(static_cast<std::size_t>(duration * 200) + 2);
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const double t = static_cast<double>(i) / 200.0;
      samples[i].time_s = 100000.0 + t;
      samples[i].p_m = Vec3(60 * t, 0.0, 1000 + std::sin(0.1 * t));
      samples[i].roll = 0.003 * std::sin(0.5 * t);
      samples[i].pitch = 0.002 * std::cos(0.3 * t);
      samples[i].heading = deg2rad(90) + 0.001 * std::sin(0.2 * t);
    }
    out.trajectory = std::make_shared<const Trajectory>(std::move(samples));
    out.t.resize(n);
    out.theta.resize(n);
    out.rho.resize(n);
    out.r_s.resize(3 * n);
    out.x_m.resize(3 * n);
    const LineScannerModel line;
    for (std::size_t k = 0; k < n; ++k) {
      out.t[k] = 100000.0 + static_cast<double>(k) / prf;
      out.theta[k] = deg2rad(30) * std::sin(2 * kPi * 40.0 * static_cast<double>(k) / prf);
      out.rho[k] = 1000.0 / std::cos(out.theta[k]);
      Eigen::Map<Vec3>{&out.r_s[3 * k]} = line.vector(out.theta[k], out.rho[k]);
    }
    return out;
  }();
  return s;
}

const MountingParameters kMounting = MountingParameters::fromDegrees(Vec3(0.1, -0.05, 0.2), Vec3(0.05, -0.08, 0.12));

void BM_ForwardLineScan(benchmark::State& state) {
  const Survey& s = survey();
  GeoreferenceModel model(s.trajectory, kMounting);
  std::vector<double> x(s.x_m.size());
  const LineScannerModel line;
  for (auto _ : state) {
    model.forwardLineScan(line, s.t.data(), s.theta.data(), s.rho.data(), x.data(), s.t.size());
    benchmark::DoNotOptimize(x.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * s.t.size()));
}
BENCHMARK(BM_ForwardLineScan)->Unit(benchmark::kMillisecond)->Iterations(3);

// The baseline of issue 13: a plain Eigen loop that slerps the attitude for every pulse (the
// trajectory's own pose(), then seed eq. (1)).
void BM_PlainLoopLineScan(benchmark::State& state) {
  const Survey& s = survey();
  const Mat3 R_bs = kMounting.R_bs();
  std::vector<double> x(s.x_m.size());
  const LineScannerModel line;
  for (auto _ : state) {
    std::size_t cursor = 0;
    for (std::size_t k = 0; k < s.t.size(); ++k) {
      const Pose pose = s.trajectory->pose(s.t[k], &cursor);
      Eigen::Map<Vec3>{&x[3 * k]} = georeference(pose, R_bs, kMounting.a_b, line.vector(s.theta[k], s.rho[k]));
    }
    benchmark::DoNotOptimize(x.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * s.t.size()));
}
BENCHMARK(BM_PlainLoopLineScan)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_ForwardVectors(benchmark::State& state) {
  const Survey& s = survey();
  GeoreferenceModel model(s.trajectory, kMounting);
  std::vector<double> x(s.x_m.size());
  for (auto _ : state) {
    model.forward(s.t.data(), s.r_s.data(), x.data(), s.t.size());
    benchmark::DoNotOptimize(x.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * s.t.size()));
}
BENCHMARK(BM_ForwardVectors)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_InverseVectors(benchmark::State& state) {
  const Survey& s = survey();
  GeoreferenceModel model(s.trajectory, kMounting);
  std::vector<double> x(s.x_m.size()), r(s.x_m.size());
  model.forward(s.t.data(), s.r_s.data(), x.data(), s.t.size());
  for (auto _ : state) {
    model.inverse(s.t.data(), x.data(), r.data(), s.t.size());
    benchmark::DoNotOptimize(r.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * s.t.size()));
}
BENCHMARK(BM_InverseVectors)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
