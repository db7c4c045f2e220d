#!/usr/bin/env python3
"""RMS of error/σ, share within 2σ, worst and mean per parameter, from run_seed.sh lines on stdin."""
import math
import sys

rows = [[float(x) for x in line.split()[1:]] for line in sys.stdin if line.strip()]
print(len(rows), "seeds")
for k, name in enumerate(["lever_arm_x", "lever_arm_y", "lever_arm_z", "boresight_roll", "boresight_pitch", "boresight_heading"]):
    v = [r[k] for r in rows if not math.isnan(r[k])]
    if v:
        print("%-18s RMS %.2f  within 2σ %d/%d  worst %.1f  mean %+.2f" % (
            name, math.sqrt(sum(x * x for x in v) / len(v)), sum(abs(x) <= 2 for x in v), len(v), max(abs(x) for x in v), sum(v) / len(v)))
