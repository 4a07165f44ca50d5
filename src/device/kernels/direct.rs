//! Kernel `direct` (`glsl/direct.comp`): exact direct irradiance at a range of nodes by shadow
//! rays (`ALGORITHM.md` §2), counting per light the nodes it lights.

use std::ops::Range;

use bytemuck::{Pod, Zeroable};

use super::{kernel, per_element, Recorder};

/// The push constants of `direct` (GLSL `DirectPush`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct DirectPush {
    pub globals: u64,
    /// First node (global index) of the range.
    pub first: u32,
    /// Nodes in the range.
    pub count: u32,
}

kernel!(Direct, "direct", DIRECT, DirectPush);

impl Direct {
    /// Records the kernel over the nodes `nodes`.
    pub fn record(&self, rec: &mut Recorder, nodes: Range<usize>) {
        let push = DirectPush {
            globals: rec.globals,
            first: nodes.start as u32,
            count: nodes.len() as u32,
        };
        rec.dispatch(&self.0, &push, per_element(nodes.len() as u64));
    }
}
