//! Kernel `accumulate` (`glsl/accumulate.comp`): the end of a bounce over a range of nodes:
//! indirect += next, un-shot = next.

use std::ops::Range;

use bytemuck::{Pod, Zeroable};

use super::{kernel, per_element, Recorder};

/// The push constants of `accumulate` (GLSL `AccumulatePush`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct AccumulatePush {
    pub globals: u64,
    /// First node (global index) of the range.
    pub first: u32,
    /// Nodes in the range.
    pub count: u32,
}

kernel!(Accumulate, "accumulate", ACCUMULATE, AccumulatePush);

impl Accumulate {
    /// Records the kernel over the nodes `nodes`.
    pub fn record(&self, rec: &mut Recorder, nodes: Range<usize>) {
        let push = AccumulatePush {
            globals: rec.globals,
            first: nodes.start as u32,
            count: nodes.len() as u32,
        };
        rec.dispatch(&self.0, &push, per_element(nodes.len() as u64));
    }
}
