#!/usr/bin/env python3
"""Turns a Tinsel / GLSL-PathTracer `.scene` file (the format of the interiors in
github.com/Zielon/PBRScenes and knightcrawler25/GLSL-PathTracer: Bitterli's staircase,
dining room, bedroom...) into one OBJ + MTL + meshrad scene file, for diffuse global
illumination (issue #32's second interior):

    python3 scenes/tinsel2meshrad.py SCENE_FILE OUT_DIR NAME

Writes OUT_DIR/NAME.obj (every mesh, scaled and placed, in metres as the scene gives
them), NAME.mtl and NAME.toml. What meshrad cannot model is said on stderr, never dropped
silently:
- `color` and `albedoTexture` become Kd / map_Kd (textures copied to OUT_DIR/textures);
  metallic, roughness and specular terms are left out: every surface is Lambertian with
  that albedo (an albedo of 1 is clamped by meshrad, with its own note);
- meshes of a transmissive material (`transmission` or `spectrans` > 0: glass) are left
  out, since a diffuse glass would be an opaque wall;
- `Quad` lights become one-sided emitting quads (Ke = emission, facing cross(v1-p, v2-p)
  as the path tracer has them); sphere lights are left out;
- the camera keeps its position and target; its vertical fov is turned into meshrad's fov
  along the image's smaller axis.
Only the standard library is used, so it runs wherever the fetch script does.
"""
import math, os, re, shutil, sys


def blocks(text):
    """(kind, name, {key: [values]}) for each `kind [name] { key values... }` block."""
    text = re.sub(r"#[^\n]*", "", text)
    out = []
    for m in re.finditer(r"(\w+)[ \t]*([^{}\n]*?)\s*\{([^{}]*)\}", text):
        kind, name, body = m.group(1).lower(), m.group(2).strip(), m.group(3)
        kv = {}
        for line in body.splitlines():
            p = line.split()
            if len(p) >= 2:
                kv[p[0].lower()] = p[1:]
        out.append((kind, name, kv))
    return out


def vec(kv, key, default=None):
    return [float(x) for x in kv[key][:3]] if key in kv else default


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    scene_file, out_dir, name = sys.argv[1:]
    base = os.path.dirname(os.path.abspath(scene_file))
    os.makedirs(out_dir, exist_ok=True)
    bl = blocks(open(scene_file).read())
    mats = {n: kv for k, n, kv in bl if k == "material"}
    note = lambda s: print(f"tinsel2meshrad: {s}", file=sys.stderr)
    obj = [f"# {name}: converted from {os.path.basename(scene_file)} by scenes/tinsel2meshrad.py",
           f"mtllib {name}.mtl"]
    mtl = [f"# {name}: converted from {os.path.basename(scene_file)} (Lambertian albedos only)"]
    nv = nvt = nvn = 0
    used = []
    for kind, _, kv in bl:
        if kind != "mesh":
            continue
        mat = kv.get("material", ["default"])[0]
        m = mats.get(mat, {})
        if any(float(m.get(k, ["0"])[0]) > 0 for k in ("transmission", "spectrans")):
            note(f"left out {kv['file'][0]}: material `{mat}` transmits (glass)")
            continue
        for k in ("metallic", "specular", "clearcoat", "sheen", "subsurface"):
            if k in m and float(m[k][0]) > 0:
                note(f"material `{mat}`: {k} {m[k][0]} read as diffuse")
        s = vec(kv, "scale", [1.0, 1.0, 1.0])
        t = vec(kv, "position", [0.0, 0.0, 0.0])
        path = os.path.join(base, kv["file"][0])
        if not os.path.isfile(path) or os.path.getsize(path) == 0:
            note(f"left out {kv['file'][0]}: no such file, or empty")
            continue
        with open(path, "rb") as f:
            if f.read(40).startswith(b"version https://git-lfs"):
                note(f"left out {kv['file'][0]}: a Git LFS pointer, not the mesh (fetch it with `git lfs pull`)")
                continue
        obj.append(f"o {os.path.splitext(os.path.basename(path))[0]}")
        obj.append(f"usemtl {mat}")
        if mat not in used:
            used.append(mat)
        lv, lvt, lvn = nv, nvt, nvn
        for line in open(path, errors="replace"):
            p = line.split()
            if not p:
                continue
            if p[0] == "v":
                x = [float(a) * s[i] + t[i] for i, a in enumerate(p[1:4])]
                obj.append("v " + " ".join(f"{a:.7g}" for a in x)); nv += 1
            elif p[0] == "vt":
                obj.append(line.strip()); nvt += 1
            elif p[0] == "vn":
                n = [float(a) / s[i] for i, a in enumerate(p[1:4])]
                l = math.sqrt(sum(a * a for a in n)) or 1.0
                obj.append("vn " + " ".join(f"{a / l:.6g}" for a in n)); nvn += 1
            elif p[0] == "f":
                def shift(c):
                    ix = c.split("/")
                    offs = (lv, lvt, lvn)
                    for j, a in enumerate(ix):
                        if a:
                            i = int(a)
                            # relative (negative) indices stay relative
                            ix[j] = str(i + offs[j]) if i > 0 else a
                    return "/".join(ix)
                obj.append("f " + " ".join(shift(c) for c in p[1:]))
    for mat in used:
        m = mats.get(mat, {})
        mtl.append(f"newmtl {mat}")
        if "albedotexture" in m:
            tex = os.path.join(base, m["albedotexture"][0])
            rel = os.path.join("textures", os.path.basename(tex))
            os.makedirs(os.path.join(out_dir, "textures"), exist_ok=True)
            shutil.copyfile(tex, os.path.join(out_dir, rel))
            mtl.append("map_Kd " + rel)
            mtl.append("Kd 1 1 1")
        else:
            c = vec(m, "color", [1.0, 1.0, 1.0])
            mtl.append("Kd " + " ".join(f"{a:g}" for a in c))
    nl = 0
    for kind, _, kv in bl:
        if kind != "light":
            continue
        typ = kv.get("type", ["quad"])[0].lower()
        if typ != "quad":
            note(f"left out a `{typ}` light (only quads are converted)")
            continue
        p, a, b = vec(kv, "position"), vec(kv, "v1"), vec(kv, "v2")
        e = vec(kv, "emission")
        u = [a[i] - p[i] for i in range(3)]
        v = [b[i] - p[i] for i in range(3)]
        q = [p, a, [a[i] + v[i] for i in range(3)], b]
        nl += 1
        mtl.append(f"newmtl light{nl}\nKd 0 0 0\nKe " + " ".join(f"{x:g}" for x in e))
        obj.append(f"o light{nl}\nusemtl light{nl}")
        for c in q:
            obj.append("v " + " ".join(f"{x:.7g}" for x in c))
        # counter-clockwise seen from where cross(u, v) points: meshrad's front side
        obj.append(f"f {nv + 1} {nv + 2} {nv + 3} {nv + 4}")
        nv += 4
    cam = next((kv for k, _, kv in bl if k == "camera"), None)
    res = next((kv.get("resolution") for k, _, kv in bl if k == "renderer"), None)
    toml = [f"# {name}: converted from {os.path.basename(scene_file)} by scenes/tinsel2meshrad.py",
            "# (every surface Lambertian with its albedo; glass left out; quad lights as emitters)",
            "", "[[object]]", f'mesh = "{name}.obj"', ""]
    if cam:
        w, h = (int(res[0]), int(res[1])) if res else (4, 3)
        vf = float(cam.get("fov", ["60"])[0])
        # the scene's fov is vertical; meshrad's is along the smaller axis
        f = vf if h <= w else math.degrees(2 * math.atan(math.tan(math.radians(vf) / 2) * w / h))
        sc = 320 / max(w, h)
        toml += ["[camera]",
                 "position = [" + ", ".join(f"{x:g}" for x in vec(cam, "position")) + "]",
                 "target = [" + ", ".join(f"{x:g}" for x in vec(cam, "lookat")) + "]",
                 f"fov = {f:.4g}", f"width = {round(w * sc)}", f"height = {round(h * sc)}", ""]
    if not used:
        sys.exit(f"tinsel2meshrad: {scene_file}: no mesh could be read (see the notes above); nothing written")
    open(os.path.join(out_dir, f"{name}.obj"), "w").write("\n".join(obj) + "\n")
    open(os.path.join(out_dir, f"{name}.mtl"), "w").write("\n".join(mtl) + "\n")
    open(os.path.join(out_dir, f"{name}.toml"), "w").write("\n".join(toml))
    print(f"tinsel2meshrad: wrote {out_dir}/{name}.obj ({nv} vertices, {len(used)} materials, "
          f"{nl} lights), {name}.mtl, {name}.toml", file=sys.stderr)


main()
