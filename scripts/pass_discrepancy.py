#!/usr/bin/env python3
"""The pass-to-pass discrepancy of two strips, written again from its definition with numpy alone
(no mountcal code computes it here), in the variants that tell the project's metric
(`mountcal evaluate`) from issue 28's independent one:

  * ours: every point of the smaller pass against the least-squares plane of its 10 nearest in the
    other, where those neighbours make a plane (σ_min ≤ 2 cm, √(λ_mid/λ_max) ≥ 0.2, √λ_max ≤ 0.3 m,
    nearest within 1 m) — chosen again in each state;
  * ungated: the same distances without the plane gates, on one fixed point set (the points with a
    neighbour within 1 m in the other pass both before and after);
  * gated, fixed: the plane gates passed in both states, one fixed point set.

Usage: scripts/pass_discrepancy.py BEFORE_JOB AFTER_JOB
  BEFORE_JOB: a job whose strips are the original files; AFTER_JOB: the same job with every strip's
  path pointing at the file `mountcal apply` wrote. Prints median and P90 of each variant.
Needs the Python module (PYTHONPATH=build/python) to read the strips.
"""
import sys

import numpy as np


def nearest(query, reference, k=10, chunk=256):
    """Indices and distances of the k nearest reference points of each query point (brute force)."""
    idx = np.empty((len(query), k), dtype=np.int64)
    dist = np.empty((len(query), k))
    r2 = np.einsum("ij,ij->i", reference, reference)
    for a in range(0, len(query), chunk):
        q = query[a:a + chunk]
        d2 = np.einsum("ij,ij->i", q, q)[:, None] + r2[None, :] - 2.0 * q @ reference.T
        part = np.argpartition(d2, k - 1, axis=1)[:, :k]
        pd = np.take_along_axis(d2, part, axis=1)
        order = np.argsort(pd, axis=1)
        idx[a:a + chunk] = np.take_along_axis(part, order, axis=1)
        dist[a:a + chunk] = np.sqrt(np.maximum(np.take_along_axis(pd, order, axis=1), 0.0))
    return idx, dist


def plane_distances(query, reference, k=10):
    """|distance| of each query point to the plane of its k nearest, the nearest's distance, and
    whether the neighbours pass the plane gates."""
    origin = reference.mean(axis=0)  # coordinates near the origin: the squares stay exact enough
    q, r = query - origin, reference - origin
    idx, dist = nearest(q, r, k)
    nb = r[idx]
    c = nb.mean(axis=1)
    x = nb - c[:, None, :]
    w, v = np.linalg.eigh(np.einsum("nki,nkj->nij", x, x) / k)
    w = np.maximum(w, 0.0)
    normal = v[:, :, 0]
    d = np.abs(np.einsum("ni,ni->n", normal, q - c))
    ok = (np.sqrt(w[:, 0]) <= 0.02) & (np.sqrt(w[:, 1] / np.maximum(w[:, 2], 1e-300)) >= 0.2) & (np.sqrt(w[:, 2]) <= 0.3)
    return d, dist[:, 0], ok


def variants(before, after):
    """before, after: [query points, reference points] of each state (the same points, moved)."""
    db, nb, okb = plane_distances(*before)
    da, na, oka = plane_distances(*after)
    ours_b, ours_a = (nb < 1.0) & okb, (na < 1.0) & oka
    fixed = (nb < 1.0) & (na < 1.0)
    both = fixed & okb & oka

    def stats(d, m):
        return {"points": int(m.sum()), "median_m": float(np.median(d[m])), "p90_m": float(np.percentile(d[m], 90))}

    return {
        "ours": (stats(db, ours_b), stats(da, ours_a)),
        "ungated_fixed": (stats(db, fixed), stats(da, fixed)),
        "gated_fixed": (stats(db, both), stats(da, both)),
    }


def passes(job_path):
    import mountcal
    data = mountcal.load_job_data(mountcal.read_job(job_path))
    xs = [np.asarray(data.strip(i)["x_m"], dtype=float) for i in range(len(data))]
    if len(xs) != 2:
        raise SystemExit(f"{job_path}: two strips expected, found {len(xs)}")
    return xs


def compare(before_job, after_job):
    """variants() of the two jobs' passes, the smaller pass querying, as mountcal evaluate does."""
    b, a = passes(before_job), passes(after_job)
    if [len(p) for p in b] != [len(p) for p in a]:
        raise SystemExit(f"{before_job}, {after_job}: the passes differ in their points")
    q = 0 if len(b[0]) <= len(b[1]) else 1
    return variants([b[q], b[1 - q]], [a[q], a[1 - q]])


def main(argv):
    if len(argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    out = compare(argv[1], argv[2])
    for name, (sb, sa) in out.items():
        print(f"{name:14s} points {sb['points']:6d} / {sa['points']:6d}  median {sb['median_m']:.4f} / {sa['median_m']:.4f} m"
              f"  P90 {sb['p90_m']:.4f} / {sa['p90_m']:.4f} m")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
