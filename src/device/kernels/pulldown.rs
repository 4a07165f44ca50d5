//! Kernel `pulldown` (`glsl/pulldown.comp`): pull-down from the parents (paper §5, Fig. 4), into
//! the prediction or, for a level without integrals, into its new values; built only for
//! the absolute hierarchy.

use std::ops::Range;

use bytemuck::{Pod, Zeroable};

use super::{kernel, per_element, Recorder};

/// The push constants of `pulldown` (GLSL `PulldownPush`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct PulldownPush {
    pub globals: u64,
    /// First node (global index) of the range.
    pub first: u32,
    /// Nodes in the range.
    pub count: u32,
    /// 1: into `next` (a level without integrals); 0: into `pred` (the prediction).
    pub fill: u32,
    /// Padding.
    pub pad0: u32,
}

kernel!(Pulldown, "pulldown", PULLDOWN, PulldownPush);

impl Pulldown {
    /// Records the kernel over the nodes `nodes`: with `fill`, into `next`, else into `pred`.
    pub fn record(&self, rec: &mut Recorder, nodes: Range<usize>, fill: bool) {
        let push = PulldownPush {
            globals: rec.globals,
            first: nodes.start as u32,
            count: nodes.len() as u32,
            fill: fill as u32,
            pad0: 0,
        };
        rec.dispatch(&self.0, &push, per_element(nodes.len() as u64));
    }
}
