"""Errors of a probe CSV against a reference CSV at the same points (indirect irradiance).

    python3 errors_at_points.py REFERENCE.csv PROBE.csv

Prints one line for all points (as `meshrad bench accuracy`'s metrics: points below 1 % of
the mean reference or with a reference noisier than 5 % are left out), then one line per
stratum: the points that get no direct light from any source in the reference (lit only
indirectly) and the lit ones, each with its own floor, and the headline: the worse
stratum's rel-RMS.
"""
import csv
import sys


def errors(rows):
    """rows: (reference rgb, reference se mean, estimate rgb) triples."""
    if not rows:
        return None
    mean = sum(sum(r) / 3 for r, _, _ in rows) / len(rows)
    e2 = r2 = se = sr = leak = 0.0
    ratios, nb = [], 0
    for r3, s, e3 in rows:
        rv, em = sum(r3) / 3, sum(e3) / 3
        if rv < 0.01 * mean or rv <= 0:
            nb += 1
            leak += max(em, 0)
            continue
        if s > 0.05 * rv:
            continue
        e2 += sum((a - b) ** 2 for a, b in zip(e3, r3))
        r2 += sum(b * b for b in r3)
        ratios.append(em / rv)
        se += em
        sr += rv
    ratios.sort()
    k = len(ratios)
    if k == 0:
        return None
    med = ratios[k // 2] if k % 2 else 0.5 * (ratios[k // 2 - 1] + ratios[k // 2])
    return {
        "rel_rms": (e2 / r2) ** 0.5,
        "median": med,
        "mean": sum(ratios) / k,
        "energy": se / sr,
        "off3x": sum(1 for q in ratios if q > 3 or q < 1 / 3),
        "points": k,
        "leak": leak / max(nb, 1) / mean if mean > 0 else 0.0,
        "below": nb,
    }


def line(e):
    if e is None:
        return "no measurable points"
    return (
        f"rel_rms {100 * e['rel_rms']:.2f}%  median {e['median']:.3f}  mean {e['mean']:.3f} "
        f"energy {e['energy']:.3f} off3x {e['off3x']} of {e['points']} leak {e['leak']:.4f} below {e['below']}"
    )


def main():
    ref = [l.split(",") for l in open(sys.argv[1]).read().split("\n")[2:] if l]
    est = list(csv.DictReader(open(sys.argv[2])))
    assert len(ref) == len(est), f"{len(ref)} reference points, {len(est)} estimates"
    rows, lit = [], []
    for r, e in zip(ref, est):
        r3 = tuple(float(r[i]) for i in (9, 10, 11))
        s = sum(float(r[i]) for i in (15, 16, 17)) / 3
        e3 = (float(e["indirect_r"]), float(e["indirect_g"]), float(e["indirect_b"]))
        rows.append((r3, s, e3))
        lit.append(max(float(r[i]) for i in (6, 7, 8)) > 0)
    print(line(errors(rows)))
    io = errors([x for x, l in zip(rows, lit) if not l])
    li = errors([x for x, l in zip(rows, lit) if l])
    print(f"  indirect-only ({lit.count(False)} points): {line(io)}")
    print(f"  lit ({lit.count(True)} points): {line(li)}")
    worse = max((e for e in (io, li) if e), key=lambda e: e["rel_rms"], default=None)
    print(f"  headline (worse stratum): {100 * worse['rel_rms']:.2f}%" if worse else "  headline: -")


main()
