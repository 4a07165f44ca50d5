//! Reconstruction of a field stored on the hierarchy at a surface point (`ALGORITHM.md`
//! §5): exact Shepard on one level (modified), the sum of deltas over levels (original),
//! and the first kd-tree leaf with normal rejection (approximate, paper §5.1).
//! GLSL twins in `glsl/include/hierarchy.glsl`.

use glam::{DVec3, Vec3, Vec4, Vec4Swizzles};

use crate::geom::sampling::onb;

use crate::hierarchy::weight::clip_ok;
use crate::hierarchy::{kdtree, Hierarchy};
use crate::params::Variant;

/// `Σ_j w_j(p) v_j` and `Σ_j w_j(p)` over level `l` of object `o`.
#[inline]
pub fn shepard_sums(h: &Hierarchy, o: usize, l: usize, p: Vec3, n: Vec3, values: &[Vec4]) -> (Vec3, f32) {
    let mut sum = Vec3::ZERO;
    let mut wsum = 0.0;
    h.for_each_weight(o, l, p, n, |j, w| {
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

/// Approximate: the value of the first kd-tree leaf near `p` with an agreeing normal,
/// falling back to coarser levels.
#[inline]
pub fn approx(h: &Hierarchy, o: usize, l: usize, p: Vec3, n: Vec3, values: &[Vec4], cos_min: f32) -> Option<Vec3> {
    (0..=l).rev().find_map(|k| {
        let (nodes, splits, base) = h.level(o, k);
        let hk = h.support(o, k);
        let ok = |i: usize| {
            let nd = &nodes[i];
            let nj = Vec3::from(nd.normal);
            n.dot(nj) > cos_min && clip_ok(&h.clips[base + i], p - Vec3::from(nd.pos), nj, hk)
        };
        kdtree::first_leaf(nodes, splits, p, hk, ok).map(|i| values[base + i].xyz())
    })
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

/// Ridge added to the tangent second moments of [`linear_fit`], in units of the support
/// squared times the weight sum: where the nodes do not constrain a direction (a strip one
/// node wide) the fit's slope along it goes to zero, i.e. to Shepard's value.
const LINEAR_RIDGE: f64 = 1e-3;

/// Weighted least-squares plane through the node values of level `l` around `p`, in the
/// tangent plane of `n`, with the Shepard weights: `f(x) ≈ a + g · (x - p)`; returns `a`,
/// clamped per channel to the range of the supporting nodes' values (so it adds no
/// ringing), or `None` where no node supports `p`. Shepard's weighted mean is exact only
/// for constants: where the nodes sit on one side of `p` (the foot of a wall, the edge
/// of a floor, a node-sparse strip) it returns the value of a point a fraction of a node
/// spacing inside, a bias proportional to the gradient times the spacing (`ALGORITHM.md`
/// §6). The plane reproduces linear fields exactly.
#[inline]
pub fn linear_fit(h: &Hierarchy, o: usize, l: usize, p: Vec3, n: Vec3, values: &[Vec4]) -> Option<Vec3> {
    let (t, b) = onb(n);
    let inv_h = 1.0 / h.support(o, l) as f64;
    // Moments of (1, u, v) and of f (1, u, v).
    let (mut s0, mut su, mut sv, mut suu, mut suv, mut svv) = (0.0f64, 0.0, 0.0, 0.0, 0.0, 0.0);
    let (mut f0, mut fu, mut fv) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    h.for_each_weight(o, l, p, n, |j, w| {
        let d = Vec3::from(h.nodes[j].pos) - p;
        let (u, v) = (d.dot(t) as f64 * inv_h, d.dot(b) as f64 * inv_h);
        let w = w as f64;
        let f = values[j].xyz().as_dvec3();
        s0 += w;
        su += w * u;
        sv += w * v;
        suu += w * u * u;
        suv += w * u * v;
        svv += w * v * v;
        f0 += f * w;
        fu += f * (w * u);
        fv += f * (w * v);
        lo = lo.min(f);
        hi = hi.max(f);
    });
    if s0 <= 0.0 {
        return None;
    }
    let (suu, svv) = (suu + LINEAR_RIDGE * s0, svv + LINEAR_RIDGE * s0);
    // Cramer's rule for the constant term of [s0 su sv; su suu suv; sv suv svv] x = f.
    let c00 = suu * svv - suv * suv;
    let c01 = sv * suv - su * svv;
    let c02 = su * suv - sv * suu;
    let det = s0 * c00 + su * c01 + sv * c02;
    if !(det > 0.0) || !det.is_finite() {
        return Some((f0 / s0).as_vec3());
    }
    let a = (f0 * c00 + fu * c01 + fv * c02) / det;
    if std::env::var("MESHRAD_NOCLAMP").is_ok() { return Some(a.max(DVec3::ZERO).as_vec3()); }
    Some(a.clamp(lo, hi).as_vec3())
}

/// [`linear_fit`] on level `l`, falling back to the nearest coarser level that covers `p`.
#[inline]
pub fn linear(h: &Hierarchy, o: usize, l: usize, p: Vec3, n: Vec3, values: &[Vec4]) -> Option<Vec3> {
    (0..=l).rev().find_map(|k| linear_fit(h, o, k, p, n, values))
}

/// The value of a solved field at an object-space surface point, read from level `l`
/// with exact reconstruction (outputs: images and probes), or with the linear fit under
/// `linear` (absolute hierarchies only). The delta hierarchy can ring below zero next to
/// a discontinuity (e.g. a surface in a thin unlit gap): the raw value is returned and
/// the caller clamps and counts.
#[inline]
pub fn output(h: &Hierarchy, delta: bool, linear_read: bool, o: usize, l: usize, p: Vec3, n: Vec3, values: &[Vec4]) -> Vec3 {
    if delta {
        delta_sum(h, o, l, p, n, values)
    } else if linear_read {
        linear(h, o, l, p, n, values).unwrap_or(Vec3::ZERO)
    } else {
        exact(h, o, l, p, n, values).unwrap_or(Vec3::ZERO)
    }
}
