//! Kernel `energy` (`glsl/energy.comp`): sums over the level-0 nodes in one workgroup, in
//! a fixed order: the stop criterion's energies, or the mean direct irradiance per channel
//! (the oracle's ε_abs scale). Slots: `ENERGY_*` in `crate::constants`.

use std::ops::Range;

use bytemuck::{Pod, Zeroable};

use super::{kernel, Recorder};

/// The push constants of `energy` (GLSL `EnergyPush`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct EnergyPush {
    pub globals: u64,
    /// First level-0 node.
    pub first: u32,
    /// Level-0 nodes.
    pub count: u32,
    /// 1: mean direct irradiance per channel; 0: the stop criterion's sums.
    pub mean_direct: u32,
    /// Padding.
    pub pad0: u32,
}

kernel!(Energy, "energy", ENERGY, EnergyPush);

impl Energy {
    /// Records the sums over the level-0 nodes `level0`: with `mean_direct`, the mean
    /// direct irradiance per channel, else Σ mean(un-shot) and Σ mean(direct).
    pub fn record(&self, rec: &mut Recorder, level0: Range<usize>, mean_direct: bool) {
        let push = EnergyPush {
            globals: rec.globals,
            first: level0.start as u32,
            count: level0.len() as u32,
            mean_direct: mean_direct as u32,
            pad0: 0,
        };
        rec.dispatch(&self.0, &push, 1);
    }
}
