"""Per-bounce increments in the indirect-only stratum (issue #32; bounces.sh writes the inputs).

    python3 bounces.py OUT_DIR CONVERGED_REFERENCE.csv K PROBE.csv

OUT_DIR holds ref-b1..ref-b{K+1}.csv (the reference cut at k bounces) and
probe-b0..probe-b{K}.csv (the solve cut at k bounces, plus the final gather's hop);
PROBE.csv is the uncut probe run. The stratum and its floor are those of
experiments/area-accuracy/errors_at_points.py, from the converged reference.
"""
import statistics
import sys
from pathlib import Path


sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "results"))
from bounces import est, ref  # noqa: E402  (the stratum's reading, shared)

out, K = sys.argv[1], int(sys.argv[3])
inf, se, lit = ref(sys.argv[2])
full = est(sys.argv[4])
R = {k: ref(f"{out}/ref-b{k}.csv")[0] for k in range(1, K + 2)}
P = {k: est(f"{out}/probe-b{k}.csv") for k in range(0, K + 1)}
mean = sum(inf) / len(inf)
keep = [i for i in range(len(inf)) if not lit[i] and inf[i] >= 0.01 * mean and se[i] <= 0.05 * inf[i]]
S = lambda v: sum(v[i] for i in keep)
print(f"{len(keep)} indirect-only points kept")
zero = [0.0] * len(inf)
for k in range(1, K + 2):
    pk, rk = P[k - 1], R[k]
    pm, rm = (P[k - 2], R[k - 1]) if k >= 2 else (zero, zero)
    inc = (S(pk) - S(pm)) / (S(rk) - S(rm))
    med = statistics.median(pk[i] / rk[i] for i in keep if rk[i] > 0)
    print(
        f"bounce {k}: increment {inc:.3f}, share of the light {(S(rk) - S(rm)) / S(inf):.3f}; "
        f"up to it: median {med:.3f}, energy {S(pk) / S(rk):.3f}"
    )
last, rest = S(P[K]), S(inf) - S(R[K + 1])
print(f"bounces after {K + 1}: share {rest / S(inf):.3f}, delivered {(S(full) - last) / rest:.3f}")
print(f"whole: median {statistics.median(full[i] / inf[i] for i in keep):.3f}, energy {S(full) / S(inf):.3f}")
