//! The [`Builder`]: a scene's objects read and placed one after another (triangles, BVH,
//! materials), then the scene finished (textures, bounds, camera, emitters, CWBVH).

use std::path::{Path, PathBuf};

use glam::Vec3;

use super::assemble::object_transform;
use super::memory::plan_memory;
use super::{config, emitter, gltf_file, obj, source, texture, Camera, LoadReport, Scene, SceneObject, Source};
use crate::error::{Error, Result};
use crate::geom::bvh;
use crate::geom::transform::{xform_point, xform_vector, Affine};
use crate::geom::Transform;
use crate::layout::{BvhNode, GpuLight, Material, TextureInfo, Tri, TriUv, NONE};
use crate::limits::{Limits, Part};
use crate::params::SolverParams;

/// A scene under construction: the objects added so far, their triangles, BVH nodes and
/// materials, and what loading them reported.
#[derive(Default)]
pub(super) struct Builder {
    pub(super) limits: Limits,
    pub(super) objects: Vec<SceneObject>,
    pub(super) tris: Vec<Tri>,
    pub(super) uvs: Vec<[f32; 6]>,
    /// Corner normals per triangle (object space), empty until an object has some.
    pub(super) normals: Vec<[f32; 9]>,
    pub(super) bvh: Vec<BvhNode>,
    pub(super) materials: Vec<obj::MtlData>,
    /// Whether each material's object lets it emit.
    pub(super) material_emits: Vec<bool>,
    pub(super) report: LoadReport,
    /// glTF objects' lights (`[[light]]` tables in world space) with their object's name.
    pub(super) gltf_lights: Vec<(String, gltf_file::GltfLight)>,
    /// The first glTF camera, in world space.
    pub(super) gltf_camera: Option<config::CameraEntry>,
}

impl Builder {
    /// Reads object `i`'s mesh, places its triangles, BVH and materials after those
    /// already added, and records its transform.
    pub(super) fn add_object(
        &mut self,
        source: &Source,
        scene_path: &Path,
        i: usize,
        e: &config::ObjectEntry,
    ) -> Result<()> {
        let transform = object_transform(scene_path, i, e)?;
        let expanded = source::expand_scenes_var(&e.mesh);
        let rel = expanded.as_deref().unwrap_or(Path::new(&e.mesh));
        let (mut mesh, gltf) = self.read_mesh(source, scene_path, i, e, rel, expanded.as_deref())?;
        self.report.notes.append(&mut mesh.notes);
        self.report.inputs.append(&mut mesh.inputs);
        self.report.duplicate_dropped += mesh.duplicates;
        self.report.degenerate_dropped += mesh.degenerate;
        self.report.faces_without_material += mesh.unassigned;
        let mat_base = self.materials.len() as u32;
        for t in &mut mesh.tris {
            t.material += mat_base;
        }
        let has_uv = !mesh.uvs.is_empty();
        let has_normals = !mesh.normals.is_empty() && e.smooth_normals.unwrap_or(true);
        // The uvs and normals follow the triangles' reordering.
        let mut corners: Vec<([f32; 6], [f32; 9])> = if has_uv || has_normals {
            (0..mesh.tris.len())
                .map(|t| {
                    (
                        mesh.uvs.get(t).copied().unwrap_or_default(),
                        if has_normals { mesh.normals[t] } else { [0.0; 9] },
                    )
                })
                .collect()
        } else {
            Vec::new()
        };
        let mut nodes = bvh::build(&mut mesh.tris, &mut corners, &e.mesh)?;
        let (uvs, normals): (Vec<[f32; 6]>, Vec<[f32; 9]>) = corners.into_iter().unzip();
        let tri_offset = self.tris.len() as u32;
        let node_offset = self.bvh.len() as u32;
        bvh::rebase(&mut nodes, node_offset, tri_offset);
        let area = object_area(&mesh.tris);
        let name = self.object_name(scene_path, i, e)?;
        if let Some(g) = gltf {
            self.place_gltf(g, &transform, &name);
        }
        let emits = e.emission.unwrap_or(true);
        if !emits {
            for m in mesh.materials.iter().filter(|m| m.emission.iter().any(|&c| c > 0.0)) {
                if !self.report.emissive_materials_ignored.contains(&m.name) {
                    self.report.emissive_materials_ignored.push(m.name.clone());
                }
            }
        }
        self.objects.push(SceneObject {
            emits,
            name,
            transform,
            to_world: transform.to_world(),
            to_object: transform.to_object(),
            tri_offset,
            tri_count: mesh.tris.len() as u32,
            bvh_root: node_offset,
            area,
            parts: std::mem::take(&mut mesh.parts),
        });
        let n = mesh.tris.len();
        self.tris.extend(mesh.tris);
        if has_uv {
            self.uvs.resize(tri_offset as usize, [0.0; 6]);
            self.uvs.extend(uvs);
        }
        self.uvs.resize(tri_offset as usize + n, [0.0; 6]);
        if has_normals {
            self.normals.resize(tri_offset as usize, [0.0; 9]);
            self.normals.extend(normals);
        } else if !self.normals.is_empty() {
            self.normals.resize(tri_offset as usize + n, [0.0; 9]);
        }
        self.bvh.extend(nodes);
        self.material_emits.extend(mesh.materials.iter().map(|_| emits));
        self.materials.extend(mesh.materials);
        Ok(())
    }

    /// Object `i`'s name (`name`, default `object<i>`): not empty, and not an earlier
    /// object's.
    fn object_name(&self, scene_path: &Path, i: usize, e: &config::ObjectEntry) -> Result<String> {
        let name = e.name.clone().unwrap_or_else(|| format!("object{i}"));
        if name.trim().is_empty() || self.objects.iter().any(|o| o.name == name) {
            return Err(Error::SceneValue {
                path: scene_path.into(),
                key: format!("object[{i}].name"),
                message: if name.trim().is_empty() {
                    "is empty".into()
                } else if e.name.is_none() {
                    format!(
                        "this object has no `name`, and its default `{name}` names an earlier object: \
                         names must be unique, so give it one"
                    )
                } else {
                    format!("`{name}` names an earlier object too: names must be unique")
                },
            });
        }
        Ok(name)
    }

    /// Records a glTF object's lights and, if none was met before, its camera, placed in
    /// the world by the object's transform.
    fn place_gltf(&mut self, g: gltf_file::LoadedGltf, transform: &Transform, name: &str) {
        let to_world = transform.to_world();
        for mut l in g.lights {
            place_light_table(&mut l.table, &to_world);
            self.gltf_lights.push((name.to_string(), l));
        }
        if let (None, Some(c)) = (&self.gltf_camera, g.camera) {
            let p = xform_point(&to_world, c.position);
            let (w, h) = match c.aspect {
                Some(a) => (((256.0 * a).round() as u32).clamp(1, 16384), 256),
                None => (256, 256),
            };
            // The target a step along the view that f32 resolves at the camera's distance
            // from the origin (a camera at 1e9 plus a unit vector rounds back onto itself).
            let step = 1f32.max(p.length() * 1e-3);
            let forward = xform_vector(&to_world, c.forward).normalize_or_zero();
            self.gltf_camera = Some(config::CameraEntry {
                position: p.to_array(),
                target: (p + forward * step).to_array(),
                up: xform_vector(&to_world, c.up).to_array(),
                fov: c.fov,
                width: w,
                height: h,
                spp: None,
                filter: None,
            });
        }
    }

    /// Object `i`'s mesh `rel` (`expanded` from `$MESHRAD_SCENES` if it named it), within
    /// the memory limit, tessellated as asked.
    fn read_mesh(
        &self,
        source: &Source,
        scene_path: &Path,
        i: usize,
        e: &config::ObjectEntry,
        rel: &Path,
        expanded: Option<&Path>,
    ) -> Result<(obj::LoadedMesh, Option<gltf_file::LoadedGltf>)> {
        let key = |f: &str| format!("object[{i}].{f}");
        let tess = e.tessellate.unwrap_or(0);
        if tess > 8 {
            return Err(Error::SceneValue {
                path: scene_path.into(),
                key: key("tessellate"),
                message: format!("{tess} is above 8 (65536× the triangles)"),
            });
        }
        if e.mesh.trim().is_empty() {
            return Err(Error::SceneValue {
                path: scene_path.into(),
                key: key("mesh"),
                message: "is empty: give the OBJ file's path".into(),
            });
        }
        // The OBJ text, its normalised copy and tobj's arrays: about 4× the file.
        let read_limit = crate::limits::MAX_MESH_BYTES.min(self.limits.max_memory / 4);
        let groups = e.group.as_ref().map(config::Groups::names);
        if groups
            .as_ref()
            .is_some_and(|g| g.is_empty() || g.iter().any(|n| n.trim().is_empty()))
        {
            return Err(Error::SceneValue {
                path: scene_path.into(),
                key: key("group"),
                message: "names no group (give a group name of the OBJ, or a list of them)".into(),
            });
        }
        let tris_bytes = |what: String, count: f64| {
            let loaded = self.tris.len() as f64;
            let after = count * 4f64.powi(tess as i32);
            self.limits.check(
                scene_path,
                &key(if tess > 0 { "tessellate" } else { "mesh" }),
                &[Part {
                    what: format!(
                        "{} triangles ({what}{})",
                        (loaded + after) as u64,
                        if tess > 0 {
                            format!(" × 4^{tess}")
                        } else {
                            String::new()
                        }
                    ),
                    bytes: (loaded + after) * crate::limits::BYTES_PER_TRIANGLE as f64,
                }],
            )
        };
        let loaded = if gltf_file::is_gltf(rel) {
            // Counted from the accessors before any triangle is built.
            let budget = |n: u64| {
                tris_bytes(
                    format!("{n} in {} by its accessors' counts, before reading them", e.mesh),
                    n as f64,
                )
            };
            gltf_file::load_within(source, rel, read_limit, groups.as_deref(), &budget)
                .map(|mut g| (std::mem::take(&mut g.mesh), Some(g)))
        } else {
            obj::load(source, rel, read_limit, groups.as_deref()).map(|m| (m, None))
        };
        let (mut mesh, gltf) = loaded.map_err(|err| match (expanded, err) {
            (Some(p), Error::Io { path, error }) if !p.exists() => Error::Io {
                path,
                error: std::io::Error::new(
                    error.kind(),
                    format!(
                        "{error} (object[{i}].mesh starts with ${}: set it to the folder of the public \
                         scenes, default {}; scenes/README.md says where each comes from)",
                        source::SCENES_VAR,
                        source::SCENES_DEFAULT
                    ),
                ),
            },
            (_, err) => err,
        })?;
        tris_bytes(format!("{} in {}", mesh.tris.len(), e.mesh), mesh.tris.len() as f64)?;
        for _ in 0..tess {
            let (t, u, n) = obj::tessellate(&mesh.tris, &mesh.uvs, &mesh.normals);
            mesh.tris = t;
            mesh.uvs = u;
            mesh.normals = n;
        }
        drop_cut_out(&mut mesh, &source.display(rel));
        if mesh.tris.is_empty() {
            return Err(Error::Mesh {
                path: source.display(rel),
                line: None,
                message: "no (non-degenerate) triangles".into(),
            });
        }
        Ok((mesh, gltf))
    }

    /// The GPU materials: each MTL material checked (albedo below 1, a texture's mean
    /// albedo too), its texture loaded once however many materials use it; and each
    /// one's emission texture (or `NONE`), in the same table.
    #[allow(clippy::type_complexity)]
    fn resolve_materials(
        &mut self,
        source: &Source,
        srgb: &[f32; 256],
        max_albedo: f32,
    ) -> Result<(Vec<Material>, Vec<u32>, Vec<TextureInfo>, Vec<u32>)> {
        let mut table = TextureTable::default();
        let mut materials = Vec::new();
        let mut emission_textures = Vec::new();
        let mut clamped: Vec<String> = Vec::new();
        for m in &self.materials {
            let mut kd = m.kd;
            let bad_kd = |msg: &str| Error::Mesh {
                path: m.origin.clone(),
                line: m.kd_line,
                message: format!(
                    "material `{}` (used by {}): Kd {kd:?} {msg}",
                    m.name,
                    m.used_by.display()
                ),
            };
            if kd.iter().any(|c| !c.is_finite() || *c < 0.0) {
                return Err(bad_kd("must be finite and non-negative"));
            }
            if kd.iter().any(|&c| c > 1.0) {
                return Err(bad_kd("is an albedo above 1: the surface would create energy"));
            }
            let texture = match &m.texture {
                None => {
                    if kd.iter().any(|&c| c > max_albedo) {
                        clamped.push(format!("`{}` (used by {}) Kd {kd:?}", m.name, m.used_by.display()));
                        kd = kd.map(|c| c.min(max_albedo));
                    }
                    NONE
                }
                Some(t) => {
                    let k = table.load(
                        (&mut self.report.inputs, self.limits),
                        source,
                        t,
                        m.texture_data.as_deref(),
                        m.wrap,
                        false,
                    )?;
                    // The texture's mean albedo under this material's factor: above
                    // `max_albedo`, the factor is scaled down to bring it there.
                    let mean = texture::mean(&table.texels, &table.textures[k as usize], srgb) * Vec3::from(kd);
                    if mean.max_element() > max_albedo {
                        clamped.push(format!(
                            "`{}` (used by {}) mean albedo {:.3} of {} under Kd {kd:?}",
                            m.name,
                            m.used_by.display(),
                            mean.max_element(),
                            source.display(t).display()
                        ));
                        let f = max_albedo / mean.max_element();
                        kd = kd.map(|c| c * f);
                    }
                    k
                }
            };
            // A cutout's alpha: a mask (`map_d`), the albedo texture's alpha (glTF), or a
            // constant at or above the cutoff (opaque; below it, its triangles were
            // dropped at load).
            let alpha_texture = match (&m.alpha_texture, m.cutout) {
                (_, false) => NONE,
                (Some(t), true) => table.load(
                    (&mut self.report.inputs, self.limits),
                    source,
                    t,
                    m.alpha_texture_data.as_deref(),
                    m.wrap,
                    true,
                )?,
                (None, true) if m.alpha_from_albedo => texture,
                (None, true) => NONE,
            };
            if alpha_texture != NONE {
                self.report.cutout_materials.push(m.name.clone());
            }
            materials.push(Material {
                kd,
                texture,
                alpha_texture,
                opacity: m.opacity,
                cutoff: m.cutoff,
                pad: 0,
            });
            emission_textures.push(match &m.emission_texture {
                Some(t) => table.load(
                    (&mut self.report.inputs, self.limits),
                    source,
                    t,
                    m.emission_texture_data.as_deref(),
                    m.emission_wrap,
                    false,
                )?,
                None => NONE,
            });
        }
        if !clamped.is_empty() {
            let n = clamped.len();
            let shown: Vec<String> = clamped.into_iter().take(20).collect();
            self.report.notes.push(format!(
                "albedo lowered to {max_albedo} (solver key max_albedo; at 1 light would never decay) in {n} \
                 material(s): {}{}",
                shown.join("; "),
                if n > 20 { "; …" } else { "" }
            ));
        }
        Ok((materials, emission_textures, table.textures, table.texels))
    }

    pub(super) fn finish(
        mut self,
        path: &Path,
        source: &Source,
        lights: Vec<GpuLight>,
        camera: Option<&config::CameraEntry>,
        params: &SolverParams,
    ) -> Result<Scene> {
        let srgb = texture::srgb_table();
        let (materials, emission_textures, textures, texels) =
            self.resolve_materials(source, &srgb, params.max_albedo)?;
        let uvs = if textures.is_empty() {
            Vec::new()
        } else {
            self.uvs.iter().map(|&uv| TriUv { uv }).collect()
        };
        let (lo, hi, scale) = world_bounds(&self.objects, &self.tris).map_err(|message| Error::SceneValue {
            path: path.into(),
            key: "object".into(),
            message,
        })?;
        let camera = match camera {
            Some(c) => Camera::from_entry(c, path)?,
            None => Camera::framing(lo, hi, path)?,
        };
        self.report.triangles = self.tris.len();
        self.report.textures = textures.len();
        self.report.planned_bytes =
            plan_memory(&self.limits, path, self.tris.len(), params, &camera, self.objects.len())?;
        let emission: Vec<Vec3> = self
            .materials
            .iter()
            .zip(&self.material_emits)
            .map(|(m, &on)| if on { Vec3::from(m.emission) } else { Vec3::ZERO })
            .collect();
        let placed: Vec<_> = self
            .objects
            .iter()
            .map(|o| (o.to_world, o.tri_offset..o.tri_offset + o.tri_count))
            .collect();
        let emitters = emitter::Emitters::new(
            &self.tris,
            &placed,
            |t| {
                let m = self.tris[t as usize].material as usize;
                let (scale, tex) = (emission[m], emission_textures[m]);
                let mean = if tex == NONE || scale == Vec3::ZERO {
                    scale
                } else {
                    scale * texture::mean_over(&texels, &textures[tex as usize], &self.uvs[t as usize], &srgb)
                };
                emitter::Emission {
                    mean,
                    scale,
                    texture: tex,
                }
            },
            params.emitter_samples,
            params.final_gather,
        );
        self.report.emitting_triangles = emitters.list.len();
        let ranges: Vec<_> = self
            .objects
            .iter()
            .map(|o| o.tri_offset as usize..(o.tri_offset + o.tri_count) as usize)
            .collect();
        let cw = bvh::CwForest::build(&self.tris, &ranges);
        let mut normals = std::mem::take(&mut self.normals);
        if !normals.is_empty() {
            normals.resize(self.tris.len(), [0.0; 9]);
        }
        Ok(Scene {
            cw,
            sky: None,
            emission,
            emission_textures,
            emitters,
            path: path.into(),
            objects: self.objects,
            tris: self.tris,
            uvs,
            normals,
            bvh: self.bvh,
            cutouts: materials.iter().any(|m| m.alpha_texture != NONE),
            materials,
            material_names: self.materials.iter().map(|m| m.name.clone()).collect(),
            textures,
            texels,
            srgb,
            light_names: (0..lights.len()).map(|i| format!("light{i}")).collect(),
            light_tables: Vec::new(),
            lights,
            camera,
            bounds: (lo, hi),
            scale,
            report: self.report,
        })
    }
}

/// Drops the triangles of materials that are cut out everywhere (a constant alpha below
/// the cutoff, no texture: rays would always pass), with their uvs and normals, and notes
/// it naming the materials.
fn drop_cut_out(mesh: &mut obj::LoadedMesh, shown: &Path) {
    let gone: Vec<bool> = mesh.materials.iter().map(obj::MtlData::cut_out_entirely).collect();
    if !gone.iter().any(|&g| g) {
        return;
    }
    let keep: Vec<bool> = mesh
        .tris
        .iter()
        .map(|t| !gone.get(t.material as usize).copied().unwrap_or(false))
        .collect();
    let dropped = keep.iter().filter(|&&k| !k).count();
    let mut k = keep.iter();
    mesh.tris.retain(|_| *k.next().unwrap_or(&true));
    if !mesh.uvs.is_empty() {
        let mut k = keep.iter();
        mesh.uvs.retain(|_| *k.next().unwrap_or(&true));
    }
    if !mesh.normals.is_empty() {
        let mut k = keep.iter();
        mesh.normals.retain(|_| *k.next().unwrap_or(&true));
    }
    let names: Vec<String> = mesh
        .materials
        .iter()
        .filter(|m| m.cut_out_entirely())
        .map(|m| format!("`{}` (alpha {} below the cutoff {})", m.name, m.opacity, m.cutoff))
        .collect();
    mesh.notes.push(format!(
        "{}: {dropped} triangle(s) of material(s) {} dropped: cut out everywhere, rays pass them",
        shown.display(),
        names.join(", ")
    ));
}

/// The scene's textures as they are loaded: each (file, wrap) decoded once.
#[derive(Default)]
struct TextureTable {
    textures: Vec<TextureInfo>,
    texels: Vec<u32>,
    /// Each texture's file, wrap modes, and whether it was read as a mask (`map_d`).
    paths: Vec<(PathBuf, u32, bool)>,
}

impl TextureTable {
    /// The index of texture `t` (its bytes `data` where they are not a file of their own)
    /// with wrap modes `wrap`, decoded on first use within the memory limit.
    fn load(
        &mut self,
        (inputs, limits): (&mut Vec<PathBuf>, Limits),
        source: &Source,
        t: &Path,
        data: Option<&[u8]>,
        wrap: u32,
        mask: bool,
    ) -> Result<u32> {
        if let Some(k) = self.paths.iter().position(|p| p.0 == t && p.1 == wrap && p.2 == mask) {
            return Ok(k as u32);
        }
        let shown = source.display(t);
        let read;
        let bytes: &[u8] = match data {
            Some(b) => b,
            None => {
                inputs.push(shown.clone());
                read = source.read(t)?;
                &read
            }
        };
        // Sized from the header before decoding (a small PNG can decode to gigabytes):
        // the textures kept so far and this one's decoding within the memory limit.
        if let Some((w, h)) = texture::dimensions(bytes) {
            let px = w as f64 * h as f64;
            limits.check(
                &shown,
                "texture",
                &[
                    Part {
                        what: format!("{} earlier texels", self.texels.len()),
                        bytes: (self.texels.len() as u64 * texture::KEPT_BYTES_PER_PIXEL) as f64,
                    },
                    Part {
                        what: format!("decoding its {w}×{h} pixels"),
                        bytes: px * texture::DECODE_BYTES_PER_PIXEL as f64,
                    },
                ],
            )?;
        }
        let (w, h, px) = if mask {
            texture::decode_mask(bytes, &shown)?
        } else {
            texture::decode(bytes, &shown)?
        };
        self.textures.push(TextureInfo {
            offset: self.texels.len() as u32,
            width: w,
            height: h,
            wrap,
        });
        self.texels.extend(px);
        self.paths.push((t.to_path_buf(), wrap, mask));
        Ok((self.textures.len() - 1) as u32)
    }
}

/// Moves a glTF light's `[[light]]` table from its file's space to the world by its
/// object's placement: `position` as a point, `direction` as a unit vector.
fn place_light_table(t: &mut toml::Table, to_world: &Affine) {
    let get = |t: &toml::Table, k: &str| -> Option<Vec3> {
        let a = t.get(k)?.as_array()?;
        let f = |i: usize| a.get(i).and_then(toml::Value::as_float).map(|x| x as f32);
        Some(Vec3::new(f(0)?, f(1)?, f(2)?))
    };
    let arr = |v: Vec3| toml::Value::Array(v.to_array().iter().map(|&x| toml::Value::Float(x as f64)).collect());
    if let Some(p) = get(t, "position") {
        t.insert("position".into(), arr(xform_point(to_world, p)));
    }
    if let Some(d) = get(t, "direction") {
        t.insert("direction".into(), arr(xform_vector(to_world, d).normalize_or_zero()));
    }
}

/// The world-space bounds of object `obj`'s triangles (of `tris`, the scene's) under
/// `obj`'s transform.
pub fn object_box(obj: &SceneObject, tris: &[Tri]) -> (Vec3, Vec3) {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for t in &tris[obj.tri_offset as usize..(obj.tri_offset + obj.tri_count) as usize] {
        for v in [t.v0, t.v1, t.v2] {
            let w = xform_point(&obj.to_world, Vec3::from(v));
            lo = lo.min(w);
            hi = hi.max(w);
        }
    }
    (lo, hi)
}

/// World-space bounds of every object and the length of their diagonal.
pub(super) fn world_bounds(objects: &[SceneObject], tris: &[Tri]) -> std::result::Result<(Vec3, Vec3, f32), String> {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for o in objects {
        let (a, b) = object_box(o, tris);
        lo = lo.min(a);
        hi = hi.max(b);
    }
    let scale = (hi - lo).length();
    if !(scale.is_finite() && scale > 0.0) {
        return Err("the geometry's bounds are empty or not finite".into());
    }
    Ok((lo, hi, scale))
}

/// The surface area (one side) of an object's triangles, in its own space.
fn object_area(tris: &[Tri]) -> f64 {
    tris.iter()
        .map(|t| {
            let v0 = Vec3::from(t.v0).as_dvec3();
            (Vec3::from(t.v1).as_dvec3() - v0)
                .cross(Vec3::from(t.v2).as_dvec3() - v0)
                .length()
                * 0.5
        })
        .sum()
}
