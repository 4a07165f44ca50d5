//! Kernel `clips` (`glsl/clips.comp`): the support clips an arrangement computes, on the
//! device (`ALGORITHM.md` §3.3): every node's, or after objects moved those of the nodes
//! a [`crate::hierarchy::ClipSelection`] holds; the changed ones come back. It runs
//! before a solve ([`crate::device::arrange`]), not in the bounce loop's schedule.

use bytemuck::{Pod, Zeroable};

use super::{kernel, per_element, Recorder};

/// `ClipsPush::boxes` when every node is selected.
pub const ALL: u32 = u32::MAX;

/// The push constants of `clips` (GLSL `ClipsPush`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct ClipsPush {
    pub globals: u64,
    /// Address of the moved objects' world boxes (2 `vec4` each: lo, hi).
    pub box_list: u64,
    /// Address of one word per object: 1 if it moved.
    pub moved: u64,
    /// Address of the indices of the nodes whose clip changed (in the order they finish).
    pub out_nodes: u64,
    /// Address of their new clips (16 bytes each).
    pub out_clips: u64,
    /// Address of two words: the nodes selected, the clips that changed.
    pub out_count: u64,
    /// Address of one word per node: 1 if its clip changed.
    pub changed: u64,
    /// Nodes.
    pub count: u32,
    /// Boxes in `box_list`, or [`ALL`].
    pub boxes: u32,
    /// Margin of the box test, world units.
    pub eps: f32,
    /// Padding.
    pub pad0: u32,
}

kernel!(Clips, "clips", CLIPS, ClipsPush);

impl Clips {
    /// Records the kernel over every node (`push.count`).
    pub fn record(&self, rec: &mut Recorder, push: &ClipsPush) {
        let push = ClipsPush {
            globals: rec.globals,
            ..*push
        };
        rec.dispatch(&self.0, &push, per_element(push.count as u64));
    }
}
