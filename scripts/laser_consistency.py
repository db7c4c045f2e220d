#!/usr/bin/env python3
"""Do a sensor's per-laser offsets repeat between calibrations? (docs/real-data-gravity.md)

    scripts/laser_consistency.py RESULT.json RESULT.json [...]

Reads the `intrinsics` of two or more result files of the same scanner (mountcal calibrate) and,
per group of offsets estimated in all of them, compares every laser's values between every two
files against their σ: z = (a − b) / √(σa² + σb²). Prints the number of comparisons, the RMS of z
and how many lie beyond 3σ. Offsets that are properties of the scanner give an RMS near 1; far
above 1, the offsets absorb what differs between the recordings (or their σ are too small).
"""
import itertools
import json
import math
import sys

GROUPS = [("elevation", "laser_elevation_offset_deg", "laser_elevation_sigma_deg"),
          ("azimuth", "laser_azimuth_offset_deg", "laser_azimuth_sigma_deg"),
          ("range", "laser_range_offset_m", "laser_range_sigma_m"),
          ("vertical", "laser_vertical_offset_m", "laser_vertical_sigma_m"),
          ("horizontal", "laser_horizontal_offset_m", "laser_horizontal_sigma_m")]


def main(paths):
    if len(paths) < 2:
        sys.exit(__doc__)
    results = []
    for p in paths:
        with open(p) as f:
            results.append(json.load(f).get("intrinsics", {}))
    for name, value, sigma in GROUPS:
        if not all(value in r and sigma in r for r in results):
            continue
        z = []
        for a, b in itertools.combinations(results, 2):
            for va, vb, sa, sb in zip(a[value], b[value], a[sigma], b[sigma]):
                if sa is not None and sb is not None and sa > 0 and sb > 0:
                    z.append((va - vb) / math.hypot(sa, sb))
        if z:
            rms = math.sqrt(sum(v * v for v in z) / len(z))
            print(f"{name:10s} comparisons {len(z):4d}  RMS of z {rms:5.2f}  beyond 3 sigma {sum(abs(v) > 3 for v in z):3d}"
                  f"  largest {max(abs(v) for v in z):5.1f}")


if __name__ == "__main__":
    main(sys.argv[1:])
