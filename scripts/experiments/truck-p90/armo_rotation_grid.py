#!/usr/bin/env python3
"""Gravity Truck's discrepancy under a world-frame rotation of each pass about its sensor positions,
in the form of `apply_rotation` in ARMO's algos/Lidar_utils.h (lanl-ansi/ARMO, read to learn the
transform it applies; nothing of it is used here): x' = p + Rz(yaw) Ry(roll) Rx(pitch) (x − p) for the
first pass, roll and yaw negated for the second (MODE armo), or the same rotation for both (MODE same).
(issue 28, 2026-12-05)

Usage: armo_rotation_grid.py LAS MODE CENTRE STEP N
  LAS    Truck.las (LAS 1.2 PDRF 3 with Gravity's extra bytes: frameNo, SensorX/Y/Z)
  CENTRE roll,pitch,yaw [deg]; STEP three steps [deg]; N grid points on each side
Prints the six lowest P90 of scripts/pass_discrepancy.py's "ungated, fixed" variant (with the
median, and the project's metric's P90 and median beside them).
Needs PYTHONPATH=build/python (pass_discrepancy imports the module) and scipy.
"""
import itertools
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", ".."))
sys.path.insert(0, os.path.dirname(__file__))
import pass_discrepancy as pd  # noqa: E402
import fast_nearest  # noqa: E402

fast_nearest.use(pd)


def read(path):
    raw = open(path, "rb").read()
    off = int.from_bytes(raw[96:100], "little")
    rl = int.from_bytes(raw[105:107], "little")
    n = int.from_bytes(raw[107:111], "little")
    scale = np.frombuffer(raw[131:155], "<f8")
    offset = np.frombuffer(raw[155:179], "<f8")
    rec = np.frombuffer(raw[off:off + n * rl], dtype=np.uint8).reshape(n, rl)
    xyz = rec[:, 0:12].copy().view("<i4").reshape(n, 3) * scale + offset
    frame = rec[:, 34:38].copy().view("<i4").ravel()  # extra bytes after the 34 bytes of PDRF 3
    sensor = rec[:, 38:62].copy().view("<f8").reshape(n, 3)
    return xyz, frame, sensor


def rotation(r, p, y):
    b, g, a = np.radians([r, p, y])
    Rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    Ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    Rx = np.array([[1, 0, 0], [0, np.cos(g), -np.sin(g)], [0, np.sin(g), np.cos(g)]])
    return Rz @ Ry @ Rx


def main(argv):
    if len(argv) != 6:
        print(__doc__, file=sys.stderr)
        return 2
    xyz, frame, sensor = read(argv[1])
    mode = argv[2]
    centre = np.array([float(t) for t in argv[3].split(",")])
    step = np.array([float(t) for t in argv[4].split(",")])
    n = int(argv[5])
    frames = np.unique(frame)
    cut = frames[np.argmax(np.diff(frames))]  # the two passes: the frame numbers' largest gap
    A = frame <= cut
    B = ~A
    o = sensor.mean(0)
    x0, s0 = xyz - o, sensor - o
    before = [x0[A], x0[B]]
    q = 0 if A.sum() <= B.sum() else 1
    rows = []
    for i, j, k in itertools.product(range(-n, n + 1), repeat=3):
        r, p, y = centre + step * np.array([i, j, k])
        second = (-r, p, -y) if mode == "armo" else (r, p, y)
        after = [s0[A] + (x0[A] - s0[A]) @ rotation(r, p, y).T, s0[B] + (x0[B] - s0[B]) @ rotation(*second).T]
        try:
            v = pd.variants([before[q], before[1 - q]], [after[q], after[1 - q]])
        except (IndexError, ValueError):  # no point passes the gates at this rotation
            continue
        u, ours = v["ungated_fixed"][1], v["ours"][1]
        rows.append((u["p90_m"], u["median_m"], ours["p90_m"], ours["median_m"], (round(r, 3), round(p, 3), round(y, 3))))
    rows.sort()
    for row in rows[:6]:
        print("ungated P90 %.4f median %.4f | ours P90 %.4f median %.4f | angles %s" % row)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
