//! OBJ/MTL loading. The OBJ text is checked and normalised here line by line (every
//! malformed line is reported with its number; a byte-order mark, comments, `v x y z w`
//! and short `vt` lines are resolved) and then handed to tobj for faces, groups and
//! materials. MTL files are parsed here in full: tobj panics on short colour lines and
//! reads `map_Kd` options as part of the file name. Non-finite vertices are errors,
//! degenerate triangles are dropped and counted.

use std::cell::RefCell;
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
    /// The texture's bytes when they are not a file of their own (a glTF's embedded
    /// image; `texture` then only names it).
    pub texture_data: Option<std::sync::Arc<[u8]>>,
    /// The texture's wrap modes (`TextureInfo::wrap`; repeat for OBJ).
    pub wrap: u32,
    /// `map_Kd -o u v` and `-s u v`: texture coordinates become `offset + scale * uv`.
    pub uv_offset: [f32; 2],
    pub uv_scale: [f32; 2],
    /// `Ke`: emitted radiance (W/(m²·sr) per channel, one-sided: the side the winding
    /// normal points to), zero for none.
    pub emission: [f32; 3],
    /// The line of its `Ke` (for messages).
    pub ke_line: Option<usize>,
    /// `map_Ke` (glTF `emissiveTexture`): the emission is `emission` times it, per
    /// texel; its bytes where they are not a file of their own, and its wrap modes.
    pub emission_texture: Option<PathBuf>,
    pub emission_texture_data: Option<std::sync::Arc<[u8]>>,
    pub emission_wrap: u32,
    /// A cutout (MTL `map_d`/`d`/`Tr`, glTF `alphaMode` MASK or BLEND): rays pass where
    /// `opacity` × the alpha texture's value is below `cutoff`. False: opaque.
    pub cutout: bool,
    /// MTL `d` (1 − `Tr`), glTF `baseColorFactor`'s alpha.
    pub opacity: f32,
    pub cutoff: f32,
    /// MTL `map_d` (a mask: its alpha channel if it has one, else its red one).
    pub alpha_texture: Option<PathBuf>,
    pub alpha_texture_data: Option<std::sync::Arc<[u8]>>,
    /// glTF: the alpha is the base colour texture's alpha channel.
    pub alpha_from_albedo: bool,
    /// The file it was defined in and the line of its `Kd` (for messages).
    pub origin: PathBuf,
    pub kd_line: Option<usize>,
    /// The OBJ file whose `mtllib` read it.
    pub used_by: PathBuf,
}

impl MtlData {
    /// A material of the default albedo, untextured, defined in `origin`.
    pub(super) fn grey(name: String, origin: PathBuf) -> MtlData {
        MtlData {
            name,
            kd: DEFAULT_KD,
            texture: None,
            texture_data: None,
            wrap: 0,
            uv_offset: [0.0; 2],
            uv_scale: [1.0; 2],
            emission: [0.0; 3],
            ke_line: None,
            emission_texture: None,
            emission_texture_data: None,
            emission_wrap: 0,
            cutout: false,
            opacity: 1.0,
            cutoff: CUTOFF,
            alpha_texture: None,
            alpha_texture_data: None,
            alpha_from_albedo: false,
            origin,
            kd_line: None,
            used_by: PathBuf::new(),
        }
    }
}

/// One OBJ file's triangles; `Tri::material` indexes `materials`.
#[derive(Clone, Debug, Default)]
pub struct LoadedMesh {
    pub tris: Vec<Tri>,
    /// Corner uvs per triangle (empty when the file has none).
    pub uvs: Vec<[f32; 6]>,
    /// Corner normals per triangle, unit, on its front (empty when the file has none;
    /// zero for a triangle without them).
    pub normals: Vec<[f32; 9]>,
    pub materials: Vec<MtlData>,
    pub degenerate: usize,
    /// Faces without a material (given a default grey).
    pub unassigned: usize,
    /// Exact duplicates of an earlier triangle (the same three corners) dropped.
    pub duplicates: usize,
    /// Things read but not used, one line each (e.g. ignored `map_Kd` options).
    pub notes: Vec<String>,
    /// The files read: the OBJ and its material libraries.
    pub inputs: Vec<PathBuf>,
    /// The named parts (OBJ `o`/`g` groups, glTF nodes) and their bounds, in the file's
    /// space: what `group` can name, for the warning that names the part enclosing the
    /// scene.
    pub parts: Vec<Part>,
}

/// A named part of a mesh file (an OBJ group, a glTF node) and the bounds of its kept
/// triangles, in the file's space.
#[derive(Clone, Debug)]
pub struct Part {
    pub name: String,
    pub lo: Vec3,
    pub hi: Vec3,
}

/// Adds the triangles `from..` of `out` to the part `name` (merged with an earlier part of
/// that name); nothing for an unnamed part or no triangles.
pub fn add_part(out: &mut LoadedMesh, name: &str, from: usize) {
    if name.is_empty() || from >= out.tris.len() {
        return;
    }
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for t in &out.tris[from..] {
        for v in [t.v0, t.v1, t.v2] {
            lo = lo.min(Vec3::from(v));
            hi = hi.max(Vec3::from(v));
        }
    }
    match out.parts.iter_mut().find(|p| p.name == name) {
        Some(p) => {
            p.lo = p.lo.min(lo);
            p.hi = p.hi.max(hi);
        }
        None => out.parts.push(Part {
            name: name.to_string(),
            lo,
            hi,
        }),
    }
}

/// The alpha below which a cutout lets rays through (MTL `d`/`map_d`, glTF BLEND; glTF
/// MASK gives its own `alphaCutoff`).
pub const CUTOFF: f32 = 0.5;

impl MtlData {
    /// Whether its cutout takes every ray through (a constant alpha below the cutoff, no
    /// texture): its triangles are dropped at load.
    pub fn cut_out_entirely(&self) -> bool {
        self.cutout
            && self.alpha_texture.is_none()
            && !(self.alpha_from_albedo && self.texture.is_some())
            && self.opacity < self.cutoff
    }
}

/// Albedo of faces that have no material.
pub const DEFAULT_KD: [f32; 3] = [0.8, 0.8, 0.8];

/// At most this many characters of an offending line are quoted in a message.
const QUOTE: usize = 80;

/// `s`, cut to [`QUOTE`] characters.
fn quote(s: &str) -> String {
    if s.chars().count() <= QUOTE {
        s.to_string()
    } else {
        format!("{}…", s.chars().take(QUOTE).collect::<String>())
    }
}

/// Loads `rel` from `source`; it and its material libraries may have at most `limit`
/// bytes each. With `groups`, only the faces of those `o`/`g` groups are kept (each must
/// exist).
pub fn load(source: &Source, rel: &Path, limit: u64, groups: Option<&[String]>) -> Result<LoadedMesh> {
    let shown = source.display(rel);
    let bytes = source.read_limited(rel, limit)?;
    let text = String::from_utf8_lossy(&bytes);
    let clean = sanitize(crate::limits::strip_bom(&text)).map_err(|(line, message)| Error::Mesh {
        path: shown.clone(),
        line: Some(line),
        message,
    })?;
    let (models, mut out) = parse_obj(source, rel, limit, &shown, &clean)?;
    let models = select_groups(models, groups, &shown, &clean)?;
    add_triangles(&models, &mut out);
    if out.unassigned > 0 {
        out.materials.push(MtlData {
            used_by: shown.clone(),
            ..MtlData::grey("(default)".into(), shown)
        });
    }
    Ok(out)
}

/// tobj's models of `clean`, the sanitized text of the OBJ file `rel` (`shown` in
/// messages), and a mesh without triangles yet: the materials of its material libraries
/// (each at most `limit` bytes), the notes on them and the files read.
fn parse_obj(
    source: &Source,
    rel: &Path,
    limit: u64,
    shown: &Path,
    clean: &str,
) -> Result<(Vec<tobj::Model>, LoadedMesh)> {
    let dir = rel.parent().map(Path::to_path_buf).unwrap_or_default();
    let mtl_error: RefCell<Option<Error>> = RefCell::new(None);
    let materials: RefCell<Vec<MtlData>> = RefCell::new(Vec::new());
    let notes: RefCell<Vec<String>> = RefCell::new(Vec::new());
    let inputs: RefCell<Vec<PathBuf>> = RefCell::new(vec![shown.to_path_buf()]);
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _) = tobj::load_obj_buf(&mut Cursor::new(clean.as_bytes()), &opts, |list| {
        // `mtllib a.mtl b.mtl` names several files; tobj passes the whole list. tobj is
        // given only the names (in order, so that its material ids index ours).
        let base = materials.borrow().len();
        let mut names = String::new();
        for name in list.to_string_lossy().split_whitespace() {
            let p = dir.join(name);
            let parsed = source
                .read_limited(&p, limit)
                .map_err(|e| Error::Mesh {
                    path: shown.to_path_buf(),
                    line: None,
                    message: format!("its material library could not be read: {e}"),
                })
                .and_then(|b| parse_mtl(&String::from_utf8_lossy(&b), &source.display(&p), &dir));
            match parsed {
                Ok((list, n)) => {
                    inputs.borrow_mut().push(source.display(&p));
                    for mut m in list {
                        m.used_by = shown.to_path_buf();
                        names.push_str("newmtl ");
                        names.push_str(&m.name);
                        names.push('\n');
                        materials.borrow_mut().push(m);
                    }
                    notes.borrow_mut().extend(n);
                }
                Err(e) => {
                    mtl_error.borrow_mut().get_or_insert(e);
                    materials.borrow_mut().truncate(base);
                    return Err(tobj::LoadError::OpenFileFailed);
                }
            }
        }
        tobj::load_mtl_buf(&mut Cursor::new(names.as_bytes()))
    })
    .map_err(|e| Error::Mesh {
        path: shown.to_path_buf(),
        line: None,
        message: format!("OBJ parse error: {e}"),
    })?;
    if let Some(e) = mtl_error.into_inner() {
        return Err(e);
    }
    let out = LoadedMesh {
        materials: materials.into_inner(),
        notes: notes.into_inner(),
        inputs: inputs.into_inner(),
        ..Default::default()
    };
    Ok((models, out))
}

/// With `groups`, only the models of those `o`/`g` groups (each must exist in the OBJ
/// file `shown`, whose sanitised text is `text`, and have faces); without, all of them.
fn select_groups(
    models: Vec<tobj::Model>,
    groups: Option<&[String]>,
    shown: &Path,
    text: &str,
) -> Result<Vec<tobj::Model>> {
    Ok(match groups {
        None => models,
        Some(names) => {
            // `!g` leaves group g out; with no group named to keep, every other one stays.
            let names: Vec<String> = names.iter().map(|g| g.trim_start_matches('!').to_string()).collect();
            let dropped = |g: &String| {
                groups
                    .unwrap_or(&[])
                    .iter()
                    .any(|e| e.strip_prefix('!') == Some(g.as_str()))
            };
            let has_faces = |g: &String| models.iter().any(|m| &m.name == g && !m.mesh.indices.is_empty());
            if let Some(missing) = names.iter().find(|g| !has_faces(g)) {
                let mut have: Vec<&str> = Vec::new();
                for m in models.iter().filter(|m| !m.mesh.indices.is_empty()) {
                    if !have.contains(&m.name.as_str()) {
                        have.push(&m.name);
                    }
                }
                let shown_have: Vec<&str> = have.iter().take(40).copied().collect();
                // A group named but holding no face (McGuire's files put their `g` lines
                // after the faces) is not a missing one.
                let declared = text.lines().enumerate().find(|(_, l)| {
                    let mut w = l.split_whitespace();
                    matches!(w.next(), Some("o" | "g")) && w.collect::<Vec<_>>().join(" ") == **missing
                });
                let what = match declared {
                    Some((i, _)) => format!(
                        "group `{missing}` (line {}) has no faces: its faces come before it or belong to the next group",
                        i + 1
                    ),
                    None => format!("has no group `{missing}`"),
                };
                return Err(Error::Mesh {
                    path: shown.to_path_buf(),
                    line: None,
                    message: format!(
                        "{what} (its o/g groups with faces: {}{})",
                        if have.is_empty() {
                            "none".to_string()
                        } else {
                            shown_have.join(", ")
                        },
                        if have.len() > 40 { ", …" } else { "" }
                    ),
                });
            }
            let keep: Vec<&String> = names.iter().filter(|g| !dropped(g)).collect();
            models
                .into_iter()
                .filter(|m| (keep.is_empty() || keep.contains(&&m.name)) && !dropped(&m.name))
                .collect()
        }
    })
}

/// Appends the triangles of tobj's models to `out` (with their corner uvs, mapped by the
/// material's `map_Kd -o/-s`), dropping and counting degenerate triangles and exact
/// duplicates; faces without a known material get the default one (index
/// `out.materials.len()`, added by the caller).
fn add_triangles(models: &[tobj::Model], out: &mut LoadedMesh) {
    // Coincident copies of a triangle add nothing but doubled area and a traversal that
    // must test every copy; the first one stays.
    let mut seen = std::collections::HashSet::new();
    let default_material = out.materials.len() as u32;
    let mut any_uv = false;
    let mut any_normal = false;
    for model in models {
        let from = out.tris.len();
        add_model(model, out, &mut seen, default_material, &mut any_uv, &mut any_normal);
        add_part(out, &model.name, from);
    }
    if !any_uv {
        out.uvs.clear();
    }
    if !any_normal {
        out.normals.clear();
    }
}

/// One tobj model's triangles, as [`add_triangles`] adds them.
fn add_model(
    model: &tobj::Model,
    out: &mut LoadedMesh,
    seen: &mut std::collections::HashSet<[[u32; 3]; 3]>,
    default_material: u32,
    any_uv: &mut bool,
    any_normal: &mut bool,
) {
    {
        let m = &model.mesh;
        let has_uv = !m.texcoords.is_empty() && m.texcoord_indices.len() == m.indices.len();
        *any_uv |= has_uv;
        let has_normal = !m.normals.is_empty() && m.normal_indices.len() == m.indices.len();
        *any_normal |= has_normal;
        let material = match m.material_id {
            Some(id) if id < out.materials.len() => id as u32,
            _ => {
                out.unassigned += m.indices.len() / 3;
                default_material
            }
        };
        let (uv_o, uv_s) = match out.materials.get(material as usize) {
            Some(md) => (md.uv_offset, md.uv_scale),
            None => ([0.0; 2], [1.0; 2]),
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
            if !keep(&tri, seen, out) {
                continue;
            }
            out.tris.push(tri);
            let mut uv = [0.0f32; 6];
            if has_uv {
                for c in 0..3 {
                    let t = m.texcoord_indices[f * 3 + c] as usize * 2;
                    uv[c * 2] = uv_o[0] + uv_s[0] * m.texcoords[t];
                    uv[c * 2 + 1] = uv_o[1] + uv_s[1] * m.texcoords[t + 1];
                }
            }
            out.uvs.push(uv);
            let mut nc = [0.0f32; 9];
            if has_normal {
                let corners: [Vec3; 3] = std::array::from_fn(|c| {
                    let k = m.normal_indices[f * 3 + c] as usize * 3;
                    Vec3::new(m.normals[k], m.normals[k + 1], m.normals[k + 2])
                });
                nc = corner_normals(&tri, corners);
            }
            out.normals.push(nc);
        }
    }
}

/// A triangle's corner normals as kept: each made unit and on the triangle's front (the
/// side its winding normal points to); all zero (flat) when one is zero or not finite, or
/// when none of them lies on the front (normals that contradict the winding).
pub fn corner_normals(tri: &Tri, n: [Vec3; 3]) -> [f32; 9] {
    let front = crate::geom::ray::tri_normal(tri);
    let unit: Option<Vec<Vec3>> = n.iter().map(|v| v.try_normalize().filter(|u| u.is_finite())).collect();
    match unit {
        Some(u) if u.iter().any(|v| v.dot(front) > 0.0) => {
            [u[0].x, u[0].y, u[0].z, u[1].x, u[1].y, u[1].z, u[2].x, u[2].y, u[2].z]
        }
        _ => [0.0; 9],
    }
}

/// Parses `n` numbers that must be finite.
fn finite_numbers(words: &[&str], what: &str) -> std::result::Result<Vec<f32>, String> {
    words
        .iter()
        .map(|w| match w.parse::<f32>() {
            Ok(x) if x.is_finite() => Ok(x),
            Ok(_) => Err(format!("{what} `{}` is not finite", quote(w))),
            Err(_) => Err(format!("{what} `{}` is not a number", quote(w))),
        })
        .collect()
}

/// Checks every line of an OBJ file and writes it the way tobj reads it without
/// surprises: comments and a byte-order mark removed, `v x y z w` divided out, vertex
/// colours dropped, `vt u` completed to `vt u 0`, point and line elements dropped. Line
/// numbers are kept (a dropped line stays as an empty one), so every error names the
/// line of the input. Errors: (line, message).
pub fn sanitize(text: &str) -> std::result::Result<String, (usize, String)> {
    let (mut nv, mut nvt, mut nvn) = (0i64, 0i64, 0i64);
    let mut out = String::with_capacity(text.len());
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let l = raw.split('#').next().unwrap_or("").trim();
        let words: Vec<&str> = l.split_whitespace().collect();
        let Some((&key, args)) = words.split_first() else {
            out.push('\n');
            continue;
        };
        let err = |m: String| (line, m);
        match key {
            "v" => {
                out.push_str(&vertex(args, l).map_err(err)?);
                nv += 1;
            }
            "vt" => {
                out.push_str(&texture_coordinate(args, l).map_err(err)?);
                nvt += 1;
            }
            "vn" => {
                out.push_str(&normal(args, l).map_err(err)?);
                nvn += 1;
            }
            "f" => {
                check_face(args, l, [nv, nvt, nvn]).map_err(err)?;
                out.push_str(l);
                out.push('\n');
            }
            "mtllib" | "usemtl" => {
                if args.is_empty() {
                    return Err(err(format!("`{key}` needs a name")));
                }
                out.push_str(key);
                out.push(' ');
                out.push_str(&args.join(" "));
                out.push('\n');
            }
            "o" | "g" => {
                out.push_str(l);
                out.push('\n');
            }
            // Points, lines, smoothing groups, free-form geometry: not used.
            _ => out.push('\n'),
        }
    }
    Ok(out)
}

/// A `v` statement's line as tobj reads it (`args` its words after `v`, `l` the whole
/// line): 3 finite coordinates, divided by `w` where a fourth is given; an RGB colour after
/// them checked and dropped.
fn vertex(args: &[&str], l: &str) -> std::result::Result<String, String> {
    if !(args.len() == 3 || args.len() == 4 || args.len() == 6) {
        return Err(format!(
            "vertex needs 3 coordinates (and optionally w or an RGB colour), found {} values: `{}`",
            args.len(),
            quote(l)
        ));
    }
    let c = finite_numbers(&args[..3], "vertex coordinate")?;
    let mut p = [c[0], c[1], c[2]];
    if args.len() == 4 {
        let w = finite_numbers(&args[3..4], "vertex weight w")?[0];
        if w == 0.0 {
            return Err("vertex weight w is 0".into());
        }
        p = p.map(|x| x / w);
        if p.iter().any(|x| !x.is_finite()) {
            return Err(format!("vertex divided by w = {w} is not finite"));
        }
    }
    if args.len() == 6 {
        finite_numbers(&args[3..6], "vertex colour")?;
    }
    Ok(format!("v {} {} {}\n", p[0], p[1], p[2]))
}

/// A `vt` statement's line as tobj reads it: 1 to 3 finite numbers, the first two kept
/// (`v` 0 where it is missing).
fn texture_coordinate(args: &[&str], l: &str) -> std::result::Result<String, String> {
    if args.is_empty() || args.len() > 3 {
        return Err(format!(
            "texture coordinate needs 1 to 3 numbers, found {}: `{}`",
            args.len(),
            quote(l)
        ));
    }
    let t = finite_numbers(args, "texture coordinate")?;
    Ok(format!("vt {} {}\n", t[0], t.get(1).copied().unwrap_or(0.0)))
}

/// A `vn` statement's line as tobj reads it: 3 finite numbers.
fn normal(args: &[&str], l: &str) -> std::result::Result<String, String> {
    if args.len() != 3 {
        return Err(format!("normal needs 3 numbers, found {}: `{}`", args.len(), quote(l)));
    }
    let n = finite_numbers(args, "normal component")?;
    Ok(format!("vn {} {} {}\n", n[0], n[1], n[2]))
}

/// Checks an `f` statement: at least 3 vertex references, each of at most 3 indices
/// that refer to a vertex, texture coordinate and normal defined before it (`defined`:
/// how many of each).
fn check_face(args: &[&str], l: &str, defined: [i64; 3]) -> std::result::Result<(), String> {
    let [nv, nvt, nvn] = defined;
    if args.len() < 3 {
        return Err(format!("face needs at least 3 vertices: `{}`", quote(l)));
    }
    for r in args {
        let parts: Vec<&str> = r.split('/').collect();
        if parts.len() > 3 {
            return Err(format!("face reference `{}` has more than 3 indices", quote(r)));
        }
        if parts[0].is_empty() {
            return Err(format!("face reference `{}` has no vertex index", quote(r)));
        }
        for (k, (what, n)) in [("vertex", nv), ("texture coordinate", nvt), ("normal", nvn)]
            .into_iter()
            .enumerate()
        {
            let Some(s) = parts.get(k).filter(|s| !s.is_empty()) else {
                continue;
            };
            match s.parse::<i64>() {
                Ok(x) if (x > 0 && x <= n) || (x < 0 && -x <= n) => {}
                Ok(x) => return Err(format!("face refers to {what} {x}, but {n} are defined before it")),
                Err(_) => return Err(format!("face reference `{}` is not an index", quote(r))),
            }
        }
    }
    Ok(())
}

/// Parses one MTL file (`shown` in messages; `dir` the OBJ's directory, against which
/// texture paths are resolved). Returns the materials and notes on what was ignored.
pub fn parse_mtl(text: &str, shown: &Path, dir: &Path) -> Result<(Vec<MtlData>, Vec<String>)> {
    let mut out: Vec<MtlData> = Vec::new();
    let mut notes = Vec::new();
    for (i, raw) in crate::limits::strip_bom(text).lines().enumerate() {
        let line = i + 1;
        let err = |message: String| Error::Mesh {
            path: shown.into(),
            line: Some(line),
            message,
        };
        let l = raw.split('#').next().unwrap_or("").trim();
        let words: Vec<&str> = l.split_whitespace().collect();
        let Some((&key, args)) = words.split_first() else {
            continue;
        };
        if key == "newmtl" {
            if args.is_empty() {
                return Err(err("`newmtl` needs a material name".into()));
            }
            out.push(MtlData::grey(args.join(" "), shown.into()));
            continue;
        }
        let is_colour = matches!(key, "Ka" | "Kd" | "Ks" | "Ke" | "Tf");
        let is_map = key == "map_Kd" || key == "map_Ke" || key == "map_d";
        let is_alpha = key == "d" || key == "Tr";
        if !is_colour && !is_map && !is_alpha {
            continue;
        }
        // Statements before the first `newmtl` belong to no material: tobj drops them too.
        let Some(cur) = out.last_mut() else { continue };
        if is_alpha {
            // `d 0.3` or `d -halo 0.3` (the halo form is read as plain dissolve).
            let v: Vec<&str> = args.iter().copied().filter(|w| *w != "-halo").collect();
            let x = match v.as_slice() {
                [w] => w
                    .parse::<f32>()
                    .ok()
                    .filter(|x| x.is_finite() && (0.0..=1.0).contains(x)),
                _ => None,
            }
            .ok_or_else(|| {
                err(format!(
                    "`{key}` needs one number in [0, 1], found `{}`",
                    quote(&args.join(" "))
                ))
            })?;
            cur.opacity = if key == "d" { x } else { 1.0 - x };
            cur.cutout = true;
            continue;
        }
        if is_colour {
            let c = match colour(key, args) {
                Ok(c) => c,
                // Strict only where the value changes the answer (issue #34): `Ka`, `Ks`
                // and `Tf` are not read, so a typo there is a note.
                Err(m) if !matches!(key, "Kd" | "Ke") => {
                    notes.push(format!(
                        "{}:{line}: {m} (`{key}` is not used here: ignored)",
                        shown.display()
                    ));
                    continue;
                }
                Err(m) => return Err(err(m)),
            };
            match key {
                "Kd" => {
                    cur.kd = c;
                    cur.kd_line = Some(line);
                }
                "Ke" => {
                    if c.iter().any(|&x| x < 0.0) {
                        return Err(err(format!(
                            "`Ke` {c:?} is an emitted radiance: it must not be negative"
                        )));
                    }
                    if c.iter().any(|&x| x > crate::limits::MAX_RADIANCE) {
                        return Err(err(format!(
                            "`Ke` {c:?} is above {:e}, where the light's sums would overflow",
                            crate::limits::MAX_RADIANCE
                        )));
                    }
                    cur.emission = c;
                    cur.ke_line = Some(line);
                }
                _ => {}
            }
        } else if key == "map_d" {
            let (file, _, _, ignored) = map_options(args).map_err(err)?;
            cur.alpha_texture = Some(dir.join(file.replace('\\', "/")));
            cur.cutout = true;
            if !ignored.is_empty() {
                notes.push(format!("{}:{line}: map_d options ignored", shown.display()));
            }
        } else if key == "map_Ke" {
            // The emission texture reads the uvs `map_Kd` gives (its own -o/-s too would
            // need a second set per triangle).
            let (file, o, s, ignored) = map_options(args).map_err(err)?;
            cur.emission_texture = Some(dir.join(file.replace('\\', "/")));
            if o != [0.0; 2] || s != [1.0; 2] || !ignored.is_empty() {
                notes.push(format!(
                    "{}:{line}: map_Ke options ignored (the emission texture reads the uvs map_Kd gives)",
                    shown.display()
                ));
            }
        } else {
            let (file, o, s, ignored) = map_options(args).map_err(err)?;
            cur.texture = Some(dir.join(file.replace('\\', "/")));
            cur.uv_offset = o;
            cur.uv_scale = s;
            if !ignored.is_empty() {
                notes.push(format!(
                    "{}:{line}: map_Kd option(s) {} ignored (they do not change a diffuse albedo lookup here)",
                    shown.display(),
                    ignored.join(" ")
                ));
            }
        }
    }
    // `map_Ke` with no `Ke`: the texture is the emission (a factor of 1).
    for m in out
        .iter_mut()
        .filter(|m| m.emission_texture.is_some() && m.ke_line.is_none())
    {
        m.emission = [1.0; 3];
        notes.push(format!(
            "{}: material `{}` has map_Ke but no Ke: its emission is the texture (Ke 1 1 1)",
            shown.display(),
            m.name
        ));
    }
    Ok((out, notes))
}

/// `Kd r g b`, or `Kd r` meaning grey (the MTL specification: g and b default to r).
fn colour(key: &str, args: &[&str]) -> std::result::Result<[f32; 3], String> {
    if let Some(first) = args.first() {
        if *first == "spectral" || *first == "xyz" {
            return Err(format!("`{key} {first}` colours are not supported; give `{key} r g b`"));
        }
    }
    if args.len() != 1 && args.len() != 3 {
        return Err(format!("`{key}` needs 1 or 3 numbers (r [g b]), found {}", args.len()));
    }
    let v = finite_numbers(args, &format!("`{key}` value"))?;
    Ok(if v.len() == 1 { [v[0]; 3] } else { [v[0], v[1], v[2]] })
}

/// `map_Kd [options] file`: the file name, uv offset and scale (`-o`, `-s`), and the
/// options accepted without effect. Options that would change the albedo and that this
/// renderer cannot honour (`-clamp on`, `-mm` other than `0 1`) are errors.
type MapKd<'a> = (String, [f32; 2], [f32; 2], Vec<&'a str>);

/// Long by design: one `match` arm per `map_Kd` option.
fn map_options<'a>(args: &[&'a str]) -> std::result::Result<MapKd<'a>, String> {
    let (mut o, mut s) = ([0.0f32; 2], [1.0f32; 2]);
    let mut ignored = Vec::new();
    let mut k = 0;
    let number = |w: &str| w.parse::<f32>().ok().filter(|x| x.is_finite());
    while k < args.len() && args[k].starts_with('-') && args.len() - k > 1 {
        let opt = args[k];
        k += 1;
        // The option's values: numbers, at most `max`, never the last word (the file).
        let take_numbers = |max: usize, k: &mut usize| {
            let mut v = Vec::new();
            while v.len() < max && *k + 1 < args.len() {
                match number(args[*k]) {
                    Some(x) => {
                        v.push(x);
                        *k += 1;
                    }
                    None => break,
                }
            }
            v
        };
        match opt {
            "-o" | "-s" | "-t" => {
                let v = take_numbers(3, &mut k);
                if v.is_empty() {
                    return Err(format!("map_Kd option `{opt}` needs 1 to 3 numbers"));
                }
                let u = v[0];
                let vv = v.get(1).copied().unwrap_or(if opt == "-s" { 1.0 } else { 0.0 });
                match opt {
                    "-o" => o = [u, vv],
                    "-s" => s = [u, vv],
                    _ => ignored.push(opt),
                }
            }
            "-mm" => {
                let v = take_numbers(2, &mut k);
                if v.len() != 2 {
                    return Err("map_Kd option `-mm` needs 2 numbers (base gain)".into());
                }
                if v != [0.0, 1.0] {
                    return Err(format!(
                        "map_Kd option `-mm {} {}` (a remapped texture range) is not supported",
                        v[0], v[1]
                    ));
                }
            }
            "-clamp" | "-blendu" | "-blendv" | "-cc" => {
                let v = args.get(k).copied().unwrap_or("");
                if v != "on" && v != "off" || k + 1 >= args.len() {
                    return Err(format!("map_Kd option `{opt}` needs `on` or `off`"));
                }
                k += 1;
                if opt == "-clamp" && v == "on" {
                    return Err("map_Kd option `-clamp on` is not supported (textures repeat)".into());
                }
                if v == "on" && opt == "-cc" {
                    ignored.push(opt);
                }
            }
            "-boost" | "-texres" | "-bm" => {
                if take_numbers(1, &mut k).len() != 1 {
                    return Err(format!("map_Kd option `{opt}` needs a number"));
                }
                ignored.push(opt);
            }
            "-imfchan" => {
                if k + 1 >= args.len() {
                    return Err("map_Kd option `-imfchan` needs a channel".into());
                }
                k += 1;
                ignored.push(opt);
            }
            _ => return Err(format!("unknown map_Kd option `{}`", quote(opt))),
        }
    }
    if k >= args.len() {
        return Err("`map_Kd` needs a file name".into());
    }
    if s.contains(&0.0) {
        return Err("map_Kd option `-s` must not scale by 0".into());
    }
    Ok((args[k..].join(" "), o, s, ignored))
}

/// Whether `tri` joins `out`: not degenerate, and not an exact copy (the same three
/// corners) of a triangle in `seen`; a dropped one is counted in `out`.
pub(super) fn keep(tri: &Tri, seen: &mut std::collections::HashSet<[[u32; 3]; 3]>, out: &mut LoadedMesh) -> bool {
    if is_degenerate(tri) {
        out.degenerate += 1;
        return false;
    }
    let mut key = [tri.v0, tri.v1, tri.v2].map(|v| v.map(f32::to_bits));
    key.sort_unstable();
    if !seen.insert(key) {
        out.duplicates += 1;
        return false;
    }
    true
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

/// Splits every triangle into four at its edge midpoints, with its corner uvs and
/// normals (midpoints of the corners'; the normals are made unit where they are read).
pub fn tessellate(tris: &[Tri], uvs: &[[f32; 6]], normals: &[[f32; 9]]) -> (Vec<Tri>, Vec<[f32; 6]>, Vec<[f32; 9]>) {
    let mut out = Vec::with_capacity(tris.len() * 4);
    let mut out_uv = Vec::with_capacity(uvs.len() * 4);
    let mut out_n = Vec::with_capacity(normals.len() * 4);
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
        if let Some(n) = normals.get(i) {
            let c = |k: usize| Vec3::new(n[3 * k], n[3 * k + 1], n[3 * k + 2]);
            let (a, b, cc) = (c(0), c(1), c(2));
            let (ab, bc, ca) = ((a + b) * 0.5, (b + cc) * 0.5, (cc + a) * 0.5);
            let pack = |p: Vec3, q: Vec3, r: Vec3| [p.x, p.y, p.z, q.x, q.y, q.z, r.x, r.y, r.z];
            out_n.push(pack(a, ab, ca));
            out_n.push(pack(ab, b, bc));
            out_n.push(pack(ca, bc, cc));
            out_n.push(pack(ab, bc, ca));
        }
    }
    (out, out_uv, out_n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reports_line_of_bad_vertex() {
        let e = sanitize("v 0 0 0\nv 1 nan 0\n").unwrap_err();
        assert_eq!(e.0, 2);
        let e = sanitize("v 0 0 0\nv 1 x 0\n").unwrap_err();
        assert_eq!(e.0, 2);
        let e = sanitize("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n").unwrap_err();
        assert_eq!(e.0, 4);
        assert!(sanitize("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n").is_ok());
        let e = sanitize("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\n").unwrap_err();
        assert!(e.0 == 4 && e.1.contains("normal 1"), "{e:?}");
        let e = sanitize("vn nan nan nan\n").unwrap_err();
        assert_eq!(e.0, 1);
    }

    #[test]
    fn weights_and_short_texcoords_are_resolved() {
        let s = sanitize("v 2 4 6 2\nvt 0.5\n# c\nv 1 1 1 0.1 0.2 0.3 # colour\n").unwrap();
        assert_eq!(s, "v 1 2 3\nvt 0.5 0\n\nv 1 1 1\n");
        assert!(sanitize("v 1 2 3 0\n").is_err());
        assert!(sanitize("v 1 2 3 4 5\n").is_err());
    }

    #[test]
    fn mtl_colours_and_map_options() {
        let d = Path::new("");
        let (m, _) = parse_mtl("newmtl a\nKd 0.5\nnewmtl b\nKd 0.1 0.2 0.3\n", d, d).unwrap();
        assert_eq!(m[0].kd, [0.5; 3]);
        assert_eq!(m[1].kd, [0.1, 0.2, 0.3]);
        let (m, _) = parse_mtl("newmtl a\nKe 17 12 4\nnewmtl b\n", d, d).unwrap();
        assert_eq!((m[0].emission, m[1].emission), ([17.0, 12.0, 4.0], [0.0; 3]));
        for bad in ["Kd", "Kd 0.5 0.5", "Ke 1 2", "Kd spectral a.rfl", "Ke -1 0 0", "Ke nan"] {
            let e = parse_mtl(&format!("newmtl a\n{bad}\n"), Path::new("m.mtl"), d).unwrap_err();
            assert!(e.to_string().starts_with("m.mtl:2:"), "{bad}: {e}");
        }
        // Keys not read (Ka, Ks, Tf) are not strict: a value that does not parse is a note.
        let (m, notes) = parse_mtl("newmtl a\nKa x\nKs 1 2\nKd 0.25\n", Path::new("m.mtl"), d).unwrap();
        assert_eq!(m[0].kd, [0.25; 3]);
        assert!(
            notes.len() == 2 && notes[0].starts_with("m.mtl:2:") && notes[1].starts_with("m.mtl:3:"),
            "{notes:?}"
        );
        let (m, notes) = parse_mtl("newmtl a\nmap_Kd -s 2 2 1 -o 0.5 0 -bm 1 tex dir/a b.png\n", d, d).unwrap();
        assert_eq!(m[0].texture.as_deref(), Some(Path::new("tex dir/a b.png")));
        assert_eq!((m[0].uv_scale, m[0].uv_offset), ([2.0, 2.0], [0.5, 0.0]));
        assert_eq!(notes.len(), 1);
        for bad in [
            "map_Kd",
            "map_Kd -clamp on t.png",
            "map_Kd -mm 0.2 2 t.png",
            "map_Kd -zz t.png",
        ] {
            assert!(parse_mtl(&format!("newmtl a\n{bad}\n"), d, d).is_err(), "{bad}");
        }
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
        let (out, _, _) = tessellate(&[t], &[], &[]);
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

    /// The corner normals split with the triangle: at every new triangle's corners, the
    /// normals interpolated over the old one there.
    #[test]
    fn tessellation_splits_the_corner_normals() {
        let t = Tri {
            v0: [0.0; 3],
            v1: [1.0, 0.0, 0.0],
            v2: [0.0, 1.0, 0.0],
            ..Default::default()
        };
        let n = corner_normals(
            &t,
            [
                Vec3::new(0.0, 0.0, 1.0),
                Vec3::new(1.0, 0.0, 1.0),
                Vec3::new(0.0, 1.0, 1.0),
            ],
        );
        let at = |p: Vec3| {
            // Barycentrics of p in the unit right triangle: (b1, b2) = (x, y).
            let c = |k: usize| Vec3::new(n[3 * k], n[3 * k + 1], n[3 * k + 2]);
            c(0) * (1.0 - p.x - p.y) + c(1) * p.x + c(2) * p.y
        };
        let (out, _, on) = tessellate(&[t], &[], &[n]);
        assert_eq!(on.len(), 4);
        for (t, c) in out.iter().zip(&on) {
            for (k, v) in [t.v0, t.v1, t.v2].into_iter().enumerate() {
                let want = at(Vec3::from(v));
                let got = Vec3::new(c[3 * k], c[3 * k + 1], c[3 * k + 2]);
                assert!((got - want).length() < 1e-6, "{got} {want}");
            }
        }
        // Normals behind the winding, or a zero one: flat.
        assert_eq!(corner_normals(&t, [Vec3::NEG_Z; 3]), [0.0; 9]);
        assert_eq!(corner_normals(&t, [Vec3::Z, Vec3::ZERO, Vec3::Z]), [0.0; 9]);
    }
}
