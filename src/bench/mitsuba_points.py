"""Irradiance at probe points by Mitsuba 3, from a scene exported by meshrad
(`meshrad bench mitsuba`; src/bench/mitsuba.rs): an independent check of
`meshrad reference --points`.

Usage: python3 points.py EXPORT_DIR POINTS SAMPLES OUT.csv [SEED]

POINTS holds `px py pz nx ny nz` per line (`#` starts a comment), as `meshrad probe`
reads them. At each point, SAMPLES cosine-distributed directions about the normal are
traced by Mitsuba's `path` integrator (no depth limit): the irradiance is pi times their
mean radiance. Its direct part is pi times the mean radiance emitted where the same rays
first meet an emitter or leave into the sky, plus the point, spot and directional lights
evaluated exactly with a shadow ray; the indirect part is the rest, so that one ray's
direct light is not noise in the other's. OUT has `meshrad reference`'s columns (after
one `#` line): position, normal, direct, indirect and total RGB, and the indirect
value's standard error.
"""

import os
import sys

import numpy as np
import mitsuba as mi
import drjit as dr

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def lights_at(s, sc, p, n, eps):
    """Irradiance from the point, spot and directional lights at points p, normals n."""
    e = np.zeros_like(p)
    o = p + n * eps
    for l in s["lights"]:
        if l["type"] == "directional":
            w = -np.array(l["direction"], dtype=np.float64)
            w /= np.linalg.norm(w)
            cos = n @ w
            dist = np.full(len(p), 1e30)
            irr = np.outer(np.maximum(cos, 0.0), l["irradiance"])
        else:
            q = np.array(l["position"], dtype=np.float64)
            v = q - o
            dist = np.linalg.norm(v, axis=1)
            w = v / dist[:, None]
            cos = np.einsum("ij,ij->i", n, w)
            f = np.ones(len(p))
            if l["type"] == "spot":
                axis = np.array(l["direction"], dtype=np.float64)
                axis /= np.linalg.norm(axis)
                theta = np.arccos(np.clip(-(w @ axis), -1.0, 1.0))
                cut, beam = np.radians(l["cutoff_angle"]), np.radians(l["beam_width"])
                f = np.where(theta <= beam, 1.0, np.where(theta >= cut, 0.0, (cut - theta) / max(cut - beam, 1e-12)))
            irr = np.outer(np.maximum(cos, 0.0) * f / dist**2, l["intensity"])
        dirs = np.broadcast_to(w, p.shape) if w.ndim == 1 else w
        ray = mi.Ray3f(mi.Point3f(*[mi.Float(o[:, k]) for k in range(3)]),
                       mi.Vector3f(*[mi.Float(np.ascontiguousarray(dirs[:, k])) for k in range(3)]),
                       mi.Float(dist * (1 - 1e-4)), 0.0, [])
        blocked = np.array(sc.ray_test(ray), dtype=bool)
        e += np.where(blocked[:, None], 0.0, irr)
    return e


def main():
    d, pts_file, samples, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
    seed = int(sys.argv[5]) if len(sys.argv) > 5 else 1
    mi.set_variant("llvm_ad_rgb")
    from mitsuba_render import load

    scene, s = load(d)
    sc = mi.load_dict(scene)
    bb = sc.bbox()
    eps = 1e-5 * float(dr.norm(bb.max - bb.min))
    rows = []
    with open(pts_file) as f:
        for line in f:
            line = line.split("#")[0].split()
            if line:
                rows.append([float(x) for x in line[:6]])
    pts = np.array(rows, dtype=np.float64)
    p, n = pts[:, :3], pts[:, 3:6]
    n = n / np.linalg.norm(n, axis=1)[:, None]
    npts = len(pts)
    integrator = mi.load_dict({"type": "path", "max_depth": -1})
    env = sc.environment()
    per_batch = max(1, min(samples, (1 << 22) // npts))
    sums = {k: np.zeros((npts, 3)) for k in ("total", "direct", "indirect")}
    sq = np.zeros((npts, 3))
    done, batch = 0, 0

    def to_np(c, count):
        arr = np.array(c, dtype=np.float64)
        return arr if arr.shape == (count, 3) else arr.T

    while done < samples:
        m = min(per_batch, samples - done)
        idx = np.repeat(np.arange(npts), m)
        o = p[idx] + n[idx] * eps
        nn = n[idx]
        sampler = mi.load_dict({"type": "independent"})
        sampler.seed((seed * 7919 + batch) & 0xFFFFFFFF, len(idx))
        local = mi.warp.square_to_cosine_hemisphere(sampler.next_2d())
        frame = mi.Frame3f(mi.Vector3f(*[mi.Float(np.ascontiguousarray(nn[:, j])) for j in range(3)]))
        ray = mi.Ray3f(mi.Point3f(*[mi.Float(np.ascontiguousarray(o[:, j])) for j in range(3)]), frame.to_world(local))
        si = sc.ray_intersect(ray)
        emitted = si.emitter(sc).eval(si, si.is_valid())
        if env is not None:
            emitted += dr.select(si.is_valid(), 0.0, env.eval(si))
        spec, _, _ = integrator.sample(sc, sampler, ray)
        t = np.pi * to_np(spec, len(idx)).reshape(npts, m, 3)
        d = np.pi * to_np(emitted, len(idx)).reshape(npts, m, 3)
        sums["total"] += t.sum(axis=1)
        sums["direct"] += d.sum(axis=1)
        sums["indirect"] += (t - d).sum(axis=1)
        sq += ((t - d) ** 2).sum(axis=1)
        done, batch = done + m, batch + 1
    mean = {k: sums[k] / samples for k in sums}
    se = np.sqrt(np.maximum(sq / samples - mean["indirect"] ** 2, 0.0) / max(samples - 1, 1))
    point_lights = lights_at(s, sc, p, n, eps)
    direct = mean["direct"] + point_lights
    indirect = mean["indirect"]
    total = direct + indirect
    with open(out, "w") as f:
        f.write("# mitsuba points samples=%d seed=%d\n" % (samples, seed))
        f.write(
            "px,py,pz,nx,ny,nz,direct_r,direct_g,direct_b,indirect_r,indirect_g,indirect_b,"
            "total_r,total_g,total_b,indirect_se_r,indirect_se_g,indirect_se_b\n"
        )
        for i in range(npts):
            vals = list(pts[i, :6]) + list(direct[i]) + list(indirect[i]) + list(total[i]) + list(se[i])
            f.write(",".join("%.7g" % v for v in vals) + "\n")


if __name__ == "__main__":
    main()
