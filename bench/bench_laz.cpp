// LAZ throughput (issue "LAZ: read and write compressed strips natively"): decoding and encoding
// in points per second on one core (the chunk codecs called in a loop) and on all cores
// (LasReader / LasWriter, which decode and encode one chunk per core, file I/O included), and the
// compression ratio — on the largest reference file (../shared/data/laz, 697,721 points, format
// 8 + 3 extra bytes, 14 chunks) and on a simulated 10 M-point line-scanner strip (format 6).
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include "mountcal/io/las.hpp"
#include "mountcal/io/laz.hpp"

using namespace mountcal::io;
namespace fs = std::filesystem;

namespace {

const std::string kLargest = std::string(MOUNTCAL_SHARED_DIR) + "/data/laz/las_with_several_extra_byte_bloc.laz";

struct Strip {
  LasHeader header;
  std::vector<std::uint8_t> records;
  std::vector<LazChunk> chunks;  // as compressed in the original (largest file)
  std::vector<std::vector<std::uint8_t>> compressed;
  std::uint64_t points() const { return records.size() / header.point_record_length; }
};

Strip& largest() {
  static Strip s = [] {
    Strip s;
    if (!fs::exists(kLargest)) return s;
    LasReader r(kLargest);
    s.header = r.header();
    std::vector<std::uint8_t> part;
    while (r.readRaw(&part, 1u << 20) > 0) s.records.insert(s.records.end(), part.begin(), part.end());
    std::ifstream in(kLargest, std::ios::binary);
    for (const LazChunk& c : r.lazChunks()) {
      s.chunks.push_back(c);
      std::vector<std::uint8_t> b(c.bytes);
      in.seekg(static_cast<std::streamoff>(c.offset));
      in.read(reinterpret_cast<char*>(b.data()), static_cast<std::streamsize>(b.size()));
      s.compressed.push_back(std::move(b));
    }
    return s;
  }();
  return s;
}

/// 10 M pulses of a line scanner: 100 lines/s, 1000 pulses a line over ±30°, 60 m above gentle
/// terrain, mm coordinates, a GPS time per pulse, intensity from the range, single returns.
Strip& simulated() {
  static Strip s = [] {
    Strip s;
    s.header.version_minor = 4;
    s.header.point_format = 6;
    s.header.point_record_length = 30;
    const std::size_t n = 10'000'000;
    s.records.resize(n * 30);
    std::mt19937 rng(7);
    std::normal_distribution<double> noise(0.0, 0.02);
    for (std::size_t i = 0; i < n; ++i) {
      const double t = 1.0e5 + static_cast<double>(i) * 1e-5;
      const std::size_t line = i / 1000, k = i % 1000;
      const double angle = (static_cast<double>(line % 2 ? 999 - k : k) / 999.0 - 0.5) * (M_PI / 3);
      const double x = static_cast<double>(i) * 5e-5 * 10;  // 5 m/s along track
      const double y = 60.0 * std::tan(angle);
      const double z = 2.0 * std::sin(x / 20) + 1.5 * std::cos(y / 15) + noise(rng);
      std::uint8_t* r = s.records.data() + i * 30;
      const std::int32_t X = static_cast<std::int32_t>(std::lround(x * 1000)), Y = static_cast<std::int32_t>(std::lround(y * 1000)),
                         Z = static_cast<std::int32_t>(std::lround(z * 1000));
      const std::uint16_t intensity = static_cast<std::uint16_t>(800 - 5 * std::abs(y) + (rng() % 40));
      const std::int16_t scan = static_cast<std::int16_t>(std::lround(angle * 180 / M_PI / 0.006));
      std::memcpy(r, &X, 4);
      std::memcpy(r + 4, &Y, 4);
      std::memcpy(r + 8, &Z, 4);
      std::memcpy(r + 12, &intensity, 2);
      r[14] = 0x11;
      r[15] = static_cast<std::uint8_t>((line % 2) << 6);
      r[16] = 2;
      r[17] = 0;
      std::memcpy(r + 18, &scan, 2);
      const std::uint16_t source = 1;
      std::memcpy(r + 20, &source, 2);
      std::memcpy(r + 22, &t, 8);
    }
    const LazVlr vlr = lazVlrFor(6, 30);
    for (std::size_t first = 0; first < n; first += vlr.chunk_size) {
      const std::size_t points = std::min<std::size_t>(vlr.chunk_size, n - first);
      s.compressed.push_back(encodeLazChunk(vlr, s.records.data() + first * 30, points));
      s.chunks.push_back({0, s.compressed.back().size(), points});
    }
    return s;
  }();
  return s;
}

Strip& strip(int which) { return which == 0 ? largest() : simulated(); }

void ratio(benchmark::State& state, const Strip& s) {
  double bytes = 0;
  for (const auto& c : s.compressed) bytes += static_cast<double>(c.size());
  state.counters["ratio"] = bytes / static_cast<double>(s.records.size());
  state.counters["points/s"] = benchmark::Counter(static_cast<double>(s.points()), benchmark::Counter::kIsIterationInvariantRate);
}

void decodeOneCore(benchmark::State& state) {
  Strip& s = strip(static_cast<int>(state.range(0)));
  if (s.records.empty()) return state.SkipWithError(("data not found: " + kLargest).c_str());
  const LazVlr vlr = lazVlrFor(s.header.point_format, s.header.point_record_length);
  std::vector<std::uint8_t> out(s.records.size());
  for (auto _ : state) {
    std::size_t first = 0;
    for (std::size_t i = 0; i < s.chunks.size(); ++i) {
      decodeLazChunk(vlr, s.compressed[i].data(), s.compressed[i].size(), s.chunks[i].points, out.data() + first, "bench", "chunk");
      first += s.chunks[i].points * s.header.point_record_length;
    }
    benchmark::DoNotOptimize(out.data());
  }
  if (out != s.records) state.SkipWithError("decoded records differ");
  ratio(state, s);
}

void encodeOneCore(benchmark::State& state) {
  Strip& s = strip(static_cast<int>(state.range(0)));
  if (s.records.empty()) return state.SkipWithError(("data not found: " + kLargest).c_str());
  const LazVlr vlr = lazVlrFor(s.header.point_format, s.header.point_record_length);
  for (auto _ : state) {
    std::size_t bytes = 0;
    for (std::size_t first = 0; first < s.points(); first += vlr.chunk_size)
      bytes += encodeLazChunk(vlr, s.records.data() + first * s.header.point_record_length,
                              std::min<std::size_t>(vlr.chunk_size, s.points() - first))
                   .size();
    benchmark::DoNotOptimize(bytes);
  }
  ratio(state, s);
}

std::string fileOf(int which) {
  return (fs::temp_directory_path() / (which == 0 ? "mountcal_bench_largest.laz" : "mountcal_bench_sim.laz")).string();
}

void encodeAllCores(benchmark::State& state) {
  Strip& s = strip(static_cast<int>(state.range(0)));
  if (s.records.empty()) return state.SkipWithError(("data not found: " + kLargest).c_str());
  for (auto _ : state) {
    LasWriter w(fileOf(static_cast<int>(state.range(0))), s.header);
    w.writeRaw(s.records.data(), s.points());
    w.close();
  }
  state.counters["file_ratio"] =
      static_cast<double>(fs::file_size(fileOf(static_cast<int>(state.range(0))))) / static_cast<double>(s.records.size());
  state.counters["points/s"] = benchmark::Counter(static_cast<double>(s.points()), benchmark::Counter::kIsIterationInvariantRate);
}

void decodeAllCores(benchmark::State& state) {
  Strip& s = strip(static_cast<int>(state.range(0)));
  if (s.records.empty()) return state.SkipWithError(("data not found: " + kLargest).c_str());
  const std::string path = fileOf(static_cast<int>(state.range(0)));
  if (!fs::exists(path)) {
    LasWriter w(path, s.header);
    w.writeRaw(s.records.data(), s.points());
    w.close();
  }
  std::vector<std::uint8_t> part;
  for (auto _ : state) {
    LasReader r(path);
    std::uint64_t n = 0;
    while (r.readRaw(&part, 1u << 20) > 0) n += part.size();
    benchmark::DoNotOptimize(n);
  }
  state.counters["points/s"] = benchmark::Counter(static_cast<double>(s.points()), benchmark::Counter::kIsIterationInvariantRate);
}

}  // namespace

// Argument 0: the largest reference file; 1: the simulated 10 M-point strip.
BENCHMARK(decodeOneCore)
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(3)
    ->ReportAggregatesOnly(true)
    ->UseRealTime();
BENCHMARK(decodeAllCores)
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(3)
    ->ReportAggregatesOnly(true)
    ->UseRealTime();
BENCHMARK(encodeOneCore)
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(3)
    ->ReportAggregatesOnly(true)
    ->UseRealTime();
BENCHMARK(encodeAllCores)
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(3)
    ->ReportAggregatesOnly(true)
    ->UseRealTime();

BENCHMARK_MAIN();
