//! Data that lives on the GPU as it lives on the CPU: `#[repr(C)]` + `Pod`, std430-safe,
//! mirrored by name in `glsl/include/layout.glsl`. The CPU reference uses these very
//! structs, so an upload is a `bytemuck::cast_slice`. Sizes and offsets are asserted here
//! and the GLSL side is checked by `tests/layout.rs` against the `Offset` decorations of
//! the compiled kernels.

use bytemuck::{Pod, Zeroable};

use crate::params::MAX_LEVELS;

pub use crate::constants::{LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT, NONE};

/// One triangle in object space. `material` indexes the scene's material table.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Tri {
    pub v0: [f32; 3],
    pub material: u32,
    pub v1: [f32; 3],
    pub pad0: u32,
    pub v2: [f32; 3],
    pub pad1: u32,
}

/// Texture coordinates of a triangle's three corners (only for textured scenes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct TriUv {
    pub uv: [f32; 6],
}

/// A basis-function centre of the meshless hierarchy, in its object's space.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Node {
    pub pos: [f32; 3],
    pub level: u32,
    pub normal: [f32; 3],
    pub object: u32,
}

/// Inner node of a median-split kd-tree (8 bytes, as in the paper §4.2): the split plane
/// of the range whose midpoint has this index.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct KdSplit {
    pub value: f32,
    pub dim: u32,
}

/// A parent relation with its pull-down weight `B_p^l(x_c)` (paper §5).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Parent {
    pub node: u32,
    pub weight: f32,
}

/// A diffuse material: `kd` times the texture's texel, if any.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Material {
    pub kd: [f32; 3],
    /// Index into the texture table, or [`NONE`].
    pub texture: u32,
    /// A cutout: the texture whose alpha (times `opacity`) rays pass below `cutoff` (its
    /// alpha byte, linear), or [`NONE`] for an opaque material.
    pub alpha_texture: u32,
    pub opacity: f32,
    pub cutoff: f32,
    pub pad: u32,
}

/// A texture stored as RGBA8 texels (sRGB) at `offset` in the texel array.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct TextureInfo {
    pub offset: u32,
    pub width: u32,
    pub height: u32,
    /// Wrap modes: u in bits 0–1, v in bits 2–3, each [`WRAP_REPEAT`], [`WRAP_CLAMP`] or
    /// [`WRAP_MIRROR`] (glTF's samplers; OBJ textures repeat).
    pub wrap: u32,
}

/// An emitting triangle as the kernels read it (`scene::emitter::Emitter` with its
/// selection probability by power and the running sum of those).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuEmitter {
    pub tri: u32,
    pub object: u32,
    pub prob: f32,
    pub cdf: f32,
    pub radiance: [f32; 3],
    /// Luminance of `radiance` (Rec. 709).
    pub lum: f32,
    /// The emission factor and the emission texture (or [`NONE`]): `scene::emitter::Emitter`.
    pub scale: [f32; 3],
    pub texture: u32,
}

/// Texture wrap modes ([`TextureInfo::wrap`]).
pub const WRAP_REPEAT: u32 = 0;
pub const WRAP_CLAMP: u32 = 1;
pub const WRAP_MIRROR: u32 = 2;

/// A light in world space (see `ALGORITHM.md` §2).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuLight {
    /// Position (point, spot); unused for directional.
    pub position: [f32; 3],
    pub kind: u32,
    /// Spot axis or directional direction of travel, unit length.
    pub direction: [f32; 3],
    /// Spot cutoff angle in radians.
    pub cutoff: f32,
    /// Intensity (W/sr) or perpendicular irradiance (W/m²), RGB.
    pub power: [f32; 3],
    /// Spot beam width in radians.
    pub beam: f32,
}

/// One scene object: its rigid transform, its geometry and its hierarchy ranges.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct ObjectInfo {
    /// World → object, rows of a 3×4 affine matrix.
    pub to_object: [[f32; 4]; 3],
    /// Object → world, rows of a 3×4 affine matrix.
    pub to_world: [[f32; 4]; 3],
    /// Uniform scale (object → world).
    pub scale: f32,
    pub tri_offset: u32,
    pub tri_count: u32,
    pub bvh_offset: u32,
    /// First global node index of each level of this object.
    pub level_start: [u32; MAX_LEVELS as usize],
    /// Node count of each level of this object.
    pub level_count: [u32; MAX_LEVELS as usize],
    /// Poisson radius `r_l` of each level, in object space.
    pub radius: [f32; MAX_LEVELS as usize],
    /// Root of this object's CWBVH in the scene's CWBVH node array (if built).
    pub cw_root: u32,
    pub pad: [u32; 3],
}

/// The BVH node type (obvhs' `Bvh2Node`, 48 bytes), uploaded as it is.
pub type BvhNode = obvhs::bvh2::node::Bvh2Node;

/// The compressed wide BVH node (obvhs' `CwBvhNode`, 80 bytes), uploaded as it is.
pub type CwNode = obvhs::cwbvh::node::CwBvhNode;

const _: () = {
    assert!(std::mem::size_of::<Tri>() == 48);
    assert!(std::mem::size_of::<TriUv>() == 24);
    assert!(std::mem::size_of::<Node>() == 32);
    assert!(std::mem::size_of::<KdSplit>() == 8);
    assert!(std::mem::size_of::<Parent>() == 8);
    assert!(std::mem::size_of::<Material>() == 32);
    assert!(std::mem::size_of::<GpuEmitter>() == 48);
    assert!(std::mem::size_of::<TextureInfo>() == 16);
    assert!(std::mem::size_of::<GpuLight>() == 48);
    assert!(std::mem::size_of::<ObjectInfo>() == 112 + 12 * MAX_LEVELS as usize + 16);
    assert!(std::mem::size_of::<CwNode>() == 80);
    assert!(std::mem::size_of::<BvhNode>() == 48);
    assert!(std::mem::offset_of!(ObjectInfo, level_start) == 112);
    assert!(std::mem::offset_of!(BvhNode, prim_count) == 32);
    assert!(std::mem::offset_of!(BvhNode, first_index) == 36);
};

/// What the `image` kernel reads besides `Globals` (GLSL `ImageInfoRef` in
/// `glsl/image.comp`): the camera, the corner normals and the gather's directions, and how
/// the indirect light is read (`device::image`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct ImageInfo {
    /// The camera's position, and the tangent of half its field of view in `w`.
    pub position: [f32; 4],
    pub forward: [f32; 4],
    pub right: [f32; 4],
    pub up: [f32; 4],
    /// Device address of the corner normals (9 floats per triangle), or 0 without.
    pub normals: u64,
    /// Device address of the gather's directions (`halton_table(gather_rays)`).
    pub halton: u64,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// [`crate::constants::FILTER_BOX`] or [`crate::constants::FILTER_GAUSSIAN`].
    pub filter_kind: u32,
    /// The output level the basis is read on.
    pub level: u32,
    pub seed: u32,
    /// [`crate::constants::IMAGE_BASIS`], `IMAGE_DOUBT` or `IMAGE_GATHER`.
    pub mode: u32,
    pub gather_rays: u32,
    pub doubt_nodes: u32,
    pub doubt_spread: f32,
    /// Chunks a sample's gather is split into (one thread each), and their rays.
    pub chunks: u32,
    pub chunk_rays: u32,
    /// `SolverParams::short_hops`: most hops a gather ray takes past hits nearer than the
    /// output level's support.
    pub short_hops: u32,
    pub pad: [u32; 3],
}
