//! Candidate surface samples and Poisson-disk levels by dart throwing (paper §3,
//! `ALGORITHM.md` §3). Candidates are uniform by area over the sides light can reach;
//! they come in random order, so any prefix is itself a uniform pool: level `l` throws
//! darts over the first `candidate_factor × E[N_l]` of them.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::geom::ray::{tri_normal, tri_point};
use crate::geom::rng::Rng;
use crate::geom::sampling::uniform_triangle;
use crate::layout::Tri;

/// A candidate node: object-space position and the normal of the side it lies on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    pub pos: Vec3,
    pub normal: Vec3,
}

/// `count` candidates on the reachable sides (`sides[2t + back]`) of `tris`.
pub fn candidates(tris: &[Tri], sides: &[bool], count: usize, seed: u64) -> Vec<Candidate> {
    let mut cdf = Vec::new();
    let mut which = Vec::new();
    let mut total = 0.0f64;
    for (t, tri) in tris.iter().enumerate() {
        let v0 = Vec3::from(tri.v0).as_dvec3();
        let a = (Vec3::from(tri.v1).as_dvec3() - v0)
            .cross(Vec3::from(tri.v2).as_dvec3() - v0)
            .length()
            * 0.5;
        for back in 0..2 {
            if sides[t * 2 + back] {
                total += a;
                cdf.push(total);
                which.push((t, back == 1));
            }
        }
    }
    if total <= 0.0 || count == 0 {
        return Vec::new();
    }
    const CHUNK: usize = 4096;
    let chunks = count.div_ceil(CHUNK);
    (0..chunks)
        .into_par_iter()
        .flat_map_iter(|c| {
            let mut rng = Rng::new(seed, c as u64);
            let n = CHUNK.min(count - c * CHUNK);
            let cdf = &cdf;
            let which = &which;
            (0..n).map(move |_| {
                let u = rng.next_f64() * total;
                let k = cdf.partition_point(|&x| x <= u).min(cdf.len() - 1);
                let (t, back) = which[k];
                let (b1, b2) = uniform_triangle(Vec2::new(rng.next_f32(), rng.next_f32()));
                let nrm = tri_normal(&tris[t]);
                Candidate {
                    pos: tri_point(&tris[t], b1, b2),
                    normal: if back { -nrm } else { nrm },
                }
            })
        })
        .collect()
}

/// Total area of the reachable sides.
pub fn reachable_area(tris: &[Tri], sides: &[bool]) -> f64 {
    tris.iter()
        .enumerate()
        .map(|(t, tri)| {
            let v0 = Vec3::from(tri.v0).as_dvec3();
            let a = (Vec3::from(tri.v1).as_dvec3() - v0)
                .cross(Vec3::from(tri.v2).as_dvec3() - v0)
                .length()
                * 0.5;
            a * (sides[2 * t] as u8 + sides[2 * t + 1] as u8) as f64
        })
        .sum()
}

/// A fast hasher for grid cells (FxHash's multiply-rotate).
#[derive(Default)]
pub struct CellHasher(u64);

impl Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }
    fn write_i32(&mut self, i: i32) {
        self.write_u64(i as u32 as u64);
    }
    fn write_u64(&mut self, i: u64) {
        self.0 = (self.0.rotate_left(5) ^ i).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
}

type Cells = HashMap<(i32, i32, i32), u32, BuildHasherDefault<CellHasher>>;

/// A uniform grid over accepted points, cell size `r`, with per-cell linked lists.
pub struct Grid {
    r: f32,
    cells: Cells,
    next: Vec<u32>,
    pub points: Vec<Candidate>,
}

impl Grid {
    pub fn new(r: f32) -> Self {
        Grid {
            r,
            cells: Cells::default(),
            next: Vec::new(),
            points: Vec::new(),
        }
    }

    fn cell(&self, p: Vec3) -> (i32, i32, i32) {
        let c = (p / self.r).floor();
        (c.x as i32, c.y as i32, c.z as i32)
    }

    /// Whether some point on the same side (`n · n' > 0`) lies closer than `r` to `c`.
    pub fn conflicts(&self, c: &Candidate) -> bool {
        let (x, y, z) = self.cell(c.pos);
        let r2 = self.r * self.r;
        // The own cell first: most rejections happen there.
        const ORDER: [i32; 3] = [0, -1, 1];
        for dx in ORDER {
            for dy in ORDER {
                for dz in ORDER {
                    let mut i = *self.cells.get(&(x + dx, y + dy, z + dz)).unwrap_or(&u32::MAX);
                    while i != u32::MAX {
                        let q = &self.points[i as usize];
                        if (q.pos - c.pos).length_squared() < r2 && q.normal.dot(c.normal) > 0.0 {
                            return true;
                        }
                        i = self.next[i as usize];
                    }
                }
            }
        }
        false
    }

    pub fn insert(&mut self, c: Candidate) {
        let key = self.cell(c.pos);
        let i = self.points.len() as u32;
        let head = self.cells.insert(key, i).unwrap_or(u32::MAX);
        self.next.push(head);
        self.points.push(c);
    }
}

/// Dart throwing: accepts each candidate, in order, that keeps distance `r` to every
/// accepted point on the same side and that `usable(index)` admits (asked only for
/// candidates that would be accepted). The result is maximal for the usable pool.
pub fn dart_throw(pool: &[Candidate], r: f32, usable: impl Fn(usize) -> bool) -> Vec<Candidate> {
    let mut g = Grid::new(r);
    for (i, c) in pool.iter().enumerate() {
        if !g.conflicts(c) && usable(i) {
            g.insert(*c);
        }
    }
    g.points
}
