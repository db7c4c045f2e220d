#!/usr/bin/env bash
# Builds mountcal and runs its whole test suite with CTest.
#   scripts/test.sh             Release build in build/
#   scripts/test.sh --sanitize  AddressSanitizer + UndefinedBehaviorSanitizer build in build-asan/
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# shellcheck source=deps.sh
source "$root/scripts/deps.sh"
# Headless Chromium renders the visual report in tests/test_report.cpp; Snakemake runs the block
# workflow (workflows/block) in tests/test_block.cpp; ccache keeps the objects of unchanged sources
# between builds (CMakeLists.txt uses it when present).
mountcal_ensure_deps chromium snakemake ccache

build="$root/build"; args=(-DCMAKE_BUILD_TYPE=Release)
if [ "${1:-}" = "--sanitize" ]; then
  # -O1 with line tables only: half the compile time of -O2 -g, and stack traces keep file:line.
  # Benchmarks and examples are not run here, so not built.
  build="$root/build-asan"
  args=(-DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG" -DMOUNTCAL_SANITIZE=ON
        -DMOUNTCAL_BUILD_BENCHMARKS=OFF -DMOUNTCAL_BUILD_EXAMPLES=OFF)
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
fi
jobs="$(nproc)"
cmake -S "$root" -B "$build" "${args[@]}" >/dev/null
cmake --build "$build" -j "$jobs"
cd "$build"
ctest --output-on-failure -j "$jobs" --timeout 1500
