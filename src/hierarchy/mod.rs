//! The meshless hierarchy (paper §3, `ALGORITHM.md` §3): per object, `m` Poisson-disk
//! levels of basis-function centres in object space, a kd-tree per level, and parent
//! relations carrying the pull-down weights `B_p^l(x_c)`.
//!
//! Layout (shared with the GPU): all nodes in one array, level-major, then by object;
//! the nodes of one (object, level) are contiguous and in kd order.

pub mod kdtree;
pub mod poisson;
pub mod weight;

use std::sync::atomic::{AtomicU8, Ordering};
use std::time::Instant;

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use serde::Serialize;

use crate::error::{Error, Result};
use crate::geom::sampling::{cosine_direction, integral_rotation, onb};
use crate::geom::transform::{xform_point, xform_vector};
use crate::geom::{Hit, Ray};
use crate::layout::{KdSplit, Node, ObjectInfo, Parent};
use crate::params::{Reach, SolverParams, MAX_LEVELS};
use crate::progress::Progress;
use crate::scene::{reach, Scene};
use poisson::Candidate;
use weight::{clip_ok, node_weight};

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
fn node_clip_in(scene: &Scene, h: &Hierarchy, i: usize, normals: &[Vec3], near: &mut Vec<(u32, u32)>) -> weight::Clip {
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

/// The most triangles near a node or candidate that its rays are tested against one by
/// one; beyond, they are traced through the BVH.
const NEAR_CAP: usize = 32;

/// The half-width of the cube about `origin` that holds rays of length `len` from it, with
/// a margin for rounding.
fn ray_cube(origin: Vec3, len: f32) -> f32 {
    len * 1.01 + 1e-5 * origin.abs().max_element()
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

/// Whether a candidate lies in a crevice: 7 of 8 stratified cosine-distributed rays from it
/// hit something within `d_min` (world units). Such a point sits in a gap light does not
/// enter (under an object resting on the floor, behind a luminaire a hair below the
/// ceiling); a node there would blend its darkness into the lit surface facing it.
///
/// The rays are traced only where they can hit something: they leave `origin` into the
/// upper half-space of the candidate's tangent plane through it, so a triangle lying at
/// least half the ray offset below that plane cannot stop one. Where every triangle within
/// `d_min` of the origin does (a candidate on open floor: its own surface alone), the
/// answer is "no crevice" without a ray.
pub fn in_crevice(scene: &Scene, o: usize, c: &Candidate, d_min: f32, index: u32) -> bool {
    let obj = &scene.objects[o];
    let x = xform_point(&obj.to_world, c.pos);
    let n = xform_vector(&obj.to_world, c.normal).normalize();
    let origin = scene.offset(x, n);
    let below = 0.5 * (origin - x).dot(n);
    let reach = ray_cube(origin, d_min);
    let above = |oi: usize, tri: &crate::layout::Tri| {
        let m = &scene.objects[oi].to_world;
        [tri.v0, tri.v1, tri.v2]
            .iter()
            .any(|&v| above_plane(xform_point(m, Vec3::from(v)), origin, n, below))
    };
    if below > 0.0 && !scene.any_triangle_near(origin, reach, above) {
        return false;
    }
    // Few triangles within reach: the rays tested against them, without a walk each.
    let mut near = Vec::with_capacity(NEAR_CAP + 1);
    if scene.triangles_near(origin, reach, NEAR_CAP, &mut near) {
        return crevice_rays(scene, o, c, index, |ray| scene.occluded_among(&near, ray, d_min));
    }
    in_crevice_traced(scene, o, c, d_min, index)
}

/// Whether `v` lies less than `below` under the plane through `origin` with normal `n`
/// (in double precision: the shortcuts' margin is the ray offset, a few ulps).
#[inline]
fn above_plane(v: Vec3, origin: Vec3, n: Vec3, below: f32) -> bool {
    (v.as_dvec3() - origin.as_dvec3()).dot(n.as_dvec3()) > -(below as f64)
}

/// [`in_crevice`] with every ray traced (what the shortcut must reproduce; tests).
pub fn in_crevice_traced(scene: &Scene, o: usize, c: &Candidate, d_min: f32, index: u32) -> bool {
    crevice_rays(scene, o, c, index, |ray| scene.occluded(ray, d_min))
}

/// Whether at least 7 of the crevice test's 8 world-space rays from candidate `c` are
/// `blocked` ([`Scene::occluded`] within `d_min`, or what gives the same).
fn crevice_rays(scene: &Scene, o: usize, c: &Candidate, index: u32, blocked: impl Fn(&Ray) -> bool) -> bool {
    let obj = &scene.objects[o];
    let x = xform_point(&obj.to_world, c.pos);
    let n = xform_vector(&obj.to_world, c.normal).normalize();
    let origin = scene.offset(x, n);
    let (t, b) = onb(n);
    let phi0 = integral_rotation(0x0c0e_u32, index);
    let mut near = 0;
    for k in 0..8 {
        let u = Vec2::new((k as f32 + 0.5) / 8.0, (k as f32 * 0.618_034).fract());
        let d = cosine_direction(n, t, b, u, phi0);
        if blocked(&Ray { o: origin, d }) {
            near += 1;
        }
    }
    near >= 7
}

/// [`in_crevice`] against object `o` alone, in object space (`reach = "object"`): the
/// gap must lie within the object (`d_min_obj` in object units), so the answer does not
/// depend on where the object is or on the other objects.
/// Rays are traced only where they can hit something, as in [`in_crevice`].
pub fn in_crevice_within(scene: &Scene, o: usize, c: &Candidate, d_min_obj: f32, index: u32, diag: f32) -> bool {
    let obj = &scene.objects[o];
    let origin = crate::geom::ray::offset_origin(c.pos, c.normal, diag);
    let below = 0.5 * (origin - c.pos).dot(c.normal);
    if below > 0.0 {
        let reach = ray_cube(origin, d_min_obj);
        let may_hit = crate::geom::bvh::any_in_box(
            &scene.bvh,
            &scene.tris,
            obj.bvh_root,
            origin - reach,
            origin + reach,
            |_, tri| {
                [tri.v0, tri.v1, tri.v2]
                    .iter()
                    .any(|&v| above_plane(Vec3::from(v), origin, c.normal, below))
            },
        );
        if !may_hit {
            return false;
        }
    }
    in_crevice_within_traced(scene, o, c, d_min_obj, index, diag)
}

/// [`in_crevice_within`] with every ray traced (tests).
pub fn in_crevice_within_traced(scene: &Scene, o: usize, c: &Candidate, d_min_obj: f32, index: u32, diag: f32) -> bool {
    let origin = crate::geom::ray::offset_origin(c.pos, c.normal, diag);
    let (t, b) = onb(c.normal);
    let phi0 = integral_rotation(0x0c0e_u32, index);
    let mut near = 0;
    for k in 0..8 {
        let u = Vec2::new((k as f32 + 0.5) / 8.0, (k as f32 * 0.618_034).fract());
        let d = cosine_direction(c.normal, t, b, u, phi0);
        let ray = Ray { o: origin, d };
        if crate::geom::bvh::trace_cw(&scene.cw, &scene.tris, scene.cw.roots[o], &ray, d_min_obj, true).is_some() {
            near += 1;
        }
    }
    near >= 7
}

/// Object-space diagonal of object `o`'s bounds (the offset scale of object-space rays).
pub fn object_diagonal(scene: &Scene, o: usize) -> f32 {
    let obj = &scene.objects[o];
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for t in &scene.tris[obj.tri_offset as usize..(obj.tri_offset + obj.tri_count) as usize] {
        for v in [t.v0, t.v1, t.v2] {
            lo = lo.min(Vec3::from(v));
            hi = hi.max(Vec3::from(v));
        }
    }
    (hi - lo).length()
}

/// Where the objects were when a hierarchy was last arranged (their transforms, and the
/// scene's bounds, which set the ray offsets).
#[derive(Clone, Debug)]
pub struct Arrangement {
    pub objects: Vec<crate::scene::SceneObject>,
    pub bounds: (Vec3, Vec3),
    pub scale: f32,
}

impl Arrangement {
    /// The scene's arrangement now.
    pub fn of(scene: &Scene) -> Arrangement {
        Arrangement {
            objects: scene.objects.clone(),
            bounds: scene.bounds,
            scale: scene.scale,
        }
    }
}

/// Where one object's nodes of each level live, and the levels' radii in object space.
#[derive(Clone, Debug, Default)]
pub struct ObjectLevels {
    pub start: Vec<u32>,
    pub count: Vec<u32>,
    pub radius: Vec<f32>,
}

/// What building the hierarchy did, for stats.json.
#[derive(Clone, Debug, Default, Serialize)]
pub struct HierarchyStats {
    pub nodes_per_level: Vec<u32>,
    pub candidates_per_level: Vec<u64>,
    /// World-space Poisson radius `r_l`.
    pub radius_per_level: Vec<f32>,
    /// Children whose parent level has no weight at their centre (nearest parent used).
    pub parent_holes_per_level: Vec<u32>,
    /// Children with no same-side node on the parent level at all.
    pub orphans_per_level: Vec<u32>,
    pub reachable_area: f64,
    /// Candidates found in a crevice (a gap narrower than the finest level's radius, e.g.
    /// under an object resting on the floor), of those tested: on the host the crevice
    /// test runs on the candidates that no node of an earlier chunk of the dart throwing
    /// covers, on the device on those whose earlier neighbours were all left out.
    pub crevice_candidates_dropped: usize,
    /// Where the Poisson-disk levels were thrown: `"host"` or `"device"`
    /// (`dart_throwing`).
    pub poisson_on: &'static str,
    /// On the device: the rounds of decisions over all (object, level) pairs (at least
    /// one submission of 4 per pair; 0 on the host).
    pub poisson_rounds: usize,
    pub reachable_sides: usize,
    pub seconds_reach: f64,
    pub seconds_candidates: f64,
    pub seconds_poisson: f64,
    pub seconds_kdtree: f64,
    pub seconds_clips: f64,
    /// Nodes whose support a nearby surface cuts (a wall standing on their floor).
    pub clipped_nodes: usize,
    pub seconds_parents: f64,
}

/// The hierarchy of every object.
#[derive(Clone, Debug)]
pub struct Hierarchy {
    pub levels: u32,
    pub kappa: f32,
    pub alpha: f32,
    pub nodes: Vec<Node>,
    pub splits: Vec<KdSplit>,
    /// Per node, the free distance of its support in 8 tangent sectors (`weight::clip_ok`).
    pub clips: Vec<weight::Clip>,
    /// Global start of each level (`levels + 1` entries).
    pub level_start: Vec<u32>,
    pub objects: Vec<ObjectLevels>,
    /// CSR: the parents of node `i` are `parents[parent_offset[i]..parent_offset[i + 1]]`.
    pub parent_offset: Vec<u32>,
    pub parents: Vec<Parent>,
    /// CSR: children of node `i`.
    pub child_offset: Vec<u32>,
    pub children: Vec<u32>,
    pub stats: HierarchyStats,
    /// The triangle sides that got nodes (two flags per global triangle).
    pub sides: Vec<bool>,
    /// Under `reach = "object"`: what decides the sides, to tell after an edit whether
    /// they still hold (`crate::edit`).
    pub object_reach: Option<reach::ObjectReach>,
}

/// The parent lists of a run of consecutive children ([`Hierarchy::parents_of_group`]):
/// concatenated, with each child's length and the holes among them per level.
struct GroupParents {
    parents: Vec<Parent>,
    lens: Vec<u32>,
    holes: Vec<u32>,
    /// Scratch: the parent-level nodes near the current group, their positions by
    /// coordinate (a child's distances to all of them in one vectorised loop), and the
    /// ones within the support of the current child.
    near: Vec<u32>,
    near_x: Vec<f32>,
    near_y: Vec<f32>,
    near_z: Vec<f32>,
    within: Vec<u32>,
}

/// The levels' density: each object's reachable area (world units²) and the world-space
/// Poisson radius of each level (§3: `r_0 = sqrt(0.7 A / N_0)`, halved per level).
struct Density {
    areas: Vec<f64>,
    radius: Vec<f64>,
}

impl Density {
    /// Checks that light reaches some surface and that the candidate cap leaves the finest
    /// level its density (else the solve would lose light silently).
    fn plan(scene: &Scene, p: &SolverParams, sides: &[bool]) -> Result<Density> {
        let m = p.levels as usize;
        let areas: Vec<f64> = scene
            .objects
            .iter()
            .map(|o| {
                let r = o.tri_offset as usize..(o.tri_offset + o.tri_count) as usize;
                let s = o.transform.scale as f64;
                poisson::reachable_area(&scene.tris[r.clone()], &sides[r.start * 2..r.end * 2]) * s * s
            })
            .collect();
        let area: f64 = areas.iter().sum();
        if area <= 0.0 {
            return Err(Error::SceneValue {
                path: scene.path.clone(),
                key: "light".into(),
                message: format!(
                    "none of the {} light paths traced (solver key reach_paths) reached a surface: check the \
                     lights' positions and directions",
                    p.reach_paths
                ),
            });
        }
        let r0 = (0.7 * area / p.coarsest as f64).sqrt();
        let d = Density {
            radius: (0..m).map(|l| r0 / (1u64 << l) as f64).collect(),
            areas,
        };
        for (i, &a) in d.areas.iter().enumerate() {
            let need = d.expected(a, m - 1).ceil();
            if need > p.max_candidates as f64 {
                return Err(Error::param(
                    "max_candidates",
                    format!(
                        "{} caps the candidate pool of object {i} ({}) below the {need} nodes its finest level \
                         needs; raise it, or lower coarsest or levels",
                        p.max_candidates, scene.objects[i].name
                    ),
                ));
            }
        }
        Ok(d)
    }

    /// Nodes a Poisson-disk set of level `l` holds on area `a`.
    fn expected(&self, a: f64, l: usize) -> f64 {
        0.7 * a / (self.radius[l] * self.radius[l])
    }

    /// Candidates of object `o`'s pool (of `pool` in all) that level `l` throws darts
    /// from: `candidate_factor` times the level's expected count, at least 64.
    fn take(&self, p: &SolverParams, o: usize, l: usize, pool: usize) -> usize {
        let want = (p.candidate_factor as f64 * self.expected(self.areas[o], l)).ceil() as usize;
        want.clamp(pool.min(64), pool)
    }
}

/// Candidates per object on its reachable sides, enough for the finest level, within
/// `max_candidates`.
fn candidate_pools(scene: &Scene, p: &SolverParams, sides: &[bool], d: &Density) -> Vec<Vec<Candidate>> {
    let m = p.levels as usize;
    scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let r = o.tri_offset as usize..(o.tri_offset + o.tri_count) as usize;
            let want = (p.candidate_factor as f64 * d.expected(d.areas[i], m - 1)).ceil();
            let count = (want as u64).min(p.max_candidates as u64) as usize;
            poisson::candidates(
                &scene.tris[r.clone()],
                &sides[r.start * 2..r.end * 2],
                count,
                (p.seed as u64) << 32 | i as u64,
            )
        })
        .collect()
}

/// One Poisson-disk level of one object: dart throwing over the first `take` candidates of
/// the object's pool with radius `radius` (object space).
#[derive(Clone, Copy, Debug)]
pub struct LevelJob {
    pub object: usize,
    pub level: usize,
    pub take: usize,
    pub radius: f32,
}

/// The crevice test as dart throwing asks it of object `o`'s candidates
/// ([`in_crevice`], or [`in_crevice_within`] with `within`).
#[derive(Clone, Debug)]
pub struct CreviceTest {
    /// The gap width, world units (0: no test).
    pub d_min: f32,
    /// `reach = "object"`: the test within each object, in object space.
    pub within: bool,
    /// Per object, with `within`: its diagonal (the ray offset's scale).
    pub diags: Vec<f32>,
}

impl CreviceTest {
    /// The gap width in object `o`'s units with `within` (world units without).
    pub fn d_min_in(&self, scene: &Scene, o: usize) -> f32 {
        if self.within {
            self.d_min / scene.objects[o].transform.scale
        } else {
            self.d_min
        }
    }
}

/// What dart throwing elsewhere gave: every job's accepted candidates, in pool order,
/// exactly those of [`poisson::dart_throw`] with the crevice test `usable` (but for the
/// float rounding of the crevice rays), the count of candidates found in a crevice, and
/// the rounds of decisions it took over all jobs.
pub struct Thrown {
    pub sets: Vec<Vec<Candidate>>,
    pub crevices: usize,
    pub rounds: usize,
}

/// Dart throwing somewhere other than on the host (the GPU backend's device), with a
/// progress bar over the jobs' candidates; `None` where it declines the jobs (the host
/// throws them).
pub type LevelsElsewhere<'a> =
    &'a dyn Fn(&Scene, &[Vec<Candidate>], &[LevelJob], &CreviceTest, &Progress) -> Result<Option<Thrown>>;

/// Every (object, level), object-major, and the crevice test.
fn level_jobs(scene: &Scene, p: &SolverParams, d: &Density, pools: &[Vec<Candidate>]) -> (Vec<LevelJob>, CreviceTest) {
    let m = p.levels as usize;
    let jobs = (0..scene.objects.len())
        .flat_map(|o| (0..m).map(move |l| (o, l)))
        .map(|(o, l)| LevelJob {
            object: o,
            level: l,
            take: d.take(p, o, l, pools[o].len()),
            radius: (d.radius[l] / scene.objects[o].transform.scale as f64) as f32,
        })
        .collect();
    let within = p.reach() == Reach::Object;
    let crevice = CreviceTest {
        d_min: (p.crevice_distance as f64 * d.radius[m - 1]) as f32,
        within,
        diags: (0..scene.objects.len())
            .map(|o| if within { object_diagonal(scene, o) } else { 0.0 })
            .collect(),
    };
    (jobs, crevice)
}

/// The Poisson-disk set of every job, independent and in parallel; candidates in crevices
/// are dropped (the test memoised per candidate). Returns the sets and the count of
/// candidates found in a crevice.
fn poisson_levels(
    scene: &Scene,
    pools: &[Vec<Candidate>],
    jobs: &[LevelJob],
    crevice: &CreviceTest,
) -> (Vec<Vec<Candidate>>, usize) {
    // Crevice test, memoised per candidate across levels: 0 unknown, 1 open, 2 crevice.
    let memo: Vec<Vec<AtomicU8>> = pools
        .iter()
        .map(|p| (0..p.len()).map(|_| AtomicU8::new(0)).collect())
        .collect();
    let sets: Vec<Vec<Candidate>> = jobs
        .par_iter()
        .map(|job| {
            let o = job.object;
            let pool = &pools[o];
            let usable = |i: usize| {
                if crevice.d_min <= 0.0 {
                    return true;
                }
                let state = memo[o][i].load(Ordering::Relaxed);
                if state != 0 {
                    return state == 1;
                }
                let d = crevice.d_min_in(scene, o);
                let open = if crevice.within {
                    !in_crevice_within(scene, o, &pool[i], d, i as u32, crevice.diags[o])
                } else {
                    !in_crevice(scene, o, &pool[i], d, i as u32)
                };
                memo[o][i].store(if open { 1 } else { 2 }, Ordering::Relaxed);
                open
            };
            poisson::dart_throw(&pool[..job.take], job.radius, usable)
        })
        .collect();
    let dropped = memo
        .iter()
        .map(|m| m.iter().filter(|s| s.load(Ordering::Relaxed) == 2).count())
        .sum();
    (sets, dropped)
}

/// The node array, level-major then object, with each level's start and each object's
/// ranges and object-space radii.
fn assemble(scene: &Scene, d: &Density, sets: Vec<Vec<Candidate>>) -> (Vec<Node>, Vec<u32>, Vec<ObjectLevels>) {
    let m = d.radius.len();
    let mut level_start = Vec::with_capacity(m + 1);
    let mut objects = vec![
        ObjectLevels {
            start: vec![0; m],
            count: vec![0; m],
            radius: vec![0.0; m],
        };
        scene.objects.len()
    ];
    // Where each (level, object) block goes, level-major.
    let mut blocks = Vec::with_capacity(m * scene.objects.len());
    let mut at = 0usize;
    for l in 0..m {
        level_start.push(at as u32);
        for (o, obj) in scene.objects.iter().enumerate() {
            let set = &sets[o * m + l];
            objects[o].start[l] = at as u32;
            objects[o].count[l] = set.len() as u32;
            objects[o].radius[l] = (d.radius[l] / obj.transform.scale as f64) as f32;
            blocks.push((l, o, set));
            at += set.len();
        }
    }
    level_start.push(at as u32);
    // The blocks written into place in parallel.
    let mut nodes: Vec<Node> = Vec::with_capacity(at);
    let mut rest = &mut nodes.spare_capacity_mut()[..at];
    let mut parts = Vec::with_capacity(blocks.len());
    for (l, o, set) in blocks {
        let (part, tail) = std::mem::take(&mut rest).split_at_mut(set.len());
        parts.push((l, o, set, part));
        rest = tail;
    }
    const CHUNK: usize = 1 << 15;
    parts.into_par_iter().for_each(|(l, o, set, part)| {
        part.par_chunks_mut(CHUNK)
            .zip(set.par_chunks(CHUNK))
            .for_each(|(part, set)| {
                for (dst, c) in part.iter_mut().zip(set) {
                    dst.write(Node {
                        pos: c.pos.into(),
                        level: l as u32,
                        normal: c.normal.into(),
                        object: o as u32,
                    });
                }
            })
    });
    // SAFETY: the blocks tile the first `at` slots, and every slot of each was written.
    unsafe { nodes.set_len(at) };
    (nodes, level_start, objects)
}

/// A kd-tree per (object, level), built in place over its disjoint node range, in
/// parallel; returns the splits.
fn kd_trees(nodes: &mut [Node], objects: &[ObjectLevels]) -> Vec<KdSplit> {
    let mut splits = vec![KdSplit::default(); nodes.len()];
    let mut ranges: Vec<(u32, u32)> = objects
        .iter()
        .flat_map(|ol| ol.start.iter().zip(&ol.count).map(|(&s, &c)| (s, c)))
        .collect();
    ranges.sort();
    let mut rest_n: &mut [Node] = nodes;
    let mut rest_s: &mut [KdSplit] = &mut splits;
    let mut offset = 0u32;
    let mut parts = Vec::new();
    for (start, count) in ranges {
        let (_, a) = rest_n.split_at_mut((start - offset) as usize);
        let (_, b) = rest_s.split_at_mut((start - offset) as usize);
        let (pn, an) = a.split_at_mut(count as usize);
        let (ps, bs) = b.split_at_mut(count as usize);
        parts.push((pn, ps));
        rest_n = an;
        rest_s = bs;
        offset = start + count;
    }
    parts.into_par_iter().for_each(|(n, s)| kdtree::build(n, s));
    splits
}

impl Hierarchy {
    /// Whether side `back` of global triangle `tri` got nodes. A hit on a side without
    /// them (no light reaches it: the inside of a closed solid, the back of a wall) reads
    /// nothing as a sender (`ALGORITHM.md` §5.1), without a search.
    #[inline]
    pub fn side_has_nodes(&self, tri: u32, back: bool) -> bool {
        self.sides[2 * tri as usize + back as usize]
    }

    /// Builds the hierarchy of `scene` for the solver parameters `p`: reachable sides,
    /// the levels' density, candidate pools, Poisson-disk levels, the level-major node
    /// array with its kd-trees, support clips, and the parent relations.
    pub fn build(scene: &Scene, p: &SolverParams, progress: &Progress) -> Result<Hierarchy> {
        let mut h = Hierarchy::build_unarranged(scene, p, progress)?;
        h.arrange(scene, p, progress);
        Ok(h)
    }

    /// [`Hierarchy::build`] up to what depends on the arrangement: no clips and no
    /// relations yet ([`Hierarchy::arrange`] adds them, or the device: `crate::device::arrange`).
    pub fn build_unarranged(scene: &Scene, p: &SolverParams, progress: &Progress) -> Result<Hierarchy> {
        Hierarchy::build_unarranged_with(scene, p, progress, None)
    }

    /// [`Hierarchy::build_unarranged`] with the Poisson-disk levels thrown by `elsewhere`
    /// (the device) if given.
    pub fn build_unarranged_with(
        scene: &Scene,
        p: &SolverParams,
        progress: &Progress,
        elsewhere: Option<LevelsElsewhere>,
    ) -> Result<Hierarchy> {
        let mut stats = HierarchyStats {
            poisson_on: "host",
            ..Default::default()
        };
        let t = Instant::now();
        progress.stage("reachable surfaces");
        let (sides, object_reach) = match p.reach() {
            Reach::Lights => (
                reach::reachable_sides(scene, p.reach_paths, p.reach_bounces, p.seed),
                None,
            ),
            Reach::Object => {
                let r = reach::ObjectReach::new(scene, p.reach_paths, p.reach_bounces, p.seed);
                (r.sides_for(scene), Some(r))
            }
        };
        stats.seconds_reach = t.elapsed().as_secs_f64();
        stats.reachable_sides = sides.iter().filter(|&&s| s).count();

        let density = Density::plan(scene, p, &sides)?;
        stats.reachable_area = density.areas.iter().sum();
        stats.radius_per_level = density.radius.iter().map(|&r| r as f32).collect();

        let t = Instant::now();
        progress.stage("candidate samples");
        let pools = candidate_pools(scene, p, &sides, &density);
        stats.seconds_candidates = t.elapsed().as_secs_f64();

        let t = Instant::now();
        progress.stage("Poisson-disk levels");
        let (jobs, crevice) = level_jobs(scene, p, &density, &pools);
        let (sets, dropped) = match elsewhere
            .map(|f| f(scene, &pools, &jobs, &crevice, progress))
            .transpose()?
        {
            Some(Some(t)) => {
                stats.poisson_on = "device";
                stats.poisson_rounds = t.rounds;
                (t.sets, t.crevices)
            }
            _ => poisson_levels(scene, &pools, &jobs, &crevice),
        };
        stats.crevice_candidates_dropped = dropped;
        stats.candidates_per_level = (0..p.levels as usize)
            .map(|l| jobs.iter().filter(|j| j.level == l).map(|j| j.take as u64).sum())
            .collect();
        stats.seconds_poisson = t.elapsed().as_secs_f64();
        drop(pools);

        let t = Instant::now();
        progress.stage("kd-trees");
        let (mut nodes, level_start, objects) = assemble(scene, &density, sets);
        let splits = kd_trees(&mut nodes, &objects);
        stats.seconds_kdtree = t.elapsed().as_secs_f64();
        stats.nodes_per_level = level_start.windows(2).map(|w| w[1] - w[0]).collect();

        let mut h = Hierarchy {
            levels: p.levels,
            kappa: p.kappa,
            alpha: p.alpha,
            nodes,
            splits,
            clips: Vec::new(),
            level_start,
            objects,
            parent_offset: Vec::new(),
            parents: Vec::new(),
            child_offset: Vec::new(),
            children: Vec::new(),
            stats,
            sides,
            object_reach,
        };
        h.clips = vec![weight::NO_CLIP; h.nodes.len()];
        Ok(h)
    }

    /// What depends on where the objects are: the support clips (walls across a node's
    /// support, of any object) and, as the pull-down weights respect them, the parent
    /// relations. [`Hierarchy::build`] ends with it; after objects move, it brings a
    /// hierarchy to exactly what a build for the new arrangement gives (with `reach =
    /// "object"`, where nothing else depends on the arrangement). On the GPU backend the
    /// device does this (`crate::device::arrange`).
    pub fn arrange(&mut self, scene: &Scene, p: &SolverParams, progress: &Progress) {
        let t = Instant::now();
        progress.stage("support clipping");
        self.clips = if p.support_clip {
            let normals = world_normals(scene);
            // Every node's, written in place in parallel (no list of pairs to scatter).
            (0..self.nodes.len())
                .into_par_iter()
                .map_init(
                    || Vec::with_capacity(NEAR_CAP + 1),
                    |near, i| node_clip_in(scene, self, i, &normals, near),
                )
                .collect()
        } else {
            vec![weight::NO_CLIP; self.nodes.len()]
        };
        self.stats.seconds_clips = t.elapsed().as_secs_f64();
        self.stats.clipped_nodes = self.clips.iter().filter(|c| **c != weight::NO_CLIP).count();
        let t = Instant::now();
        progress.stage("parent relations");
        self.build_relations(None);
        self.stats.seconds_parents = t.elapsed().as_secs_f64();
    }

    /// [`Hierarchy::arrange`] after the objects `moved` were placed anew (`before`: the
    /// scene as it was arranged last), computing again only what can change: the clips of
    /// the nodes [`ClipSelection::after`] selects, and the parent lists of the children
    /// within a support of a node whose clip changed (and of those with at most one
    /// parent: holes and orphans are found by a wider search). The result is
    /// [`Hierarchy::arrange`]'s, exactly. Returns the clips computed and the parent lists
    /// computed.
    pub fn rearrange(
        &mut self,
        scene: &Scene,
        before: &Arrangement,
        moved: &[usize],
        p: &SolverParams,
        progress: &Progress,
    ) -> (usize, usize) {
        let sel = ClipSelection::after(scene, before, moved);
        if !p.support_clip || matches!(sel, ClipSelection::All) {
            self.arrange(scene, p, progress);
            return (self.nodes.len(), self.nodes.len());
        }
        let t = Instant::now();
        progress.stage("support clipping");
        let fresh = cpu_clips(scene, self, &sel);
        let clips_done = fresh.len();
        let mut changed = Vec::new();
        for (i, c) in fresh {
            if self.clips[i] != c {
                self.clips[i] = c;
                changed.push(i);
            }
        }
        self.stats.seconds_clips = t.elapsed().as_secs_f64();
        self.stats.clipped_nodes = self.clips.iter().filter(|c| **c != weight::NO_CLIP).count();
        let t = Instant::now();
        progress.stage("parent relations");
        let n = self.nodes.len();
        let mut dirty: Vec<bool> = (0..n).map(|c| self.parents_of(c).len() <= 1).collect();
        for &j in &changed {
            let nd = &self.nodes[j];
            let (o, l) = (nd.object as usize, nd.level as usize);
            if l + 1 >= self.levels as usize {
                continue;
            }
            let (nodes, splits, base) = self.level(o, l + 1);
            kdtree::range(nodes, splits, Vec3::from(nd.pos), self.support(o, l) * 1.0001, |i| {
                dirty[base + i] = true;
            });
        }
        // Level 0 has no parents: its nodes' lists are empty, not computed.
        let parents_done = (0..n).filter(|&c| dirty[c] && self.nodes[c].level > 0).count();
        self.build_relations(Some(&dirty));
        self.stats.seconds_parents = t.elapsed().as_secs_f64();
        (clips_done, parents_done)
    }

    /// Support `h_l` of level `l` of object `o`, object space.
    #[inline]
    pub fn support(&self, o: usize, l: usize) -> f32 {
        self.kappa * self.objects[o].radius[l]
    }

    /// The nodes and splits of (object, level), and the global index of the first.
    #[inline]
    pub fn level(&self, o: usize, l: usize) -> (&[Node], &[KdSplit], usize) {
        let ol = &self.objects[o];
        let s = ol.start[l] as usize;
        let e = s + ol.count[l] as usize;
        (&self.nodes[s..e], &self.splits[s..e], s)
    }

    /// Calls `f(global index, w)` for every node of (o, l) with `w_j(p) > 0`.
    #[inline]
    pub fn for_each_weight(&self, o: usize, l: usize, p: Vec3, n: Vec3, mut f: impl FnMut(usize, f32)) {
        let (nodes, splits, base) = self.level(o, l);
        let h = self.support(o, l);
        kdtree::range(nodes, splits, p, h, |i| {
            let nd = &nodes[i];
            let (x, nj) = (Vec3::from(nd.pos), Vec3::from(nd.normal));
            let w = node_weight(p, n, x, nj, h, self.alpha);
            if w > 0.0 && clip_ok(&self.clips[base + i], p - x, nj, h) {
                f(base + i, w);
            }
        });
    }

    /// The nearest node of (o, l) on the same side as `n` (n · n_j > 0) whose clip planes
    /// admit `p`, if any.
    pub fn nearest_same_side(&self, o: usize, l: usize, p: Vec3, n: Vec3) -> Option<usize> {
        let (nodes, splits, base) = self.level(o, l);
        if nodes.is_empty() {
            return None;
        }
        let h = self.support(o, l);
        let mut r = h;
        for _ in 0..40 {
            let mut best = None;
            let mut best_d = f32::INFINITY;
            kdtree::range(nodes, splits, p, r, |i| {
                let nd = &nodes[i];
                let (x, nj) = (Vec3::from(nd.pos), Vec3::from(nd.normal));
                let d = (x - p).length_squared();
                if n.dot(nj) > 0.0 && d < best_d && clip_ok(&self.clips[base + i], p - x, nj, h) {
                    best_d = d;
                    best = Some(base + i);
                }
            });
            if best.is_some() {
                return best;
            }
            r *= 2.0;
        }
        None
    }

    /// The parent lists of `children`, consecutive nodes of one object and level `l ≥ 1`
    /// (a marked child's when `dirty` is given; the others keep theirs): the nodes of level
    /// `l − 1` with `w_j > 0` whose clips admit the child, in ascending order, normalised;
    /// where none, the nearest same-side node (a hole). The nodes a child's own kd descent
    /// would find ([`Self::for_each_weight`]), through one walk over the group's bounds
    /// (GLSL twin: `weights` in `glsl/relations.comp`).
    fn parents_of_group(&self, children: std::ops::Range<usize>, dirty: Option<&[bool]>, out: &mut GroupParents) {
        let first = &self.nodes[children.start];
        let (o, l) = (first.object as usize, first.level as usize - 1);
        let todo = |c: usize| dirty.is_none_or(|d| d[c]);
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for c in children.clone().filter(|&c| todo(c)) {
            lo = lo.min(Vec3::from(self.nodes[c].pos));
            hi = hi.max(Vec3::from(self.nodes[c].pos));
        }
        let (nodes, splits, base) = self.level(o, l);
        let h = self.support(o, l);
        // The nodes near the group, their positions packed for the children's scans.
        out.near.clear();
        out.near_x.clear();
        out.near_y.clear();
        out.near_z.clear();
        if lo.x <= hi.x {
            // A loose prefilter (its margin covers the rounding of `lo - h`); the exact
            // test is the distance below.
            let m = 1.01 * h + 1e-6 * lo.abs().max(hi.abs()).max_element();
            kdtree::box_leaves(splits, lo, hi, h, |i| {
                let x = Vec3::from(nodes[i].pos);
                if x.cmpgt(lo - m).all() && x.cmplt(hi + m).all() {
                    out.near.push(i as u32);
                    out.near_x.push(x.x);
                    out.near_y.push(x.y);
                    out.near_z.push(x.z);
                }
            });
        }
        let r2 = h * h;
        for c in children {
            let at = out.parents.len();
            if !todo(c) {
                out.parents.extend_from_slice(self.parents_of(c));
                out.lens.push((out.parents.len() - at) as u32);
                continue;
            }
            let nd = &self.nodes[c];
            let (p, nrm) = (Vec3::from(nd.pos), Vec3::from(nd.normal));
            // The near nodes within the support, in order: `(x − p)²` as
            // `length_squared` sums it, for all at once, then compacted without branches.
            let k = out.near.len();
            out.within.clear();
            out.within.resize(k, 0);
            let mut m = 0;
            for (j, ((&x, &y), &z)) in out.near_x.iter().zip(&out.near_y).zip(&out.near_z).enumerate() {
                let (dx, dy, dz) = (x - p.x, y - p.y, z - p.z);
                out.within[m] = j as u32;
                m += usize::from(dx * dx + dy * dy + dz * dz < r2);
            }
            let mut sum = 0.0f32;
            for &j in &out.within[..m] {
                let i = out.near[j as usize];
                let x = Vec3::new(out.near_x[j as usize], out.near_y[j as usize], out.near_z[j as usize]);
                let nn = Vec3::from(nodes[i as usize].normal);
                let w = node_weight(p, nrm, x, nn, h, self.alpha);
                if w > 0.0 && clip_ok(&self.clips[base + i as usize], p - x, nn, h) {
                    out.parents.push(Parent {
                        node: (base + i as usize) as u32,
                        weight: w,
                    });
                    sum += w;
                }
            }
            if sum > 0.0 {
                for q in &mut out.parents[at..] {
                    q.weight /= sum;
                }
            } else if let Some(j) = self.nearest_same_side(o, l, p, nrm) {
                out.parents.push(Parent {
                    node: j as u32,
                    weight: 1.0,
                });
                out.holes[l + 1] += 1;
            }
            out.lens.push((out.parents.len() - at) as u32);
        }
    }

    /// The parent and child relations; with `dirty`, only the marked children's parent
    /// lists are computed again (the others keep theirs).
    fn build_relations(&mut self, dirty: Option<&[bool]>) {
        let n = self.nodes.len();
        let m = self.levels as usize;
        // Groups of up to GROUP consecutive children of one (object, level): neighbours in
        // kd order, so one kd walk over their bounds serves them all. In node order, so
        // that their lists concatenate into the CSR (level 0 has none).
        const GROUP: usize = 16;
        let mut groups = Vec::new();
        for ol in &self.objects {
            for l in 1..m {
                let s = ol.start[l] as usize;
                let e = s + ol.count[l] as usize;
                groups.extend((s..e).step_by(GROUP).map(|a| a..(a + GROUP).min(e)));
            }
        }
        groups.sort_by_key(|g| g.start);
        // The groups tile the nodes after level 0 in order; runs of them fill one output.
        let lists: Vec<GroupParents> = groups
            .par_chunks(64)
            .map(|run| {
                let mut out = GroupParents {
                    parents: Vec::new(),
                    lens: Vec::new(),
                    holes: vec![0; m],
                    near: Vec::new(),
                    near_x: Vec::new(),
                    near_y: Vec::new(),
                    near_z: Vec::new(),
                    within: Vec::new(),
                };
                for g in run {
                    self.parents_of_group(g.clone(), dirty, &mut out);
                }
                out
            })
            .collect();
        let mut holes = vec![0u32; m];
        // Level 0 has no parents.
        let mut lens = vec![0u32; self.level_start[1] as usize];
        for g in &lists {
            for (a, b) in holes.iter_mut().zip(&g.holes) {
                *a += b;
            }
            lens.extend_from_slice(&g.lens);
        }
        debug_assert_eq!(lens.len(), n);
        let mut orphans = vec![0u32; m];
        self.parent_offset = Vec::with_capacity(n + 1);
        let mut acc = 0u32;
        for (c, &k) in lens.iter().enumerate() {
            let l = self.nodes[c].level as usize;
            if k == 0 && l > 0 {
                orphans[l] += 1;
            }
            self.parent_offset.push(acc);
            acc += k;
        }
        self.parent_offset.push(acc);
        // The runs' lists copied into place in parallel.
        let total = acc as usize;
        let mut parents: Vec<Parent> = Vec::with_capacity(total);
        let mut rest = &mut parents.spare_capacity_mut()[..total];
        let mut parts = Vec::with_capacity(lists.len());
        for g in &lists {
            let (part, tail) = std::mem::take(&mut rest).split_at_mut(g.parents.len());
            parts.push((part, &g.parents));
            rest = tail;
        }
        parts.into_par_iter().for_each(|(dst, src)| {
            for (d, q) in dst.iter_mut().zip(src) {
                d.write(*q);
            }
        });
        // SAFETY: the runs' parts tile the first `total` slots (their lengths sum to
        // `total`, the last offset), and every slot of each part was written above.
        unsafe { parents.set_len(total) };
        self.parents = parents;
        self.stats.parent_holes_per_level = holes;
        self.stats.orphans_per_level = orphans;

        // Children: the inverse relation, in ascending order.
        let mut counts = vec![0u32; n + 1];
        for q in &self.parents {
            counts[q.node as usize] += 1;
        }
        self.child_offset = Vec::with_capacity(n + 1);
        let mut acc = 0;
        for c in &counts[..n] {
            self.child_offset.push(acc);
            acc += c;
        }
        self.child_offset.push(acc);
        let mut fill = self.child_offset.clone();
        self.children = vec![0; acc as usize];
        for c in 0..n {
            for q in &self.parents[self.parent_offset[c] as usize..self.parent_offset[c + 1] as usize] {
                let k = &mut fill[q.node as usize];
                self.children[*k as usize] = c as u32;
                *k += 1;
            }
        }
    }

    /// Parents of node `c`.
    #[inline]
    pub fn parents_of(&self, c: usize) -> &[Parent] {
        &self.parents[self.parent_offset[c] as usize..self.parent_offset[c + 1] as usize]
    }

    /// Children of node `p`.
    #[inline]
    pub fn children_of(&self, p: usize) -> &[u32] {
        &self.children[self.child_offset[p] as usize..self.child_offset[p + 1] as usize]
    }

    /// The global node range of level `l`.
    #[inline]
    pub fn level_range(&self, l: usize) -> std::ops::Range<usize> {
        self.level_start[l] as usize..self.level_start[l + 1] as usize
    }

    /// The per-object records shared with the GPU.
    pub fn object_infos(&self, scene: &Scene) -> Vec<ObjectInfo> {
        scene
            .objects
            .iter()
            .zip(&self.objects)
            .zip(&scene.cw.roots)
            .map(|((o, ol), &root)| {
                let mut info = o.info(root);
                for l in 0..(self.levels as usize).min(MAX_LEVELS as usize) {
                    info.level_start[l] = ol.start[l];
                    info.level_count[l] = ol.count[l];
                    info.radius[l] = ol.radius[l];
                }
                info
            })
            .collect()
    }
}
