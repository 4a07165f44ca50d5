//! Reconstruction of a field stored on the hierarchy at a surface point (`ALGORITHM.md`
//! §5): exact Shepard on one level (modified), the sum of deltas over levels (original),
//! and the first kd-tree leaf with normal rejection (approximate, paper §5.1).
//! GLSL twins in `glsl/include/hierarchy.glsl`.

use glam::{Vec3, Vec4, Vec4Swizzles};

use crate::hierarchy::weight::clip_ok;
use crate::hierarchy::{kdtree, Hierarchy};
use crate::params::Variant;

/// `Σ_j w_j(p) v_j` and `Σ_j w_j(p)` over level `l` of object `o`.
#[inline]
pub fn shepard_sums(h: &Hierarchy, o: usize, l: usize, p: Vec3, n: Vec3, values: &[Vec4]) -> (Vec3, f32) {
    let mut sum = Vec3::ZERO;
    let mut wsum = 0.0;
    h.for_each_read_weight(o, l, p, n, |j, w| {
        sum += values[j].xyz() * w;
        wsum += w;
    });
    (sum, wsum)
}

/// Exact Shepard value on level `l`, falling back to the nearest coarser level that covers
/// `p` (a hole); `None` when no level does.
#[inline]
pub fn exact(h: &Hierarchy, o: usize, l: usize, p: Vec3, n: Vec3, values: &[Vec4]) -> Option<Vec3> {
    (0..=l).rev().find_map(|k| {
        let (s, w) = shepard_sums(h, o, k, p, n, values);
        (w > 0.0).then(|| s / w)
    })
}

/// The original hierarchy: `F_l(p) = Σ_{k ≤ l} Σ_j α_j^k B_j^k(p)`; a level with a hole
/// at `p` adds nothing.
#[inline]
pub fn delta_sum(h: &Hierarchy, o: usize, l: usize, p: Vec3, n: Vec3, values: &[Vec4]) -> Vec3 {
    (0..=l).fold(Vec3::ZERO, |acc, k| {
        let (s, w) = shepard_sums(h, o, k, p, n, values);
        if w > 0.0 {
            acc + s / w
        } else {
            acc
        }
    })
}

/// Approximate: the global index of the first kd-tree leaf near `p` with an agreeing
/// normal that passes its clip, falling back to coarser levels. It depends on the geometry
/// alone, not on the values, so a gathering ray's sender node is the same in every bounce
/// (`transport::links`).
#[inline]
pub fn approx_node(h: &Hierarchy, o: usize, l: usize, p: Vec3, n: Vec3, cos_min: f32) -> Option<usize> {
    (0..=l).rev().find_map(|k| {
        let (nodes, splits, base) = h.level(o, k);
        let hk = h.support(o, k);
        let ok = |i: usize| {
            let nd = &nodes[i];
            let nj = Vec3::from(nd.normal);
            let v = p - Vec3::from(nd.pos);
            n.dot(nj) > cos_min && h.on_sheet(v, nj, hk) && clip_ok(&h.clips[base + i], v, nj, hk)
        };
        kdtree::first_leaf(nodes, splits, p, hk, ok).map(|i| base + i)
    })
}

/// Approximate: the value of the first kd-tree leaf near `p` with an agreeing normal,
/// falling back to coarser levels.
#[inline]
pub fn approx(h: &Hierarchy, o: usize, l: usize, p: Vec3, n: Vec3, values: &[Vec4], cos_min: f32) -> Option<Vec3> {
    approx_node(h, o, l, p, n, cos_min).map(|j| values[j].xyz())
}

/// How the transport reads un-shot energy at hit points: the variant's reconstruction
/// on sender level `level`.
#[derive(Clone, Copy, Debug)]
pub struct Sender {
    pub variant: Variant,
    pub level: usize,
    pub cos_min: f32,
}

impl Sender {
    /// From the solver parameters.
    pub fn of(p: &crate::params::SolverParams) -> Self {
        Sender {
            variant: p.variant,
            level: p.sender_level as usize,
            cos_min: p.approx_cos,
        }
    }

    /// The value at a hit: nothing on a triangle side without nodes
    /// (`Hierarchy::side_has_nodes`), else [`Sender::read`] at its object-space point.
    #[inline]
    pub fn read_hit(&self, h: &Hierarchy, s: &crate::scene::LocalSurface, values: &[Vec4]) -> Vec3 {
        if h.side_has_nodes(s.tri, s.back) {
            self.read(h, s.object as usize, s.p_obj, s.n_obj, values)
        } else {
            Vec3::ZERO
        }
    }

    /// The value at an object-space point of object `o`.
    #[inline]
    pub fn read(&self, h: &Hierarchy, o: usize, p: Vec3, n: Vec3, values: &[Vec4]) -> Vec3 {
        match self.variant {
            Variant::Original => delta_sum(h, o, self.level, p, n, values),
            Variant::Modified => exact(h, o, self.level, p, n, values).unwrap_or(Vec3::ZERO),
            Variant::Approx => approx(h, o, self.level, p, n, values, self.cos_min).unwrap_or(Vec3::ZERO),
        }
    }
}

/// The value of a solved field at an object-space surface point, read from level `l`
/// with exact reconstruction (outputs: images and probes). The delta hierarchy can ring
/// below zero next to a discontinuity (e.g. a surface in a thin unlit gap): the raw value
/// is returned and the caller clamps and counts.
#[inline]
pub fn output(h: &Hierarchy, delta: bool, o: usize, l: usize, p: Vec3, n: Vec3, values: &[Vec4]) -> Vec3 {
    if delta {
        delta_sum(h, o, l, p, n, values)
    } else {
        exact(h, o, l, p, n, values).unwrap_or(Vec3::ZERO)
    }
}
