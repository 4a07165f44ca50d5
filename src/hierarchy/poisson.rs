//! Candidate surface samples and Poisson-disk levels by dart throwing (paper §3,
//! `ALGORITHM.md` §3). Candidates are uniform by area over the sides light can reach;
//! they come in random order, so any prefix is itself a uniform pool: level `l` throws
//! darts over the first `candidate_factor × E[N_l]` of them.

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

/// `count` candidates on the reachable sides (`sides[2t + back]`) of `tris`; where
/// `normals` (corner normals per triangle, or empty) gives a triangle some, a candidate's
/// normal is the shading normal there (`scene::interpolate_normal`), on its side. Where
/// `stops(t, b1, b2)` (triangle `t` of `tris`) is false (a cutout's cut-out part, which
/// rays pass), a draw is made again, up to [`CUTOUT_TRIES`] times, and dropped after: no
/// node sits where no light stops.
pub fn candidates(
    tris: &[Tri],
    normals: &[[f32; 9]],
    sides: &[bool],
    count: usize,
    seed: u64,
    stops: &(dyn Fn(usize, f32, f32) -> bool + Sync),
) -> Vec<Candidate> {
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
                let nrm = tri_normal(tri);
                which.push((t, if back == 1 { -nrm } else { nrm }));
            }
        }
    }
    if total <= 0.0 || count == 0 {
        return Vec::new();
    }
    // Cut points (Chen & Asau): `guide[j]` is the first side whose cumulative area exceeds
    // `j · total / G`, so the search for a draw `u` starts at `guide[floor(u G / total) - 1]`
    // and scans a few entries: the side `partition_point` finds, without its cache misses.
    let g = cdf.len().next_power_of_two();
    let guide: Vec<u32> = (0..g)
        .into_par_iter()
        .map(|j| cdf.partition_point(|&x| x <= j as f64 * total / g as f64) as u32)
        .collect();
    let side = |u: f64| {
        let j = ((u / total * g as f64) as usize).saturating_sub(1).min(g - 1);
        let mut k = guide[j] as usize;
        while k < cdf.len() && cdf[k] <= u {
            k += 1;
        }
        k.min(cdf.len() - 1)
    };
    // Each chunk of 4096 draws its own stream and fills its own part of the pool, written
    // once, in parallel (a pool first filled with zeros took one thread 0.07 s on Sponza's
    // 8 M candidates, the first touch of 192 MB).
    const CHUNK: usize = 4096;
    let mut pool: Vec<Candidate> = Vec::with_capacity(count);
    pool.spare_capacity_mut()[..count]
        .par_chunks_mut(CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            let mut rng = Rng::new(seed, c as u64);
            for o in out {
                // A cut-out draw: a zero normal, dropped below.
                let mut got = Candidate {
                    pos: Vec3::ZERO,
                    normal: Vec3::ZERO,
                };
                for _ in 0..CUTOUT_TRIES {
                    let (t, mut normal) = which[side(rng.next_f64() * total)];
                    let (b1, b2) = uniform_triangle(Vec2::new(rng.next_f32(), rng.next_f32()));
                    if !stops(t, b1, b2) {
                        continue;
                    }
                    if let Some(c) = normals.get(t) {
                        let front = tri_normal(&tris[t]);
                        if let Some(ns) = crate::scene::interpolate_normal(c, front, b1, b2) {
                            normal = if normal.dot(front) < 0.0 { -ns } else { ns };
                        }
                    }
                    got = Candidate {
                        pos: tri_point(&tris[t], b1, b2),
                        normal,
                    };
                    break;
                }
                o.write(got);
            }
        });
    // SAFETY: the chunks tile the first `count` slots, and each slot was written above.
    unsafe { pool.set_len(count) };
    pool.retain(|c| c.normal != Vec3::ZERO);
    pool
}

/// Draws a candidate takes before it is dropped as cut out ([`candidates`]).
pub const CUTOUT_TRIES: usize = 16;

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

/// A cell of [`Grid`]'s open-addressing table: its coordinates and the first block of its
/// points (`NONE`: a free slot).
#[derive(Clone, Copy)]
struct Slot {
    key: [i32; 3],
    head: u32,
}

const NONE: u32 = u32::MAX;
const FREE: Slot = Slot {
    key: [0; 3],
    head: NONE,
};

/// Up to two points of a cell and the cell's next block, in one 64-byte line: a cell of
/// up to two points (most of them: about 2.8 points per cell on a plane) is one line to
/// fetch, where a list of records takes one dependent miss per point.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Block {
    pos: [Vec3; 2],
    normal: [Vec3; 2],
    len: u32,
    next: u32,
}

/// `x.floor() as i32` without the call to libm's `floorf` (the default x86-64 target has
/// no rounding instruction): the same value for every `f32`, saturating alike.
#[inline(always)]
fn floor_i32(x: f32) -> i32 {
    let t = x as i32;
    t.saturating_sub(((t as f32) > x) as i32)
}

/// Asks the cache for the line holding `x`; no effect on what the program computes.
#[inline(always)]
fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint; it reads nothing the program sees and cannot fault.
    unsafe {
        std::arch::x86_64::_mm_prefetch(x as *const T as *const i8, std::arch::x86_64::_MM_HINT_T0);
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}

/// Which of the cells about a candidate's own cell [`Grid::open_in_cells`] looks in.
#[derive(Clone, Copy)]
enum Neighbours {
    /// Those across a face of the own cell.
    Faces,
    /// Those across an edge or a corner.
    EdgesAndCorners,
}

/// A uniform grid over accepted points with per-cell lists, hashed by linear probing.
/// Cells are `2r` wide, so the ball of radius `r` about a point meets at most two cells
/// per axis: eight lookups where cells of `r` take twenty-seven. Dart throwing is bound by
/// memory latency, hence the flat table (a lookup is one cache line) and the blocks.
pub struct Grid {
    r: f32,
    inv_cell: f32,
    slots: Vec<Slot>,
    used: usize,
    blocks: Vec<Block>,
    /// The points in insertion order.
    order: Vec<Candidate>,
}

impl Grid {
    pub fn new(r: f32) -> Self {
        Grid {
            r,
            inv_cell: 0.5 / r,
            slots: vec![FREE; 64],
            used: 0,
            blocks: Vec::new(),
            order: Vec::new(),
        }
    }

    fn cell(&self, p: Vec3) -> [i32; 3] {
        let c = p * self.inv_cell;
        [floor_i32(c.x), floor_i32(c.y), floor_i32(c.z)]
    }

    fn home(&self, k: [i32; 3]) -> usize {
        let h = (k[0] as u32 as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)
            ^ (k[1] as u32 as u64).wrapping_mul(0xc2b2_ae3d_27d4_eb4f)
            ^ (k[2] as u32 as u64).wrapping_mul(0x1656_67b1_9e37_79f9);
        // The table's length is a power of two; the high bits mix best.
        (h.wrapping_mul(0x51_7c_c1_b7_27_22_0a_95) >> (64 - self.slots.len().trailing_zeros())) as usize
    }

    /// The slot holding `k`, or the free slot where it would go.
    fn slot(&self, k: [i32; 3]) -> usize {
        self.probe(self.home(k), k)
    }

    /// [`Self::slot`] from `k`'s home slot `i`, computed earlier.
    #[inline]
    fn probe(&self, mut i: usize, k: [i32; 3]) -> usize {
        let mask = self.slots.len() - 1;
        loop {
            let s = &self.slots[i];
            if s.head == NONE || s.key == k {
                return i;
            }
            i = (i + 1) & mask;
        }
    }

    /// Whether some point on the same side (`n · n' > 0`) lies closer than `r` to `c`.
    pub fn conflicts(&self, c: &Candidate) -> bool {
        // Every point within r lies in a cell between those of p - r and p + r (rounding
        // is monotonic); the own cell first, where most rejections happen.
        let own = self.cell(c.pos);
        let lo = self.cell(c.pos - Vec3::splat(self.r));
        let hi = self.cell(c.pos + Vec3::splat(self.r));
        let scan = |key: [i32; 3]| self.cell_conflicts(self.slots[self.slot(key)].head, c);
        if scan(own) {
            return true;
        }
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    if [x, y, z] != own && scan([x, y, z]) {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// [`Self::conflicts`] for many candidates at once: `keep(i)` is called, in order, for
    /// the indices of `cands` that conflict with no point. Dart throwing waits on memory
    /// (cache misses for cells and their blocks), so each stage runs as a pipeline:
    /// candidate `i + 3D` computes its cells and prefetches their home slots, candidate
    /// `i + 2D` finds the slots and prefetches their first blocks, candidate `i + D` their
    /// second blocks (cells of more than two points), candidate `i` is tested against the
    /// blocks found, nothing computed twice.
    pub fn open_candidates(&self, cands: &[Candidate], mut keep: impl FnMut(usize)) {
        // First the own cell alone (two lines to fetch, where most rejections happen),
        // then the other cells of the neighbourhood for the candidates it leaves open.
        let mut left = Vec::with_capacity(cands.len());
        self.open_in_own_cell(cands, |i| left.push(i));
        self.open_in_neighbourhood(cands, &left, &mut keep);
    }

    /// Whether the cell whose first block is `head` holds a point on the same side closer
    /// than `r` to `c`.
    #[inline]
    fn cell_conflicts(&self, head: u32, c: &Candidate) -> bool {
        let r2 = self.r * self.r;
        let mut i = head;
        while i != NONE {
            let b = &self.blocks[i as usize];
            for k in 0..b.len as usize {
                if (b.pos[k] - c.pos).length_squared() < r2 && b.normal[k].dot(c.normal) > 0.0 {
                    return true;
                }
            }
            i = b.next;
        }
        false
    }

    /// The indices of `cands` whose own cell does not reject them, in order: a pipeline
    /// as in [`Self::open_in_neighbourhood`], one cell per candidate.
    fn open_in_own_cell(&self, cands: &[Candidate], mut keep: impl FnMut(usize)) {
        const D: usize = 8;
        const RING: usize = 4 * D;
        let mut keys = [[0i32; 3]; RING];
        let mut homes = [0usize; RING];
        let mut heads = [NONE; RING];
        for i in 0..cands.len() + 3 * D {
            if i < cands.len() {
                let k = self.cell(cands[i].pos);
                let h = self.home(k);
                prefetch(&self.slots[h]);
                keys[i % RING] = k;
                homes[i % RING] = h;
            }
            if let Some(b) = i.checked_sub(D).filter(|&b| b < cands.len()) {
                let head = self.slots[self.probe(homes[b % RING], keys[b % RING])].head;
                if head != NONE {
                    prefetch(&self.blocks[head as usize]);
                }
                heads[b % RING] = head;
            }
            if let Some(b) = i.checked_sub(2 * D).filter(|&b| b < cands.len()) {
                self.prefetch_next(heads[b % RING]);
            }
            if let Some(t) = i.checked_sub(3 * D).filter(|&t| t < cands.len()) {
                if !self.cell_conflicts(heads[t % RING], &cands[t]) {
                    keep(t);
                }
            }
        }
    }

    /// Whether a cell of the neighbourhood of the candidates `which` of `all`, other than
    /// their own cells (which [`Self::open_in_own_cell`] tested), holds a conflicting
    /// point; `keep` gets the others, in order. In two passes: first the cells across a
    /// face of the own cell (the nearest, where most conflicts are), then, for the
    /// candidates those leave open, the cells across an edge or a corner: a candidate
    /// rejected early costs no lookups of the far cells. Each pass skips the cells the
    /// ball of radius `r` cannot reach ([`Self::neighbours`]).
    fn open_in_neighbourhood(&self, all: &[Candidate], which: &[usize], keep: impl FnMut(usize)) {
        let mut left = Vec::with_capacity(which.len());
        self.open_in_cells(all, which, Neighbours::Faces, |i| left.push(i));
        self.open_in_cells(all, &left, Neighbours::EdgesAndCorners, keep);
    }

    /// The cells of `kind` about candidate `c` that a point within `r` of it can lie in,
    /// into `out` (their keys): those whose distance from `c` (bounded from below, with
    /// a margin for the rounding of the cell coordinates and of the distance test) is
    /// less than `r`. `None` where `c ± r` rounds across two borders on an axis (`r` near
    /// the ulp of the coordinates): such a candidate takes the plain test.
    #[inline]
    fn neighbours(&self, c: Vec3, kind: Neighbours, out: &mut [[i32; 3]; 4]) -> Option<usize> {
        // Every point within r lies in a cell between those of p - r and p + r (rounding
        // is monotonic); cells are 2r wide, so two per axis, three where p ± r rounds
        // across one more border.
        let own = self.cell(c);
        let lo = self.cell(c - Vec3::splat(self.r));
        let hi = self.cell(c + Vec3::splat(self.r));
        let u = c * self.inv_cell;
        // Per axis: the other cell (if any) and the gap to it, in cell units. A point q in
        // the cell above has fl(q/2r) >= own + 1, c has fl(c/2r) = u; the slack covers the
        // rounding of both products.
        let mut other = [0i32; 3];
        let mut gap2 = [0.0f64; 3];
        let mut span = 0u32;
        for a in 0..3 {
            if hi[a] - lo[a] > 1 {
                return None;
            }
            let slack = 4.0 * f32::EPSILON as f64 * (u[a].abs() as f64 + 1.0);
            if hi[a] > own[a] {
                other[a] = hi[a];
                gap2[a] = ((hi[a] as f64 - u[a] as f64) - slack).max(0.0).powi(2);
                span |= 1 << a;
            } else if lo[a] < own[a] {
                other[a] = lo[a];
                gap2[a] = ((u[a] as f64 - own[a] as f64) - slack).max(0.0).powi(2);
                span |= 1 << a;
            }
        }
        // (r / 2r)² with a margin for the rounding of `inv_cell` and of the distance test.
        const REACH2: f64 = 0.25 * (1.0 + 1e-4);
        let mut n = 0;
        for m in 1u32..8 {
            let ones = m.count_ones();
            let wanted = match kind {
                Neighbours::Faces => ones == 1,
                Neighbours::EdgesAndCorners => ones >= 2,
            };
            if !wanted || m & span != m {
                continue;
            }
            let d2: f64 = (0..3).filter(|a| m & (1 << a) != 0).map(|a| gap2[a]).sum();
            if d2 < REACH2 {
                let mut k = own;
                for a in 0..3 {
                    if m & (1 << a) != 0 {
                        k[a] = other[a];
                    }
                }
                out[n] = k;
                n += 1;
            }
        }
        Some(n)
    }

    /// Whether a cell of `kind` about the candidates `which` of `all` holds a conflicting
    /// point; `keep` gets the others, in order. A pipeline: candidate `i + 3D` prefetches
    /// its cells' home slots, candidate `i + 2D` finds the slots and prefetches their
    /// first blocks, candidate `i + D` their second blocks, candidate `i` is tested.
    fn open_in_cells(&self, all: &[Candidate], which: &[usize], kind: Neighbours, mut keep: impl FnMut(usize)) {
        const D: usize = 8;
        const RING: usize = 4 * D;
        const MAX: usize = 4;
        const PLAIN: usize = usize::MAX;
        let mut keys = [[[0i32; 3]; MAX]; RING];
        let mut homes = [[0usize; MAX]; RING];
        let mut heads = [[NONE; MAX]; RING];
        let mut counts = [0usize; RING];
        for i in 0..which.len() + 3 * D {
            if i < which.len() {
                let e = i % RING;
                let c = &all[which[i]];
                counts[e] = match self.neighbours(c.pos, kind, &mut keys[e]) {
                    Some(n) => {
                        for k in 0..n {
                            let h = self.home(keys[e][k]);
                            prefetch(&self.slots[h]);
                            homes[e][k] = h;
                        }
                        n
                    }
                    None => PLAIN,
                };
            }
            if let Some(b) = i.checked_sub(D).filter(|&b| b < which.len()) {
                let e = b % RING;
                for k in 0..counts[e].min(MAX) {
                    let head = self.slots[self.probe(homes[e][k], keys[e][k])].head;
                    if head != NONE {
                        prefetch(&self.blocks[head as usize]);
                    }
                    heads[e][k] = head;
                }
            }
            if let Some(b) = i.checked_sub(2 * D).filter(|&b| b < which.len()) {
                for &head in &heads[b % RING][..counts[b % RING].min(MAX)] {
                    self.prefetch_next(head);
                }
            }
            if let Some(t) = i.checked_sub(3 * D).filter(|&t| t < which.len()) {
                let c = &all[which[t]];
                let e = t % RING;
                let conflict = if counts[e] == PLAIN {
                    self.conflicts(c)
                } else {
                    heads[e][..counts[e]].iter().any(|&h| self.cell_conflicts(h, c))
                };
                if !conflict {
                    keep(which[t]);
                }
            }
        }
    }

    /// Prefetches the block after `head`: a cell of more than two points has a second
    /// block, allocated later and elsewhere, one more dependent miss without this.
    #[inline]
    fn prefetch_next(&self, head: u32) {
        if head != NONE {
            let next = self.blocks[head as usize].next;
            if next != NONE {
                prefetch(&self.blocks[next as usize]);
            }
        }
    }

    /// The points in insertion order.
    pub fn points(&self) -> impl Iterator<Item = Candidate> + '_ {
        self.order.iter().copied()
    }

    /// Empties the grid, keeping its allocations.
    pub fn clear(&mut self) {
        self.slots.fill(FREE);
        self.used = 0;
        self.blocks.clear();
        self.order.clear();
    }

    /// Inserts `cs` in order, prefetching the home slots and first blocks of the cells of
    /// the points a few ahead.
    pub fn insert_all(&mut self, cs: &[Candidate]) {
        const D: usize = 8;
        while 2 * (self.used + cs.len()) > self.slots.len() {
            self.grow();
        }
        for (i, c) in cs.iter().enumerate() {
            if let Some(a) = cs.get(i + 2 * D) {
                prefetch(&self.slots[self.home(self.cell(a.pos))]);
            }
            if let Some(a) = cs.get(i + D) {
                let head = self.slots[self.home(self.cell(a.pos))].head;
                if head != NONE {
                    prefetch(&self.blocks[head as usize]);
                }
            }
            self.insert(*c);
        }
    }

    /// Doubles the table.
    fn grow(&mut self) {
        let grown = vec![FREE; self.slots.len() * 2];
        let old = std::mem::replace(&mut self.slots, grown);
        for s in old.into_iter().filter(|s| s.head != NONE) {
            let i = self.slot(s.key);
            self.slots[i] = s;
        }
    }

    pub fn insert(&mut self, c: Candidate) {
        if 2 * (self.used + 1) > self.slots.len() {
            self.grow();
        }
        let key = self.cell(c.pos);
        let i = self.slot(key);
        let s = &mut self.slots[i];
        if s.head == NONE {
            *s = Slot { key, head: NONE };
            self.used += 1;
        }
        // The newest block first: it is the one with room.
        match self.blocks.get_mut(s.head as usize) {
            Some(b) if b.len < 2 => {
                b.pos[b.len as usize] = c.pos;
                b.normal[b.len as usize] = c.normal;
                b.len += 1;
            }
            _ => {
                self.blocks.push(Block {
                    pos: [c.pos, Vec3::ZERO],
                    normal: [c.normal, Vec3::ZERO],
                    len: 1,
                    next: s.head,
                });
                s.head = (self.blocks.len() - 1) as u32;
            }
        }
        self.order.push(c);
    }
}

/// Dart throwing: accepts each candidate, in order, that keeps distance `r` to every
/// accepted point on the same side and that `usable(index)` admits. The result is
/// maximal for the usable pool, and exactly that of the sequential loop
/// ([`dart_throw_sequential`]).
///
/// The pool goes in chunks. Within a chunk, the test against the points accepted by
/// earlier chunks and `usable` (the crevice test: eight shadow rays) run in parallel,
/// and only the candidates that pass both meet the sequential loop, against the points
/// this chunk accepted so far. `usable` must be a pure function of the index: it is asked
/// for candidates that an earlier one of the same chunk then covers.
pub fn dart_throw(pool: &[Candidate], r: f32, usable: impl Fn(usize) -> bool + Sync) -> Vec<Candidate> {
    const CHUNK: usize = 8192;
    const BLOCK: usize = 256;
    let mut g = Grid::new(r);
    let mut local = Grid::new(r);
    for (k, chunk) in pool.chunks(CHUNK).enumerate() {
        let base = k * CHUNK;
        let g_ref = &g;
        let open: Vec<u32> = chunk
            .par_chunks(BLOCK)
            .enumerate()
            .flat_map_iter(|(b, block)| {
                // The grid's pipeline first, then the crevice tests of what it leaves open
                // (their rays would evict the lines it prefetched).
                let mut open = Vec::new();
                g_ref.open_candidates(block, |i| open.push((b * BLOCK + i) as u32));
                open.retain(|&i| usable(base + i as usize));
                open
            })
            .collect();
        for i in open {
            let c = &chunk[i as usize];
            if !local.conflicts(c) {
                local.insert(*c);
            }
        }
        g.insert_all(&local.order);
        local.clear();
    }
    g.points().collect()
}

/// The plain sequential loop that [`dart_throw`] reproduces: `usable` is asked only for
/// candidates that would be accepted.
pub fn dart_throw_sequential(pool: &[Candidate], r: f32, usable: impl Fn(usize) -> bool) -> Vec<Candidate> {
    let mut g = Grid::new(r);
    for (i, c) in pool.iter().enumerate() {
        if !g.conflicts(c) && usable(i) {
            g.insert(*c);
        }
    }
    g.points().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pipelined test ([`Grid::open_candidates`]) keeps exactly the candidates that
    /// [`Grid::conflicts`] clears, including those whose neighbourhood spans three cells on
    /// an axis (rounding of `p ± r`).
    #[test]
    fn pipelined_test_equals_plain_test() {
        let mut rng = Rng::new(17, 0);
        let mut spans3 = 0;
        for &r in &[0.1f32, 0.3, 1.7, 1e-3] {
            let mut g = Grid::new(r);
            let cell = 2.0 * r;
            // Points and candidates crowd the cell borders (multiples of 2r) on a few
            // planes, both sides, so that a cell's neighbourhood often has 2 or 3 cells.
            let at = |rng: &mut Rng| {
                let k = (rng.next_f32() * 40.0).floor();
                let jitter = (rng.next_f32() - 0.5) * r * [1e-5, 1e-2, 1.0][(rng.next_f32() * 3.0) as usize % 3];
                k * cell + jitter
            };
            let point = |rng: &mut Rng| Candidate {
                pos: Vec3::new(at(rng), at(rng), (rng.next_f32() * 3.0).floor() * r * 0.5),
                normal: if rng.next_f32() < 0.8 { Vec3::Z } else { -Vec3::Z },
            };
            let pts: Vec<Candidate> = (0..3000).map(|_| point(&mut rng)).collect();
            let mut cands: Vec<Candidate> = (0..20_000).map(|_| point(&mut rng)).collect();
            // Far from the origin, where p ± r rounds by more: x a few ulps above r past a
            // cell border, so that p - r may round below it and p + r past the next one.
            for k in 0..2000 {
                let border = (1000.0 + (k % 40) as f32) * cell;
                let x = f32::from_bits((border + r).to_bits().wrapping_add(k / 40) - 20);
                cands.push(Candidate {
                    pos: Vec3::new(x, at(&mut rng), 0.0),
                    normal: Vec3::Z,
                });
                g.insert(Candidate {
                    pos: Vec3::new(x - 0.99 * r, cands.last().unwrap().pos.y, 0.0),
                    normal: if k % 2 == 0 { Vec3::Z } else { -Vec3::Z },
                });
            }
            // Pairs a hair under r apart across an edge or a corner of the cells: the point
            // just inside one cell, the candidate in a diagonal neighbour, the conflict
            // found only if that neighbour is searched (the cull must not drop it).
            for k in 0..3000 {
                let corner = Vec3::new(
                    (rng.next_f32() * 40.0).floor() * cell,
                    (rng.next_f32() * 40.0).floor() * cell,
                    (rng.next_f32() * 4.0).floor() * cell,
                );
                let sign = |rng: &mut Rng| if rng.next_f32() < 0.5 { -1.0 } else { 1.0 };
                let mut dir = Vec3::new(sign(&mut rng), sign(&mut rng), sign(&mut rng));
                if k % 2 == 0 {
                    dir.z = 0.0; // across an edge
                }
                let dir =
                    (dir * Vec3::new(0.5 + rng.next_f32(), 0.5 + rng.next_f32(), 0.5 + rng.next_f32())).normalize();
                let q = corner - dir * (r * 0.5 * rng.next_f32());
                let d = r * (1.0 - 1e-5 * [0.5, 2.0, 10.0, 100.0][k % 4]);
                g.insert(Candidate {
                    pos: q,
                    normal: Vec3::Z,
                });
                cands.push(Candidate {
                    pos: q + dir * d,
                    normal: Vec3::Z,
                });
            }
            g.insert_all(&pts);
            let mut got = Vec::new();
            g.open_candidates(&cands, |i| got.push(i));
            let want: Vec<usize> = (0..cands.len()).filter(|&i| !g.conflicts(&cands[i])).collect();
            let first = got.iter().zip(&want).position(|(a, b)| a != b);
            assert!(
                got == want,
                "r = {r}: {} kept against {}, first difference at {first:?}",
                got.len(),
                want.len()
            );
            assert!(
                !want.is_empty() && want.len() < cands.len(),
                "r = {r}: a test that can tell"
            );
            spans3 += cands
                .iter()
                .filter(|c| {
                    let (lo, hi) = (g.cell(c.pos - Vec3::splat(r)), g.cell(c.pos + Vec3::splat(r)));
                    (0..3).any(|a| hi[a] - lo[a] >= 2)
                })
                .count();
        }
        assert!(spans3 > 0, "no neighbourhood of three cells on an axis");
    }

    #[test]
    fn floor_i32_is_floor() {
        let mut v = vec![
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.999_999_8,
            -2.999_999_8,
            1e9,
            -1e9,
            3e9,
            -3e9,
        ];
        v.extend([
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
        ]);
        v.extend([2_147_483_520.0, -2_147_483_648.0, 8_388_607.5, -8_388_607.5]);
        let mut x = 0x1234_5678u32;
        for _ in 0..1_000_000 {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            v.push(f32::from_bits(x));
        }
        for a in v {
            assert_eq!(super::floor_i32(a), a.floor() as i32, "{a}");
        }
    }
}
