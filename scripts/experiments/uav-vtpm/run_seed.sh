#!/bin/bash
# The uav-vlp16 preset's own VTPM job, one seed: error/σ of every parameter against truth.json.
#   run_seed.sh SEED preset        the preset as it is (a-priori boresight error 0.5°, −0.8°, 1.2°)
#   run_seed.sh SEED drift         the preset with issue 26's Gauss–Markov navigation drift (noise "navigation_drift_gauss_markov")
#   run_seed.sh SEED small         the same survey with a tenth of that error (true boresight 0.05°, −0.08°, 0.12°)
#   run_seed.sh SEED estimated     the preset's job with "vtpm": {"estimate_tie_sigma": true} (the tie σ from the data)
#   run_seed.sh SEED again         picked again: simulated with the `preset` run's result as the mounting used
#                                  (the simulator's picks made there), calibrated again (run `preset` first)
# Prints: seed, then error/σ of lever x, y, z (nan: held), roll, pitch, heading. Scratch in /tmp.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../../.." && pwd)"
s=$1 kind=$2
d=/tmp/mountcal-uav-vtpm/$kind/$s
rm -rf "$d"; mkdir -p "$d"
case $kind in
  preset) echo "{\"preset\": \"uav-vlp16\", \"seed\": $s}" > "$d/scn.json" ;;
  drift) echo "{\"preset\": \"uav-vlp16\", \"seed\": $s, \"noise\": \"navigation_drift_gauss_markov\"}" > "$d/scn.json" ;;
  small) echo "{\"preset\": \"uav-vlp16\", \"seed\": $s, \"true_mounting\": {\"lever_arm_m\": [0.1, -0.05, 0.2], \"boresight_deg\": [0.05, -0.08, 0.12]}}" > "$d/scn.json" ;;
  again) /usr/bin/env python3 - "$s" "/tmp/mountcal-uav-vtpm/preset/$s/r.json" "$d/scn.json" <<'P'
import json, sys
m = json.load(open(sys.argv[2]))["mounting"]
json.dump({"preset": "uav-vlp16", "seed": int(sys.argv[1]), "nominal_mounting": m}, open(sys.argv[3], "w"))
P
  ;;
  estimated) echo "{\"preset\": \"uav-vlp16\", \"seed\": $s}" > "$d/scn.json" ;;
  *) echo "run_seed.sh: kind must be preset, drift, small, estimated or again" >&2; exit 2 ;;
esac
"$root/build/mountcal" simulate "$d/scn.json" --seed "$s" --out "$d/sim" > /dev/null
if [ "$kind" = estimated ]; then
  /usr/bin/env python3 - "$d/sim/job.json" <<'P'
import json, sys
j = json.load(open(sys.argv[1]))
j.setdefault("vtpm", {})["estimate_tie_sigma"] = True
json.dump(j, open(sys.argv[1], "w"), indent=2)
P
fi
"$root/build/mountcal" calibrate "$d/sim/job.json" --result "$d/r.json" > "$d/cal.txt" 2>&1 || true
/usr/bin/env python3 - "$d" "$s" "$root/scripts/experiments" <<'P'
import sys
sys.path.insert(0, sys.argv[3])
import result_vs_truth
d = sys.argv[1]
est, truth, sig = result_vs_truth.read(d)
print(sys.argv[2], " ".join("%.2f" % ((e - x) / s) if s else "nan" for e, x, s in zip(est, truth, sig)))
P
