"""Energy estimate/reference per bounce in the indirect-only stratum (issue #32, step 2).

    python3 bounces.py OUT_DIR REFERENCE.csv   (OUT_DIR as bounces.sh wrote it; REFERENCE:
                                                 the converged one, for the stratum)
"""
import csv
import sys


def ref(f):
    rows = [l.split(",") for l in open(f).read().split("\n") if l and l[0] not in "#p"]
    m = [sum(float(r[i]) for i in (9, 10, 11)) / 3 for r in rows]
    se = [sum(float(r[i]) for i in (15, 16, 17)) / 3 for r in rows]
    lit = [max(float(r[i]) for i in (6, 7, 8)) > 0 for r in rows]
    return m, se, lit


def est(f):
    return [sum(float(e[c]) for c in ("indirect_r", "indirect_g", "indirect_b")) / 3 for e in csv.DictReader(open(f))]


def main():
    out = sys.argv[1]
    inf, se, lit = ref(sys.argv[2])
    R = {k: ref(f"{out}/ref-b{k}.csv")[0] for k in (1, 2, 3)}
    P = {k: est(f"{out}/probe-b{k}.csv") for k in (0, 1, 2)}
    mean = sum(inf) / len(inf)
    keep = [i for i in range(len(inf)) if not lit[i] and inf[i] >= 0.01 * mean and se[i] <= 0.05 * inf[i]]
    S = lambda v: sum(v[i] for i in keep)
    print(f"{len(keep)} indirect-only points kept")
    print(f"bounce 1: {S(P[0]) / S(R[1]):.3f}")
    print(f"bounce 2: {(S(P[1]) - S(P[0])) / (S(R[2]) - S(R[1])):.3f}")
    print(f"bounce 3: {(S(P[2]) - S(P[1])) / (S(R[3]) - S(R[2])):.3f}")
    t = S(inf)
    print(f"share of the reference: {S(R[1]) / t:.3f} {(S(R[2]) - S(R[1])) / t:.3f} {(S(R[3]) - S(R[2])) / t:.3f}, rest {(t - S(R[3])) / t:.3f}")


if __name__ == "__main__":
    main()
