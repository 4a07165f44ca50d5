//! One BVH2 per object (obvhs, PLOC build), traversed by a stack-based loop that the GPU
//! kernels mirror (`trace_object` in `glsl/include/bvh.glsl`).

use glam::{Vec3, Vec3A};
use obvhs::{bvh2::builder::build_bvh2_from_tris, triangle::Triangle, BvhBuildParams};

use super::ray::{Ray, WatertightRay};
use crate::error::{Error, Result};
use crate::layout::{BvhNode, CwNode, Tri};

/// Traversal stack entries; a BVH deeper than this is rejected at build time.
pub const BVH_STACK: usize = crate::constants::BVH_STACK as usize;

/// Our triangles as obvhs takes them.
fn obvhs_triangles(tris: &[Tri]) -> Vec<Triangle> {
    tris.iter()
        .map(|t| Triangle {
            v0: Vec3A::from_array(t.v0),
            v1: Vec3A::from_array(t.v1),
            v2: Vec3A::from_array(t.v2),
        })
        .collect()
}

/// Builds a BVH2 over `tris` and reorders `tris` (and `extra`, e.g. uvs) so that leaves
/// index triangles directly.
pub fn build<T: Copy>(tris: &mut Vec<Tri>, extra: &mut Vec<T>, name: &str) -> Result<Vec<BvhNode>> {
    let input = obvhs_triangles(tris);
    let mut time = std::time::Duration::ZERO;
    let bvh = build_bvh2_from_tris(&input, BvhBuildParams::medium_build(), &mut time);
    let order = &bvh.primitive_indices;
    *tris = order.iter().map(|&i| tris[i as usize]).collect();
    if !extra.is_empty() {
        *extra = order.iter().map(|&i| extra[i as usize]).collect();
    }
    let depth = depth(&bvh.nodes);
    if depth >= BVH_STACK {
        return Err(Error::Mesh {
            path: name.into(),
            line: None,
            message: format!("BVH depth {depth} exceeds the traversal stack of {BVH_STACK}"),
        });
    }
    Ok(bvh.nodes)
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
    let tfar = t0.max(t1).min_element() * 1.000_000_4;
    if tnear <= tfar && tnear < tmax {
        tnear
    } else {
        f32::INFINITY
    }
}

/// A CWBVH over `tris` (already in BVH2 order) placed at `node_offset` in a shared node
/// array, its leaves indexing a shared primitive array at `prim_offset` that holds global
/// triangle indices (`tri_offset` + local).
pub fn build_cwbvh(tris: &[Tri], node_offset: u32, prim_offset: u32, tri_offset: u32) -> (Vec<CwNode>, Vec<u32>) {
    let input = obvhs_triangles(tris);
    let mut time = std::time::Duration::ZERO;
    let cw = obvhs::cwbvh::builder::build_cwbvh_from_tris(&input, BvhBuildParams::medium_build(), &mut time);
    let mut nodes = cw.nodes;
    for n in &mut nodes {
        n.child_base_idx += node_offset;
        n.primitive_base_idx += prim_offset;
    }
    let prims = cw.primitive_indices.iter().map(|&i| i + tri_offset).collect();
    (nodes, prims)
}

/// Shifts a BVH's indices so that it can live at `node_offset` in a shared node array
/// whose triangles start at `tri_offset`.
pub fn rebase(nodes: &mut [BvhNode], node_offset: u32, tri_offset: u32) {
    for n in nodes {
        n.first_index += if n.prim_count > 0 { tri_offset } else { node_offset };
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
