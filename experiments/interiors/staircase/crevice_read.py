"""What the basis read would give if it read nothing at points in a crevice (issue #32).

    python3 crevice_read.py MESH.obj REFERENCE.csv BASIS.csv D_MIN

An offline what-if, not the solver: at each point of REFERENCE.csv the crevice test of
ALGORITHM.md §3.3 (8 stratified cosine-distributed rays, a crevice where at least 7 hit
something within D_MIN; here against the OBJ's triangles by brute force, with its own
rotation) decides whether the point is one where the hierarchy puts no node; the basis
read (`meshrad probe --set final_gather=0`, BASIS.csv) is then set to 0 at those points
and the indirect-only stratum's rel-RMS and median compared (floors as
experiments/area-accuracy/errors_at_points.py). D_MIN: the crevice distance, the finest
level's radius (the staircase: 1.95 m / 2^5 = 0.061 m).
"""
import csv
import sys

import numpy as np


def load(path):
    v, f = [], []
    for line in open(path):
        if line.startswith("v "):
            v.append([float(x) for x in line.split()[1:4]])
        elif line.startswith("f "):
            idx = [int(t.split("/")[0]) for t in line.split()[1:]]
            idx = [i - 1 if i > 0 else len(v) + i for i in idx]
            f += [[idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1)]
    v, f = np.array(v), np.array(f)
    return v[f[:, 0]], v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]


def nearest(tris, o, d):
    a, e1, e2 = tris
    p = np.cross(d, e2)
    det = (e1 * p).sum(1)
    with np.errstate(all="ignore"):
        inv = 1.0 / det
        s = o - a
        u = (s * p).sum(1) * inv
        q = np.cross(s, e1)
        w = (q * d).sum(1) * inv
        t = (q * e2).sum(1) * inv
        ok = (np.abs(det) > 1e-12) & (u >= 0) & (w >= 0) & (u + w <= 1) & (t > 1e-4)
    return np.min(np.where(ok, t, np.inf))


def in_crevice(tris, x, n, d_min, phi0):
    o = x + n * 1e-3
    t = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0])
    t = t - n * (t @ n)
    t /= np.linalg.norm(t)
    b = np.cross(n, t)
    near = 0
    for k in range(8):
        u1, u2 = (k + 0.5) / 8, (k * 0.618034) % 1
        ph = 2 * np.pi * u2 + phi0
        d = n * np.sqrt(1 - u1) + np.sqrt(u1) * (t * np.cos(ph) + b * np.sin(ph))
        near += nearest(tris, o, d) < d_min
    return near >= 7


def stratum(ref, est, zero):
    rows = []
    for i, (r, e) in enumerate(zip(ref, est)):
        if max(float(r[j]) for j in (6, 7, 8)) > 0:
            continue
        r3 = [float(r[j]) for j in (9, 10, 11)]
        e3 = [0.0] * 3 if i in zero else [float(e[k]) for k in ("indirect_r", "indirect_g", "indirect_b")]
        rows.append((r3, sum(float(r[j]) for j in (15, 16, 17)) / 3, e3))
    mean = sum(sum(r3) / 3 for r3, _, _ in rows) / len(rows)
    e2 = r2 = 0.0
    ratios = []
    for r3, se, e3 in rows:
        rv = sum(r3) / 3
        if rv < 0.01 * mean or se > 0.05 * rv:
            continue
        e2 += sum((a - b) ** 2 for a, b in zip(e3, r3))
        r2 += sum(b * b for b in r3)
        ratios.append(sum(e3) / 3 / rv)
    ratios.sort()
    return (e2 / r2) ** 0.5, ratios[len(ratios) // 2], len(ratios)


def main():
    tris = load(sys.argv[1])
    ref = [l.split(",") for l in open(sys.argv[2]).read().split("\n")[2:] if l]
    est = list(csv.DictReader(open(sys.argv[3])))
    d_min = float(sys.argv[4])
    rng = np.random.default_rng(1)
    zero = set()
    for i, r in enumerate(ref):
        x = np.array([float(a) for a in r[:6]])
        if in_crevice(tris, x[:3], x[3:], d_min, rng.random() * 2 * np.pi):
            zero.add(i)
    print(f"points in a crevice: {sorted(zero)}")
    print("basis read as is:         rel-RMS %.2f %%, median %.3f (%d points)" % (lambda e: (100 * e[0], e[1], e[2]))(stratum(ref, est, set())))
    print("0 at crevice points:      rel-RMS %.2f %%, median %.3f (%d points)" % (lambda e: (100 * e[0], e[1], e[2]))(stratum(ref, est, zero)))


main()
