//! Kernel `compact` (`glsl/compact.comp`): the next level's active set, appended through the
//! activated-count counter of the level above.

use std::ops::Range;

use bytemuck::{Pod, Zeroable};

use super::{kernel, per_element, Recorder};

/// The push constants of `compact` (GLSL `CompactPush`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct CompactPush {
    pub globals: u64,
    /// First node (global index) of the range.
    pub first: u32,
    /// Nodes in the range.
    pub count: u32,
    /// The level whose refined nodes activated these.
    pub parent_level: u32,
    /// 1: the nodes that hold links go to the linked list (a bounce whose gathers read
    /// links: not the exact first bounce).
    pub split: u32,
}

kernel!(Compact, "compact", COMPACT, CompactPush);

impl Compact {
    /// Records the kernel over the nodes `nodes` (of level `parent_level + 1`); with
    /// `split`, those that hold links go to the linked list.
    pub fn record(&self, rec: &mut Recorder, nodes: Range<usize>, parent_level: u32, split: bool) {
        let push = CompactPush {
            globals: rec.globals,
            first: nodes.start as u32,
            count: nodes.len() as u32,
            parent_level,
            split: split as u32,
        };
        rec.dispatch(&self.0, &push, per_element(nodes.len() as u64));
    }
}
