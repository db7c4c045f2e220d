#!/usr/bin/env python3
"""Calibrates the Gravity Truck passes (two passes of a UAV's HDL-32E over a truck, SPEC §5) from
Python, prints the mounting with its σ and the pass-to-pass discrepancy before and after, and
plots it: a thin vertical profile through the truck, both passes, at the mounting the files were
written with and at the calibrated one, and the median discrepancy by laser.

Usage: gravity_truck.py [JOB] [--out truck_discrepancy.png]
"""
import argparse
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import mountcal  # noqa: E402

HERE = pathlib.Path(__file__).resolve().parent


def profile(points_a, points_b, width_m=0.08):
    """Both passes' points within width_m/2 of a vertical plane through the truck's long axis:
    (distance along the axis, height) of each."""
    xy = points_a[:, :2]
    centre = np.median(xy, axis=0)
    _, _, vt = np.linalg.svd(xy - centre, full_matrices=False)
    along, across = vt[0], vt[1]
    out = []
    for p in (points_a, points_b):
        d = p[:, :2] - centre
        keep = np.abs(d @ across) < width_m / 2
        out.append((d[keep] @ along, p[keep, 2]))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("job", nargs="?", default=str(HERE.parent / "gravity" / "truck.json"))
    ap.add_argument("--out", default="truck_discrepancy.png")
    args = ap.parse_args()

    # One call, as `mountcal calibrate` does: the result file's content, with its evaluation.
    result = mountcal.calibrate_job(args.job)
    bore, sigma = result["mounting"]["boresight_deg"], result["sigma"]["boresight_deg"]
    print("boresight [deg]: " + ", ".join(f"{b:+.4f} ± {s:.4f}" for b, s in zip(bore, sigma)))
    print(f"verdict: {result['verdict']['kind']}")
    pair = result["evaluation"]["discrepancy"][0]
    for when in ("before", "after"):
        d = pair[when]
        print(f"discrepancy {when}: median {d['median_m']:.4f} m, 90th percentile {d['p90_m']:.4f} m")

    # Step by step, for the points: the same job's data, calibrated, georeferenced both ways.
    job = mountcal.read_job(args.job)
    data = mountcal.load_job_data(job)
    summary = mountcal.calibrate(data)
    ids = data.strip_ids
    before = profile(data.points(ids[0], job.mounting_used), data.points(ids[1], job.mounting_used))
    after = profile(data.points(ids[0], summary.mounting), data.points(ids[1], summary.mounting))

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5), gridspec_kw={"width_ratios": [1, 1, 1.2]})
    for ax, (title, prof) in zip(axes[:2], [("as delivered (boresight 0)", before), ("calibrated mounting", after)]):
        for (s, z), name, colour in zip(prof, ids, ("tab:blue", "tab:orange")):
            ax.scatter(s, z, s=1.5, c=colour, label=name)
        ax.set_title(f"profile through the truck, {title}")
        ax.set_xlabel("along the profile [m]")
        ax.set_ylabel("height [m]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.legend(markerscale=6, loc="lower right")
    lasers = result["evaluation"]["discrepancy_breakdown"]["by_laser"]
    ids_l = np.array([int(c["class"].split()[-1]) for c in lasers])
    for when, colour in (("before", "tab:red"), ("after", "tab:green")):
        axes[2].plot(ids_l, [c[when]["median_m"] for c in lasers], "o-", c=colour, label=when)
    axes[2].set_yscale("log")
    axes[2].set_xlabel("laser id (HDL-32E)")
    axes[2].set_ylabel("median point-to-plane discrepancy [m]")
    axes[2].set_title("pass-to-pass discrepancy by laser")
    axes[2].legend()
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
