// Python overhead (issue 31): `mountcal.apply` of 10 M points from NumPy against the C++ call it
// wraps (reGeoreference), measured in one run of one program — the interpreter is embedded, the
// module imported from the build tree. Both on one thread, on the same trajectory and points.
//   BM_ApplyCpp          reGeoreference into a preallocated buffer (the baseline)
//   BM_ApplyCppNew       the same into a new buffer per call (the baseline of BM_ApplyNumpyNew)
//   BM_ApplyNumpyOut     mountcal.apply(..., out=y): arrays in and out used in place
//   BM_ApplyNumpyNew     mountcal.apply(...): a new (n, 3) array per call, as most scripts call it
#include <benchmark/benchmark.h>
#include <pybind11/embed.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "mountcal/core/georeference_model.hpp"

namespace py = pybind11;
using namespace mountcal;

namespace {

constexpr std::size_t kPoints = 10'000'000;

/// A 100 s straight flight at 50 m/s with a slow roll; points spread over it, sorted in time.
struct Setup {
  std::vector<double> traj_t, traj_p, traj_a, t, x, y;
  Setup() {
    for (int i = 0; i <= 20000; ++i) {
      const double s = 0.005 * i;
      traj_t.push_back(s);
      traj_p.insert(traj_p.end(), {50.0 * s, 0.1 * s * s, 500.0});
      traj_a.insert(traj_a.end(), {0.01 * std::sin(s), 0.005, 0.3});
    }
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> u(0.0, 100.0), r(-300.0, 300.0);
    t.resize(kPoints);
    for (double& v : t) v = u(rng);
    std::sort(t.begin(), t.end());
    x.resize(3 * kPoints);
    for (double& v : x) v = r(rng);
    y.resize(3 * kPoints);
  }
  std::shared_ptr<Trajectory> trajectory() const {
    std::vector<TrajectorySample> s(traj_t.size());
    for (std::size_t i = 0; i < s.size(); ++i) {
      s[i].time_s = traj_t[i];
      s[i].p_m = Vec3(traj_p[3 * i], traj_p[3 * i + 1], traj_p[3 * i + 2]);
      s[i].roll = traj_a[3 * i], s[i].pitch = traj_a[3 * i + 1], s[i].heading = traj_a[3 * i + 2];
    }
    return std::make_shared<Trajectory>(std::move(s));
  }
};

Setup& setup() {
  static Setup s;
  return s;
}
const MountingParameters kUsed = MountingParameters::fromDegrees(Vec3(0.1, 0.2, 0.3), Vec3(0, 0, 0));
const MountingParameters kNew = MountingParameters::fromDegrees(Vec3(0.12, 0.18, 0.3), Vec3(0.01, -0.02, 0.05));

void BM_ApplyCpp(benchmark::State& state) {
  Setup& s = setup();
  const auto traj = s.trajectory();
  const GeoreferenceModel from(traj, kUsed), to(traj, kNew);
  for (auto _ : state) {
    reGeoreference(from, to, s.t.data(), s.x.data(), s.y.data(), kPoints, 1);
    benchmark::DoNotOptimize(s.y.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(kPoints));
}

/// The same with a new output buffer per call (uninitialised, as NumPy's): what a C++ caller pays
/// for fresh memory — the baseline of BM_ApplyNumpyNew.
void BM_ApplyCppNew(benchmark::State& state) {
  Setup& s = setup();
  const auto traj = s.trajectory();
  const GeoreferenceModel from(traj, kUsed), to(traj, kNew);
  for (auto _ : state) {
    std::unique_ptr<double[]> y(new double[3 * kPoints]);
    reGeoreference(from, to, s.t.data(), s.x.data(), y.get(), kPoints, 1);
    benchmark::DoNotOptimize(y.get());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(kPoints));
}

/// The Python side: the module, NumPy views of the same buffers (no copy), the trajectory built
/// from NumPy arrays, and the call.
void applyFromPython(benchmark::State& state, bool out) {
  Setup& s = setup();
  py::module_ np = py::module_::import("numpy");
  py::module_ mc = py::module_::import("mountcal");
  auto view = [](std::vector<double>& v, py::ssize_t cols) {
    const py::ssize_t n = static_cast<py::ssize_t>(v.size()) / cols;
    return cols == 1
               ? py::array_t<double>({n}, {sizeof(double)}, v.data(), py::none())
               : py::array_t<double>({n, cols}, {cols * static_cast<py::ssize_t>(sizeof(double)), static_cast<py::ssize_t>(sizeof(double))},
                                     v.data(), py::none());
  };
  py::object traj = mc.attr("Trajectory")(view(s.traj_t, 1), view(s.traj_p, 3), view(s.traj_a, 3));
  py::object used = mc.attr("Mounting")(std::vector<double>{0.1, 0.2, 0.3}, std::vector<double>{0, 0, 0});
  py::object nw = mc.attr("Mounting")(std::vector<double>{0.12, 0.18, 0.3}, std::vector<double>{0.01, -0.02, 0.05});
  py::object t = view(s.t, 1), x = view(s.x, 3), y = view(s.y, 3);
  py::object apply = mc.attr("apply");
  for (auto _ : state) {
    py::object r =
        out ? apply(traj, used, nw, t, x, py::arg("out") = y, py::arg("threads") = 1) : apply(traj, used, nw, t, x, py::arg("threads") = 1);
    benchmark::DoNotOptimize(r.ptr());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(kPoints));
}
void BM_ApplyNumpyOut(benchmark::State& state) { applyFromPython(state, true); }
void BM_ApplyNumpyNew(benchmark::State& state) { applyFromPython(state, false); }

BENCHMARK(BM_ApplyCpp)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ApplyCppNew)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ApplyNumpyOut)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ApplyNumpyNew)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  py::scoped_interpreter python;
  py::module_::import("sys").attr("path").attr("insert")(0, MOUNTCAL_PYTHON_BUILD_DIR);
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
