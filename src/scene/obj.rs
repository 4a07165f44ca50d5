//! OBJ/MTL loading through tobj, with the checks tobj does not make: every malformed
//! line is reported with its number, non-finite vertices are errors, degenerate
//! triangles are dropped and counted.

use std::io::Cursor;
use std::path::{Path, PathBuf};

use glam::Vec3;

use super::source::Source;
use crate::error::{Error, Result};
use crate::layout::Tri;

/// A material as the MTL file gives it.
#[derive(Clone, Debug)]
pub struct MtlData {
    pub name: String,
    pub kd: [f32; 3],
    /// `map_Kd`, relative to the scene source.
    pub texture: Option<PathBuf>,
    pub emissive: bool,
    /// The OBJ file it was loaded for (for messages).
    pub origin: PathBuf,
}

/// One OBJ file's triangles; `Tri::material` indexes `materials`.
#[derive(Clone, Debug, Default)]
pub struct LoadedMesh {
    pub tris: Vec<Tri>,
    /// Corner uvs per triangle (empty when the file has none).
    pub uvs: Vec<[f32; 6]>,
    pub materials: Vec<MtlData>,
    pub degenerate: usize,
    /// Faces without a material (given a default grey).
    pub unassigned: usize,
}

/// Albedo of faces that have no material.
pub const DEFAULT_KD: [f32; 3] = [0.8, 0.8, 0.8];

/// Loads `rel` from `source`.
pub fn load(source: &Source, rel: &Path) -> Result<LoadedMesh> {
    let shown = source.display(rel);
    let bytes = source.read(rel)?;
    let text = String::from_utf8_lossy(&bytes);
    if let Err((line, message)) = check_lines(&text) {
        return Err(Error::Mesh {
            path: shown,
            line: Some(line),
            message,
        });
    }
    let dir = rel.parent().map(Path::to_path_buf).unwrap_or_default();
    let mtl_error = std::cell::RefCell::new(None);
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, mats) = tobj::load_obj_buf(&mut Cursor::new(&bytes), &opts, |mtl| {
        let p = dir.join(mtl);
        match source.read(&p) {
            Ok(b) => tobj::load_mtl_buf(&mut Cursor::new(b)),
            Err(e) => {
                *mtl_error.borrow_mut() = Some(e);
                Err(tobj::LoadError::OpenFileFailed)
            }
        }
    })
    .map_err(|e| Error::Mesh {
        path: shown.clone(),
        line: None,
        message: format!("OBJ parse error: {e}"),
    })?;
    if let Some(e) = mtl_error.into_inner() {
        return Err(Error::Mesh {
            path: shown,
            line: None,
            message: format!("its material library could not be read: {e}"),
        });
    }
    let mats = mats.map_err(|e| Error::Mesh {
        path: shown.clone(),
        line: None,
        message: format!("material library: {e}"),
    })?;
    let mut out = LoadedMesh {
        materials: mats
            .iter()
            .map(|m| MtlData {
                name: m.name.clone(),
                kd: m.diffuse.unwrap_or(DEFAULT_KD),
                texture: m.diffuse_texture.as_ref().map(|t| dir.join(t.replace('\\', "/"))),
                emissive: m.emissive.is_some_and(|e| e.iter().any(|&c| c != 0.0)),
                origin: shown.clone(),
            })
            .collect(),
        ..Default::default()
    };
    let default_material = out.materials.len() as u32;
    let mut any_uv = false;
    for model in &models {
        let m = &model.mesh;
        let has_uv = !m.texcoords.is_empty() && m.texcoord_indices.len() == m.indices.len();
        any_uv |= has_uv;
        let material = match m.material_id {
            Some(id) if id < mats.len() => id as u32,
            _ => {
                out.unassigned += m.indices.len() / 3;
                default_material
            }
        };
        for (f, idx) in m.indices.chunks_exact(3).enumerate() {
            let p = |i: u32| {
                let i = i as usize * 3;
                [m.positions[i], m.positions[i + 1], m.positions[i + 2]]
            };
            let tri = Tri {
                v0: p(idx[0]),
                v1: p(idx[1]),
                v2: p(idx[2]),
                material,
                ..Default::default()
            };
            if is_degenerate(&tri) {
                out.degenerate += 1;
                continue;
            }
            out.tris.push(tri);
            let mut uv = [0.0f32; 6];
            if has_uv {
                for c in 0..3 {
                    let t = m.texcoord_indices[f * 3 + c] as usize * 2;
                    uv[c * 2] = m.texcoords[t];
                    uv[c * 2 + 1] = m.texcoords[t + 1];
                }
            }
            out.uvs.push(uv);
        }
    }
    if !any_uv {
        out.uvs.clear();
    }
    if out.unassigned > 0 {
        out.materials.push(MtlData {
            name: "(default)".into(),
            kd: DEFAULT_KD,
            texture: None,
            emissive: false,
            origin: shown,
        });
    }
    Ok(out)
}

/// Zero-area (to float precision) or non-finite triangles.
pub fn is_degenerate(t: &Tri) -> bool {
    let v0 = Vec3::from(t.v0);
    let e1 = Vec3::from(t.v1) - v0;
    let e2 = Vec3::from(t.v2) - v0;
    let c = e1.cross(e2).length();
    let scale = e1.length_squared().max(e2.length_squared());
    !(c.is_finite() && scale.is_finite()) || c <= 1e-12 * scale
}

/// Splits every triangle into four at its edge midpoints.
pub fn tessellate(tris: &[Tri], uvs: &[[f32; 6]]) -> (Vec<Tri>, Vec<[f32; 6]>) {
    let mut out = Vec::with_capacity(tris.len() * 4);
    let mut out_uv = Vec::with_capacity(uvs.len() * 4);
    for (i, t) in tris.iter().enumerate() {
        let v = [Vec3::from(t.v0), Vec3::from(t.v1), Vec3::from(t.v2)];
        let m = [(v[0] + v[1]) * 0.5, (v[1] + v[2]) * 0.5, (v[2] + v[0]) * 0.5];
        let mk = |a: Vec3, b: Vec3, c: Vec3| Tri {
            v0: a.into(),
            v1: b.into(),
            v2: c.into(),
            material: t.material,
            ..Default::default()
        };
        out.push(mk(v[0], m[0], m[2]));
        out.push(mk(m[0], v[1], m[1]));
        out.push(mk(m[2], m[1], v[2]));
        out.push(mk(m[0], m[1], m[2]));
        if let Some(uv) = uvs.get(i) {
            let c = |k: usize| [uv[2 * k], uv[2 * k + 1]];
            let mid = |a: [f32; 2], b: [f32; 2]| [(a[0] + b[0]) * 0.5, (a[1] + b[1]) * 0.5];
            let (a, b, cc) = (c(0), c(1), c(2));
            let (ab, bc, ca) = (mid(a, b), mid(b, cc), mid(cc, a));
            let pack = |p: [f32; 2], q: [f32; 2], r: [f32; 2]| [p[0], p[1], q[0], q[1], r[0], r[1]];
            out_uv.push(pack(a, ab, ca));
            out_uv.push(pack(ab, b, bc));
            out_uv.push(pack(ca, bc, cc));
            out_uv.push(pack(ab, bc, ca));
        }
    }
    (out, out_uv)
}

/// Checks the lines tobj would accept silently or reject without a line number:
/// vertices must be finite numbers, faces must reference existing vertices.
fn check_lines(text: &str) -> std::result::Result<(), (usize, String)> {
    let (mut nv, mut nvt) = (0i64, 0i64);
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let l = raw.split('#').next().unwrap_or("").trim();
        let mut words = l.split_whitespace();
        match words.next() {
            Some("v") => {
                let vals: Vec<&str> = words.collect();
                if vals.len() < 3 {
                    return Err((line, format!("vertex needs 3 coordinates: `{l}`")));
                }
                for w in &vals[..3] {
                    match w.parse::<f32>() {
                        Ok(x) if x.is_finite() => {}
                        Ok(_) => return Err((line, format!("vertex coordinate `{w}` is not finite"))),
                        Err(_) => return Err((line, format!("vertex coordinate `{w}` is not a number"))),
                    }
                }
                nv += 1;
            }
            Some("vt") => {
                for w in words.take(2) {
                    if !w.parse::<f32>().is_ok_and(f32::is_finite) {
                        return Err((line, format!("texture coordinate `{w}` is not a finite number")));
                    }
                }
                nvt += 1;
            }
            Some("f") => {
                let refs: Vec<&str> = words.collect();
                if refs.len() < 3 {
                    return Err((line, format!("face needs at least 3 vertices: `{l}`")));
                }
                for r in refs {
                    let mut parts = r.split('/');
                    let check = |s: Option<&str>, n: i64, what: &str| -> std::result::Result<(), String> {
                        match s {
                            None | Some("") => Ok(()),
                            Some(s) => match s.parse::<i64>() {
                                Ok(k) if (k > 0 && k <= n) || (k < 0 && -k <= n) => Ok(()),
                                Ok(k) => Err(format!("face refers to {what} {k}, but {n} are defined before it")),
                                Err(_) => Err(format!("face reference `{r}` is not an index")),
                            },
                        }
                    };
                    let v = parts.next();
                    if v.is_none_or(str::is_empty) {
                        return Err((line, format!("face reference `{r}` has no vertex index")));
                    }
                    check(v, nv, "vertex").map_err(|m| (line, m))?;
                    check(parts.next(), nvt, "texture coordinate").map_err(|m| (line, m))?;
                }
            }
            _ => {}
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reports_line_of_bad_vertex() {
        let e = check_lines("v 0 0 0\nv 1 nan 0\n").unwrap_err();
        assert_eq!(e.0, 2);
        let e = check_lines("v 0 0 0\nv 1 x 0\n").unwrap_err();
        assert_eq!(e.0, 2);
        let e = check_lines("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n").unwrap_err();
        assert_eq!(e.0, 4);
        assert!(check_lines("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n").is_ok());
    }

    #[test]
    fn degenerate_detection() {
        let t = Tri {
            v0: [0.0; 3],
            v1: [1.0, 0.0, 0.0],
            v2: [2.0, 0.0, 0.0],
            ..Default::default()
        };
        assert!(is_degenerate(&t));
        let s = Tri {
            v2: [0.0, 1e-3, 0.0],
            ..t
        };
        assert!(!is_degenerate(&s));
    }

    #[test]
    fn tessellation_preserves_area() {
        let t = Tri {
            v0: [0.0; 3],
            v1: [1.0, 0.0, 0.0],
            v2: [0.0, 1.0, 0.0],
            ..Default::default()
        };
        let (out, _) = tessellate(&[t], &[]);
        let area: f32 = out
            .iter()
            .map(|t| {
                let v0 = Vec3::from(t.v0);
                (Vec3::from(t.v1) - v0).cross(Vec3::from(t.v2) - v0).length() * 0.5
            })
            .sum();
        assert_eq!(out.len(), 4);
        assert!((area - 0.5).abs() < 1e-6);
    }
}
