#!/usr/bin/env bash
# Builds mountcal and runs the main job: the paper's error curves (Figs 1-3) today; the simulated
# survey calibrated end to end once the calibrators land.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# shellcheck source=deps.sh
source "$root/scripts/deps.sh"
mountcal_ensure_deps
build="$root/build"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j "$(nproc)"
out="$root/build/demo"
mkdir -p "$out"
"$build/examples/error_curves" --out "$out"
