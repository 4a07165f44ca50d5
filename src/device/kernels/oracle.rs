//! Kernel `oracle` (`glsl/oracle.comp`): new values of a level and the refinement decision
//! (`ALGORITHM.md` §5), counting refined nodes.

use std::ops::Range;

use bytemuck::{Pod, Zeroable};

use super::{kernel, per_element, Recorder};

/// The push constants of `oracle` (GLSL `OraclePush`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct OraclePush {
    pub globals: u64,
    /// First node (global index) of the range.
    pub first: u32,
    /// Nodes in the range.
    pub count: u32,
    /// The level of the range.
    pub level: u32,
    /// 1: mark the children of refined nodes for `compact`.
    pub activate: u32,
    /// With `activate`: the children with at most this many parents of lit nodes that are
    /// not refined are marked too (`sparse_parents` in the bounces it applies to; 0: off).
    pub sparse_parents: u32,
    pub pad: u32,
}

kernel!(Oracle, "oracle", ORACLE, OraclePush);

impl Oracle {
    /// Records the kernel over the nodes `nodes` of `level`; with `activate`, the children
    /// of refined nodes are marked, and the sparse children of lit ones (`sparse_parents`).
    pub fn record(&self, rec: &mut Recorder, nodes: Range<usize>, level: u32, activate: bool, sparse_parents: u32) {
        let push = OraclePush {
            globals: rec.globals,
            first: nodes.start as u32,
            count: nodes.len() as u32,
            level,
            activate: activate as u32,
            sparse_parents,
            pad: 0,
        };
        rec.dispatch(&self.0, &push, per_element(nodes.len() as u64));
    }
}
