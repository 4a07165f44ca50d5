//! The push constants of one gathering batch, shared by its four kernels (`hemisphere`,
//! `trace`, `reconstruct`, `reduce`; GLSL `GatherPush` in `glsl/include/gather.glsl`),
//! and how their grids are sized.

use bytemuck::{Pod, Zeroable};

use super::{per_element, Recorder};
use crate::constants::{DISPATCH_RAYS, DISPATCH_REDUCE};
use crate::gpu::buffer::Buffer;
use crate::gpu::pipeline::Kernel;

/// The push constants of a gathering batch (GLSL `GatherPush`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GatherPush {
    pub globals: u64,
    /// First node (global index) of the level.
    pub first: u32,
    /// Integrals in this batch (for a device-sized batch: at most).
    pub count: u32,
    /// First integral of this batch within the level's integrals.
    pub batch_first: u32,
    /// 1: integral i is node `active_list[batch_first + i]`; 2: node
    /// `linked_list[batch_first + i]`; 0: node `first + batch_first + i`.
    pub from_list: u32,
    /// `NONE`, or the counter slot holding the level's active count (device-sized batches).
    pub count_slot: u32,
    /// 1: the reconstruct kernel reads the exact direct irradiance at each hit (shadow
    /// rays) instead of the sender level (the first bounce under `exact_first_bounce`).
    pub exact_direct: u32,
    /// Rays per integral of this batch: `rays_per_integral`, times `level1_rays` on
    /// level 1 (a multiple of it: the integral takes that many link slots).
    pub rays: u32,
    pub pad0: u32,
}

/// Who sizes a batch's grids.
#[derive(Clone, Copy)]
pub enum Grid<'a> {
    /// The host: `count` integrals of `rays` rays.
    Host,
    /// The device: the batch's words of the dispatch-argument buffer, from byte `at`
    /// (written by `batches`).
    Device { args: &'a Buffer, at: u64 },
}

/// One gathering batch: its push constants (rays per integral among them) and grid.
#[derive(Clone, Copy)]
pub struct Batch<'a> {
    pub push: GatherPush,
    pub grid: Grid<'a>,
}

/// Records `kernel` with one thread per ray of the batch.
pub(super) fn per_ray(rec: &mut Recorder, kernel: &Kernel, b: &Batch) {
    match b.grid {
        Grid::Host => rec.dispatch(kernel, &b.push, per_element(b.push.count as u64 * b.push.rays as u64)),
        Grid::Device { args, at } => rec.dispatch_indirect(kernel, &b.push, args, at + 4 * DISPATCH_RAYS as u64),
    }
}

/// Records `kernel` with one workgroup per integral of the batch.
pub(super) fn per_integral(rec: &mut Recorder, kernel: &Kernel, b: &Batch) {
    match b.grid {
        Grid::Host => rec.dispatch(kernel, &b.push, b.push.count as u64),
        Grid::Device { args, at } => rec.dispatch_indirect(kernel, &b.push, args, at + 4 * DISPATCH_REDUCE as u64),
    }
}
