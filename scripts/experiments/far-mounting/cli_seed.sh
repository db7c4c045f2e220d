#!/bin/bash
# The far mounting through the command line (the restart with correspondences, 2026-12-05):
#   cli_seed.sh SEED METHOD [far-lever]
# METHOD correspondences or auto (planes "auto"). The crossing field simulated with the true
# boresight (0.25°, −0.30°, 0.40°), points within 12 m of the features; with `far-lever` the
# strips are georeferenced with a lever arm (0.9, −0.7, 0.2) m used, 1 m from the truth. The
# simulated job calibrates all six parameters with its ground control, default options.
# Prints: error and |error|/σ per parameter, then the verdict's first words. Scratch in /tmp.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../../.." && pwd)"
s=$1 m=$2 far=${3:-}
d=/tmp/mountcal-far-cli/$m${far:+-$far}/$s
rm -rf "$d"; mkdir -p "$d"
nominal=""
[ "$far" = far-lever ] && nominal='"nominal_mounting": {"lever_arm_m": [0.9, -0.7, 0.2], "boresight_deg": [0, 0, 0]},'
echo "{\"preset\": \"paper-calibration-field\", \"seed\": $s, \"noise\": \"realistic\", \"roi_radius_m\": 12, $nominal
 \"true_mounting\": {\"lever_arm_m\": [0.10, -0.05, 0.20], \"boresight_deg\": [0.25, -0.30, 0.40]}}" > "$d/scn.json"
"$root/build/mountcal" simulate "$d/scn.json" --seed "$s" --out "$d/sim" > /dev/null
/usr/bin/env python3 - "$d" "$m" <<'P'
import json, sys
d, m = sys.argv[1], sys.argv[2]
j = json.load(open(d + "/sim/job.json"))
j["method"] = "planes" if m == "auto" else m
if m == "auto":
    j["planes"] = "auto"
else:
    j.pop("planes", None)
j.pop("ties", None)
j.pop("solver", None)
j["gcps"] = "gcps.csv"
j["estimate"] = {"lever_arm": [True, True, True], "boresight": [True, True, True]}
json.dump(j, open(d + "/sim/job_far.json", "w"), indent=1)
P
"$root/build/mountcal" calibrate "$d/sim/job_far.json" --result "$d/r.json" > "$d/cal.txt" 2>&1 || true
/usr/bin/env python3 - "$d" "$s" "$root/scripts/experiments" <<'P'
import sys
sys.path.insert(0, sys.argv[3])
import result_vs_truth
d = sys.argv[1]
est, truth, sig = result_vs_truth.read(d)
v = [l for l in open(d + "/cal.txt").read().splitlines() if l.startswith("Verdict")]
print(sys.argv[2], " ".join("%.3g(%.1fσ)" % (e - x, abs(e - x) / s) for e, x, s in zip(est, truth, sig)), "|", v[0][:70] if v else "no verdict")
P
