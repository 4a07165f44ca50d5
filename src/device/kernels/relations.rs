//! Kernel `relations` (`glsl/relations.comp`): the parent and child relations built on
//! the device, in the host's CSR layout, one mode per dispatch (mark the children of
//! changed clips, count, fill, and the inverse relation). It runs before a solve
//! ([`crate::device::arrange`]), not in the bounce loop's schedule.

use bytemuck::{Pod, Zeroable};

use super::{kernel, per_element, Recorder};

/// A node whose clip changed marks the children within its support.
pub const MARK: u32 = 0;
/// Per child: whether its list is computed again, and its length.
pub const COUNT: u32 = 1;
/// The parent lists.
pub const FILL: u32 = 2;
/// Children per parent.
pub const CHILD_COUNT: u32 = 3;
/// The children lists, in the order they finish.
pub const CHILD_FILL: u32 = 4;
/// Each parent's children sorted ascending.
pub const CHILD_SORT: u32 = 5;

/// The push constants of `relations` (GLSL `RelationsPush`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct RelationsPush {
    pub globals: u64,
    /// Address of the parent offsets being replaced (read unless `all`).
    pub old_offset: u64,
    /// Address of the parent lists being replaced.
    pub old_parents: u64,
    /// Address of the new parent offsets (`n + 1` words).
    pub new_offset: u64,
    /// Address of the new parent lists.
    pub new_parents: u64,
    /// Address of the child offsets (`n + 1` words).
    pub child_offset: u64,
    /// Address of the children lists.
    pub children: u64,
    /// Address of one word per node: its list is computed again.
    pub dirty: u64,
    /// Address of one word per node: its clip changed.
    pub changed: u64,
    /// Address of one word per node: children placed so far.
    pub cursor: u64,
    /// Address of `2 MAX_LEVELS + 1` words: holes per level, orphans per level, lists
    /// computed.
    pub stats: u64,
    /// Nodes.
    pub count: u32,
    /// One of [`MARK`] .. [`CHILD_SORT`].
    pub mode: u32,
    /// 1: every list is computed again.
    pub all: u32,
    /// Padding.
    pub pad0: u32,
}

kernel!(Relations, "relations", RELATIONS, RelationsPush);

impl Relations {
    /// Records one mode over every node (`push.count`).
    pub fn record(&self, rec: &mut Recorder, push: &RelationsPush, mode: u32) {
        let push = RelationsPush {
            globals: rec.globals,
            mode,
            ..*push
        };
        rec.dispatch(&self.0, &push, per_element(push.count as u64));
    }
}
