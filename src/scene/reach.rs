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
    let hit = trace_marks(scene, paths, bounces, seed);
    let mut uf = UnionFind::new(hit.len());
    for o in &scene.objects {
        join_edges(scene, o.tri_offset, o.tri_count, &mut uf);
    }
    let mut comp_hit = vec![false; hit.len()];
    for (s, &h) in hit.iter().enumerate() {
        if h {
            comp_hit[uf.find(s as u32) as usize] = true;
        }
    }
    (0..hit.len()).map(|s| comp_hit[uf.find(s as u32) as usize]).collect()
}

fn emit(scene: &Scene, light: usize, rng: &mut Rng) -> Ray {
    let l = &scene.lights[light];
    let u = Vec2::new(rng.next_f32(), rng.next_f32());
    match l.kind {
        LIGHT_DIRECTIONAL => {
            let d = Vec3::from(l.direction);
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
        LIGHT_SPOT => Ray {
            o: Vec3::from(l.position),
            d: uniform_cone(Vec3::from(l.direction), l.cutoff.cos(), u),
        },
        _ => Ray {
            o: Vec3::from(l.position),
            d: uniform_sphere(u),
        },
    }
}

fn trace_marks(scene: &Scene, paths: u32, bounces: u32, seed: u32) -> Vec<bool> {
    let marks: Vec<AtomicBool> = (0..scene.tris.len() * 2).map(|_| AtomicBool::new(false)).collect();
    let lights = scene.lights.len() as u32;
    let chunk = 1024u32;
    let chunks = paths.div_ceil(chunk);
    (0..chunks).into_par_iter().for_each(|c| {
        let mut rng = Rng::new(seed as u64 ^ 0x5ca1_ab1e, c as u64);
        for p in c * chunk..((c + 1) * chunk).min(paths) {
            let mut ray = emit(scene, (p % lights) as usize, &mut rng);
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
