//! Scenes with known answers (`ALGORITHM.md` §7), generated on the fly: the closed-sphere
//! furnace and the point light over a plane. Used by the tests, the benches and the
//! reference's self-check; each writes an OBJ/MTL/TOML triple into a directory.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// Vertices and faces of an icosphere of radius `r` with `subdiv` subdivisions, faces
/// oriented outwards.
pub fn icosphere(r: f64, subdiv: u32) -> (Vec<[f64; 3]>, Vec<[usize; 3]>) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<[f64; 3]> = vec![
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let mut f: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let norm = |p: [f64; 3]| {
        let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        [p[0] / l, p[1] / l, p[2] / l]
    };
    for p in &mut v {
        *p = norm(*p);
    }
    for _ in 0..subdiv {
        let mut mid = std::collections::HashMap::new();
        let mut nf = Vec::with_capacity(f.len() * 4);
        let mut midpoint = |a: usize, b: usize, v: &mut Vec<[f64; 3]>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let (p, q) = (v[a], v[b]);
                v.push(norm([(p[0] + q[0]) / 2.0, (p[1] + q[1]) / 2.0, (p[2] + q[2]) / 2.0]));
                v.len() - 1
            })
        };
        for [a, b, c] in f {
            let ab = midpoint(a, b, &mut v);
            let bc = midpoint(b, c, &mut v);
            let ca = midpoint(c, a, &mut v);
            nf.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = nf;
    }
    for p in &mut v {
        *p = [p[0] * r, p[1] * r, p[2] * r];
    }
    (v, f)
}

/// OBJ text for vertices and faces with one material.
pub fn obj_text(v: &[[f64; 3]], f: &[[usize; 3]], mtllib: &str, material: &str) -> String {
    let mut s = format!("mtllib {mtllib}\nusemtl {material}\n");
    for p in v {
        let _ = writeln!(s, "v {} {} {}", p[0], p[1], p[2]);
    }
    for t in f {
        let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    s
}

fn write(dir: &Path, name: &str, text: &str) -> Result<PathBuf> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let p = dir.join(name);
    std::fs::write(&p, text).map_err(|e| Error::io(&p, e))?;
    Ok(p)
}

/// The furnace: a closed sphere of radius `r` and albedo `rho`, a point light of
/// intensity `i` at `light` inside it (power `Φ = 4πi`). Whatever the light's position,
/// bounce `k` alone gives `ρ^k Φ/(4πr²)` at every point, so after `k` bounces
/// `E_ind = Φ/(4πr²) Σ_{b=1..k} ρ^b`; at the centre `E_d = i/r²` too. Returns the scene
/// file's path; `solver` is appended to its `[solver]` table.
pub fn furnace(dir: &Path, r: f64, subdiv: u32, rho: f64, light: [f64; 3], i: f64, solver: &str) -> Result<PathBuf> {
    let (v, f) = icosphere(r, subdiv);
    write(dir, "sphere.obj", &obj_text(&v, &f, "sphere.mtl", "wall"))?;
    write(dir, "sphere.mtl", &format!("newmtl wall\nKd {rho} {rho} {rho}\n"))?;
    write(
        dir,
        "furnace.toml",
        &format!(
            "[[object]]\nmesh = \"sphere.obj\"\n\n[[light]]\ntype = \"point\"\nposition = [{}, {}, {}]\n\
             intensity = [{i}, {i}, {i}]\n\n[camera]\nposition = [0.0, 0.0, {cz}]\ntarget = [0.0, 0.0, 0.0]\n\
             fov = 90.0\nwidth = 32\nheight = 32\n\n[solver]\n{solver}\n",
            light[0],
            light[1],
            light[2],
            cz = r * 0.5
        ),
    )
}

/// A low-poly sphere of radius `r` (`subdiv` subdivisions of the icosahedron, facing out,
/// albedo 0.5) under a directional light of irradiance 1 travelling down −y: a point of
/// the true sphere with normal `n` gets `E_d = max(0, n_y)`, and nothing else (a convex
/// object lights nothing of itself). With `normals`, every vertex carries the sphere's
/// normal there (`vn`, `f v//vn`): what the smooth shading normals interpolate. Returns
/// the scene file's path; `solver` is appended to its `[solver]` table.
pub fn lit_sphere(dir: &Path, r: f64, subdiv: u32, normals: bool, solver: &str) -> Result<PathBuf> {
    let (v, f) = icosphere(r, subdiv);
    let mut obj = String::from("mtllib sphere.mtl\nusemtl grey\n");
    for p in &v {
        let _ = writeln!(obj, "v {} {} {}", p[0], p[1], p[2]);
        if normals {
            let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            let _ = writeln!(obj, "vn {} {} {}", p[0] / l, p[1] / l, p[2] / l);
        }
    }
    for t in &f {
        let [a, b, c] = t.map(|i| i + 1);
        let _ = if normals {
            writeln!(obj, "f {a}//{a} {b}//{b} {c}//{c}")
        } else {
            writeln!(obj, "f {a} {b} {c}")
        };
    }
    write(dir, "sphere.obj", &obj)?;
    write(dir, "sphere.mtl", "newmtl grey\nKd 0.5 0.5 0.5\n")?;
    write(
        dir,
        "sphere.toml",
        &format!(
            "[[object]]\nmesh = \"sphere.obj\"\n\n[[light]]\ntype = \"directional\"\ndirection = [0.0, -1.0, 0.0]\n\
             irradiance = [1.0, 1.0, 1.0]\n\n[camera]\nposition = [0.0, {cy}, {cz}]\ntarget = [0.0, 0.0, 0.0]\n\
             fov = 40.0\nwidth = 64\nheight = 64\n\n[solver]\n{solver}\n",
            cy = 2.0 * r,
            cz = 3.0 * r
        ),
    )
}

/// A floor `[-s, s]² × {0}` (albedo 0.5) under a directional light of irradiance 1 going
/// straight down, and above it at height 1 a screen `[-1, 1]²` (albedo 0.5) cut out by
/// `map_d mask.png`: a 256×16 greyscale PNG (no alpha channel: its grey is the mask),
/// black (transparent) in its left half, white in its right, u running with x. The floor
/// gets `E_d = 1` under the screen's cut-out half (`x < 0`) and beside the screen, 0 under
/// its opaque half (`x > 0`), but for a blend one texel wide at the mask's edges.
pub fn cutout_screen(dir: &Path, s: f64, solver: &str) -> Result<PathBuf> {
    write(
        dir,
        "screen.obj",
        &format!(
            "mtllib screen.mtl\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
             usemtl floor\nv {s} 0 {s}\nv {s} 0 -{s}\nv -{s} 0 -{s}\nv -{s} 0 {s}\nf 1/1 2/1 3/1\nf 1/1 3/1 4/1\n\
             usemtl screen\nv -1 1 -1\nv 1 1 -1\nv 1 1 1\nv -1 1 1\nf 5/1 6/2 7/3\nf 5/1 7/3 8/4\n"
        ),
    )?;
    write(
        dir,
        "screen.mtl",
        "newmtl floor\nKd 0.5 0.5 0.5\nnewmtl screen\nKd 0.5 0.5 0.5\nmap_d mask.png\n",
    )?;
    let mask = image::GrayImage::from_fn(256, 16, |x, _| image::Luma([if x < 128 { 0 } else { 255 }]));
    let png = dir.join("mask.png");
    mask.save(&png).map_err(|e| Error::Texture {
        path: png.clone(),
        message: e.to_string(),
    })?;
    write(
        dir,
        "screen.toml",
        &format!(
            "[[object]]\nmesh = \"screen.obj\"\n\n[[light]]\ntype = \"directional\"\ndirection = [0.0, -1.0, 0.0]\n\
             irradiance = [1.0, 1.0, 1.0]\n\n[camera]\nposition = [0.0, 0.5, {cz}]\ntarget = [0.0, 0.0, 0.0]\n\
             fov = 60.0\nwidth = 32\nheight = 32\n\n[solver]\n{solver}\n",
            cz = s
        ),
    )
}

/// Closed-form furnace answers: `(E_d for a centred light, E_ind after k bounces,
/// bounce k alone)`.
pub fn furnace_expected(r: f64, rho: f64, i: f64, k: u32) -> (f64, f64, f64) {
    let ed = i / (r * r);
    let total: f64 = (1..=k).map(|b| rho.powi(b as i32)).sum();
    (ed, ed * total, ed * rho.powi(k as i32))
}

/// A square plane `[-s, s]² × {0}` (normal +y) with a point light at height `h` above the
/// origin: `E_d(d) = I h / (h² + d²)^{3/2}` at distance `d` from the foot point.
pub fn plane(dir: &Path, s: f64, h: f64, i: f64, tessellate: u32, solver: &str) -> Result<PathBuf> {
    write(
        dir,
        "plane.obj",
        &format!("mtllib plane.mtl\nusemtl floor\nv {s} 0 {s}\nv {s} 0 -{s}\nv -{s} 0 -{s}\nv -{s} 0 {s}\nf 1 2 3\nf 1 3 4\n"),
    )?;
    write(dir, "plane.mtl", "newmtl floor\nKd 0.5 0.5 0.5\n")?;
    write(
        dir,
        "plane.toml",
        &format!(
            "[[object]]\nmesh = \"plane.obj\"\ntessellate = {tessellate}\n\n[[light]]\ntype = \"point\"\n\
             position = [0.0, {h}, 0.0]\nintensity = [{i}, {i}, {i}]\n\n[camera]\nposition = [0.0, {cy}, 0.0]\n\
             target = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nfov = 60.0\nwidth = 32\nheight = 32\n\n[solver]\n{solver}\n",
            cy = h * 2.0
        ),
    )
}

/// `I h / (h² + d²)^{3/2}`.
pub fn plane_expected(h: f64, i: f64, d: f64) -> f64 {
    i * h / (h * h + d * d).powf(1.5)
}

/// The faces of a cube `[-a, a]³`, each square as two triangles wound so that their
/// normals point inward (`inward`) or outward.
fn cube(a: f64, inward: bool) -> (Vec<[f64; 3]>, Vec<[usize; 3]>) {
    let v: Vec<[f64; 3]> = (0..8)
        .map(|k| {
            let s = |b: usize| if k >> b & 1 == 1 { a } else { -a };
            [s(0), s(1), s(2)]
        })
        .collect();
    let quads = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    let mut f = Vec::new();
    for q in quads {
        for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            let p = |i: usize| glam::DVec3::from(v[t[i]]);
            let n = (p(1) - p(0)).cross(p(2) - p(0));
            let out = n.dot(p(0) + p(1) + p(2)) > 0.0;
            f.push(if out == inward { [t[0], t[2], t[1]] } else { t });
        }
    }
    (v, f)
}

/// The emitting furnace: a closed cube `[-a, a]³` whose walls all emit radiance `le`
/// from their inside (MTL `Ke`) and reflect `rho`; no light. At every point of the inside
/// the walls fill the hemisphere, so `E_d = π L_e`, and bounce `k` alone adds `ρ^k π L_e`:
/// `E_ind = π L_e Σ_{b=1..k} ρ^b` after `k` bounces, `π L_e ρ/(1 − ρ)` converged.
pub fn emitting_box(dir: &Path, a: f64, rho: f64, le: f64, tessellate: u32, solver: &str) -> Result<PathBuf> {
    let (v, f) = cube(a, true);
    write(dir, "box.obj", &obj_text(&v, &f, "box.mtl", "wall"))?;
    write(
        dir,
        "box.mtl",
        &format!("newmtl wall\nKd {rho} {rho} {rho}\nKe {le} {le} {le}\n"),
    )?;
    write(
        dir,
        "box.toml",
        &format!(
            "[[object]]\nmesh = \"box.obj\"\ntessellate = {tessellate}\n\n[camera]\nposition = [0.0, 0.0, {cz}]\n\
             target = [0.0, 0.0, 0.0]\nfov = 90.0\nwidth = 32\nheight = 32\n\n[solver]\n{solver}\n",
            cz = a * 0.5
        ),
    )
}

/// A floor `[-s, s]² × {0}` (normal +y, albedo 0.5) under a square emitter
/// `[-a, a]² × {h}` facing down with radiance `le` (MTL `Ke`); no light.
pub fn square_emitter(dir: &Path, s: f64, a: f64, h: f64, le: f64, solver: &str) -> Result<PathBuf> {
    write(
        dir,
        "scene.obj",
        &format!(
            "mtllib scene.mtl\nusemtl floor\nv {s} 0 {s}\nv {s} 0 -{s}\nv -{s} 0 -{s}\nv -{s} 0 {s}\nf 1 2 3\nf 1 3 4\n\
             usemtl lamp\nv {a} {h} {a}\nv -{a} {h} {a}\nv -{a} {h} -{a}\nv {a} {h} -{a}\nf 5 6 7\nf 5 7 8\n"
        ),
    )?;
    write(
        dir,
        "scene.mtl",
        &format!("newmtl floor\nKd 0.5 0.5 0.5\nnewmtl lamp\nKd 0 0 0\nKe {le} {le} {le}\n"),
    )?;
    write(
        dir,
        "scene.toml",
        &format!(
            "[[object]]\nmesh = \"scene.obj\"\n\n[camera]\nposition = [0.0, {cy}, {cz}]\ntarget = [0.0, 0.0, 0.0]\n\
             fov = 60.0\nwidth = 32\nheight = 32\n\n[solver]\n{solver}\n",
            cy = h * 0.5,
            cz = s
        ),
    )
}

/// The x-range of [`masked_emitter`]'s lamp that emits, in units of its half side `a`.
pub const MASKED_STRIP: [f64; 2] = [1.0 / 16.0, 15.0 / 16.0];

/// [`square_emitter`] with its emission masked: the lamp is two squares `[-a, 0] × [-a,
/// a]` and `[0, a] × [-a, a]` (two triangles each) with `Ke le` times `map_Ke mask.png`,
/// a 256×16 sRGB PNG, u running with x across the lamp: white in texel columns 136 to
/// 247, black elsewhere (so that the repeating bilinear read stays black over the left
/// square, its edges included). Only the strip `x ∈ [a/16, 15a/16]` emits
/// ([`MASKED_STRIP`]: `L_e = le`, the one-texel blends at its borders even out), and the
/// dark square's triangles are no emitters.
pub fn masked_emitter(dir: &Path, s: f64, a: f64, h: f64, le: f64, solver: &str) -> Result<PathBuf> {
    let path = square_emitter(dir, s, a, h, le, solver)?;
    write(
        dir,
        "scene.obj",
        &format!(
            "mtllib scene.mtl\nvt 0 0\nvt 0 1\nvt 0.5 1\nvt 1 1\nvt 0.5 0\nvt 1 0\n\
             usemtl floor\nv {s} 0 {s}\nv {s} 0 -{s}\nv -{s} 0 -{s}\nv -{s} 0 {s}\nf 1/1 2/1 3/1\nf 1/1 3/1 4/1\n\
             usemtl lamp\nv {a} {h} {a}\nv 0 {h} {a}\nv -{a} {h} {a}\nv -{a} {h} -{a}\nv 0 {h} -{a}\nv {a} {h} -{a}\n\
             f 5/4 6/3 9/5\nf 5/4 9/5 10/6\nf 6/3 7/2 8/1\nf 6/3 8/1 9/5\n"
        ),
    )?;
    write(
        dir,
        "scene.mtl",
        &format!("newmtl floor\nKd 0.5 0.5 0.5\nnewmtl lamp\nKd 0 0 0\nKe {le} {le} {le}\nmap_Ke mask.png\n"),
    )?;
    let mask = image::RgbImage::from_fn(256, 16, |x, _| {
        image::Rgb([if (136..248).contains(&x) { 255 } else { 0 }; 3])
    });
    let png = dir.join("mask.png");
    mask.save(&png).map_err(|e| Error::Texture {
        path: png.clone(),
        message: e.to_string(),
    })?;
    Ok(path)
}

/// Irradiance at `x` (unit normal `n`) from a uniformly emitting polygon of radiance `le`
/// with corners `poly` (in order), wholly above `x`'s tangent plane: Lambert's formula
/// `E = (L/2) |Σ_i θ_i n · (v_i × v_{i+1}) / |v_i × v_{i+1}||`, `v_i` the unit vectors to
/// the corners and `θ_i` the angle between consecutive ones.
pub fn polygon_irradiance(x: glam::DVec3, n: glam::DVec3, poly: &[glam::DVec3], le: f64) -> f64 {
    let mut s = 0.0;
    for i in 0..poly.len() {
        let a = (poly[i] - x).normalize();
        let b = (poly[(i + 1) % poly.len()] - x).normalize();
        let c = a.cross(b);
        let theta = a.dot(b).clamp(-1.0, 1.0).acos();
        s += theta * n.dot(c.normalize());
    }
    0.5 * le * s.abs()
}

/// A floor `[-s, s]² × {0}` (normal +y, albedo 0.5) under a constant `[sky]` of radiance
/// `l`; with `wall`, a wall `x = 1, y ∈ [0, 2]` across the floor facing −x (albedo 0.5)
/// that blocks part of the sky and sends its bounce light to the floor. Without it the
/// floor's upper side sees the whole sky: `E_d = π l` everywhere on it.
pub fn sky_plane(dir: &Path, s: f64, wall: bool, l: f64, solver: &str) -> Result<PathBuf> {
    let mut obj = format!(
        "mtllib sky.mtl\nusemtl grey\nv {s} 0 {s}\nv {s} 0 -{s}\nv -{s} 0 -{s}\nv -{s} 0 {s}\nf 1 2 3\nf 1 3 4\n"
    );
    if wall {
        obj.push_str(&format!(
            "v 1 0 -{s}\nv 1 0 {s}\nv 1 2 {s}\nv 1 2 -{s}\nf 5 6 7\nf 5 7 8\n"
        ));
    }
    write(dir, "sky.obj", &obj)?;
    write(dir, "sky.mtl", "newmtl grey\nKd 0.5 0.5 0.5\n")?;
    write(
        dir,
        "sky.toml",
        &format!(
            "[[object]]\nmesh = \"sky.obj\"\n\n[sky]\nradiance = [{l}, {l}, {l}]\n\n[camera]\n\
             position = [-3.0, 2.0, 0.0]\ntarget = [1.0, 0.5, 0.0]\nfov = 60.0\nwidth = 32\nheight = 32\n\n\
             [solver]\n{solver}\n"
        ),
    )
}
