#!/usr/bin/env bash
# Builds mountcal and runs the main job: the first paper's experiments on simulated surveys
# with known truth — calibration on the crossing field (Table 1), correction of the check block
# (Tables 2 and 3) — printed as tables; then the same field calibrated by every method.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# shellcheck source=deps.sh
source "$root/scripts/deps.sh"
mountcal_ensure_deps
build="$root/build"
mapfile -t generator < <(mountcal_generator "$build")
cmake -S "$root" -B "$build" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j "$(nproc)" --target vtpm_paper_experiment method_comparison
"$build/examples/vtpm_paper_experiment" "$@"
echo
# The same field calibrated by every method of the one adjustment (VTPM, planes, correspondences).
"$build/examples/method_comparison"
