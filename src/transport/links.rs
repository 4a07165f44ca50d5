//! Links: each gathering ray traced once per solve (`ALGORITHM.md` §5.6).
//!
//! A node's integral casts the same rays in every bounce: the directions are the Halton
//! points rotated by an angle that depends on the seed and the node alone (§5.2), so the
//! hits are the same. Under the approximate reconstruction the node a hit reads is the
//! same too: the first kd-tree leaf that passes the normal and clip tests depends on the
//! geometry, not on the values (`reconstruct::approx_node`). So the first time a node is
//! gathered with the sender read, each of its rays keeps a link, the sender node and the
//! albedo at the hit (or, where all the node's hits are on untextured materials, the
//! material, whose `kd` is that albedo: half the bytes), and every later gather of that
//! node is `(1/N) Σ ρ_r U[sender_r]`
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

use super::estimator::{Estimator, Gathered};

/// A link's sender when the ray escaped or its hit reconstructs to no value.
pub const NO_SENDER: u32 = u32::MAX;

/// `Link::material` of a hit whose albedo varies over its triangle (a texture).
pub const TEXTURED: u32 = u32::MAX;

/// One gathering ray's hit as the later bounces read it, as the traced integral records
/// it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Link {
    /// Global index of the node the hit reads (`NO_SENDER`: adds nothing).
    pub sender: u32,
    /// Albedo at the hit.
    pub albedo: Vec3,
    /// The hit triangle's material where the albedo is that material's `kd` everywhere on
    /// it (no texture), else `TEXTURED`.
    pub material: u32,
}

impl Link {
    /// A ray that adds nothing.
    pub const NONE: Link = Link {
        sender: NO_SENDER,
        albedo: Vec3::ZERO,
        material: TEXTURED,
    };
}

/// A kept link whose albedo is its material's `kd` (8 bytes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlainLink {
    pub sender: u32,
    pub material: u32,
}

/// A kept link with its albedo (16 bytes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FullLink {
    pub sender: u32,
    pub albedo: Vec3,
}

/// Bytes one kept link takes at most (a [`FullLink`]): what room is planned by. A node
/// whose every hit is on an untextured material keeps [`PlainLink`]s, half that.
pub const LINK_BYTES: u64 = std::mem::size_of::<FullLink>() as u64;

/// A node's kept links ([`Kept::of`]).
enum Held {
    Plain(Box<[PlainLink]>),
    Full(Box<[FullLink]>),
}

/// A traced integral's links as a node keeps them: without the albedos where every hit
/// that reads a sender is on an untextured material (its `kd` is the albedo). Made where
/// the integral was traced (in parallel), then [`Links::store`]d.
pub struct Kept(Held);

impl Kept {
    pub fn of(links: &[Link]) -> Kept {
        let plain = links.iter().all(|l| l.sender == NO_SENDER || l.material != TEXTURED);
        Kept(if plain {
            Held::Plain(
                links
                    .iter()
                    .map(|l| PlainLink {
                        sender: l.sender,
                        material: l.material,
                    })
                    .collect(),
            )
        } else {
            Held::Full(
                links
                    .iter()
                    .map(|l| FullLink {
                        sender: l.sender,
                        albedo: l.albedo,
                    })
                    .collect(),
            )
        })
    }
}

impl Held {
    fn bytes(&self) -> u64 {
        match self {
            Held::Plain(l) => std::mem::size_of_val(&**l) as u64,
            Held::Full(l) => std::mem::size_of_val(&**l) as u64,
        }
    }
}

/// A node's links, as [`gather`] reads them.
#[derive(Clone, Copy)]
pub enum NodeLinks<'a> {
    Plain(&'a [PlainLink]),
    Full(&'a [FullLink]),
}

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
    /// The rays those integrals stand for (level 1's integrals have `level1_rays` times
    /// the others').
    pub rays_linked: u64,
    /// Integrals traced (each records links, if it has none, while there is room): the
    /// first bounce's under `exact_first_bounce`, and the later bounces' nodes without links.
    pub integrals_traced: u64,
    /// Of those, integrals traced because the links were full.
    pub integrals_traced_full: u64,
}

/// The links of a solve, per node.
pub struct Links {
    /// Rays of an integral (`rays`), and how many times that level 1's take.
    rays: usize,
    level1: usize,
    per_node: Vec<Option<Held>>,
    /// Room in slots of `rays` links: a node takes as many slots as its integral's rays
    /// fill (level 1's nodes `level1_rays`).
    max_slots: u64,
    slots: u64,
    /// Nodes holding links (across solves that keep them), and those links' bytes.
    held: u64,
    held_bytes: u64,
    pub stats: LinkStats,
}

impl Links {
    /// Room for `capacity_bytes` of links of `rays` rays each (level 1's `level1` times
    /// that), over `nodes` nodes.
    pub fn new(nodes: usize, rays: usize, level1: usize, capacity_bytes: u64) -> Self {
        let per = (rays as u64 * LINK_BYTES).max(1);
        Links {
            rays,
            level1,
            per_node: (0..nodes).map(|_| None).collect(),
            max_slots: capacity_bytes / per,
            slots: 0,
            held: 0,
            held_bytes: 0,
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
        self.slots = 0;
        self.held_bytes = 0;
        self.new_solve();
    }

    /// Keeps the links for a solve of the same geometry, hierarchy and rays (a relighting
    /// frame of an editing session: the hits and their sender nodes are the same), and
    /// starts that solve's counts.
    pub fn new_solve(&mut self) {
        self.stats = LinkStats {
            capacity_bytes: self.stats.capacity_bytes,
            nodes: self.held,
            bytes: self.held_bytes,
            ..Default::default()
        };
    }

    /// Whether these links fit a solve with `nodes` nodes and `rays` rays (and room for
    /// `capacity_bytes`).
    pub fn fits(&self, nodes: usize, rays: usize, level1: usize, capacity_bytes: u64) -> bool {
        self.per_node.len() == nodes
            && self.rays == rays
            && self.level1 == level1
            && self.stats.capacity_bytes == capacity_bytes
    }

    /// The links of node `j`, if it has them.
    #[inline]
    pub fn of(&self, j: usize) -> Option<NodeLinks<'_>> {
        self.per_node[j].as_ref().map(|h| match h {
            Held::Plain(l) => NodeLinks::Plain(l),
            Held::Full(l) => NodeLinks::Full(l),
        })
    }

    /// For each node of `list` in order: whether it records links when traced (it has
    /// none yet and there is room). Counts what the gather will do. An `exact` gather (the
    /// first bounce under `exact_first_bounce`) reads no link: it traces every integral.
    /// Each integral of `list` has `slots` times `rays` rays.
    pub fn plan(&mut self, list: &[u32], exact: bool, slots: u64) -> Vec<bool> {
        list.iter()
            .map(|&j| {
                let has = self.per_node[j as usize].is_some();
                if has && !exact {
                    self.stats.integrals_linked += 1;
                    self.stats.rays_linked += slots * self.rays as u64;
                    return false;
                }
                self.stats.integrals_traced += 1;
                if has {
                    false
                } else if self.slots + slots <= self.max_slots {
                    self.slots += slots;
                    self.held += 1;
                    self.stats.nodes = self.held;
                    true
                } else {
                    self.stats.integrals_traced_full += 1;
                    false
                }
            })
            .collect()
    }

    /// Keeps the links recorded for node `j`.
    pub fn store(&mut self, j: usize, kept: Kept) {
        let held = kept.0;
        let n = match &held {
            Held::Plain(l) => l.len(),
            Held::Full(l) => l.len(),
        };
        debug_assert!(n == self.rays || n == self.rays * self.level1, "{n} links");
        self.held_bytes += held.bytes();
        if let Some(old) = self.per_node[j].replace(held) {
            self.held_bytes -= old.bytes();
        }
        self.stats.bytes = self.held_bytes;
    }
}

/// A gathering integral over recorded links: `(1/N) Σ ρ_r U[sender_r]`, the same sum
/// `cpu::gather_integral` makes by tracing (a plain link's albedo is its material's
/// `kd`, [`Scene::kd`](crate::scene::Scene::kd), the value the traced hit read).
#[inline]
pub fn gather(links: NodeLinks, unshot: &[Vec4], scene: &crate::scene::Scene) -> Gathered {
    let mut est = Estimator::default();
    let n = match links {
        NodeLinks::Plain(ls) => {
            for l in ls {
                if l.sender != NO_SENDER {
                    est.add(scene.kd(l.material) * unshot[l.sender as usize].xyz());
                }
            }
            ls.len()
        }
        NodeLinks::Full(ls) => {
            for l in ls {
                if l.sender != NO_SENDER {
                    est.add(l.albedo * unshot[l.sender as usize].xyz());
                }
            }
            ls.len()
        }
    };
    est.finish(n)
}
