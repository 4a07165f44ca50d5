"""Direct irradiance of probe CSVs against a converged one at the same points (issue #32,
step 4), over the points with direct light.

    python3 direct_errors.py CONVERGED.csv PROBE.csv...
"""
import csv
import sys

t = list(csv.DictReader(open(sys.argv[1])))
for f in sys.argv[2:]:
    e = list(csv.DictReader(open(f)))
    d = lambda r: [float(r[f"direct_{c}"]) for c in "rgb"]
    lit = [(d(a), d(b)) for a, b in zip(e, t) if sum(d(b)) > 0]
    e2 = sum((x - y) ** 2 for a, b in lit for x, y in zip(a, b))
    r2 = sum(y * y for a, b in lit for y in b)
    rat = sorted(sum(a) / sum(b) for a, b in lit)
    en = sum(sum(a) for a, b in lit) / sum(sum(b) for a, b in lit)
    print(f"{f}: {len(lit)} lit points, direct rel-RMS {100 * (e2 / r2) ** .5:.2f} %, median {rat[len(rat) // 2]:.4f}, energy {en:.4f}")
