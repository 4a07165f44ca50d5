//! Support clip planes (`ALGORITHM.md` §3.6): per node, the walls standing across its
//! support ([`node_clip`]), packed into its clip record (`weight::Clip`, read by
//! `weight::clip_ok`), and the nodes whose clips an arrangement computes
//! ([`ClipSelection`]). The device's twin is the arrangement on the GPU
//! (`crate::device::arrange`, kernel `glsl/clips.comp`).

use glam::Vec3;
use rayon::prelude::*;

use super::{ray_cube, weight, Arrangement, Hierarchy, NEAR_CAP};
use crate::geom::sampling::onb;
use crate::geom::transform::{xform_point, xform_vector};
use crate::geom::{Hit, Ray};
use crate::layout::Node;
use crate::scene::Scene;

/// Support clipping (`node_clip`): from each node, 8 rays in its tangent plane (at k·45°), lifted 2 %
/// of the support off the surface, look for surfaces standing across the support
/// (`|n · n_hit| < 0.5`: a wall on the node's floor, not the node's own curved surface).
/// The rays reach 1.1 h, so that the ray nearest the perpendicular (within 22.5°) finds
/// any wall closer than h. The nearest two such planes (distinct directions) bound the
/// support in the directions whose rays met them: points behind them get no weight, so
/// light does not leak under walls into the room behind, while a finite obstacle (a box)
/// only cuts the directions it covers (`weight::clip_ok`).
///
/// The rays are traced only where they can meet a wall: a node whose reach holds no
/// triangle standing across it ([`may_meet_wall`]: most nodes, away from edges) gets the
/// empty clip the rays would give, without tracing them.
///
/// Where one is, the triangles whose bounds meet the rays' cube, gathered in that one
/// walk, are what the 8 rays are tested against ([`Scene::intersect_among`]): one BVH
/// walk per node, not one per ray.
///
/// One node's (computing every triangle's world normal first: for many,
/// [`Hierarchy::arrange`] or [`cpu_clips`]).
pub fn node_clip(scene: &Scene, h: &Hierarchy, i: usize) -> weight::Clip {
    node_clip_in(
        scene,
        h,
        i,
        &world_normals(scene),
        &mut Vec::with_capacity(NEAR_CAP + 1),
    )
}

/// [`node_clip`] with the triangles' world normals ([`world_normals`]) and `near` as
/// scratch for the gathered triangles (one per thread in [`cpu_clips`] and
/// [`Hierarchy::arrange`], not one allocation per node).
pub(super) fn node_clip_in(
    scene: &Scene,
    h: &Hierarchy,
    i: usize,
    normals: &[Vec3],
    near: &mut Vec<(u32, u32)>,
) -> weight::Clip {
    let nd = &h.nodes[i];
    let h_obj = h.support(nd.object as usize, nd.level as usize);
    let (origin, n, h_w) = clip_ray_origin(scene, nd, h_obj);
    let all = scene.triangles_near(origin, clip_reach(origin, h_w), NEAR_CAP, near);
    let wall = near.iter().any(|&(_, t)| normals[t as usize].dot(n).abs() < 0.5);
    if !all {
        // Many triangles (a coarse node's wide support): the rays traced, where they can
        // meet a wall (one among those gathered, or else one the whole query finds).
        if !wall && !may_meet_wall(scene, nd, h_obj) {
            return encode_clip(Vec::new());
        }
        return clip_traced(scene, h, i, normals);
    }
    if !wall {
        return encode_clip(Vec::new());
    }
    // The 8 rays lie in one plane (through `origin`, normal `n`): a triangle wholly on one
    // side of it, by more than the rays' drift off the plane and the rounding, cannot be
    // hit, and is dropped (a floor under the rays, a shelf above them).
    let margin = 1e-3 * h_w as f64 + 1e-5 * origin.abs().max_element() as f64;
    near.retain(|&(o, t)| {
        let m = &scene.objects[o as usize].to_world;
        let tri = &scene.tris[t as usize];
        let s = [tri.v0, tri.v1, tri.v2]
            .map(|v| (xform_point(m, Vec3::from(v)).as_dvec3() - origin.as_dvec3()).dot(n.as_dvec3()));
        s.iter().any(|&x| x >= -margin) && s.iter().any(|&x| x <= margin)
    });
    let mut planes = walls_across_support(scene, nd, h_obj, normals, |ray, tmax| {
        scene.intersect_among(near, ray, tmax)
    });
    widen_to_neighbour_sectors(&mut planes);
    encode_clip(planes)
}

/// [`node_clip`] with every ray traced (what the shortcut must reproduce; tests).
pub fn node_clip_traced(scene: &Scene, h: &Hierarchy, i: usize) -> weight::Clip {
    clip_traced(scene, h, i, &world_normals(scene))
}

/// [`node_clip_traced`] with the triangles' world normals.
fn clip_traced(scene: &Scene, h: &Hierarchy, i: usize, normals: &[Vec3]) -> weight::Clip {
    let nd = &h.nodes[i];
    let h_obj = h.support(nd.object as usize, nd.level as usize);
    let mut planes = walls_across_support(scene, nd, h_obj, normals, |ray, tmax| scene.intersect(ray, tmax));
    widen_to_neighbour_sectors(&mut planes);
    encode_clip(planes)
}

/// [`ray_cube`] of a node's clip rays (length 1.1 `h`).
fn clip_reach(origin: Vec3, h: f32) -> f32 {
    ray_cube(origin, 1.1 * h)
}

/// Where node `nd`'s clip rays start (world space) and its world normal and support.
fn clip_ray_origin(scene: &Scene, nd: &Node, h_obj: f32) -> (Vec3, Vec3, f32) {
    let obj = &scene.objects[nd.object as usize];
    let h = h_obj * obj.transform.scale;
    let n = xform_vector(&obj.to_world, Vec3::from(nd.normal)).normalize();
    let x = xform_point(&obj.to_world, Vec3::from(nd.pos));
    (scene.offset(x, n) + n * (0.02 * h), n, h)
}

/// Whether a clip ray of node `nd` can meet a wall: some triangle within the rays' reach
/// (1.1 h from their origin; the cube about it, with a margin for rounding) whose normal
/// is one the rays take for a wall (`|n · n_hit| < 0.5`, computed as they compute it).
/// Where none is, every ray misses or hits a surface it ignores, and the clip is empty.
pub fn may_meet_wall(scene: &Scene, nd: &Node, h_obj: f32) -> bool {
    let (origin, n, h) = clip_ray_origin(scene, nd, h_obj);
    scene.any_triangle_near(origin, clip_reach(origin, h), |o, tri| {
        world_normal_of(scene, o, tri).dot(n).abs() < 0.5
    })
}

/// Every triangle's world-space unit normal (by global index), as the clip rays compute
/// it for the surface they hit: once per arrangement, not once per node and triangle
/// near it.
pub fn world_normals(scene: &Scene) -> Vec<Vec3> {
    let mut out = vec![Vec3::ZERO; scene.tris.len()];
    for (o, obj) in scene.objects.iter().enumerate() {
        let r = obj.tri_offset as usize..(obj.tri_offset + obj.tri_count) as usize;
        out[r.clone()]
            .par_chunks_mut(1 << 14)
            .zip(scene.tris[r].par_chunks(1 << 14))
            .for_each(|(n, tris)| {
                for (n, tri) in n.iter_mut().zip(tris) {
                    *n = world_normal_of(scene, o, tri);
                }
            });
    }
    out
}

fn world_normal_of(scene: &Scene, o: usize, tri: &crate::layout::Tri) -> Vec3 {
    xform_vector(&scene.objects[o].to_world, crate::geom::ray::tri_normal(tri)).normalize()
}

/// The nodes whose support clip an arrangement computes: all of them, or after objects
/// moved those of the moved objects (`moved`, per object) and those whose clip rays (1.1
/// of the support, with a margin of 1.2 and `eps` world units) can reach one of `boxes`
/// (each moved object's world bounds before and after). GLSL twin: `glsl/clips.comp`.
#[derive(Clone, Debug)]
pub enum ClipSelection {
    All,
    Near {
        moved: Vec<bool>,
        boxes: Vec<(Vec3, Vec3)>,
        eps: f32,
    },
}

impl ClipSelection {
    /// The nodes whose clips can change when the objects `moved` go from where `before`
    /// had them to where `scene` has them: all of them if the scene's bounds, and so its
    /// ray offsets, changed.
    pub fn after(scene: &Scene, before: &Arrangement, moved: &[usize]) -> ClipSelection {
        if scene.scale != before.scale || scene.bounds != before.bounds {
            return ClipSelection::All;
        }
        ClipSelection::Near {
            moved: (0..scene.objects.len()).map(|o| moved.contains(&o)).collect(),
            boxes: moved
                .iter()
                .flat_map(|&o| {
                    [
                        crate::scene::object_box(&before.objects[o], &scene.tris),
                        crate::scene::object_box(&scene.objects[o], &scene.tris),
                    ]
                })
                .collect(),
            eps: scene.scale * 1e-4,
        }
    }

    /// Whether node `i` of `h` is selected, in `scene`'s arrangement.
    pub fn contains(&self, scene: &Scene, h: &Hierarchy, i: usize) -> bool {
        let Self::Near { moved, boxes, eps } = self else {
            return true;
        };
        let nd = &h.nodes[i];
        let o = nd.object as usize;
        if moved[o] {
            return true;
        }
        let obj = &scene.objects[o];
        let x = xform_point(&obj.to_world, Vec3::from(nd.pos));
        let r = 1.2 * h.support(o, nd.level as usize) * obj.transform.scale + eps;
        boxes
            .iter()
            .any(|(lo, hi)| (x.clamp(*lo, *hi) - x).length_squared() <= r * r)
    }
}

/// Computes the support clips of the nodes a selection holds, on the CPU: `(node, clip)`
/// in node order (after a move; a whole arrangement writes every node's clip in place,
/// [`Hierarchy::arrange`]).
pub fn cpu_clips(scene: &Scene, h: &Hierarchy, sel: &ClipSelection) -> Vec<(usize, weight::Clip)> {
    let normals = world_normals(scene);
    (0..h.nodes.len())
        .into_par_iter()
        .filter(|&i| sel.contains(scene, h, i))
        .map_init(
            || Vec::with_capacity(NEAR_CAP + 1),
            |near, i| (i, node_clip_in(scene, h, i, &normals, near)),
        )
        .collect()
}

/// A plane standing across a node's support: its quantised direction in the node's
/// tangent frame (away from the node), its distance as a fraction of the support, and the
/// 8 directions (bits) whose rays met it.
type Plane = ([i16; 2], f32, u8);

/// The planes the 8 tangent rays of node `nd` (support `h_obj`, object space) meet, with
/// `hit(ray, tmax)` the closest hit of a world-space ray ([`Scene::intersect`] or what
/// gives the same).
fn walls_across_support(
    scene: &Scene,
    nd: &Node,
    h_obj: f32,
    normals: &[Vec3],
    hit: impl Fn(&Ray, f32) -> Option<Hit>,
) -> Vec<Plane> {
    let obj = &scene.objects[nd.object as usize];
    let n_obj = Vec3::from(nd.normal);
    let x_obj = Vec3::from(nd.pos);
    let (origin, n, h) = clip_ray_origin(scene, nd, h_obj);
    let (t, b) = onb(n_obj);
    let mut planes: Vec<Plane> = Vec::new();
    for k in 0..8 {
        let a = k as f32 * std::f32::consts::FRAC_PI_4;
        let d_obj = t * a.cos() + b * a.sin();
        let d = xform_vector(&obj.to_world, d_obj).normalize();
        let Some(hit) = hit(&Ray { o: origin, d }, 1.1 * h) else {
            continue;
        };
        let hn = normals[hit.tri as usize];
        if hn.dot(n).abs() >= 0.5 {
            continue;
        }
        // The plane's normal in the node's tangent frame, pointing away from the node.
        let hn_obj = xform_vector(&obj.to_object, hn);
        let (mx, my) = (hn_obj.dot(t), hn_obj.dot(b));
        let len = (mx * mx + my * my).sqrt();
        if len < 1e-3 {
            continue;
        }
        let s = if mx * d_obj.dot(t) + my * d_obj.dot(b) < 0.0 {
            -1.0
        } else {
            1.0
        };
        let q = [
            (s * mx / len * weight::CLIP_DIR).round() as i16,
            (s * my / len * weight::CLIP_DIR).round() as i16,
        ];
        let (ux, uy) = (q[0] as f32 / weight::CLIP_DIR, q[1] as f32 / weight::CLIP_DIR);
        let p_obj = xform_point(&obj.to_object, origin + d * hit.t) - x_obj;
        let dist = (p_obj.dot(t) * ux + p_obj.dot(b) * uy) / h_obj;
        if dist <= 0.0 {
            continue;
        }
        let bit = 1u8 << weight::direction8(d_obj.dot(t), d_obj.dot(b));
        match planes.iter_mut().find(|(u, _, _)| {
            (u[0] as f32 * q[0] as f32 + u[1] as f32 * q[1] as f32) / (weight::CLIP_DIR * weight::CLIP_DIR) > 0.95
        }) {
            Some(pl) => {
                pl.1 = pl.1.min(dist);
                pl.2 |= bit;
            }
            None => planes.push((q, dist, bit)),
        }
    }
    planes
}

/// A plane met by ray k may also come within h in the neighbouring directions' sectors
/// (±22.5° around k±1·45°) where those rays reached past h: add them.
fn widen_to_neighbour_sectors(planes: &mut [Plane]) {
    for (q, dist, mask) in planes {
        let (ux, uy) = (q[0] as f32 / weight::CLIP_DIR, q[1] as f32 / weight::CLIP_DIR);
        let len = (ux * ux + uy * uy).sqrt();
        let hits = *mask;
        for k in 0..8u32 {
            let near = hits & (1 << ((k + 1) % 8)) != 0 || hits & (1 << ((k + 7) % 8)) != 0;
            if hits & (1 << k) != 0 || !near {
                continue;
            }
            // Largest cosine between u and a direction of sector k.
            let centre = k as f32 * std::f32::consts::FRAC_PI_4;
            let (cx, cy) = (centre.cos(), centre.sin());
            let angle = ((cx * ux + cy * uy) / len).clamp(-1.0, 1.0).acos();
            let best = (angle - std::f32::consts::FRAC_PI_8).max(0.0).cos() * len;
            if best > 0.0 && *dist / best < 1.0 {
                *mask |= 1 << k;
            }
        }
    }
}

/// The nearest two planes, packed into a node's clip record (`weight::Clip`).
fn encode_clip(mut planes: Vec<Plane>) -> weight::Clip {
    planes.sort_by(|a, b| a.1.total_cmp(&b.1));
    let mut clip = weight::NO_CLIP;
    for (k, (q, dist, mask)) in planes.iter().take(2).enumerate() {
        let d = ((dist * weight::CLIP_SCALE).floor() as u32).min(0xfffe) as u16;
        clip[8 * k..8 * k + 2].copy_from_slice(&q[0].to_le_bytes());
        clip[8 * k + 2..8 * k + 4].copy_from_slice(&q[1].to_le_bytes());
        clip[8 * k + 4..8 * k + 6].copy_from_slice(&d.to_le_bytes());
        clip[8 * k + 6] = *mask;
    }
    clip
}
