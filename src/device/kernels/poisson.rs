//! Kernel `poisson` (`glsl/poisson.comp`): one Poisson-disk level of one object by dart
//! throwing on the device (`ALGORITHM.md` §3.2): a hashed grid of the candidates
//! ([`COUNT`], kernel `scan`, [`SCATTER`]), then rounds of [`RESOLVE`] until every
//! candidate is in or out. It runs before the hierarchy is assembled
//! ([`crate::device::poisson`]), not in the bounce loop's schedule.

use bytemuck::{Pod, Zeroable};

use super::{kernel, per_element, Recorder};

/// Stage: count each bucket's candidates.
pub const COUNT: u32 = 0;
/// Stage: list the candidates by bucket (after the counts were scanned into offsets).
pub const SCATTER: u32 = 1;
/// Stage: one round of decisions.
pub const RESOLVE: u32 = 2;

/// A candidate's state after the rounds (GLSL `IN`).
pub const IN: u32 = 1;

/// The push constants of `poisson` (GLSL `PoissonPush`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct PoissonPush {
    pub globals: u64,
    /// Address of the object's pool: per candidate, position and normal (6 floats).
    pub cands: u64,
    /// Address of one word per candidate of the level: undecided, in or out.
    pub state: u64,
    /// Address of one word per candidate of the pool: its crevice test (0: not run).
    pub memo: u64,
    /// Address of one word per bucket and one more: counts, then offsets.
    pub table: u64,
    /// Address of one word per bucket: candidates listed so far.
    pub fill: u64,
    /// Address of the candidates by bucket (two `vec4` per candidate of the level:
    /// position and index bits, normal).
    pub sorted: u64,
    /// Address of the counters: crevices found, then one per round of a submission.
    pub counters: u64,
    /// Candidates of the level.
    pub count: u32,
    /// Buckets - 1 (a power of two less one).
    pub mask: u32,
    /// The level's radius, object space.
    pub r: f32,
    /// `r * r`.
    pub r2: f32,
    /// `0.5 / r`: cells `2r` wide.
    pub inv_cell: f32,
    /// The crevice test's distance (world units, object units with `within`; 0: none).
    pub d_min: f32,
    /// The object's diagonal (with `within`).
    pub diag: f32,
    pub object: u32,
    /// 1: the crevice test within the object (`reach = "object"`).
    pub within: u32,
    /// [`COUNT`], [`SCATTER`] or [`RESOLVE`].
    pub stage: u32,
    /// The round within the submission (its counter).
    pub round: u32,
    /// Padding.
    pub pad0: u32,
}

kernel!(Poisson, "poisson", POISSON, PoissonPush);

impl Poisson {
    /// Records `stage` over the level's candidates.
    pub fn record(&self, rec: &mut Recorder, push: &PoissonPush, stage: u32) {
        let push = PoissonPush {
            globals: rec.globals,
            stage,
            ..*push
        };
        rec.dispatch(&self.0, &push, per_element(push.count as u64));
    }
}
