#!/usr/bin/env python3
"""The pass-to-pass discrepancy of Gravity Truck over a grid of boresights (no per-laser offsets):
how low can any boresight of SPEC §2's model bring the 90th percentile? (issue 28; 2026-12-05)

Usage: boresight_grid.py JOB RESULT METRIC CENTRE STEP N
  JOB, RESULT  a Gravity job (strip paths absolute) and a result of it: its mounting's lever arm is
               kept, its boresight replaced by each grid point, its `intrinsics` dropped
  METRIC       ours: `mountcal evaluate` (the project's metric, plane gates chosen in each state);
               ungated: `mountcal apply` then scripts/pass_discrepancy.py's "ungated, fixed" variant
               (issue 28's wording: every point with a neighbour within 1 m in both states);
               the second needs PYTHONPATH=build/python and scipy (a k-d tree for the neighbours)
  CENTRE       roll,pitch,heading [deg]; STEP: three steps [deg]; N: grid points N on each side
Prints the eight grid points of lowest P90 (P90, median, points, boresight) and the lowest median.
"""
import itertools
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
MOUNTCAL = os.path.join(ROOT, "build", "mountcal")


def main(argv):
    if len(argv) != 7:
        print(__doc__, file=sys.stderr)
        return 2
    job, result, metric = argv[1], argv[2], argv[3]
    centre = np.array([float(t) for t in argv[4].split(",")])
    step = np.array([float(t) for t in argv[5].split(",")])
    n = int(argv[6])
    base = json.load(open(result))
    base.pop("intrinsics", None)
    tmp = tempfile.mkdtemp()
    if metric == "ungated":
        sys.path.insert(0, os.path.join(ROOT, "scripts"))
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        import pass_discrepancy as pd
        import fast_nearest

        fast_nearest.use(pd)
        before = pd.passes(job)
        q = 0 if len(before[0]) <= len(before[1]) else 1

    def evaluate(b):
        r = dict(base)
        r["mounting"] = dict(base["mounting"], boresight_deg=[float(v) for v in b])
        path = os.path.join(tmp, "result.json")
        json.dump(r, open(path, "w"))
        if metric == "ours":
            out = subprocess.run([MOUNTCAL, "evaluate", job, "--result", path], capture_output=True, text=True, check=True).stdout
            f = out.splitlines()[4].split()  # the pair's line: ids, points, used, median, RMS, P90 before/after
            return float(f[9]), float(f[5]), int(f[3])
        out_dir = os.path.join(tmp, "out")
        subprocess.run([MOUNTCAL, "apply", job, "--result", path, "--out", out_dir], capture_output=True, check=True)
        j = json.load(open(job))
        for s in j["strips"]:
            s["path"] = os.path.join(out_dir, os.path.basename(s["path"]))
        after_job = os.path.join(tmp, "after.json")
        json.dump(j, open(after_job, "w"))
        a = pd.passes(after_job)
        s = pd.variants([before[q], before[1 - q]], [a[q], a[1 - q]])["ungated_fixed"][1]
        return s["p90_m"], s["median_m"], s["points"]

    rows = []
    for i, j, k in itertools.product(range(-n, n + 1), repeat=3):
        b = centre + step * np.array([i, j, k])
        p90, med, pts = evaluate(b)
        rows.append((round(p90, 4), round(med, 4), pts, tuple(np.round(b, 4))))
    rows.sort()
    for r in rows[:8]:
        print("P90 %.4f  median %.4f  points %d  boresight %s" % r)
    print("lowest median: P90 %.4f  median %.4f  points %d  boresight %s" % min(rows, key=lambda r: r[1]))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
