"""Renders a scene exported by meshrad (src/bench/mitsuba.rs) with Mitsuba 3.

Usage: python3 mitsuba_render.py EXPORT_DIR SPP SEED OUT

Writes OUT (little-endian float32 RGB, rows from the top) and prints `seconds T`: the
time from building the scene to the image in memory. Written by `meshrad bench accuracy`
next to the export it reads; the scene is built as described there.
"""

import json
import sys
import time

import numpy as np
import mitsuba as mi


def load(d):
    """The export in folder `d` as a Mitsuba scene dictionary (no sensor) and its JSON."""
    with open(f"{d}/scene.json") as f:
        s = json.load(f)
    srgb = np.array(s["srgb"], dtype=np.float32)
    texels = np.fromfile(f"{d}/texels.bin", dtype=np.uint8).reshape(-1, 4)

    def bitmap(t, factor):
        w, h, o = t["width"], t["height"], t["offset"]
        lin = srgb[texels[o : o + w * h, :3]].reshape(h, w, 3) * np.array(factor, dtype=np.float32)
        return {
            "type": "bitmap",
            "bitmap": mi.Bitmap(np.ascontiguousarray(lin, dtype=np.float32)),
            "raw": True,
            "filter_type": "bilinear",
            "wrap_mode": t["wrap"],
        }

    scene = {"type": "scene", "integrator": {"type": "path", "max_depth": -1}}
    for i, m in enumerate(s["materials"]):
        n = m["triangles"]
        a = np.fromfile(f"{d}/{m['file']}", dtype=np.float32)
        k = 9 * n
        positions = a[:k]
        normals = None
        if m["normals"]:
            normals, k = a[k : k + 9 * n], k + 9 * n
        uvs = a[k : k + 6 * n] if m["uvs"] else None
        props = mi.Properties()
        refl = bitmap(m["texture"], m["albedo"]) if m["texture"] else rgb(m["albedo"])
        props["bsdf"] = mi.load_dict({"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": refl}})
        if any(x > 0 for x in m["emission"]):
            rad = bitmap(m["emission_texture"], m["emission"]) if m["emission_texture"] else rgb(m["emission"])
            props["emitter"] = mi.load_dict({"type": "area", "radiance": rad})
        mesh = mi.Mesh(
            f"m{i}",
            3 * n,
            n,
            props,
            has_vertex_normals=normals is not None,
            has_vertex_texcoords=uvs is not None,
        )
        p = mi.traverse(mesh)
        p["vertex_positions"] = mi.Float(positions)
        p["faces"] = mi.UInt32(np.arange(3 * n, dtype=np.uint32))
        if normals is not None:
            p["vertex_normals"] = mi.Float(normals)
        if uvs is not None:
            p["vertex_texcoords"] = mi.Float(uvs)
        p.update()
        scene[f"mesh{i}"] = mesh
    for i, l in enumerate(s["lights"]):
        if l["type"] == "point":
            scene[f"light{i}"] = {"type": "point", "position": l["position"], "intensity": rgb(l["intensity"])}
        elif l["type"] == "spot":
            o, dv = np.array(l["position"]), np.array(l["direction"])
            up = np.cross(dv, [1.0, 0.0, 0.0] if abs(dv[0]) < 0.9 else [0.0, 1.0, 0.0])
            scene[f"light{i}"] = {
                "type": "spot",
                "to_world": mi.ScalarTransform4f().look_at(
                    origin=o.tolist(), target=(o + dv).tolist(), up=up.tolist()
                ),
                "intensity": rgb(l["intensity"]),
                "cutoff_angle": l["cutoff_angle"],
                "beam_width": l["beam_width"],
            }
        else:
            scene[f"light{i}"] = {
                "type": "directional",
                "direction": l["direction"],
                "irradiance": rgb(l["irradiance"]),
            }
    if s["sky"] is not None:
        scene["sky"] = {"type": "constant", "radiance": rgb(s["sky"])}
    return scene, s


def rgb(v):
    return {"type": "rgb", "value": [float(x) for x in v]}


def main():
    d, spp, seed, out = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    mi.set_variant("llvm_ad_rgb")
    t0 = time.perf_counter()
    scene, s = load(d)
    c = s["camera"]
    w, h = c["width"], c["height"]
    per_pass = max(1, min(spp, (1 << 24) // (w * h)))
    scene["sensor"] = {
        "type": "perspective",
        "fov_axis": "smaller",
        "fov": c["fov"],
        "to_world": mi.ScalarTransform4f().look_at(origin=c["position"], target=c["target"], up=c["up"]),
        "film": {
            "type": "hdrfilm",
            "width": w,
            "height": h,
            "pixel_format": "rgb",
            "rfilter": {"type": c["filter"]},
        },
        "sampler": {"type": "independent", "sample_count": per_pass},
    }
    sc = mi.load_dict(scene)
    acc = np.zeros((h, w, 3), dtype=np.float64)
    done, k = 0, 0
    while done < spp:
        n = min(per_pass, spp - done)
        img = mi.render(sc, spp=n, seed=(seed * 7919 + k) & 0xFFFFFFFF)
        acc += np.array(img, dtype=np.float64)[:, :, :3] * n
        done, k = done + n, k + 1
    acc /= spp
    seconds = time.perf_counter() - t0
    acc.astype("<f4").tofile(out)
    print(f"seconds {seconds:.6f}")


if __name__ == "__main__":
    main()
