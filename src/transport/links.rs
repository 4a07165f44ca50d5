//! Links: each gathering ray traced once per solve (`ALGORITHM.md` §5.6).
//!
//! A node's integral casts the same rays in every bounce: the directions are the Halton
//! points rotated by an angle that depends on the seed and the node alone (§5.2), so the
//! hits are the same. Under the approximate reconstruction the node a hit reads is the
//! same too: the first kd-tree leaf that passes the normal and clip tests depends on the
//! geometry, not on the values (`reconstruct::approx_node`). So the first time a node is
//! gathered with the sender read, each of its rays keeps a link, the sender node and the
//! albedo at the hit, and every later gather of that node is `(1/N) Σ ρ_r U[sender_r]`
//! over its links: no ray, no search, and bit for bit the sum the traced integral makes
//! (the same products added in the same order; a miss or a hit without a value adds
//! nothing either way).
//!
//! The links' memory is bounded (`link_memory`, and what the run's memory limit leaves
//! after the planned parts);
//! nodes that find it full are traced in every bounce, as without links. The first bounce
//! under `exact_first_bounce` reads `E_d` by shadow rays at the hits, and its rays are the
//! later bounces' rays: it records the links too (the sender search at each hit, without
//! a second trace), so the later bounces trace only the nodes the first did not gather.

use glam::{Vec3, Vec4, Vec4Swizzles};
use serde::Serialize;

use super::cpu::{Estimator, Gathered};

/// A link's sender when the ray escaped or its hit reconstructs to no value.
pub const NO_SENDER: u32 = u32::MAX;

/// One gathering ray's hit as the later bounces read it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Link {
    /// Global index of the node the hit reads (`NO_SENDER`: adds nothing).
    pub sender: u32,
    /// Albedo at the hit.
    pub albedo: Vec3,
}

impl Link {
    /// A ray that adds nothing.
    pub const NONE: Link = Link {
        sender: NO_SENDER,
        albedo: Vec3::ZERO,
    };
}

/// Bytes one link takes.
pub const LINK_BYTES: u64 = std::mem::size_of::<Link>() as u64;

/// What the links did in a solve (`stats.json`, `solve.links`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct LinkStats {
    /// The most bytes the links may take.
    pub capacity_bytes: u64,
    /// Bytes they hold after the solve.
    pub bytes: u64,
    /// Nodes whose rays are linked.
    pub nodes: u64,
    /// Integrals read from links (no ray traced).
    pub integrals_linked: u64,
    /// Integrals traced (each records links, if it has none, while there is room): the
    /// first bounce's under `exact_first_bounce`, and the later bounces' nodes without links.
    pub integrals_traced: u64,
    /// Of those, integrals traced because the links were full.
    pub integrals_traced_full: u64,
}

/// The links of a solve, per node.
pub struct Links {
    rays: usize,
    per_node: Vec<Option<Box<[Link]>>>,
    max_nodes: u64,
    /// Nodes holding links (across solves that keep them).
    held: u64,
    pub stats: LinkStats,
}

impl Links {
    /// Room for `capacity_bytes` of links of `rays` rays each, over `nodes` nodes.
    pub fn new(nodes: usize, rays: usize, capacity_bytes: u64) -> Self {
        let per = (rays as u64 * LINK_BYTES).max(1);
        Links {
            rays,
            per_node: (0..nodes).map(|_| None).collect(),
            max_nodes: capacity_bytes / per,
            held: 0,
            stats: LinkStats {
                capacity_bytes,
                ..Default::default()
            },
        }
    }

    /// Drops every link and count (a new solve).
    pub fn clear(&mut self) {
        self.per_node.iter_mut().for_each(|l| *l = None);
        self.held = 0;
        self.new_solve();
    }

    /// Keeps the links for a solve of the same geometry, hierarchy and rays (a relighting
    /// frame of an editing session: the hits and their sender nodes are the same), and
    /// starts that solve's counts.
    pub fn new_solve(&mut self) {
        self.stats = LinkStats {
            capacity_bytes: self.stats.capacity_bytes,
            nodes: self.held,
            bytes: self.held * self.rays as u64 * LINK_BYTES,
            ..Default::default()
        };
    }

    /// Whether these links fit a solve with `nodes` nodes and `rays` rays (and room for
    /// `capacity_bytes`).
    pub fn fits(&self, nodes: usize, rays: usize, capacity_bytes: u64) -> bool {
        self.per_node.len() == nodes && self.rays == rays && self.stats.capacity_bytes == capacity_bytes
    }

    /// The links of node `j`, if it has them.
    #[inline]
    pub fn of(&self, j: usize) -> Option<&[Link]> {
        self.per_node[j].as_deref()
    }

    /// For each node of `list` in order: whether it records links when traced (it has
    /// none yet and there is room). Counts what the gather will do. An `exact` gather (the
    /// first bounce under `exact_first_bounce`) reads no link: it traces every integral.
    pub fn plan(&mut self, list: &[u32], exact: bool) -> Vec<bool> {
        list.iter()
            .map(|&j| {
                let has = self.per_node[j as usize].is_some();
                if has && !exact {
                    self.stats.integrals_linked += 1;
                    return false;
                }
                self.stats.integrals_traced += 1;
                if has {
                    false
                } else if self.held < self.max_nodes {
                    self.held += 1;
                    self.stats.nodes = self.held;
                    self.stats.bytes = self.held * self.rays as u64 * LINK_BYTES;
                    true
                } else {
                    self.stats.integrals_traced_full += 1;
                    false
                }
            })
            .collect()
    }

    /// Keeps the links recorded for node `j`.
    pub fn store(&mut self, j: usize, links: Box<[Link]>) {
        debug_assert_eq!(links.len(), self.rays);
        self.per_node[j] = Some(links);
    }
}

/// A gathering integral over recorded links: `(1/N) Σ ρ_r U[sender_r]`, the same sum
/// `cpu::gather_integral` makes by tracing.
#[inline]
pub fn gather(links: &[Link], unshot: &[Vec4]) -> Gathered {
    let mut est = Estimator::default();
    for l in links {
        if l.sender != NO_SENDER {
            est.add(l.albedo * unshot[l.sender as usize].xyz());
        }
    }
    est.finish(links.len())
}
