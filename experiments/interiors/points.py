"""Points drawn uniformly by area over every triangle of an OBJ, the side at random (issue #32).

    python3 points.py OBJ N SEED > points.txt   (`px py pz nx ny nz` per line)
"""
import random, sys, bisect, math
obj, n, seed = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
V, T = [], []
for l in open(obj, errors="replace"):
    if l.startswith("v "):
        V.append(tuple(map(float, l.split()[1:4])))
    elif l.startswith("f "):
        idx = [int(t.split("/")[0]) for t in l.split()[1:]]
        idx = [i - 1 if i > 0 else len(V) + i for i in idx]
        for k in range(1, len(idx) - 1):
            T.append((idx[0], idx[k], idx[k + 1]))
def sub(a, b): return (a[0]-b[0], a[1]-b[1], a[2]-b[2])
def cross(a, b): return (a[1]*b[2]-a[2]*b[1], a[2]*b[0]-a[0]*b[2], a[0]*b[1]-a[1]*b[0])
cdf, tot, nrm = [], 0.0, []
for a, b, c in T:
    x = cross(sub(V[b], V[a]), sub(V[c], V[a]))
    l = math.sqrt(sum(t*t for t in x))
    tot += 0.5 * l
    cdf.append(tot)
    nrm.append(tuple(t / l for t in x) if l > 0 else None)
r = random.Random(seed)
out = 0
while out < n:
    i = bisect.bisect_right(cdf, r.random() * tot)
    if nrm[i] is None: continue
    a, b, c = (V[j] for j in T[i])
    u1, u2 = math.sqrt(r.random()), r.random()
    p = [a[k]*(1-u1) + b[k]*u1*(1-u2) + c[k]*u1*u2 for k in range(3)]
    s = 1 if r.random() < 0.5 else -1
    nn = [s * t for t in nrm[i]]
    print(" ".join(f"{t:.7g}" for t in p + nn))
    out += 1
