#!/usr/bin/env bash
# Builds mountcal and runs its whole test suite with CTest.
#   scripts/test.sh             Release build in build/
#   scripts/test.sh --sanitize  AddressSanitizer + UndefinedBehaviorSanitizer build in build-asan/
# MOUNTCAL_BUILD_ONLY=1 builds without running the tests.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# shellcheck source=deps.sh
source "$root/scripts/deps.sh"
# Headless Chromium renders the visual report in tests/test_report.cpp; Snakemake runs the block
# workflow (workflows/block) in tests/test_block.cpp; ccache keeps the objects of unchanged sources
# between builds (CMakeLists.txt uses it when present); munge and slurm-wlm make the one-node Slurm
# cluster of tests/slurm/slurm_workflow.sh (its daemons are started and stopped by the test).
mountcal_ensure_deps chromium snakemake ccache munge slurm-wlm

# MOUNTCAL_CCACHE=OFF (.ci/run sets it): a clean machine has an empty cache, and a miss costs
# ccache's preprocessing pass on top of the compile (+12 % on a library source, 2026-11-26).
# One object per library source (not a unity build, which built the library in 396 against 544
# CPU-seconds, 2026-12-05): the fuzzers (scripts/fuzz.sh) link their instrumented readers and job
# schema against this library, replacing those sources' objects — a batch object holding one of
# them defines it twice. -O2 instead of -O3 was tried the same hour: 16 % less CPU to build, but
# the heavy tests ran 12 % longer.
build="$root/build"; kind=release
args=(-DCMAKE_BUILD_TYPE=Release "-DMOUNTCAL_CCACHE=${MOUNTCAL_CCACHE:-ON}")
if [ "${1:-}" = "--sanitize" ]; then
  # -O2 with line tables only (stack traces keep file:line). -O1 compiled in 9 % less CPU time
  # (770 against 843 CPU-seconds) but left Eigen's small products and Ceres' numeric differences
  # uninlined: the heavy tests ran 15-20 % longer (five of them, 155 against 129 s, 2026-11-29).
  # A unity build: the instrumented instantiations of Eigen, Ceres and GoogleTest templates are
  # compiled once per batch of sources, not once per source (the Release build stays one object
  # per source, so that a source missing an include still fails somewhere).
  # Benchmarks and examples are not run here, so not built.
  # Compiled by clang (Debian's clang 14, which the fuzzers use too): it builds the instrumented
  # library and tests in 27 % less CPU time than GCC (695 against 950 CPU-seconds, 2026-11-27);
  # the suite then runs 7 % longer (1297 against 1217 s). The Release build stays GCC's.
  mountcal_ensure_deps clang libclang-rt-14-dev
  build="$root/build-asan"; kind=sanitize
  args=(-DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG" -DMOUNTCAL_SANITIZE=ON
        -DCMAKE_UNITY_BUILD=ON -DMOUNTCAL_BUILD_BENCHMARKS=OFF -DMOUNTCAL_BUILD_EXAMPLES=OFF "-DMOUNTCAL_CCACHE=${MOUNTCAL_CCACHE:-ON}")
  # malloc_context_size=5: ASan records 5 frames of each allocation's and free's stack, not 30 —
  # 6 % less time on two heavy tests (32.6 → 30.7 s, 2026-11-28); an error's own stack stays whole.
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:malloc_context_size=5 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
fi
jobs="$(nproc)"
mapfile -t generator < <(mountcal_generator "$build")
cmake -S "$root" -B "$build" "${generator[@]}" "${args[@]}" >/dev/null
cmake --build "$build" -j "$jobs"
# MOUNTCAL_BUILD_ONLY=1: configure and build, no tests (.ci/run builds the sanitizer tree while the
# Release suite runs).
[ "${MOUNTCAL_BUILD_ONLY:-0}" = 1 ] && exit 0
cd "$build"
# The tests' run times of an earlier suite (tests/costs/), so that CTest starts the longest first
# and two cores are not left with one long test at the end; once it has run here, its own.
mkdir -p Testing/Temporary
[ -f Testing/Temporary/CTestCostData.txt ] || cp "$root/tests/costs/$kind.txt" Testing/Temporary/CTestCostData.txt
# The Release suite runs one test more than cores: a part of it waits on other programs (the Slurm
# test's daemons, Snakemake, Chromium, the Python tests' interpreters — the Slurm test used 40 s of
# CPU in 88 s), and a third test fills those waits (462 s at -j3 where -j2 took about 498 s, 2026-11-28).
# The sanitizer suite runs one per core: its instrumented tests are CPU-bound, and at -j3 each ran
# 1.5 times as long and the suite took 867 s against 788 s (clean-clone CI runs, 2026-11-28).
ctest_jobs=$((jobs + 1))
[ "$kind" = sanitize ] && ctest_jobs=$jobs
ctest --output-on-failure -j "$ctest_jobs" --timeout 1500
