//! Kernel `delta` (`glsl/delta.comp`): the delta hierarchy's prediction at level l ≥ 1, or its
//! initial coefficients (paper §3, §4.2); built only for the delta hierarchy.

use std::ops::Range;

use bytemuck::{Pod, Zeroable};

use super::{kernel, per_element, Recorder};

/// The push constants of `delta` (GLSL `DeltaPush`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct DeltaPush {
    pub globals: u64,
    /// First node (global index) of the range.
    pub first: u32,
    /// Nodes in the range.
    pub count: u32,
    /// The level of the range.
    pub level: u32,
    /// 1: the delta coefficients of `E_d` into `unshot`; 0: the prediction into `pred`.
    pub init: u32,
}

kernel!(Delta, "delta", DELTA, DeltaPush);

impl Delta {
    /// Records the kernel over the nodes `nodes` of `level`: with `init`, the coefficients of `E_d`, else the prediction.
    pub fn record(&self, rec: &mut Recorder, nodes: Range<usize>, level: u32, init: bool) {
        let push = DeltaPush {
            globals: rec.globals,
            first: nodes.start as u32,
            count: nodes.len() as u32,
            level,
            init: init as u32,
        };
        rec.dispatch(&self.0, &push, per_element(nodes.len() as u64));
    }
}
