//! One BVH2 per object, built here by binned SAH with a depth bound, traversed by a
//! stack-based loop that the GPU kernels mirror (`trace_object` in
//! `glsl/include/geometry.glsl`) and queried for boxes; and one CWBVH per object
//! ([`CwForest`]), converted from a single-primitive BVH2 of the same builder by obvhs,
//! which the CPU's rays traverse ([`trace_cw`]: obvhs' traversal order with a child test
//! as conservative as the BVH2's, 1.5–1.6× the BVH2's rays per second) and the GPU may
//! traverse instead of the BVH2 (`bvh = "cwbvh"`).
//!
//! The builder is O(n log n) on any input, repeated and coincident geometry included:
//! a node whose centroids coincide is split at its index median, and a node whose
//! subtree could otherwise grow past the traversal stack is split at the centroid
//! median, so the depth never exceeds what traversal can hold (obvhs' PLOC builder made
//! 1392 levels of 25 000 coincident triangles, and 75 of a 300-gon's fan).

use glam::{Vec3, Vec3A};
use obvhs::{aabb::Aabb, bvh2::Bvh2};

use super::ray::{Ray, WatertightRay};
use crate::error::{Error, Result};
use crate::layout::{BvhNode, CwNode, Tri};

/// Traversal stack entries; a BVH deeper than this is rejected at build time.
pub const BVH_STACK: usize = crate::constants::BVH_STACK as usize;
/// Stack entries of the GPU's CWBVH traversal (`glsl/include/cwbvh.glsl`).
pub const CWBVH_STACK: usize = crate::constants::CWBVH_STACK as usize;

/// Largest leaf of the BVH2.
const MAX_LEAF: usize = 8;
/// SAH bins per axis.
const BINS: usize = 16;
/// Cost of a node visit relative to one triangle test.
const TRAVERSAL_COST: f32 = 1.0;

/// Builds a BVH2 over `tris` and reorders `tris` (and `extra`, e.g. uvs) so that leaves
/// index triangles directly.
pub fn build<T: Copy>(tris: &mut Vec<Tri>, extra: &mut Vec<T>, name: &str) -> Result<Vec<BvhNode>> {
    let (nodes, order) = build_nodes(tris, MAX_LEAF, BVH_STACK);
    *tris = order.iter().map(|&i| tris[i as usize]).collect();
    if !extra.is_empty() {
        *extra = order.iter().map(|&i| extra[i as usize]).collect();
    }
    let depth = depth(&nodes);
    if depth >= BVH_STACK {
        // The builder bounds the depth; this guards the bound itself.
        return Err(Error::Mesh {
            path: name.into(),
            line: None,
            message: format!("BVH depth {depth} exceeds the traversal stack of {BVH_STACK}"),
        });
    }
    Ok(nodes)
}

/// Centroid and bounds of each triangle.
fn prim_bounds(tris: &[Tri]) -> (Vec<Vec3A>, Vec<Aabb>) {
    tris.iter()
        .map(|t| {
            let (a, b, c) = (Vec3A::from(t.v0), Vec3A::from(t.v1), Vec3A::from(t.v2));
            let bb = Aabb::new(a.min(b).min(c), a.max(b).max(c));
            ((bb.min + bb.max) * 0.5, bb)
        })
        .unzip()
}

fn half_area(b: &Aabb) -> f32 {
    let d = (b.max - b.min).max(Vec3A::ZERO);
    d.x * d.y + d.y * d.z + d.z * d.x
}

fn grow(b: &mut Aabb, o: &Aabb) {
    b.min = b.min.min(o.min);
    b.max = b.max.max(o.max);
}

const EMPTY: Aabb = Aabb {
    min: Vec3A::splat(f32::INFINITY),
    max: Vec3A::splat(f32::NEG_INFINITY),
};

fn ceil_log2(n: usize) -> usize {
    (usize::BITS - (n.max(1) - 1).leading_zeros()) as usize
}

/// The BVH2 nodes over `tris` (root at 0, the children of an inner node adjacent) and
/// the triangle order of the leaves. Leaves hold at most `max_leaf` triangles; the depth
/// (root = 1) stays below `depth_limit`.
fn build_nodes(tris: &[Tri], max_leaf: usize, depth_limit: usize) -> (Vec<BvhNode>, Vec<u32>) {
    let (cent, bounds) = prim_bounds(tris);
    let n = tris.len();
    let mut idx: Vec<u32> = (0..n as u32).collect();
    let mut nodes = vec![BvhNode::default()];
    // (node, start, end, depth)
    let mut work = vec![(0usize, 0usize, n, 1usize)];
    while let Some((node, start, end, depth)) = work.pop() {
        let count = end - start;
        let (mut bb, mut cb) = (EMPTY, EMPTY);
        for &i in &idx[start..end] {
            grow(&mut bb, &bounds[i as usize]);
            let c = cent[i as usize];
            grow(&mut cb, &Aabb::new(c, c));
        }
        nodes[node].aabb = bb;
        let leaf = |nodes: &mut Vec<BvhNode>| {
            nodes[node].prim_count = count as u32;
            nodes[node].first_index = start as u32;
        };
        if count <= 1 {
            leaf(&mut nodes);
            continue;
        }
        let extent = cb.max - cb.min;
        // Forced median: the subtree's depth is then at most depth + ceil(log2 count).
        let force = depth + ceil_log2(count) + 1 >= depth_limit;
        let mut mid = None;
        if !force && extent.max_element() > 0.0 {
            let (split, cost) = sah_split(&idx[start..end], &cent, &bounds, &cb);
            let leaf_cost = count as f32;
            if count <= max_leaf && leaf_cost <= cost {
                leaf(&mut nodes);
                continue;
            }
            if let Some((axis, bin)) = split {
                let scale = BINS as f32 / extent[axis];
                let lo = cb.min[axis];
                let m = partition(&mut idx[start..end], |i| {
                    bin_of(cent[i as usize][axis], lo, scale) <= bin
                });
                if m > 0 && m < count {
                    mid = Some(start + m);
                }
            }
        } else if count <= max_leaf && extent.max_element() <= 0.0 {
            // Coincident centroids: nothing to separate.
            leaf(&mut nodes);
            continue;
        }
        let mid = mid.unwrap_or_else(|| {
            let half = count / 2;
            let axis = extent.max_position();
            if extent[axis] > 0.0 {
                idx[start..end].select_nth_unstable_by(half, |&a, &b| {
                    cent[a as usize][axis]
                        .total_cmp(&cent[b as usize][axis])
                        .then(a.cmp(&b))
                });
            }
            start + half
        });
        let left = nodes.len();
        nodes.push(BvhNode::default());
        nodes.push(BvhNode::default());
        nodes[node].prim_count = 0;
        nodes[node].first_index = left as u32;
        work.push((left + 1, mid, end, depth + 1));
        work.push((left, start, mid, depth + 1));
    }
    (nodes, idx)
}

#[inline]
fn bin_of(c: f32, lo: f32, scale: f32) -> usize {
    (((c - lo) * scale) as usize).min(BINS - 1)
}

/// The best binned SAH split of `prims`: (axis, last bin of the left side) and its cost
/// in triangle tests, relative to the parent's area.
fn sah_split(prims: &[u32], cent: &[Vec3A], bounds: &[Aabb], cb: &Aabb) -> (Option<(usize, usize)>, f32) {
    let extent = cb.max - cb.min;
    let mut best = (None, f32::INFINITY);
    let mut parent = EMPTY;
    for &i in prims {
        grow(&mut parent, &bounds[i as usize]);
    }
    let pa = half_area(&parent).max(f32::MIN_POSITIVE);
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        let scale = BINS as f32 / extent[axis];
        let lo = cb.min[axis];
        let mut bin_box = [EMPTY; BINS];
        let mut bin_n = [0u32; BINS];
        for &i in prims {
            let b = bin_of(cent[i as usize][axis], lo, scale);
            grow(&mut bin_box[b], &bounds[i as usize]);
            bin_n[b] += 1;
        }
        // Sweep: areas and counts of the right side from the right.
        let mut right_area = [0.0f32; BINS];
        let mut right_n = [0u32; BINS];
        let (mut acc, mut accn) = (EMPTY, 0u32);
        for b in (1..BINS).rev() {
            grow(&mut acc, &bin_box[b]);
            accn += bin_n[b];
            right_area[b] = half_area(&acc);
            right_n[b] = accn;
        }
        let (mut acc, mut accn) = (EMPTY, 0u32);
        for b in 0..BINS - 1 {
            grow(&mut acc, &bin_box[b]);
            accn += bin_n[b];
            let rn = right_n[b + 1];
            if accn == 0 || rn == 0 {
                continue;
            }
            let cost = TRAVERSAL_COST + (half_area(&acc) * accn as f32 + right_area[b + 1] * rn as f32) / pa;
            if cost < best.1 {
                best = (Some((axis, b)), cost);
            }
        }
    }
    best
}

/// Moves the elements for which `left` holds to the front (stable in neither half);
/// returns how many there are.
fn partition(v: &mut [u32], left: impl Fn(u32) -> bool) -> usize {
    let mut m = 0;
    for k in 0..v.len() {
        if left(v[k]) {
            v.swap(m, k);
            m += 1;
        }
    }
    m
}

fn depth(nodes: &[BvhNode]) -> usize {
    let mut max = 0;
    let mut stack = vec![(0usize, 1usize)];
    while let Some((i, d)) = stack.pop() {
        max = max.max(d);
        let n = &nodes[i];
        if n.prim_count == 0 {
            stack.push((n.first_index as usize, d + 1));
            stack.push((n.first_index as usize + 1, d + 1));
        }
    }
    max
}

/// `1 / d` with zero components replaced by a huge value of the same sign (`d >= 0`
/// counts as positive, as in GLSL).
#[inline]
pub fn safe_inverse(d: Vec3) -> Vec3 {
    let f = |x: f32| {
        if x.abs() < 1e-30 {
            if x < 0.0 {
                -1e30
            } else {
                1e30
            }
        } else {
            1.0 / x
        }
    };
    Vec3::new(f(d.x), f(d.y), f(d.z))
}

/// Entry distance of a ray into a box, or infinity. Conservative far bound (Ize 2013).
#[inline]
pub fn slab(node: &BvhNode, o: Vec3, inv: Vec3, tmax: f32) -> f32 {
    let t0 = (Vec3::from(node.aabb.min) - o) * inv;
    let t1 = (Vec3::from(node.aabb.max) - o) * inv;
    let tnear = t0.min(t1).max_element().max(0.0);
    let tfar = t0.max(t1).min_element() * crate::constants::SLAB_FAR;
    if tnear <= tfar && tnear < tmax {
        tnear
    } else {
        f32::INFINITY
    }
}

/// A CWBVH over `tris` (already in BVH2 order), its leaves indexing a primitive array
/// that holds global triangle indices (`tri_offset` + local). Converted by obvhs from a
/// single-triangle BVH2 whose depth stays within the CWBVH stack (a wide level covers at
/// least one binary level). [`CwForest::build`] places it in the shared arrays.
fn build_cwbvh(tris: &[Tri], tri_offset: u32) -> (Vec<CwNode>, Vec<u32>) {
    let (nodes, order) = build_nodes(tris, 1, CWBVH_STACK);
    let bvh2 = Bvh2 {
        nodes,
        primitive_indices: order,
        ..Default::default()
    };
    let cw = obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh(&bvh2, 3, true, false);
    let prims = cw.primitive_indices.iter().map(|&i| i + tri_offset).collect();
    (cw.nodes, prims)
}

/// Shifts a BVH's indices so that it can live at `node_offset` in a shared node array
/// whose triangles start at `tri_offset`.
pub fn rebase(nodes: &mut [BvhNode], node_offset: u32, tri_offset: u32) {
    for n in nodes {
        n.first_index += if n.prim_count > 0 { tri_offset } else { node_offset };
    }
}

/// Whether some triangle of the BVH rooted at `root` whose bounds meet the object-space
/// box `[lo, hi]` satisfies `f(global index, triangle)`: a conservative region query (the
/// triangles' bounds, not the triangles, are tested), for the tests that would otherwise
/// trace rays which can only hit triangles in that box.
pub fn any_in_box(
    nodes: &[BvhNode],
    tris: &[Tri],
    root: u32,
    lo: Vec3,
    hi: Vec3,
    mut f: impl FnMut(u32, &Tri) -> bool,
) -> bool {
    let meets = |bmin: Vec3, bmax: Vec3| bmin.cmple(hi).all() && bmax.cmpge(lo).all();
    let node_meets = |i: u32| {
        let n = &nodes[i as usize];
        meets(Vec3::from(n.aabb.min), Vec3::from(n.aabb.max))
    };
    if !node_meets(root) {
        return false;
    }
    let mut stack = [0u32; BVH_STACK];
    let mut sp = 0usize;
    let mut cur = root;
    loop {
        let n = &nodes[cur as usize];
        if n.prim_count > 0 {
            for i in n.first_index..n.first_index + n.prim_count {
                let t = &tris[i as usize];
                let (a, b, c) = (Vec3::from(t.v0), Vec3::from(t.v1), Vec3::from(t.v2));
                if meets(a.min(b).min(c), a.max(b).max(c)) && f(i, t) {
                    return true;
                }
            }
        } else {
            let a = n.first_index;
            match (node_meets(a), node_meets(a + 1)) {
                (true, true) => {
                    stack[sp] = a + 1;
                    sp += 1;
                    cur = a;
                    continue;
                }
                (true, false) => {
                    cur = a;
                    continue;
                }
                (false, true) => {
                    cur = a + 1;
                    continue;
                }
                (false, false) => {}
            }
        }
        if sp == 0 {
            return false;
        }
        sp -= 1;
        cur = stack[sp];
    }
}

/// Closest (or, with `any`, first) hit in `(0, tmax)` of an object-space ray against the
/// BVH rooted at `root` (global indices, see [`rebase`]).
/// Returns the global triangle index, t and barycentrics.
pub fn trace(
    nodes: &[BvhNode],
    tris: &[Tri],
    root: u32,
    ray: &Ray,
    mut tmax: f32,
    any: bool,
) -> Option<(u32, f32, f32, f32)> {
    let inv = safe_inverse(ray.d);
    let wt = WatertightRay::new(ray);
    let mut best = None;
    let mut stack = [0u32; BVH_STACK];
    let mut sp = 0usize;
    if slab(&nodes[root as usize], ray.o, inv, tmax) == f32::INFINITY {
        return None;
    }
    let mut cur = root;
    loop {
        let n = &nodes[cur as usize];
        if n.prim_count > 0 {
            for i in n.first_index..n.first_index + n.prim_count {
                if let Some((t, b1, b2)) = wt.intersect(&tris[i as usize], tmax) {
                    tmax = t;
                    best = Some((i, t, b1, b2));
                    if any {
                        return best;
                    }
                }
            }
        } else {
            let a = n.first_index;
            let ta = slab(&nodes[a as usize], ray.o, inv, tmax);
            let tb = slab(&nodes[a as usize + 1], ray.o, inv, tmax);
            let (near, far, tn, tf) = if ta <= tb {
                (a, a + 1, ta, tb)
            } else {
                (a + 1, a, tb, ta)
            };
            if tn < f32::INFINITY {
                if tf < f32::INFINITY {
                    stack[sp] = far;
                    sp += 1;
                }
                cur = near;
                continue;
            }
        }
        // Pop the next node that can still be closer than the best hit.
        loop {
            if sp == 0 {
                return best;
            }
            sp -= 1;
            cur = stack[sp];
            if slab(&nodes[cur as usize], ray.o, inv, tmax) < f32::INFINITY {
                break;
            }
        }
    }
}

/// Every object's CWBVH, for the CPU's rays ([`trace_cw`]) and, with `bvh = "cwbvh"`,
/// the GPU's: one node array and one primitive array (global triangle indices), each
/// object's root in `roots`.
#[derive(Clone, Debug, Default)]
pub struct CwForest {
    pub nodes: Vec<CwNode>,
    pub prims: Vec<u32>,
    pub roots: Vec<u32>,
}

impl CwForest {
    /// The CWBVHs of the objects whose triangles are `ranges` of `tris` (each already in
    /// its BVH2's order), built in parallel and laid out in object order.
    pub fn build(tris: &[Tri], ranges: &[std::ops::Range<usize>]) -> CwForest {
        use rayon::prelude::*;
        let parts: Vec<(Vec<CwNode>, Vec<u32>)> = ranges
            .par_iter()
            .map(|r| build_cwbvh(&tris[r.clone()], r.start as u32))
            .collect();
        let mut f = CwForest::default();
        for (mut nodes, prims) in parts {
            let (node_offset, prim_offset) = (f.nodes.len() as u32, f.prims.len() as u32);
            for n in &mut nodes {
                n.child_base_idx += node_offset;
                n.primitive_base_idx += prim_offset;
            }
            f.roots.push(node_offset);
            f.nodes.extend(nodes);
            f.prims.extend(prims);
        }
        f
    }
}

/// The node array the `obvhs::traverse!` macro walks.
struct CwNodes<'a> {
    nodes: &'a [CwNode],
}

/// The ray's octant as the CWBVH traversal orders children (obvhs'
/// `ray_get_octant_inv4`).
#[inline(always)]
fn octant_inv4(d: Vec3) -> u32 {
    (if d.x < 0.0 { 0 } else { 0x0404_0404 })
        | (if d.y < 0.0 { 0 } else { 0x0202_0202 })
        | (if d.z < 0.0 { 0 } else { 0x0101_0101 })
}

/// The children of `node` that a ray from `o` (`inv`: [`safe_inverse`] of its direction
/// `d`) enters in `[0, tmax]`, as the traversal's hit mask: four boxes at a time with SSE.
/// obvhs' `CwBvhNode::intersect_ray_simd` (MIT or Apache-2.0), with two changes that make
/// it as conservative as [`slab`]: a box is entered from `t = 0` (obvhs clamps at `1e-4`
/// scene units, which culls hits closer than that, e.g. in a crevice of a millimetre
/// scene), and its far distance is widened by `SLAB_FAR` (Ize 2013).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn cw_children(node: &CwNode, o: Vec3A, inv: Vec3A, d: Vec3, tmax: f32, oct_inv4: u32) -> u32 {
    use std::arch::x86_64::*;
    let adj_inv = node.compute_extent() * inv;
    let adj_o = (Vec3A::from(node.p) - o) * inv;
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    let mut hits = 0;
    // SAFETY: SSE and SSE2 are part of the x86_64 baseline; every load is of a local.
    unsafe {
        let q = |v: &[u8; 8], i: usize| {
            _mm_set_ps(
                v[i * 4 + 3] as f32,
                v[i * 4 + 2] as f32,
                v[i * 4 + 1] as f32,
                v[i * 4] as f32,
            )
        };
        let (ix, iy, iz) = (_mm_set1_ps(adj_inv.x), _mm_set1_ps(adj_inv.y), _mm_set1_ps(adj_inv.z));
        let (ox, oy, oz) = (_mm_set1_ps(adj_o.x), _mm_set1_ps(adj_o.y), _mm_set1_ps(adj_o.z));
        let axis = |lo: __m128, hi: __m128, neg: bool, i: __m128, o: __m128| {
            let (a, b) = if neg { (hi, lo) } else { (lo, hi) };
            (_mm_add_ps(_mm_mul_ps(a, i), o), _mm_add_ps(_mm_mul_ps(b, i), o))
        };
        for i in 0..2 {
            let (nx, fx) = axis(q(&node.child_min_x, i), q(&node.child_max_x, i), d.x < 0.0, ix, ox);
            let (ny, fy) = axis(q(&node.child_min_y, i), q(&node.child_max_y, i), d.y < 0.0, iy, oy);
            let (nz, fz) = axis(q(&node.child_min_z, i), q(&node.child_max_z, i), d.z < 0.0, iz, oz);
            let t0 = _mm_max_ps(_mm_max_ps(nx, _mm_max_ps(ny, nz)), _mm_setzero_ps());
            let t1 = _mm_min_ps(
                _mm_mul_ps(
                    _mm_min_ps(fx, _mm_min_ps(fy, fz)),
                    _mm_set1_ps(crate::constants::SLAB_FAR),
                ),
                _mm_set1_ps(tmax),
            );
            let mask = _mm_movemask_ps(_mm_cmple_ps(t0, t1));
            for j in 0..4 {
                if mask & (1 << j) != 0 {
                    let bits = obvhs::cwbvh::node::extract_byte64(child_bits8, i * 4 + j);
                    let index = obvhs::cwbvh::node::extract_byte64(bit_index8, i * 4 + j);
                    hits |= bits << index;
                }
            }
        }
    }
    hits
}

/// [`cw_children`] one box at a time (targets without SSE).
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
fn cw_children(node: &CwNode, o: Vec3A, inv: Vec3A, d: Vec3, tmax: f32, oct_inv4: u32) -> u32 {
    let adj_inv = node.compute_extent() * inv;
    let adj_o = (Vec3A::from(node.p) - o) * inv;
    let (rdx, rdy, rdz) = (d.x < 0.0, d.y < 0.0, d.z < 0.0);
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    let mut hits = 0;
    for c in 0..8 {
        let (lx, hx) = (node.child_min_x[c] as f32, node.child_max_x[c] as f32);
        let (ly, hy) = (node.child_min_y[c] as f32, node.child_max_y[c] as f32);
        let (lz, hz) = (node.child_min_z[c] as f32, node.child_max_z[c] as f32);
        let near = Vec3A::new(
            if rdx { hx } else { lx },
            if rdy { hy } else { ly },
            if rdz { hz } else { lz },
        );
        let far = Vec3A::new(
            if rdx { lx } else { hx },
            if rdy { ly } else { hy },
            if rdz { lz } else { hz },
        );
        let t0 = (near * adj_inv + adj_o).max_element().max(0.0);
        let t1 = ((far * adj_inv + adj_o).min_element() * crate::constants::SLAB_FAR).min(tmax);
        if t0 <= t1 {
            let bits = obvhs::cwbvh::node::extract_byte64(child_bits8, c);
            let index = obvhs::cwbvh::node::extract_byte64(bit_index8, c);
            hits |= bits << index;
        }
    }
    hits
}

/// [`trace`] through the CWBVH rooted at `root` of `forest`: the same watertight
/// triangle test, the closest hit in `(0, tmax)` (or, with `any`, the first). It agrees
/// with [`trace`] but where two triangles lie within a rounding of the same distance, or
/// a box is grazed within a rounding (`tests/stress.rs`, `cwbvh_traversal_agrees`).
pub fn trace_cw(
    forest: &CwForest,
    tris: &[Tri],
    root: u32,
    ray: &Ray,
    tmax: f32,
    any: bool,
    keep: impl Fn(u32, f32, f32) -> bool,
) -> Option<(u32, f32, f32, f32)> {
    use glam::{uvec2, UVec2};
    if root as usize >= forest.nodes.len() {
        return None;
    }
    let wt = WatertightRay::new(ray);
    let (o, inv) = (Vec3A::from(ray.o), Vec3A::from(safe_inverse(ray.d)));
    let walk = CwNodes { nodes: &forest.nodes };
    let mut state = obvhs::cwbvh::Traversal {
        current_group: uvec2(root, 0x8000_0000),
        oct_inv4: octant_inv4(ray.d),
        ..Default::default()
    };
    let mut best = None;
    let mut t_best = tmax;
    let mut node: &CwNode;
    'walk: {
        obvhs::traverse!(
            walk,
            node,
            state,
            cw_children(node, o, inv, ray.d, t_best, state.oct_inv4),
            {
                let i = forest.prims[state.primitive_id as usize];
                if let Some((t, b1, b2)) = wt.intersect(&tris[i as usize], t_best).filter(|h| keep(i, h.1, h.2)) {
                    t_best = t;
                    best = Some((i, t, b1, b2));
                    if any {
                        break 'walk;
                    }
                }
            }
        );
    }
    best
}
