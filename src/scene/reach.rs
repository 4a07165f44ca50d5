//! Which side of each triangle light can reach (`ALGORITHM.md` §3: only surfaces that can
//! receive light get nodes; a closed object's inside gets none, a thin sheet lit from
//! both sides gets nodes on both).
//!
//! Light paths are traced from every light and mark the triangle sides they hit; the
//! marks then flood across manifold edges of each mesh (the same side of a surface stays
//! the same side across an edge, so one hit marks the whole outside of a closed mesh,
//! and never its inside).

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::Scene;
use crate::geom::rng::Rng;
use crate::geom::sampling::{cosine_direction, onb, uniform_cone, uniform_sphere};
use crate::geom::Ray;
use crate::layout::{LIGHT_DIRECTIONAL, LIGHT_SPOT};

/// Side flags, two per global triangle: `2t` is the side the geometric normal points to.
pub fn reachable_sides(scene: &Scene, paths: u32, bounces: u32, seed: u32) -> Vec<bool> {
    flood(scene, trace_marks(scene, paths, bounces, seed))
}

/// Which sides get nodes under `reach = "object"`, and what could change that.
///
/// An object's sides are those light from anywhere outside it could reach (both sides of
/// an open sheet, the outside of a closed mesh), plus the enclosures a point or spot light
/// sits in (the inside of a closed room or of the furnace sphere): from each such light,
/// 64 rays in every direction mark the first side of the object they meet. Marks flood
/// across manifold edges, so a light only matters through which connected surface it
/// sees first: moving it within a room, or turning it, changes nothing, and the object's
/// nodes depend on the object alone. Moving a light into or out of an enclosure changes
/// the sides, and then the hierarchy is built again ([`ObjectReach::sides_for`]).
#[derive(Clone, Debug, Default)]
pub struct ObjectReach {
    /// The sides reachable from outside, flooded.
    outside: Vec<bool>,
    /// Each side's connected component (its union-find root).
    component: Vec<u32>,
}

impl ObjectReach {
    /// Traces the lines from outside every object and records the components.
    pub fn new(scene: &Scene, paths: u32, bounces: u32, seed: u32) -> ObjectReach {
        let marks = outside_marks(scene, paths, bounces, seed);
        let mut uf = components(scene, marks.len());
        let component: Vec<u32> = (0..marks.len() as u32).map(|s| uf.find(s)).collect();
        let mut hit = vec![false; marks.len()];
        for (s, &m) in marks.iter().enumerate() {
            if m {
                hit[component[s] as usize] = true;
            }
        }
        ObjectReach {
            outside: component.iter().map(|&c| hit[c as usize]).collect(),
            component,
        }
    }

    /// The sides for the scene's lights as they are now placed.
    pub fn sides_for(&self, scene: &Scene) -> Vec<bool> {
        let mut lit = vec![false; self.component.len()];
        // Marks the component of the first side an object-space ray meets in object `o`.
        let mut mark = |o: usize, ray: Ray| {
            if let Some((t, _, _, _)) = scene.trace_object(o, &ray, f32::INFINITY, false) {
                let g = crate::geom::ray::tri_normal(&scene.tris[t as usize]);
                let back = g.dot(ray.d) > 0.0;
                lit[self.component[t as usize * 2 + back as usize] as usize] = true;
            }
        };
        let spread = |k: u32| Vec2::new((k as f32 + 0.5) / 64.0, (k as f32 * 0.618_034).fract());
        for l in scene.lights.iter().filter(|l| l.kind != LIGHT_DIRECTIONAL) {
            for (oi, o) in scene.objects.iter().enumerate() {
                let p = crate::geom::transform::xform_point(&o.to_object, Vec3::from(l.position));
                for k in 0..64u32 {
                    mark(
                        oi,
                        Ray {
                            o: p,
                            d: uniform_sphere(spread(k)),
                        },
                    );
                }
            }
        }
        // Emitting surfaces: 64 rays into the front of 256 points drawn by power mark the
        // first side of each object they meet (an emitter in a closed room lights its
        // inside, as a point light there does).
        let mut rng = Rng::new(0x0e31_77e2, 0);
        for _ in 0..if scene.emitters.any() { 256 } else { 0 } {
            let u = [rng.next_f32(), rng.next_f32(), rng.next_f32()];
            let Some((y, n)) = scene.emitters.sample_point(&scene.tris, u) else {
                break;
            };
            let (tb, bb) = onb(n);
            let start = scene.offset(y, n);
            for k in 0..64u32 {
                let d = cosine_direction(n, tb, bb, spread(k), 0.0);
                for (oi, o) in scene.objects.iter().enumerate() {
                    mark(
                        oi,
                        Ray {
                            o: crate::geom::transform::xform_point(&o.to_object, start),
                            d: crate::geom::transform::xform_vector(&o.to_object, d),
                        },
                    );
                }
            }
        }
        self.outside
            .iter()
            .zip(&self.component)
            .map(|(&o, &c)| o || lit[c as usize])
            .collect()
    }
}

/// The sides light from anywhere outside each object could reach, unflooded: per object,
/// `paths` lines uniform over the lines meeting its bounding sphere (through two uniform
/// points of the sphere), each followed for `bounces` diffuse bounces within the object
/// alone, in object space.
fn outside_marks(scene: &Scene, paths: u32, bounces: u32, seed: u32) -> Vec<bool> {
    let marks: Vec<AtomicBool> = (0..scene.tris.len() * 2).map(|_| AtomicBool::new(false)).collect();
    for (i, o) in scene.objects.iter().enumerate() {
        let tris = &scene.tris[o.tri_offset as usize..(o.tri_offset + o.tri_count) as usize];
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for t in tris {
            for v in [t.v0, t.v1, t.v2] {
                lo = lo.min(Vec3::from(v));
                hi = hi.max(Vec3::from(v));
            }
        }
        let diag = (hi - lo).length();
        let (c, r) = ((lo + hi) * 0.5, 0.5 * diag * 1.01 + 1e-6 * diag.max(1.0));
        let chunk = 1024u32;
        (0..paths.div_ceil(chunk)).into_par_iter().for_each(|k| {
            let mut rng = Rng::new(seed as u64 ^ 0x0b1e_c7ed ^ (i as u64) << 40, k as u64);
            for _ in k * chunk..((k + 1) * chunk).min(paths) {
                let a = c + r * uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                let b = c + r * uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                let Some(d) = (b - a).try_normalize() else {
                    continue;
                };
                let mut ray = Ray { o: a, d };
                for _ in 0..bounces {
                    let Some((t, dist, b1, b2)) = scene.trace_object(i, &ray, f32::INFINITY, false) else {
                        break;
                    };
                    let _ = dist;
                    let tri = &scene.tris[t as usize];
                    let g = crate::geom::ray::tri_normal(tri);
                    let back = g.dot(ray.d) > 0.0;
                    marks[t as usize * 2 + back as usize].store(true, Ordering::Relaxed);
                    let n = if back { -g } else { g };
                    let p = crate::geom::ray::tri_point(tri, b1, b2);
                    let (tu, tv) = onb(n);
                    let u = Vec2::new(rng.next_f32(), rng.next_f32());
                    ray = Ray {
                        o: crate::geom::ray::offset_origin(p, n, diag),
                        d: cosine_direction(n, tu, tv, u, 0.0),
                    };
                }
            }
        });
    }
    marks.into_iter().map(AtomicBool::into_inner).collect()
}

/// The marked sides, flooded across manifold edges of each object.
fn flood(scene: &Scene, hit: Vec<bool>) -> Vec<bool> {
    let mut uf = components(scene, hit.len());
    let mut comp_hit = vec![false; hit.len()];
    for (s, &h) in hit.iter().enumerate() {
        if h {
            comp_hit[uf.find(s as u32) as usize] = true;
        }
    }
    (0..hit.len()).map(|s| comp_hit[uf.find(s as u32) as usize]).collect()
}

/// The sides joined across manifold edges of each object.
fn components(scene: &Scene, sides: usize) -> UnionFind {
    let mut uf = UnionFind::new(sides);
    for o in &scene.objects {
        join_edges(scene, o.tri_offset, o.tri_count, &mut uf);
    }
    uf
}

/// A ray travelling along `d` from a disk outside the scene's bounds that covers them.
fn from_outside(scene: &Scene, d: Vec3, u: Vec2) -> Ray {
    let (lo, hi) = scene.bounds;
    let c = (lo + hi) * 0.5 - d * scene.scale;
    let (t, b) = onb(d);
    let r = scene.scale * 0.5 * u.x.sqrt();
    let phi = u.y * std::f32::consts::TAU;
    Ray {
        o: c + (t * phi.cos() + b * phi.sin()) * r,
        d,
    }
}

/// A light path's first ray from source `light` ([`Scene::sources`]: the lights, then the
/// emitting surfaces, from a point drawn by power into the cosine-weighted front, then the
/// sky, as a directional light from a uniformly drawn direction).
fn emit(scene: &Scene, light: usize, rng: &mut Rng) -> Option<Ray> {
    let u = Vec2::new(rng.next_f32(), rng.next_f32());
    if light >= scene.lights.len() + scene.emitters.any() as usize {
        let d = -uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
        return Some(from_outside(scene, d, u));
    }
    if light == scene.lights.len() {
        let (y, n) = scene
            .emitters
            .sample_point(&scene.tris, [rng.next_f32(), rng.next_f32(), rng.next_f32()])?;
        let (t, b) = onb(n);
        return Some(Ray {
            o: scene.offset(y, n),
            d: cosine_direction(n, t, b, u, 0.0),
        });
    }
    let l = &scene.lights[light];
    Some(match l.kind {
        LIGHT_DIRECTIONAL => from_outside(scene, Vec3::from(l.direction), u),
        LIGHT_SPOT => Ray {
            o: Vec3::from(l.position),
            d: uniform_cone(Vec3::from(l.direction), l.cutoff.cos(), u),
        },
        _ => Ray {
            o: Vec3::from(l.position),
            d: uniform_sphere(u),
        },
    })
}

fn trace_marks(scene: &Scene, paths: u32, bounces: u32, seed: u32) -> Vec<bool> {
    let marks: Vec<AtomicBool> = (0..scene.tris.len() * 2).map(|_| AtomicBool::new(false)).collect();
    let sources = scene.sources() as u32;
    let chunk = 1024u32;
    let chunks = paths.div_ceil(chunk);
    (0..chunks).into_par_iter().for_each(|c| {
        let mut rng = Rng::new(seed as u64 ^ 0x5ca1_ab1e, c as u64);
        for p in c * chunk..((c + 1) * chunk).min(paths) {
            let Some(mut ray) = emit(scene, (p % sources) as usize, &mut rng) else {
                continue;
            };
            for _ in 0..bounces {
                let Some(hit) = scene.intersect(&ray, f32::INFINITY) else {
                    break;
                };
                let s = scene.surface(&hit, ray.d);
                let geometric = crate::geom::ray::tri_normal(&scene.tris[hit.tri as usize]);
                let back = geometric.dot(s.n_obj) < 0.0;
                marks[hit.tri as usize * 2 + back as usize].store(true, Ordering::Relaxed);
                let (t, b) = onb(s.n);
                let u = Vec2::new(rng.next_f32(), rng.next_f32());
                ray = Ray {
                    o: scene.offset(s.p, s.n),
                    d: cosine_direction(s.n, t, b, u, 0.0),
                };
            }
        }
    });
    marks.into_iter().map(AtomicBool::into_inner).collect()
}

/// Unites triangle sides across edges shared by exactly two triangles of one object.
fn join_edges(scene: &Scene, offset: u32, count: u32, uf: &mut UnionFind) {
    let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
    let mut edges: Vec<(u64, u32, bool)> = Vec::with_capacity(count as usize * 3);
    for t in offset..offset + count {
        let tri = &scene.tris[t as usize];
        let mut v = [0u32; 3];
        for (k, p) in [tri.v0, tri.v1, tri.v2].iter().enumerate() {
            let key = [p[0].to_bits(), p[1].to_bits(), p[2].to_bits()];
            let n = ids.len() as u32;
            v[k] = *ids.entry(key).or_insert(n);
        }
        if v[0] == v[1] || v[1] == v[2] || v[2] == v[0] {
            continue;
        }
        for k in 0..3 {
            let (a, b) = (v[k], v[(k + 1) % 3]);
            let key = (a.min(b) as u64) << 32 | a.max(b) as u64;
            edges.push((key, t, a < b));
        }
    }
    edges.sort_unstable_by_key(|e| (e.0, e.1));
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j].0 == edges[i].0 {
            j += 1;
        }
        if j - i == 2 {
            let (_, t1, f1) = edges[i];
            let (_, t2, f2) = edges[i + 1];
            // Opposite edge directions: consistent orientation, front meets front.
            let flip = (f1 == f2) as u32;
            uf.union(t1 * 2, t2 * 2 + flip);
            uf.union(t1 * 2 + 1, t2 * 2 + (1 - flip));
        }
        i = j;
    }
}

struct UnionFind {
    parent: Vec<u32>,
}

impl UnionFind {
    fn new(n: usize) -> Self {
        UnionFind {
            parent: (0..n as u32).collect(),
        }
    }

    fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let p = self.parent[x as usize];
            self.parent[x as usize] = self.parent[p as usize];
            x = p;
        }
        x
    }

    fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            self.parent[ra.max(rb) as usize] = ra.min(rb);
        }
    }
}
