# Node values of a solve (`meshrad solve ... --export-nodes N.ply`) against a reference at
# the node centres, per level. Usage:
#   python3 node_errors.py pick N.ply PER_LEVEL SEED > P.txt     # nodes with E_ind > 0, sampled per level
#   python3 node_errors.py cmp N.ply P.txt REF.csv               # node E_ind against REF at P
#   python3 node_errors.py inc N1.ply N2.ply P.txt REF1.csv REF2.csv  # the increments N2 - N1 against REF2 - REF1
# REF*.csv: `meshrad reference SCENE --points P.txt --max-bounces K` (or `meshrad probe
# --bounces 0 --set final_gather=16384` for the one-bounce term). Filters as probe_errors.py.
import csv, random, statistics as st, struct, sys
def nodes(f):
    d = open(f, "rb").read(); i = d.index(b"end_header\n") + 11
    n = int(d[:i].decode().split("element vertex ")[1].split()[0]); r = struct.Struct("<6fi7f")
    return [r.unpack_from(d, i + k * r.size) for k in range(n)]
def pts(f): return [tuple(map(float, l.replace("#", " ").split()[:7])) for l in open(f) if l.strip()]
def ref(f): return list(csv.DictReader(l for l in open(f) if not l.startswith("#")))
m = lambda r, k: sum(float(r[f"{k}_{c}"]) for c in "rgb") / 3
def find(rows, p):
    idx = {tuple(round(v, 5) for v in r[:6]) + (r[6],): r for r in rows}
    return [idx[tuple(round(v, 5) for v in q[:6]) + (int(q[6]),)] for q in p]
cmd = sys.argv[1]
if cmd == "pick":
    rows = nodes(sys.argv[2]); k = int(sys.argv[3]); random.seed(int(sys.argv[4]))
    for l in sorted(set(r[6] for r in rows)):
        for r in random.sample([r for r in rows if r[6] == l and sum(r[11:14]) > 0], k):
            print(" ".join(repr(v) for v in r[:6]), "#", r[6])
else:
    if cmd == "cmp":
        p = pts(sys.argv[3]); a = find(nodes(sys.argv[2]), p); R = ref(sys.argv[4])
        val = lambda i: (sum(a[i][11:14]) / 3, m(R[i], "indirect"), m(R[i], "indirect_se"))
    else:
        p = pts(sys.argv[4]); a1 = find(nodes(sys.argv[2]), p); a2 = find(nodes(sys.argv[3]), p)
        R1, R2 = ref(sys.argv[5]), ref(sys.argv[6])
        val = lambda i: (sum(a2[i][11:14]) / 3 - sum(a1[i][11:14]) / 3, m(R2[i], "indirect") - m(R1[i], "indirect"),
                         # an increment is kept when its standard error is at most 10 %
                         (m(R1[i], "indirect_se") ** 2 + m(R2[i], "indirect_se") ** 2) ** .5 / 2)
    for l in sorted(set(int(q[6]) for q in p)):
        q, E, Rs = [], 0.0, 0.0
        for i in range(len(p)):
            if int(p[i][6]) != l: continue
            e, r, se = val(i)
            if r <= 0 or se > 0.05 * r: continue
            q.append(e / r); E += e; Rs += r
        print(f"level {l}: nodes {len(q)}, median {st.median(q):.3f}, mean {sum(q) / len(q):.3f}, energy {E / Rs:.3f}")
