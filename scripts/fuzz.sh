#!/usr/bin/env bash
# Builds the libFuzzer targets of the LAS and SBET readers with clang (ASan + UBSan) and runs
# each for a bounded time (default 60 s). Seeds come from ../shared/data when it is there.
#   scripts/fuzz.sh [SECONDS]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# shellcheck source=deps.sh
source "$root/scripts/deps.sh"
mountcal_ensure_deps clang libclang-rt-14-dev
seconds="${1:-60}"
out="$root/build-fuzz"
mkdir -p "$out/corpus_las" "$out/corpus_sbet"
flags=(-std=c++17 -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined
       -I"$root/include" -I/usr/include/eigen3)
clang++ "${flags[@]}" -o "$out/fuzz_las" "$root/tests/fuzz/fuzz_las.cpp" "$root/src/io/las.cpp" "$root/src/error.cpp"
clang++ "${flags[@]}" -o "$out/fuzz_sbet" "$root/tests/fuzz/fuzz_sbet.cpp" "$root/src/io/sbet.cpp" \
  "$root/src/io/csv.cpp" "$root/src/io/atomic_file.cpp" "$root/src/geodesy.cpp" "$root/src/trajectory.cpp" "$root/src/error.cpp"
data="$root/../shared/data"
if [ -d "$data" ]; then
  cp -f "$data/leeward/points.las" "$out/corpus_las/" 2>/dev/null || true
  cp -f "$data/pdal/2-points.sbet" "$data/pdal/badfile.sbet" "$data/leeward/sbet.out" "$out/corpus_sbet/" 2>/dev/null || true
else
  echo "fuzz: ../shared/data not found; starting from empty corpora"
fi
for target in las sbet; do
  echo "fuzz: $target for ${seconds} s"
  "$out/fuzz_$target" -max_total_time="$seconds" -max_len=65536 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$out/" \
    "$out/corpus_$target" > "$out/fuzz_$target.log" 2>&1 || { tail -40 "$out/fuzz_$target.log"; echo "fuzz: $target FAILED"; exit 1; }
  grep -E "stat::number_of_executed_units|Done" "$out/fuzz_$target.log" | tail -2
done
echo "fuzz: no crash, no sanitizer report"
