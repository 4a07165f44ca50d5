//! A loaded scene: objects (triangles in object space, one BVH each, a rigid transform),
//! materials and textures, lights, camera and solver parameters.

pub mod camera;
pub mod config;
pub mod emitter;
pub mod gltf_file;
pub mod light;
pub mod obj;
pub mod reach;
pub mod sky;
pub mod source;
pub mod texture;

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

pub use camera::Camera;
pub use source::Source;

use crate::error::{Error, Result};
use crate::geom::bvh;
use crate::geom::ray::{offset_origin, tri_normal, tri_point, WatertightRay};
use crate::geom::transform::{xform_point, xform_vector, Affine};
use crate::geom::{Hit, Ray, Transform};
use crate::layout::{BvhNode, GpuLight, Material, ObjectInfo, TextureInfo, Tri, TriUv, NONE};
use crate::limits::{Limits, Part};
use crate::params::SolverParams;

/// One scene object.
#[derive(Clone, Debug)]
pub struct SceneObject {
    pub name: String,
    pub transform: Transform,
    pub to_world: Affine,
    pub to_object: Affine,
    /// Global triangle range.
    pub tri_offset: u32,
    pub tri_count: u32,
    /// Root of this object's BVH in [`Scene::bvh`].
    pub bvh_root: u32,
    /// Surface area in object space (one side).
    pub area: f64,
    /// Its materials' emission lights the scene (`[[object]] emission`, default true).
    pub emits: bool,
}

impl SceneObject {
    /// The object's record as the kernels read it, without the hierarchy's levels: its
    /// transforms, triangle range and BVH2 root, and `cw_root` for its CWBVH.
    pub fn info(&self, cw_root: u32) -> ObjectInfo {
        ObjectInfo {
            to_object: self.to_object,
            to_world: self.to_world,
            scale: self.transform.scale,
            tri_offset: self.tri_offset,
            tri_count: self.tri_count,
            bvh_offset: self.bvh_root,
            cw_root,
            ..Default::default()
        }
    }
}

/// What loading reported (also written to stats.json).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct LoadReport {
    pub triangles: usize,
    pub degenerate_dropped: usize,
    pub faces_without_material: usize,
    /// Emitting materials whose emission an object's `emission = false` turned off.
    pub emissive_materials_ignored: Vec<String>,
    /// Triangles that emit light (MTL `Ke`).
    pub emitting_triangles: usize,
    pub textures: usize,
    /// What was read but not used (e.g. `map_Kd` options without effect), one line each.
    pub notes: Vec<String>,
    /// Exact duplicates of a triangle of the same mesh (the same three corners) dropped.
    pub duplicate_dropped: usize,
    /// Every file read (scene, meshes, material libraries, textures): outputs may not
    /// overwrite them.
    pub inputs: Vec<PathBuf>,
    /// The memory this scene's solve plans for (bytes, estimated before any work).
    pub planned_bytes: f64,
}

/// A scene ready for the solver.
#[derive(Clone, Debug)]
pub struct Scene {
    pub path: PathBuf,
    pub objects: Vec<SceneObject>,
    pub tris: Vec<Tri>,
    /// Per-triangle uvs; empty when no material is textured.
    pub uvs: Vec<TriUv>,
    pub bvh: Vec<BvhNode>,
    /// Every object's CWBVH over the same triangles: what the CPU's rays traverse
    /// ([`bvh::trace_cw`]) and the GPU's by default; the BVH2 serves box queries and the
    /// GPU's `bvh = "bvh2"`.
    pub cw: bvh::CwForest,
    pub materials: Vec<Material>,
    pub material_names: Vec<String>,
    pub textures: Vec<TextureInfo>,
    pub texels: Vec<u32>,
    pub srgb: [f32; 256],
    /// Emitted radiance per material (zero where none, or where its object's `emission`
    /// is false).
    pub emission: Vec<Vec3>,
    /// The emitting triangles and how they are sampled.
    pub emitters: emitter::Emitters,
    /// `[sky]`: radiance from every direction that leaves the scene.
    pub sky: Option<sky::Sky>,
    pub lights: Vec<GpuLight>,
    /// Each light's name (`[[light]] name`, default `light<i>`), unique.
    pub light_names: Vec<String>,
    /// Each light's table as the file gave it (less `name`): an edit replaces keys in it
    /// and parses it again, exactly as a file holding the new values would be parsed.
    pub light_tables: Vec<toml::Table>,
    pub camera: Camera,
    /// World-space bounds and the length of their diagonal (the offset scale).
    pub bounds: (Vec3, Vec3),
    pub scale: f32,
    pub report: LoadReport,
    /// The run's resource limits; what they leave after the planned parts bounds the
    /// transport's links (`transport::links`).
    pub limits: Limits,
}

/// A surface point reached by a ray, in its object's space: what a sender read needs
/// ([`Scene::local_surface`]; [`Surface`] adds the world-space point and normal).
#[derive(Clone, Copy, Debug)]
pub struct LocalSurface {
    pub object: u32,
    pub tri: u32,
    /// Object space, normal facing the ray's origin.
    pub p_obj: Vec3,
    pub n_obj: Vec3,
    /// The ray met the triangle's back (the side against its winding normal).
    pub back: bool,
    pub albedo: Vec3,
}

/// A surface point reached by a ray: its object-space part (the fields of
/// [`LocalSurface`], read through it) and the world-space point and normal.
#[derive(Clone, Copy, Debug)]
pub struct Surface {
    pub local: LocalSurface,
    /// World space.
    pub p: Vec3,
    pub n: Vec3,
}

impl std::ops::Deref for Surface {
    type Target = LocalSurface;

    #[inline]
    fn deref(&self) -> &LocalSurface {
        &self.local
    }
}

/// The object-space cube `[lo, hi]` of object `o` that the world-space cube of half-width
/// `r` about `c` becomes for the box queries ([`Scene::any_triangle_near`],
/// [`Scene::triangles_near`]); `None` where the transform makes its extent not finite.
fn object_cube(o: &SceneObject, c: Vec3, r: f32) -> Option<(Vec3, Vec3)> {
    let co = xform_point(&o.to_object, c);
    let ro = xform_vector(&o.to_object, Vec3::new(r, 0.0, 0.0)).length();
    ro.is_finite().then(|| (co - ro, co + ro))
}

impl Scene {
    /// Whether the side `n` of the surface point `p` can receive light: it is lit directly,
    /// or one of 64 cosine-distributed rays from it reaches a reflecting surface that is (so
    /// that the first bounce can bring light there). A side that neither test finds (inside a
    /// closed solid, the back of a wall of a closed room) is no receiver.
    pub fn receives_light(&self, p: Vec3, n: Vec3, rng: &mut crate::geom::rng::Rng) -> bool {
        if self.direct(p, n).max_element() > 0.0 {
            return true;
        }
        let (t, b) = crate::geom::sampling::onb(n);
        let o = self.offset(p, n);
        (0..64).any(|_| {
            let d = crate::geom::sampling::cosine_direction(n, t, b, Vec2::new(rng.next_f32(), rng.next_f32()), 0.0);
            self.intersect(&Ray { o, d }, f32::INFINITY).is_some_and(|hit| {
                let s = self.surface(&hit, d);
                s.albedo.max_element() > 0.0 && self.direct(s.p, s.n).max_element() > 0.0
            })
        })
    }

    /// Loads a scene file from disk; `overrides` replace `[solver]` keys. Resource limits
    /// are the defaults ([`Limits::default`]).
    pub fn load(path: &Path, overrides: &[(String, toml::Value)]) -> Result<(Scene, SolverParams)> {
        Scene::load_with(path, overrides, &Limits::default())
    }

    /// [`Scene::load`] within `limits`.
    pub fn load_with(
        path: &Path,
        overrides: &[(String, toml::Value)],
        limits: &Limits,
    ) -> Result<(Scene, SolverParams)> {
        let text = crate::limits::read_text(path, crate::limits::MAX_TEXT_BYTES)?;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let dir = if dir.as_os_str().is_empty() {
            PathBuf::from(".")
        } else {
            dir
        };
        Scene::from_toml_with(&text, path, Source::Dir(dir), overrides, limits)
    }

    /// The Cornell box shipped inside the binary.
    pub fn embedded_cornell(overrides: &[(String, toml::Value)]) -> Result<(Scene, SolverParams)> {
        Scene::embedded_cornell_with(overrides, &Limits::default())
    }

    /// A scene file embedded in the binary (`cornell_box.toml`, `cornell_parts.toml`).
    pub fn embedded_file(name: &str, overrides: &[(String, toml::Value)]) -> Result<(Scene, SolverParams)> {
        let src = Source::Embedded(source::EMBEDDED_CORNELL);
        let text = src.read(Path::new(name))?;
        Scene::from_toml_with(
            &String::from_utf8_lossy(&text),
            &src.display(Path::new(name)),
            src,
            overrides,
            &Limits::default(),
        )
    }

    /// [`Scene::embedded_cornell`] within `limits`.
    pub fn embedded_cornell_with(
        overrides: &[(String, toml::Value)],
        limits: &Limits,
    ) -> Result<(Scene, SolverParams)> {
        let src = Source::Embedded(source::EMBEDDED_CORNELL);
        let text = src.read(Path::new("cornell_box.toml"))?;
        Scene::from_toml_with(
            &String::from_utf8_lossy(&text),
            &src.display(Path::new("cornell_box.toml")),
            src,
            overrides,
            limits,
        )
    }

    /// Parses and loads a scene whose files come from `source`.
    pub fn from_toml(
        text: &str,
        path: &Path,
        source: Source,
        overrides: &[(String, toml::Value)],
    ) -> Result<(Scene, SolverParams)> {
        Scene::from_toml_with(text, path, source, overrides, &Limits::default())
    }

    /// [`Scene::from_toml`] within `limits`.
    pub fn from_toml_with(
        text: &str,
        path: &Path,
        source: Source,
        overrides: &[(String, toml::Value)],
        limits: &Limits,
    ) -> Result<(Scene, SolverParams)> {
        let text = crate::limits::strip_bom(text);
        let mut file: config::SceneFile = toml::from_str(text).map_err(|e| Error::SceneSyntax {
            path: path.into(),
            message: clip_lines(e.to_string().trim_end()),
        })?;
        // The file's [solver], then the overrides, validated once: a file whose values
        // are only valid together with an override (`levels = 3` and `--set
        // sender_level=2`) is fine.
        if overrides.is_empty() {
            file.solver.validate().map_err(|e| Error::SceneValue {
                path: path.into(),
                key: "solver".into(),
                message: e.to_string(),
            })?;
        } else {
            file.solver = apply_overrides(&file.solver, overrides)?;
        }
        if file.object.is_empty() {
            return Err(Error::SceneValue {
                path: path.into(),
                key: "object".into(),
                message: "the scene has no [[object]]: nothing to light".into(),
            });
        }
        let mut light_names = Vec::new();
        let mut light_tables = Vec::new();
        for (i, l) in file.light.iter().enumerate() {
            let mut t = l.clone();
            let named = t.contains_key("name");
            let name = match t.remove("name") {
                None => format!("light{i}"),
                Some(toml::Value::String(s)) if !s.trim().is_empty() => s,
                Some(v) => {
                    return Err(Error::SceneValue {
                        path: path.into(),
                        key: format!("light[{i}].name"),
                        message: format!("expected a non-empty string, found {v}"),
                    })
                }
            };
            if light_names.contains(&name) {
                return Err(Error::SceneValue {
                    path: path.into(),
                    key: format!("light[{i}].name"),
                    message: if named {
                        format!("`{name}` names an earlier light too: names must be unique")
                    } else {
                        format!(
                            "this light has no `name`, and its default `{name}` names an earlier light: \
                             names must be unique, so give it one"
                        )
                    },
                });
            }
            light_names.push(name);
            light_tables.push(t);
        }
        let lights = light_tables
            .iter()
            .enumerate()
            .map(|(i, l)| light::from_table(l, i, path))
            .collect::<Result<Vec<_>>>()?;
        if !lights.is_empty() {
            check_light_power(&lights).map_err(|message| Error::SceneValue {
                path: path.into(),
                key: "light".into(),
                message,
            })?;
        }
        // What the parameters alone ask for, before any mesh is read; checked again with
        // the triangles in `finish`.
        let camera = file.camera.as_ref().map(|c| Camera::from_entry(c, path)).transpose()?;
        let placeholder = Camera::framing(Vec3::ZERO, Vec3::ONE);
        plan_memory(
            limits,
            path,
            0,
            &file.solver,
            camera.as_ref().unwrap_or(&placeholder),
            file.object.len(),
        )?;
        let mut b = Builder {
            limits: *limits,
            ..Default::default()
        };
        b.report.inputs.push(path.into());
        for (i, entry) in file.object.iter().enumerate() {
            b.add_object(&source, path, i, entry)?;
        }
        let sky = file
            .sky
            .as_ref()
            .map(|s| read_sky(s, path, &source, limits))
            .transpose()?
            .flatten();
        if let Some(f) = sky.as_ref().and_then(sky::Sky::file) {
            b.report.inputs.push(f.to_path_buf());
        }
        let mut lights = lights;
        if !b.gltf_lights.is_empty() {
            for (object, l) in std::mem::take(&mut b.gltf_lights) {
                // The light's own name; its object's name before it where that is taken.
                let mut name = l.name.clone();
                if light_names.contains(&name) {
                    name = format!("{object}/{}", l.name);
                }
                let base = name.clone();
                let mut k = 1;
                while light_names.contains(&name) {
                    k += 1;
                    name = format!("{base}#{k}");
                }
                lights.push(light::from_table(&l.table, lights.len(), path)?);
                light_names.push(name);
                light_tables.push(l.table);
            }
            check_light_power(&lights).map_err(|message| Error::SceneValue {
                path: path.into(),
                key: "light".into(),
                message,
            })?;
        }
        let camera_entry = file.camera.clone().or(b.gltf_camera.take());
        let mut scene = b.finish(path, &source, lights, camera_entry.as_ref(), &file.solver)?;
        scene.sky = sky;
        if scene.lights.is_empty() && !scene.emitters.any() && scene.sky.is_none() {
            return Err(Error::SceneValue {
                path: path.into(),
                key: "light".into(),
                message: "the scene has no [[light]], no emitting surface (MTL Ke) and no [sky]: everything would be \
                          black"
                    .into(),
            });
        }
        scene.light_names = light_names;
        scene.light_tables = light_tables;
        Ok((scene, file.solver))
    }

    /// The index of the object named `name`.
    pub fn object_index(&self, name: &str) -> Option<usize> {
        self.objects.iter().position(|o| o.name == name)
    }

    /// The index of the light named `name`.
    pub fn light_index(&self, name: &str) -> Option<usize> {
        self.light_names.iter().position(|n| n == name)
    }

    /// Places object `i` with `t` (checked as a scene file's transform is: the error
    /// gives the field and why) and recomputes the scene's bounds, exactly as loading a
    /// file that holds `t` computes them.
    pub fn set_transform(&mut self, i: usize, t: Transform) -> std::result::Result<(), (&'static str, String)> {
        check_transform(&t)?;
        let o = &mut self.objects[i];
        o.transform = t;
        o.to_world = t.to_world();
        o.to_object = t.to_object();
        let (lo, hi, scale) = world_bounds(&self.objects, &self.tris).map_err(|m| ("translate", m))?;
        self.bounds = (lo, hi);
        self.scale = scale;
        let placed: Vec<_> = self.objects.iter().map(|o| o.to_world).collect();
        self.emitters.place(&self.tris, &placed);
        Ok(())
    }

    /// Replaces light `i` by the light `table` describes (the keys of a `[[light]]`, less
    /// `name`), parsed as a scene file's (errors name `light[i]`).
    pub fn set_light(&mut self, i: usize, table: toml::Table) -> Result<()> {
        let l = light::from_table(&table, i, &self.path)?;
        let mut lights = self.lights.clone();
        lights[i] = l;
        check_light_power(&lights).map_err(|message| Error::SceneValue {
            path: self.path.clone(),
            key: format!("light[{i}]"),
            message,
        })?;
        self.lights = lights;
        self.light_tables[i] = table;
        Ok(())
    }

    /// Closest hit of a world-space ray in `(0, tmax)` over all objects.
    pub fn intersect(&self, ray: &Ray, mut tmax: f32) -> Option<Hit> {
        let mut best = None;
        for (i, o) in self.objects.iter().enumerate() {
            let r = Ray {
                o: xform_point(&o.to_object, ray.o),
                d: xform_vector(&o.to_object, ray.d),
            };
            if let Some((tri, t, b1, b2)) = bvh::trace_cw(&self.cw, &self.tris, self.cw.roots[i], &r, tmax, false) {
                tmax = t;
                best = Some(Hit {
                    object: i as u32,
                    tri,
                    t,
                    b1,
                    b2,
                });
            }
        }
        best
    }

    /// Whether anything blocks a world-space ray in `(0, tmax)`.
    pub fn occluded(&self, ray: &Ray, tmax: f32) -> bool {
        self.objects.iter().zip(&self.cw.roots).any(|(o, &root)| {
            let r = Ray {
                o: xform_point(&o.to_object, ray.o),
                d: xform_vector(&o.to_object, ray.d),
            };
            bvh::trace_cw(&self.cw, &self.tris, root, &r, tmax, true).is_some()
        })
    }

    /// Whether some triangle whose bounds meet the world-space cube of half-width `r`
    /// about `c` satisfies `f(object, triangle)` (object-space triangle): which triangles
    /// rays from `c` no longer than `r` can reach, without tracing them.
    pub fn any_triangle_near(&self, c: Vec3, r: f32, mut f: impl FnMut(usize, &Tri) -> bool) -> bool {
        self.objects.iter().enumerate().any(|(i, o)| {
            let Some((lo, hi)) = object_cube(o, c, r) else {
                return true;
            };
            bvh::any_in_box(&self.bvh, &self.tris, o.bvh_root, lo, hi, |_, t| f(i, t))
        })
    }

    /// Every triangle whose bounds meet the world-space cube of half-width `r` about `c`
    /// (those [`Self::any_triangle_near`] tests), as (object, global triangle) in object
    /// order, into `out`, if there are at most `cap`; false, with `out` incomplete, if
    /// there are more or an object's transform makes the cube's extent not finite.
    pub fn triangles_near(&self, c: Vec3, r: f32, cap: usize, out: &mut Vec<(u32, u32)>) -> bool {
        out.clear();
        for (i, o) in self.objects.iter().enumerate() {
            let Some((lo, hi)) = object_cube(o, c, r) else {
                return false;
            };
            let over = bvh::any_in_box(&self.bvh, &self.tris, o.bvh_root, lo, hi, |t, _| {
                out.push((i as u32, t));
                out.len() > cap
            });
            if over {
                return false;
            }
        }
        true
    }

    /// Calls `f(object, triangle, t, b1, b2)` for each triangle of `near` (object order, as
    /// [`Self::triangles_near`] gives them) that the world-space `ray` hits in `(0, tmax)`,
    /// by the watertight test of [`bvh::trace`] in the object's space, until `f` returns
    /// true.
    fn hits_among(
        &self,
        near: &[(u32, u32)],
        ray: &Ray,
        tmax: f32,
        mut f: impl FnMut(u32, u32, f32, f32, f32) -> bool,
    ) {
        for run in near.chunk_by(|a, b| a.0 == b.0) {
            let o = &self.objects[run[0].0 as usize];
            let wt = WatertightRay::new(&Ray {
                o: xform_point(&o.to_object, ray.o),
                d: xform_vector(&o.to_object, ray.d),
            });
            for &(oi, tri) in run {
                if let Some((t, b1, b2)) = wt.intersect(&self.tris[tri as usize], tmax) {
                    if f(oi, tri, t, b1, b2) {
                        return;
                    }
                }
            }
        }
    }

    /// [`Self::intersect`] for a ray that stays within a cube whose triangles `near` holds
    /// ([`Self::triangles_near`]): the closest hit among them, found without a BVH walk.
    /// Where another hit lies within a relative 1e-5 of it, or it lies that close to
    /// `tmax`, the traversal's rounding could pick otherwise, and the ray is traced.
    pub fn intersect_among(&self, near: &[(u32, u32)], ray: &Ray, tmax: f32) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut second = f32::INFINITY;
        self.hits_among(near, ray, tmax, |object, tri, t, b1, b2| {
            match best {
                Some(b) if t >= b.t => second = second.min(t),
                _ => {
                    if let Some(b) = best {
                        second = second.min(b.t);
                    }
                    best = Some(Hit { object, tri, t, b1, b2 });
                }
            }
            false
        });
        match best {
            Some(b) if second - b.t <= 1e-5 * b.t || tmax - b.t <= 1e-5 * tmax => self.intersect(ray, tmax),
            _ => best,
        }
    }

    /// [`Self::occluded`] for a ray that stays within a cube whose triangles `near` holds:
    /// whether one of them is hit in `(0, tmax)`. Where every hit lies within a relative
    /// 1e-5 of `tmax` (the traversal's rounding could cull it), the ray is traced.
    pub fn occluded_among(&self, near: &[(u32, u32)], ray: &Ray, tmax: f32) -> bool {
        let (mut clear, mut marginal) = (false, false);
        self.hits_among(near, ray, tmax, |_, _, t, _, _| {
            if tmax - t > 1e-5 * tmax {
                clear = true;
            } else {
                marginal = true;
            }
            clear
        });
        clear || (marginal && self.occluded(ray, tmax))
    }

    /// The surface at a hit, its normal turned towards the ray's origin.
    pub fn surface(&self, hit: &Hit, ray_d: Vec3) -> Surface {
        let local = self.local_surface(hit, ray_d);
        let (p, n) = self.world_of(&local);
        Surface { local, p, n }
    }

    /// The world-space point and unit normal of a [`LocalSurface`] (those of
    /// [`Scene::surface`]).
    #[inline]
    pub fn world_of(&self, l: &LocalSurface) -> (Vec3, Vec3) {
        let o = &self.objects[l.object as usize];
        (
            xform_point(&o.to_world, l.p_obj),
            xform_vector(&o.to_world, l.n_obj).normalize(),
        )
    }

    /// [`Scene::surface`] in the object's space alone (the gathering rays' sender reads:
    /// no world-space point and normal to transform and normalise).
    #[inline]
    pub fn local_surface(&self, hit: &Hit, ray_d: Vec3) -> LocalSurface {
        let o = &self.objects[hit.object as usize];
        let tri = &self.tris[hit.tri as usize];
        let p_obj = tri_point(tri, hit.b1, hit.b2);
        let mut n_obj = tri_normal(tri);
        let back = n_obj.dot(xform_vector(&o.to_object, ray_d)) > 0.0;
        if back {
            n_obj = -n_obj;
        }
        LocalSurface {
            object: hit.object,
            tri: hit.tri,
            p_obj,
            n_obj,
            back,
            albedo: self.albedo(hit.tri, hit.b1, hit.b2),
        }
    }

    /// Material `m`'s `kd`: the albedo everywhere on an untextured triangle of it.
    #[inline]
    pub fn kd(&self, m: u32) -> Vec3 {
        Vec3::from(self.materials[m as usize].kd)
    }

    /// The material of global triangle `tri` if its albedo is that material's `kd`
    /// everywhere on it (no texture): what [`Scene::albedo`] returns there.
    #[inline]
    pub fn plain_material(&self, tri: u32) -> Option<u32> {
        let m = self.tris[tri as usize].material;
        (self.materials[m as usize].texture == NONE).then_some(m)
    }

    /// Albedo `ρ` at barycentrics `(b1, b2)` of global triangle `tri`.
    pub fn albedo(&self, tri: u32, b1: f32, b2: f32) -> Vec3 {
        let mi = self.tris[tri as usize].material;
        let (m, kd) = (&self.materials[mi as usize], self.kd(mi));
        if m.texture == NONE {
            return kd;
        }
        let uv = &self.uvs[tri as usize].uv;
        let b0 = 1.0 - b1 - b2;
        let u = Vec2::new(
            uv[0] * b0 + uv[2] * b1 + uv[4] * b2,
            uv[1] * b0 + uv[3] * b1 + uv[5] * b2,
        );
        kd * texture::sample(&self.texels, &self.textures[m.texture as usize], u, &self.srgb)
    }

    /// The shadow-ray origin for a world-space surface point.
    pub fn offset(&self, p: Vec3, n: Vec3) -> Vec3 {
        offset_origin(p, n, self.scale)
    }

    /// Direct irradiance at a world-space point `(x, n)` (`ALGORITHM.md` §2): every light
    /// exactly, each with a shadow ray, and the emitting surfaces estimated with
    /// `emitter_samples` shadow rays.
    pub fn direct(&self, x: Vec3, n: Vec3) -> Vec3 {
        self.direct_with_error(x, n).0
    }

    /// [`Scene::direct`] and its standard error (the emitters' sampling; lights are exact).
    pub fn direct_with_error(&self, x: Vec3, n: Vec3) -> (Vec3, Vec3) {
        let (mut e, mut se) = (Vec3::ZERO, Vec3::ZERO);
        self.direct_sources(x, n, self.emitters.samples(), emitter::point_seed(x, n), |_, v, s| {
            e += v;
            se += s;
        });
        (e, se)
    }

    /// [`Scene::direct`] with one emitter sample: the direct light at a gathering ray's
    /// hit or a reference path's vertex, whose means average many such estimates.
    pub fn direct_one(&self, x: Vec3, n: Vec3) -> Vec3 {
        let mut e = Vec3::ZERO;
        self.direct_sources(x, n, 1, emitter::point_seed(x, n), |_, v, _| e += v);
        e
    }

    /// Direct irradiance from the sources `which` only (indexed as [`Scene::sources`]).
    pub fn direct_from(&self, x: Vec3, n: Vec3, which: &[bool]) -> Vec3 {
        let mut e = Vec3::ZERO;
        self.direct_each(x, n, |i, v| {
            if which[i] {
                e += v
            }
        });
        e
    }

    /// Light sources: the lights, then the emitting surfaces as one more if there are any,
    /// then the sky if there is one.
    pub fn sources(&self) -> usize {
        self.lights.len() + self.emitters.any() as usize + self.sky.is_some() as usize
    }

    /// Calls `f(source index, irradiance)` for each source that reaches `(x, n)`
    /// ([`Scene::sources`]; the emitters with `emitter_samples` shadow rays).
    pub fn direct_each(&self, x: Vec3, n: Vec3, mut f: impl FnMut(usize, Vec3)) {
        self.direct_sources(x, n, self.emitters.samples(), emitter::point_seed(x, n), |i, v, _| {
            f(i, v)
        });
    }

    /// [`Scene::direct_each`] with each source's standard error (zero for the lights).
    pub fn direct_each_with_error(&self, x: Vec3, n: Vec3, f: impl FnMut(usize, Vec3, Vec3)) {
        self.direct_sources(x, n, self.emitters.samples(), emitter::point_seed(x, n), f);
    }

    /// [`Scene::direct_each_with_error`] with the sample sets shifted by `seed` (a node's
    /// [`emitter::node_seed`]: the GPU kernels draw the same samples).
    pub fn direct_each_seeded(&self, x: Vec3, n: Vec3, seed: u64, f: impl FnMut(usize, Vec3, Vec3)) {
        self.direct_sources(x, n, self.emitters.samples(), seed, f);
    }

    /// [`Scene::direct_one`] with the sample shifted by `seed` (a gathering ray's
    /// [`emitter::hit_seed`]).
    pub fn direct_one_seeded(&self, x: Vec3, n: Vec3, seed: u64) -> Vec3 {
        let mut e = Vec3::ZERO;
        self.direct_sources(x, n, 1, seed, |_, v, _| e += v);
        e
    }

    /// [`Scene::direct_each`] with `samples` emitter samples, and each source's standard
    /// error.
    fn direct_sources(&self, x: Vec3, n: Vec3, samples: usize, seed: u64, mut f: impl FnMut(usize, Vec3, Vec3)) {
        let o = self.offset(x, n);
        for (i, l) in self.lights.iter().enumerate() {
            if let Some(s) = light::light_sample(l, x, n, o) {
                let ray = Ray { o, d: s.to_light };
                if !self.occluded(&ray, s.tmax) {
                    f(i, s.irradiance, Vec3::ZERO);
                }
            }
        }
        if !self.emitters.any() && self.sky.is_none() {
            return;
        }
        let count = samples.min(self.emitters.samples());
        if self.emitters.any() {
            let (mut sum, mut sum2) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
            self.emitters
                .for_each_sample(&self.tris, emitter::Receiver { x, n, o }, seed, samples, |s| {
                    if let Some(s) = s {
                        let ray = Ray { o, d: s.to_point };
                        if !self.occluded(&ray, crate::constants::SHADOW_TMAX) {
                            let v = s.value.as_dvec3();
                            sum += v;
                            sum2 += v * v;
                        }
                    }
                });
            let (mean, err) = emitter::mean_and_error(sum, sum2, count);
            if mean.max_element() > 0.0 {
                f(self.lights.len(), mean, err);
            }
        }
        let sky_index = self.lights.len() + self.emitters.any() as usize;
        match &self.sky {
            None => {}
            Some(sky::Sky::Constant(l)) => {
                // Cosine-weighted directions (2-D Halton, shifted per point): each one that
                // leaves the scene adds π L_sky (1/pdf = π/cos), a Bernoulli mean.
                let (t, b) = crate::geom::sampling::onb(n);
                let shift = emitter::shift(seed ^ 0x5c1e_5c1e);
                let mut open = 0usize;
                for k in 0..count {
                    let h = emitter::halton2(k as u64 + 1);
                    let u = Vec2::new((h[0] + shift[0]).fract() as f32, (h[1] + shift[1]).fract() as f32);
                    let d = crate::geom::sampling::cosine_direction(n, t, b, u, 0.0);
                    open += !self.occluded(&Ray { o, d }, f32::INFINITY) as usize;
                }
                let nf = count.max(1) as f32;
                let p = open as f32 / nf;
                let se = if count > 1 {
                    (p * (1.0 - p) / (nf - 1.0)).sqrt()
                } else {
                    0.0
                };
                if open > 0 {
                    let pi = std::f32::consts::PI;
                    f(sky_index, *l * pi * p, *l * pi * se);
                }
            }
            Some(sky::Sky::Map(m)) => {
                // Directions (2-D Halton, shifted per point) from the even mixture of the
                // map's luminance and the cosine (the first number picks which, then is
                // reused): each that faces the point and leaves the scene adds
                // L cos / pdf with pdf the mixture's (the balance heuristic).
                let (t, b) = crate::geom::sampling::onb(n);
                let shift = emitter::shift(seed ^ 0x5c1e_5c1e);
                let (mut sum, mut sum2) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
                for k in 0..count {
                    let h = emitter::halton2(k as u64 + 1);
                    let u = [(h[0] + shift[0]).fract(), (h[1] + shift[1]).fract()];
                    let d = if u[0] < 0.5 {
                        match m.sample([2.0 * u[0], u[1]]) {
                            Some((d, _, _)) => d,
                            None => continue,
                        }
                    } else {
                        let v = Vec2::new((2.0 * u[0] - 1.0) as f32, u[1] as f32);
                        crate::geom::sampling::cosine_direction(n, t, b, v, 0.0)
                    };
                    let c = n.dot(d);
                    if c <= 0.0 {
                        continue;
                    }
                    let pdf = 0.5 * (m.pdf(d) + c as f64 / std::f64::consts::PI);
                    if !self.occluded(&Ray { o, d }, f32::INFINITY) {
                        let v = m.radiance(d).as_dvec3() * (c as f64 / pdf);
                        sum += v;
                        sum2 += v * v;
                    }
                }
                let (mean, err) = emitter::mean_and_error(sum, sum2, count);
                if mean.max_element() > 0.0 {
                    f(sky_index, mean, err);
                }
            }
        }
    }

    /// The sky's radiance seen along a ray of direction `d` that leaves the scene (zero
    /// without a sky).
    pub fn sky_radiance(&self, d: Vec3) -> Vec3 {
        self.sky.as_ref().map_or(Vec3::ZERO, |s| s.radiance(d))
    }

    /// The radiance a surface point sends toward the ray that found it by emitting: its
    /// material's `L_e` on an emitting triangle's front, zero elsewhere.
    pub fn emitted(&self, s: &Surface) -> Vec3 {
        if s.back {
            return Vec3::ZERO;
        }
        self.emission[self.tris[s.tri as usize].material as usize]
    }

    /// Whether any material is textured (texture sampling can be compiled out otherwise).
    pub fn textured(&self) -> bool {
        !self.textures.is_empty()
    }

    /// Total triangle count.
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }
}

/// The memory a solve of this scene will plan for, checked against `limits` before any
/// work: triangles, the hierarchy's candidates and nodes (their counts follow from
/// `coarsest`, `levels`, `candidate_factor` and `max_candidates` alone), rays in flight
/// and the image. Returns the estimate in bytes; the error blames the largest part.
fn plan_memory(
    limits: &Limits,
    path: &Path,
    triangles: usize,
    p: &SolverParams,
    camera: &Camera,
    objects: usize,
) -> Result<f64> {
    use crate::limits::{BYTES_PER_CANDIDATE, BYTES_PER_NODE, BYTES_PER_PIXEL, BYTES_PER_TRIANGLE};
    let m = p.levels as i32;
    // Level l holds about coarsest × 4^l nodes (r_l = r_0 / 2^l).
    let nodes = p.coarsest as f64 * (4f64.powi(m) - 1.0) / 3.0;
    let finest = p.coarsest as f64 * 4f64.powi(m - 1);
    let candidates = (p.candidate_factor as f64 * finest).min(objects as f64 * p.max_candidates as f64);
    let threads = rayon::current_num_threads() as f64;
    let pixels = camera.width as f64 * camera.height as f64;
    let parts = [
        (
            "object",
            format!("{triangles} triangles"),
            triangles as f64 * BYTES_PER_TRIANGLE as f64,
        ),
        (
            "solver.coarsest",
            format!(
                "{:.3e} hierarchy nodes (coarsest = {}, levels = {m})",
                nodes, p.coarsest
            ),
            nodes * BYTES_PER_NODE as f64,
        ),
        (
            "solver.candidate_factor",
            format!("{candidates:.3e} candidates"),
            candidates * BYTES_PER_CANDIDATE as f64,
        ),
        (
            "solver.rays",
            format!("{} rays per integral on {threads} threads", p.rays),
            p.rays as f64 * 64.0 * threads,
        ),
        (
            "camera.width",
            format!("a {}×{} image", camera.width, camera.height),
            pixels * BYTES_PER_PIXEL as f64,
        ),
    ];
    let largest = parts
        .iter()
        .max_by(|a, b| a.2.total_cmp(&b.2))
        .map(|p| p.0)
        .unwrap_or("solver");
    let list: Vec<Part> = parts
        .iter()
        .map(|(_, what, bytes)| Part {
            what: what.clone(),
            bytes: *bytes,
        })
        .collect();
    limits.check(path, largest, &list)?;
    Ok(list.iter().map(|p| p.bytes).sum())
}

/// `message` with every line cut to 160 characters (a TOML error quotes the offending
/// line, which may be as long as the file).
fn clip_lines(message: &str) -> String {
    message
        .lines()
        .map(|l| {
            if l.chars().count() > 160 {
                format!("{}…", l.chars().take(160).collect::<String>())
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Replaces `[solver]` keys; each key is checked on its own so that an error names it.
pub fn apply_overrides(params: &SolverParams, overrides: &[(String, toml::Value)]) -> Result<SolverParams> {
    let mut table = toml::Table::try_from(params).map_err(|e| Error::param("solver", e.to_string()))?;
    for (k, v) in overrides {
        let mut one = toml::Table::new();
        one.insert(k.clone(), v.clone());
        toml::Value::Table(one)
            .try_into::<SolverParams>()
            .map_err(|e| Error::param(k, e.to_string().trim_end().to_string()))?;
        table.insert(k.clone(), v.clone());
    }
    let p: SolverParams = toml::Value::Table(table)
        .try_into()
        .map_err(|e| Error::param("solver", e.to_string()))?;
    p.validate()?;
    Ok(p)
}

/// Object `i`'s transform, each part checked.
fn object_transform(scene_path: &Path, i: usize, e: &config::ObjectEntry) -> Result<Transform> {
    let t = Transform {
        scale: e.scale.unwrap_or(1.0),
        rotate_deg: Vec3::from(e.rotate.unwrap_or([0.0; 3])),
        translate: Vec3::from(e.translate.unwrap_or([0.0; 3])),
    };
    check_transform(&t).map_err(|(f, m)| Error::SceneValue {
        path: scene_path.into(),
        key: format!("object[{i}].{f}"),
        message: m,
    })?;
    Ok(t)
}

/// The `[sky]` table checked and read: `None` for a sky without light.
fn read_sky(s: &config::SkyEntry, path: &Path, source: &Source, limits: &Limits) -> Result<Option<sky::Sky>> {
    let err = |key: &str, message: String| Error::SceneValue {
        path: path.into(),
        key: format!("sky.{key}"),
        message,
    };
    match (&s.radiance, &s.envmap) {
        (Some(r), None) => {
            if s.scale.is_some() || s.rotate.is_some() {
                let k = if s.scale.is_some() { "scale" } else { "rotate" };
                return Err(err(k, "applies to an `envmap` only".into()));
            }
            let l = Vec3::from(*r);
            if !l.is_finite() || l.min_element() < 0.0 {
                return Err(err("radiance", format!("{r:?} must be finite and non-negative")));
            }
            Ok((l.max_element() > 0.0).then_some(sky::Sky::Constant(l)))
        }
        (None, Some(file)) => {
            let scale = s.scale.unwrap_or(1.0);
            if !(scale.is_finite() && scale >= 0.0) {
                return Err(err("scale", format!("{scale} must be finite and non-negative")));
            }
            let rotate = s.rotate.unwrap_or(0.0);
            if !rotate.is_finite() {
                return Err(err("rotate", format!("{rotate} must be finite")));
            }
            if file.trim().is_empty() {
                return Err(err("envmap", "is empty: give the map's file".into()));
            }
            let expanded = source::expand_scenes_var(file);
            let rel = expanded.as_deref().unwrap_or(Path::new(file));
            // The file, its decoded pixels (RGBA f32) and the sampling tables.
            let m = sky::EnvMap::load(source, rel, scale, rotate, limits.max_memory)?;
            Ok(m.any().then(|| sky::Sky::Map(Box::new(m))))
        }
        (Some(_), Some(_)) => Err(err("envmap", "give `radiance` or `envmap`, not both".into())),
        (None, None) => Err(err(
            "radiance",
            "is missing: give `radiance = [r, g, b]` or `envmap = \"FILE\"`".into(),
        )),
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

/// Whether `t` is a transform a scene may hold: the field at fault and why if not.
pub fn check_transform(t: &Transform) -> std::result::Result<(), (&'static str, String)> {
    if !(t.scale.is_finite() && t.scale > 0.0) {
        return Err(("scale", format!("{} must be finite and positive", t.scale)));
    }
    if !t.rotate_deg.is_finite() {
        return Err(("rotate", format!("{:?} must be finite", t.rotate_deg.to_array())));
    }
    if !t.translate.is_finite() {
        return Err(("translate", format!("{:?} must be finite", t.translate.to_array())));
    }
    Ok(())
}

/// Some light must give light.
fn check_light_power(lights: &[GpuLight]) -> std::result::Result<(), String> {
    if lights.iter().all(|l| l.power.iter().all(|&c| c == 0.0)) {
        return Err("every light has zero intensity or irradiance: everything would be black".into());
    }
    Ok(())
}

/// World-space bounds of every object and the length of their diagonal.
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

fn world_bounds(objects: &[SceneObject], tris: &[Tri]) -> std::result::Result<(Vec3, Vec3, f32), String> {
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

#[derive(Default)]
struct Builder {
    limits: Limits,
    objects: Vec<SceneObject>,
    tris: Vec<Tri>,
    uvs: Vec<[f32; 6]>,
    bvh: Vec<BvhNode>,
    materials: Vec<obj::MtlData>,
    /// Whether each material's object lets it emit.
    material_emits: Vec<bool>,
    report: LoadReport,
    /// glTF objects' lights (`[[light]]` tables in world space) with their object's name.
    gltf_lights: Vec<(String, gltf_file::GltfLight)>,
    /// The first glTF camera, in world space.
    gltf_camera: Option<config::CameraEntry>,
}

impl Builder {
    /// Reads object `i`'s mesh, places its triangles, BVH and materials after those
    /// already added, and records its transform.
    fn add_object(&mut self, source: &Source, scene_path: &Path, i: usize, e: &config::ObjectEntry) -> Result<()> {
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
        let mut uvs = mesh.uvs;
        let mut nodes = bvh::build(&mut mesh.tris, &mut uvs, &e.mesh)?;
        let tri_offset = self.tris.len() as u32;
        let node_offset = self.bvh.len() as u32;
        bvh::rebase(&mut nodes, node_offset, tri_offset);
        let area = mesh
            .tris
            .iter()
            .map(|t| {
                let v0 = Vec3::from(t.v0).as_dvec3();
                (Vec3::from(t.v1).as_dvec3() - v0)
                    .cross(Vec3::from(t.v2).as_dvec3() - v0)
                    .length()
                    * 0.5
            })
            .sum();
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
        if let Some(g) = gltf {
            let to_world = transform.to_world();
            for mut l in g.lights {
                place_light_table(&mut l.table, &to_world);
                self.gltf_lights.push((name.clone(), l));
            }
            if let (None, Some(c)) = (&self.gltf_camera, g.camera) {
                let p = xform_point(&to_world, c.position);
                let (w, h) = match c.aspect {
                    Some(a) => (((256.0 * a).round() as u32).clamp(1, 16384), 256),
                    None => (256, 256),
                };
                self.gltf_camera = Some(config::CameraEntry {
                    position: p.to_array(),
                    target: (p + xform_vector(&to_world, c.forward)).to_array(),
                    up: xform_vector(&to_world, c.up).to_array(),
                    fov: c.fov,
                    width: w,
                    height: h,
                });
            }
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
        });
        let n = mesh.tris.len();
        self.tris.extend(mesh.tris);
        if has_uv {
            self.uvs.resize(tri_offset as usize, [0.0; 6]);
            self.uvs.extend(uvs);
        }
        self.uvs.resize(tri_offset as usize + n, [0.0; 6]);
        self.bvh.extend(nodes);
        self.material_emits.extend(mesh.materials.iter().map(|_| emits));
        self.materials.extend(mesh.materials);
        Ok(())
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
        let loaded = if gltf_file::is_gltf(rel) {
            gltf_file::load(source, rel, read_limit, groups.as_deref())
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
        let after = mesh.tris.len() as f64 * 4f64.powi(tess as i32);
        let loaded = self.tris.len() as f64;
        self.limits.check(
            scene_path,
            &key(if tess > 0 { "tessellate" } else { "mesh" }),
            &[Part {
                what: format!(
                    "{} triangles ({} in {}{})",
                    (loaded + after) as u64,
                    mesh.tris.len(),
                    e.mesh,
                    if tess > 0 {
                        format!(" × 4^{tess}")
                    } else {
                        String::new()
                    }
                ),
                bytes: (loaded + after) * crate::limits::BYTES_PER_TRIANGLE as f64,
            }],
        )?;
        for _ in 0..tess {
            let (t, u) = obj::tessellate(&mesh.tris, &mesh.uvs);
            mesh.tris = t;
            mesh.uvs = u;
        }
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
    /// albedo too), its texture loaded once however many materials use it.
    fn resolve_materials(
        &mut self,
        source: &Source,
        srgb: &[f32; 256],
    ) -> Result<(Vec<Material>, Vec<TextureInfo>, Vec<u32>)> {
        let mut textures = Vec::new();
        let mut texels = Vec::new();
        let mut texture_paths: Vec<(PathBuf, u32)> = Vec::new();
        let mut materials = Vec::new();
        for m in &self.materials {
            let kd = m.kd;
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
            let texture = match &m.texture {
                None => {
                    if kd.iter().any(|&c| c >= 1.0) {
                        return Err(bad_kd("is an albedo ≥ 1: the surface would create energy"));
                    }
                    NONE
                }
                Some(t) => {
                    if kd.iter().any(|&c| c > 1.0) {
                        return Err(bad_kd("is above 1"));
                    }
                    match texture_paths.iter().position(|p| *p == (t.clone(), m.wrap)) {
                        Some(k) => k as u32,
                        None => {
                            let (w, h, px) = match &m.texture_data {
                                Some(bytes) => texture::decode(bytes, &source.display(t))?,
                                None => {
                                    self.report.inputs.push(source.display(t));
                                    texture::load(source, t)?
                                }
                            };
                            let info = TextureInfo {
                                offset: texels.len() as u32,
                                width: w,
                                height: h,
                                wrap: m.wrap,
                            };
                            texels.extend(px);
                            let mean = texture::mean(&texels, &info, srgb) * Vec3::from(kd);
                            if mean.max_element() >= 1.0 {
                                return Err(Error::Texture {
                                    path: source.display(t),
                                    message: format!(
                                        "mean albedo {mean} with Kd {kd:?} is ≥ 1: the surface would create energy"
                                    ),
                                });
                            }
                            textures.push(info);
                            texture_paths.push((t.clone(), m.wrap));
                            (textures.len() - 1) as u32
                        }
                    }
                }
            };
            materials.push(Material { kd, texture });
        }
        Ok((materials, textures, texels))
    }

    fn finish(
        mut self,
        path: &Path,
        source: &Source,
        lights: Vec<GpuLight>,
        camera: Option<&config::CameraEntry>,
        params: &SolverParams,
    ) -> Result<Scene> {
        let srgb = texture::srgb_table();
        let (materials, textures, texels) = self.resolve_materials(source, &srgb)?;
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
            None => Camera::framing(lo, hi),
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
            |t| emission[self.tris[t as usize].material as usize],
            params.emitter_samples,
        );
        self.report.emitting_triangles = emitters.list.len();
        let ranges: Vec<_> = self
            .objects
            .iter()
            .map(|o| o.tri_offset as usize..(o.tri_offset + o.tri_count) as usize)
            .collect();
        let cw = bvh::CwForest::build(&self.tris, &ranges);
        Ok(Scene {
            cw,
            sky: None,
            emission,
            emitters,
            path: path.into(),
            objects: self.objects,
            tris: self.tris,
            uvs,
            bvh: self.bvh,
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
            limits: self.limits,
        })
    }
}
