//! A loaded scene: objects (triangles in object space, one BVH each, a rigid transform),
//! materials and textures, lights, camera and solver parameters.
//!
//! This file holds the types; [`Scene`]'s methods live in a file per concept: `query.rs`
//! (ray and box queries, the surface a hit reads), `direct.rs` (direct light and emission),
//! `memory.rs` (memory planning), `assemble.rs` (scene files read and checked, edits) and
//! `builder.rs` (objects read, placed and finished into a scene).

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

mod assemble;
mod builder;
mod direct;
pub(crate) mod memory;
mod query;
pub use query::interpolate_normal;

use std::path::PathBuf;

use glam::Vec3;

pub use assemble::{apply_overrides, check_transform};
pub use builder::object_box;
pub use camera::Camera;
pub use source::Source;

use crate::geom::bvh;
use crate::geom::transform::Affine;
use crate::geom::Transform;
use crate::layout::{BvhNode, GpuLight, Material, ObjectInfo, TextureInfo, Tri, TriUv};

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
    /// Its mesh file's named parts (OBJ groups, glTF nodes) with their bounds in object
    /// space (`obj::Part`): the no-light warning names the one that encloses the rest.
    pub parts: Vec<obj::Part>,
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
    /// Materials with an alpha texture: rays pass their cut-out parts.
    pub cutout_materials: Vec<String>,
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
    /// Per-triangle corner normals in object space (OBJ `vn`, glTF `NORMAL`), unit, on the
    /// front; zero for a flat triangle; empty when no object has any (`Scene::shading_normal`).
    pub normals: Vec<[f32; 9]>,
    pub bvh: Vec<BvhNode>,
    /// Every object's CWBVH over the same triangles: what the CPU's rays traverse
    /// ([`bvh::trace_cw`]) and the GPU's by default; the BVH2 serves box queries and the
    /// GPU's `bvh = "bvh2"`.
    pub cw: bvh::CwForest,
    pub materials: Vec<Material>,
    /// Whether some material is a cutout with an alpha texture (rays test it at hits).
    pub cutouts: bool,
    pub material_names: Vec<String>,
    pub textures: Vec<TextureInfo>,
    pub texels: Vec<u32>,
    pub srgb: [f32; 256],
    /// Emitted radiance per material (zero where none, or where its object's `emission`
    /// is false): the factor that multiplies its emission texture where it has one.
    pub emission: Vec<Vec3>,
    /// Each material's emission texture (MTL `map_Ke`, glTF `emissiveTexture`), or
    /// `layout::NONE`.
    pub emission_textures: Vec<u32>,
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
