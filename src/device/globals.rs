//! The host/device parameter block every kernel reads, mirrored by name in
//! `glsl/include/layout.glsl`: `Globals` (device addresses of all buffers and the solve's
//! scalars, written once). Push constants are per kernel (`super::kernels`).

use bytemuck::{Pod, Zeroable};

/// Device addresses and scalars (the GLSL `GlobalsRef` block).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Globals {
    pub tris: u64,
    pub uvs: u64,
    pub bvh: u64,
    pub cw_nodes: u64,
    pub cw_prims: u64,
    pub materials: u64,
    pub textures: u64,
    pub texels: u64,
    pub srgb: u64,
    pub lights: u64,
    pub objects: u64,
    pub nodes: u64,
    pub splits: u64,
    pub clips: u64,
    /// Per triangle: bit 0, its front got nodes; bit 1, its back (`Hierarchy::sides`).
    pub sides: u64,
    pub parent_offset: u64,
    pub parents: u64,
    pub child_offset: u64,
    pub children: u64,
    pub halton: u64,
    pub direct: u64,
    pub unshot: u64,
    pub next: u64,
    pub indirect: u64,
    pub pred: u64,
    pub gathered_mean: u64,
    pub gathered_err: u64,
    pub active_flag: u64,
    pub child_flag: u64,
    pub active_list: u64,
    /// The next level's active nodes that hold links, where `compact` splits the set.
    pub linked_list: u64,
    pub counters: u64,
    pub rays: u64,
    pub hits: u64,
    pub contrib: u64,
    pub energy: u64,
    pub dispatch_args: u64,
    /// Per node: its link slot (`NONE`, or the slot, with `LINK_RECORDING` while recording).
    pub link_slot: u64,
    /// The links: per slot, `rays` records (sender node or `NONE`, albedo bits).
    pub links: u64,
    /// `LINK_COUNTERS` u32 slots (`crate::constants`).
    pub link_counters: u64,
    pub num_objects: u32,
    pub num_lights: u32,
    pub rays_per_integral: u32,
    pub seed: u32,
    pub scene_scale: f32,
    pub kappa: f32,
    pub alpha: f32,
    pub approx_cos: f32,
    pub eps_rel: f32,
    pub eps_abs: f32,
    pub noise_z: f32,
    pub levels: u32,
    pub sender_level: u32,
    /// Link slots (nodes whose rays can keep links; 0: no links).
    pub link_capacity: u32,
    /// The emitting triangles (`GpuEmitter`) and the base point set of their sampling
    /// (vec4 per sample: 3-D Halton in bases 2, 3, 5).
    pub emitters: u64,
    pub emitter_points: u64,
    /// An environment map: radiance per pixel (vec4), the rows' running sums, the pixels'
    /// running sums per row, each pixel's probability (floats).
    pub sky_texels: u64,
    pub sky_rows: u64,
    pub sky_cols: u64,
    pub sky_prob: u64,
    /// Per node, the relative standard error of its sampled direct light (-1: unlit).
    pub direct_err: u64,
    pub num_emitters: u32,
    /// Samples per point (`emitter_samples`: emitters and sky).
    pub emitter_samples: u32,
    /// `SKY_NONE`, `SKY_CONSTANT` or `SKY_MAP` (`crate::constants`).
    pub sky_kind: u32,
    pub sky_width: u32,
    pub sky_height: u32,
    /// The map's turn about +y, radians.
    pub sky_rotate: f32,
    /// A constant sky's radiance.
    pub sky_r: f32,
    pub sky_g: f32,
    pub sky_b: f32,
    /// `Hierarchy::plane`: reads take nodes within `plane · h` of their tangent plane.
    pub plane: f32,
}

/// A ray as the kernels store it (32 bytes).
pub const RAY_BYTES: u64 = 32;
/// A hit record (16 bytes).
pub const HIT_BYTES: u64 = 16;
/// A Monte Carlo sample (vec4, 16 bytes).
pub const CONTRIB_BYTES: u64 = 16;
/// A link on the device (sender, albedo: 16 bytes).
pub const LINK_RECORD_BYTES: u64 = 16;

const _: () = {
    assert!(std::mem::size_of::<Globals>() == 40 * 8 + 14 * 4 + 7 * 8 + 10 * 4);
    assert!(std::mem::offset_of!(Globals, emitters) == 376);
    assert!(std::mem::offset_of!(Globals, num_objects) == 320);
    assert!(std::mem::offset_of!(Globals, sender_level) == 368);
};
