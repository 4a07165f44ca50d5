# Error figures of a probe CSV (`meshrad probe`) against a reference CSV (`meshrad
# reference --points`, the same points), per channel, with the floor (1 % of the mean
# reference) and noise filter (reference standard error at most 5 %) of src/metrics.rs.
# With four files A1 A2 R1 R2 instead: the increments A2 - A1 against R2 - R1 (one
# more bounce of the solver against one more term of the reference series; points whose
# reference increment is noisier than 10 % left out).
# Usage: python3 probe_errors.py ESTIMATE.csv REFERENCE.csv
#        python3 probe_errors.py A1.csv A2.csv R1.csv R2.csv
import csv, statistics as st, sys
L = lambda f: list(csv.DictReader(open(f)))
if len(sys.argv) == 3:
    a, b = map(L, sys.argv[1:])
    for ch in "rgb":
        mr = sum(float(r["indirect_" + ch]) for r in b) / len(b)
        q, e2, r2, off = [], 0.0, 0.0, 0
        for ra, rb in zip(a, b):
            e, r, se = float(ra["indirect_" + ch]), float(rb["indirect_" + ch]), float(rb["indirect_se_" + ch])
            if r <= 0 or r < 0.01 * mr or se > 0.05 * r:
                continue
            q.append(e / r); e2 += (e - r) ** 2; r2 += r * r; off += e / r > 3 or e / r < 1 / 3
        print(f"{ch}: points {len(q)}, rel-RMS {100 * (e2 / r2) ** .5:.2f} %, median {st.median(q):.3f}, "
              f"mean {sum(q) / len(q):.3f}, off 3x {off}")
else:
    a1, a2, r1, r2 = map(L, sys.argv[1:5])
    m = lambda r, k: sum(float(r[f"{k}_{c}"]) for c in "rgb") / 3
    inc = [m(y, "indirect") - m(x, "indirect") for x, y in zip(r1, r2)]
    mi = sum(inc) / len(inc)
    q, E, R = [], 0.0, 0.0
    for i, ri in enumerate(inc):
        se = (m(r1[i], "indirect_se") ** 2 + m(r2[i], "indirect_se") ** 2) ** .5
        if ri < 0.01 * mi or se > 0.1 * ri:
            continue
        ei = m(a2[i], "indirect") - m(a1[i], "indirect")
        q.append(ei / ri); E += ei; R += ri
    print(f"increment (channel means): points {len(q)}, median {st.median(q):.3f}, mean {sum(q) / len(q):.3f}, "
          f"energy {E / R:.3f}")
