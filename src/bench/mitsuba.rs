//! Mitsuba 3 as a second path-tracing baseline on the image front (issue #33), where it is
//! installed (`pip install mitsuba`; its `llvm_ad_rgb` variant needs Debian's `libllvm`
//! 16 or newer). The loaded scene is exported as it is traced here — world-space
//! triangles grouped by material, their shading normals and texture coordinates, the
//! textures' sRGB texels with this project's decoding table, the emitters, the lights,
//! a constant sky and the camera — and `mitsuba_render.py` (embedded, written next to the
//! export) builds a Mitsuba scene from it: two-sided `diffuse` BSDFs, `area` emitters,
//! `point`, `spot` and `directional` lights, a `constant` emitter, a `perspective`
//! sensor with `fov_axis = smaller` and a `box` filter, rendered by `path` with no depth
//! limit in passes of at most 16 M samples. Its time runs from the scene dictionary to
//! the image in memory (Mitsuba's scene build and its kernels' compilation included; the
//! Python start and the export not). Environment-map skies and cutouts are not exported
//! (an error that says so: the bench then leaves Mitsuba's rows out for that scene).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use glam::Vec3;

use crate::error::{Error, Result};
use crate::geom::transform::{xform_point, xform_vector};
use crate::layout::{LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT, NONE};
use crate::scene::sky::Sky;
use crate::scene::Scene;

/// The renderer's script, written into the export's folder.
pub const SCRIPT: &str = include_str!("mitsuba_render.py");
/// Irradiance at probe points (`points.py`, written next to it).
pub const SCRIPT_POINTS: &str = include_str!("mitsuba_points.py");

/// The Python interpreter: `$MESHRAD_PYTHON`, or `python3`.
pub fn python() -> String {
    std::env::var("MESHRAD_PYTHON").unwrap_or_else(|_| "python3".into())
}

/// Mitsuba's version where its `llvm_ad_rgb` variant loads, or why not.
pub fn available() -> std::result::Result<String, String> {
    let py = python();
    let out = Command::new(&py)
        .args([
            "-c",
            "import mitsuba as mi; mi.set_variant('llvm_ad_rgb'); print(mi.__version__)",
        ])
        .output()
        .map_err(|e| format!("{py}: {e}"))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let last = err.lines().last().unwrap_or("").to_string();
        return Err(format!("`{py} -c 'import mitsuba'` failed: {last}"));
    }
    Ok(String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |e| Error::io(path, e)
}

fn f32_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn vec3_json(v: Vec3) -> String {
    format!("[{:e}, {:e}, {:e}]", v.x, v.y, v.z)
}

fn unsupported(dir: &Path, what: &str) -> Error {
    Error::Output {
        path: dir.into(),
        message: format!("the Mitsuba export does not cover {what}"),
    }
}

/// Writes `scene` into `dir` as `scene.json` (materials, lights, sky, camera, the sRGB
/// table), one `mesh-K.bin` per material (little-endian f32: 9 positions a triangle, then
/// 9 normals where it has them, then 6 texture coordinates where it is textured), the
/// textures' texels (`texels.bin`, RGBA8 as loaded) and the scripts.
pub fn export(scene: &Scene, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    if scene.cutouts {
        return Err(unsupported(dir, "cutouts (alpha-tested materials)"));
    }
    let nm = scene.materials.len();
    let mut pos: Vec<Vec<f32>> = vec![Vec::new(); nm];
    let mut nrm: Vec<Vec<f32>> = vec![Vec::new(); nm];
    let mut uvs: Vec<Vec<f32>> = vec![Vec::new(); nm];
    let textured =
        |m: usize| !scene.uvs.is_empty() && (scene.materials[m].texture != NONE || scene.emission_textures[m] != NONE);
    for obj in &scene.objects {
        for t in obj.tri_offset..obj.tri_offset + obj.tri_count {
            let tri = &scene.tris[t as usize];
            let m = tri.material as usize;
            let v = [tri.v0, tri.v1, tri.v2].map(|p| xform_point(&obj.to_world, Vec3::from(p)));
            let g = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
            for p in v {
                pos[m].extend_from_slice(&p.to_array());
            }
            let corners = scene.normals.get(t as usize);
            for k in 0..3 {
                let n = corners
                    .map(|c| Vec3::new(c[3 * k], c[3 * k + 1], c[3 * k + 2]))
                    .filter(|n| *n != Vec3::ZERO)
                    .map_or(g, |n| xform_vector(&obj.to_world, n).normalize_or_zero());
                nrm[m].extend_from_slice(&n.to_array());
            }
            if textured(m) {
                let uv = &scene.uvs[t as usize].uv;
                for k in 0..3 {
                    // Mitsuba reads a bitmap's top row at v = 0; this project at v = 1.
                    uvs[m].extend_from_slice(&[uv[2 * k], 1.0 - uv[2 * k + 1]]);
                }
            }
        }
    }
    let has_normals = !scene.normals.is_empty();
    let mut json = String::from("{\n  \"materials\": [\n");
    let mut first = true;
    for m in 0..nm {
        if pos[m].is_empty() {
            continue;
        }
        let file = format!("mesh-{m}.bin");
        let mut bytes = f32_bytes(&pos[m]);
        if has_normals {
            bytes.extend(f32_bytes(&nrm[m]));
        }
        bytes.extend(f32_bytes(&uvs[m]));
        let path = dir.join(&file);
        std::fs::write(&path, bytes).map_err(io(&path))?;
        let mat = &scene.materials[m];
        let tex = |t: u32| -> String {
            let i = &scene.textures[t as usize];
            let wrap = match i.wrap & 3 {
                crate::layout::WRAP_CLAMP => "clamp",
                crate::layout::WRAP_MIRROR => "mirror",
                _ => "repeat",
            };
            format!(
                "{{\"offset\": {}, \"width\": {}, \"height\": {}, \"wrap\": \"{wrap}\"}}",
                i.offset, i.width, i.height
            )
        };
        let _ = write!(
            json,
            "{}    {{\"name\": {:?}, \"file\": \"{file}\", \"triangles\": {}, \"normals\": {has_normals}, \
             \"uvs\": {}, \"albedo\": {}, \"texture\": {}, \"emission\": {}, \"emission_texture\": {}}}",
            if first { "" } else { ",\n" },
            scene.material_names.get(m).cloned().unwrap_or_default(),
            pos[m].len() / 9,
            !uvs[m].is_empty(),
            vec3_json(Vec3::from(mat.kd)),
            if mat.texture == NONE {
                "null".into()
            } else {
                tex(mat.texture)
            },
            vec3_json(scene.emission[m]),
            if scene.emission_textures[m] == NONE || scene.emission[m] == Vec3::ZERO {
                "null".into()
            } else {
                tex(scene.emission_textures[m])
            },
        );
        first = false;
    }
    json.push_str("\n  ],\n  \"lights\": [");
    for (i, l) in scene.lights.iter().enumerate() {
        let sep = if i == 0 { "\n" } else { ",\n" };
        let (p, d, w) = (Vec3::from(l.position), Vec3::from(l.direction), Vec3::from(l.power));
        let _ = match l.kind {
            LIGHT_POINT => write!(
                json,
                "{sep}    {{\"type\": \"point\", \"position\": {}, \"intensity\": {}}}",
                vec3_json(p),
                vec3_json(w)
            ),
            LIGHT_SPOT => write!(
                json,
                "{sep}    {{\"type\": \"spot\", \"position\": {}, \"direction\": {}, \"intensity\": {}, \
                 \"cutoff_angle\": {:e}, \"beam_width\": {:e}}}",
                vec3_json(p),
                vec3_json(d),
                vec3_json(w),
                l.cutoff.to_degrees(),
                l.beam.to_degrees()
            ),
            LIGHT_DIRECTIONAL => write!(
                json,
                "{sep}    {{\"type\": \"directional\", \"direction\": {}, \"irradiance\": {}}}",
                vec3_json(d),
                vec3_json(w)
            ),
            _ => return Err(unsupported(dir, "a light of an unknown kind")),
        };
    }
    json.push_str("\n  ],\n");
    match &scene.sky {
        None => json.push_str("  \"sky\": null,\n"),
        Some(Sky::Constant(l)) => {
            let _ = writeln!(json, "  \"sky\": {},", vec3_json(*l));
        }
        Some(Sky::Map(_)) => return Err(unsupported(dir, "an environment-map sky")),
    }
    let c = &scene.camera;
    let _ = writeln!(
        json,
        "  \"camera\": {{\"position\": {}, \"target\": {}, \"up\": {}, \"fov\": {:e}, \"width\": {}, \"height\": {}, \
         \"filter\": \"{}\"}},",
        vec3_json(c.position),
        vec3_json(c.position + c.forward),
        vec3_json(c.up),
        2.0 * c.tan_half.atan().to_degrees(),
        c.width,
        c.height,
        match c.filter {
            crate::scene::camera::Filter::Box => "box",
            crate::scene::camera::Filter::Gaussian => "gaussian",
        }
    );
    let srgb: Vec<String> = scene.srgb.iter().map(|x| format!("{x:e}")).collect();
    let _ = writeln!(json, "  \"srgb\": [{}]\n}}", srgb.join(", "));
    let path = dir.join("scene.json");
    std::fs::write(&path, json).map_err(io(&path))?;
    let path = dir.join("texels.bin");
    let texels: Vec<u8> = scene.texels.iter().flat_map(|t| t.to_le_bytes()).collect();
    std::fs::write(&path, texels).map_err(io(&path))?;
    for (name, text) in [("mitsuba_render.py", SCRIPT), ("points.py", SCRIPT_POINTS)] {
        let path = dir.join(name);
        std::fs::write(&path, text).map_err(io(&path))?;
    }
    Ok(())
}

/// One Mitsuba image of the export in `dir` at `spp` paths per pixel (seeded by `seed`):
/// its pixels (rows from the top) and Mitsuba's own time in seconds.
pub fn render(dir: &Path, spp: u32, seed: u32, width: u32, height: u32) -> Result<(Vec<Vec3>, f64)> {
    let image = dir.join(format!("image-{spp}-{seed}.bin"));
    let script: PathBuf = dir.join("mitsuba_render.py");
    let out = Command::new(python())
        .arg(&script)
        .arg(dir)
        .arg(spp.to_string())
        .arg(seed.to_string())
        .arg(&image)
        .output()
        .map_err(io(&script))?;
    let fail = |message: String| Error::Output {
        path: image.clone(),
        message,
    };
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let tail: Vec<&str> = err.lines().rev().take(5).collect();
        return Err(fail(format!(
            "Mitsuba failed: {}",
            tail.into_iter().rev().collect::<Vec<_>>().join(" / ")
        )));
    }
    let stdout = String::from_utf8_lossy(&out.stdout);
    let seconds: f64 = stdout
        .lines()
        .find_map(|l| l.strip_prefix("seconds "))
        .and_then(|s| s.trim().parse().ok())
        .ok_or_else(|| fail(format!("no time in Mitsuba's output: {stdout}")))?;
    let bytes = std::fs::read(&image).map_err(io(&image))?;
    let n = (width * height) as usize;
    if bytes.len() != n * 12 {
        return Err(fail(format!("{} bytes, expected {}", bytes.len(), n * 12)));
    }
    let f: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    let _ = std::fs::remove_file(&image);
    Ok((
        f.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect(),
        seconds,
    ))
}
