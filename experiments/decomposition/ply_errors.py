# Error figures from the per-point error maps of `meshrad bench accuracy --decompose`
# (SCENE-LABEL-cpu-points.ply), on the channel means the maps hold: the same floor (1 %
# of the mean reference) and noise filter (reference standard error at most 5 %) as
# src/metrics.rs; rel-RMS of the channel means, so it differs slightly from the bench's
# per-channel figure. Usage: python3 ply_errors.py FILE.ply ...
import glob, statistics as st, sys
for f in sys.argv[1:] or sorted(glob.glob("*.ply")):
    body = open(f).read().split("end_header\n")[1]
    rows = [list(map(float, l.split())) for l in body.split("\n") if l.strip()]
    mean_ref = sum(r[6] for r in rows) / len(rows)
    kept = [r for r in rows if r[6] >= 0.01 * mean_ref and r[6] > 0 and r[7] <= 0.05 * r[6]]
    e2 = sum((r[8] - r[6]) ** 2 for r in kept); r2 = sum(r[6] ** 2 for r in kept)
    q = [r[8] / r[6] for r in kept]
    off = sum(1 for x in q if x > 3 or x < 1 / 3)
    print(f"{f}: points {len(kept)}, rel-RMS {100 * (e2 / r2) ** .5:.2f} %, median {st.median(q):.3f}, "
          f"mean {sum(q) / len(q):.3f}, energy {sum(r[8] for r in kept) / sum(r[6] for r in kept):.3f}, off 3x {off}")
