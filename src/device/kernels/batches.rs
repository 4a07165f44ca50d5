//! Kernel `batches` (`glsl/batches.comp`): the indirect grids of the batches of a level
//! whose active count the device just computed. Layout of the arguments: `DISPATCH_*` in
//! `crate::constants`.

use bytemuck::{Pod, Zeroable};

use super::{kernel, per_element, Recorder};

/// The push constants of `batches` (GLSL `BatchesPush`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct BatchesPush {
    pub globals: u64,
    /// Batches the level could need (its size over `batch_size`, rounded up).
    pub batches: u32,
    /// Integrals per batch.
    pub batch_size: u32,
    /// The counter slot holding the level's active count.
    pub count_slot: u32,
    /// The device's largest x grid; wider grids fold into y.
    pub max_groups_x: u32,
    /// Where this list's grids start in the argument buffer, in batches.
    pub first_batch: u32,
    /// Padding.
    pub pad0: u32,
}

kernel!(Batches, "batches", BATCHES, BatchesPush);

impl Batches {
    /// Records the grids of `batches` batches of `batch_size` integrals whose total is in
    /// counter `count_slot`, from batch `first_batch` of the argument buffer.
    pub fn record(
        &self,
        rec: &mut Recorder,
        batches: u32,
        batch_size: u32,
        count_slot: u32,
        max_groups_x: u32,
        first_batch: u32,
    ) {
        let push = BatchesPush {
            globals: rec.globals,
            batches,
            batch_size,
            count_slot,
            max_groups_x,
            first_batch,
            pad0: 0,
        };
        rec.dispatch(&self.0, &push, per_element(batches as u64));
    }
}
