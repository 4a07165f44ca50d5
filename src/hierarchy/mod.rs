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
use crate::geom::Ray;
use crate::layout::{KdSplit, Node, ObjectInfo, Parent};
use crate::params::{SolverParams, MAX_LEVELS};
use crate::progress::Progress;
use crate::scene::{reach, Scene};
use poisson::Candidate;
use weight::{clip_ok, node_weight};

/// Support clipping: from each node, 8 rays in its tangent plane (at k·45°), lifted 2 %
/// of the support off the surface, look for surfaces standing across the support
/// (`|n · n_hit| < 0.5`: a wall on the node's floor, not the node's own curved surface).
/// The rays reach 1.1 h, so that the ray nearest the perpendicular (within 22.5°) finds
/// any wall closer than h. The nearest two such planes (distinct directions) bound the
/// support in the directions whose rays met them: points behind them get no weight, so
/// light does not leak under walls into the room behind, while a finite obstacle (a box)
/// only cuts the directions it covers (`weight::clip_ok`).
fn support_clips(scene: &Scene, nodes: &[Node], objects: &[ObjectLevels], kappa: f32) -> Vec<weight::Clip> {
    nodes
        .par_iter()
        .map(|nd| {
            let h_obj = kappa * objects[nd.object as usize].radius[nd.level as usize];
            let mut planes = walls_across_support(scene, nd, h_obj);
            widen_to_neighbour_sectors(&mut planes);
            encode_clip(planes)
        })
        .collect()
}

/// A plane standing across a node's support: its quantised direction in the node's
/// tangent frame (away from the node), its distance as a fraction of the support, and the
/// 8 directions (bits) whose rays met it.
type Plane = ([i16; 2], f32, u8);

/// The planes the 8 tangent rays of node `nd` (support `h_obj`, object space) meet.
fn walls_across_support(scene: &Scene, nd: &Node, h_obj: f32) -> Vec<Plane> {
    let obj = &scene.objects[nd.object as usize];
    let h = h_obj * obj.transform.scale;
    let n_obj = Vec3::from(nd.normal);
    let x_obj = Vec3::from(nd.pos);
    let n = xform_vector(&obj.to_world, n_obj).normalize();
    let x = xform_point(&obj.to_world, x_obj);
    let origin = scene.offset(x, n) + n * (0.02 * h);
    let (t, b) = onb(n_obj);
    let mut planes: Vec<Plane> = Vec::new();
    for k in 0..8 {
        let a = k as f32 * std::f32::consts::FRAC_PI_4;
        let d_obj = t * a.cos() + b * a.sin();
        let d = xform_vector(&obj.to_world, d_obj).normalize();
        let Some(hit) = scene.intersect(&Ray { o: origin, d }, 1.1 * h) else {
            continue;
        };
        let hit_obj = &scene.objects[hit.object as usize];
        let tri = &scene.tris[hit.tri as usize];
        let hn = xform_vector(&hit_obj.to_world, crate::geom::ray::tri_normal(tri)).normalize();
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
pub fn in_crevice(scene: &Scene, o: usize, c: &Candidate, d_min: f32, index: u32) -> bool {
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
        if scene.occluded(&Ray { o: origin, d }, d_min) {
            near += 1;
        }
    }
    near >= 7
}

/// Largest `Σ |w|` of a parent set's linear weights: where the parents are nearly
/// collinear the weights are blended back towards Shepard's until they stay under this.
const MAX_LINEAR_GAIN: f32 = 3.0;

/// Ridge of the tangent second moments (in support² times the weight sum) of
/// [`linear_weights`]: a direction the parents do not span gets no slope.
const LINEAR_RIDGE: f64 = 1e-3;

/// Turns the normalised Shepard weights `w_p` of a child at `x` (normal `n`) into the
/// weights of a weighted least-squares plane through its parents' values, read at `x`:
/// `w'_p = w_p (λ_0 + λ_1 u_p + λ_2 v_p)` with `(u_p, v_p)` the parent's offset in the
/// tangent plane over the support `h`, so that `Σ w'_p = 1` and `Σ w'_p (u_p, v_p) = 0`:
/// the pull-down reproduces linear fields, where Shepard's weighted mean returns the
/// value of a point inside the parents' cloud — at a surface's edge, a fraction of a
/// spacing inward (`ALGORITHM.md` §5.5). Blended back towards `w_p` where the gain
/// `Σ |w'_p|` would exceed [`MAX_LINEAR_GAIN`].
fn linear_weights(v: &mut [Parent], nodes: &[Node], x: Vec3, n: Vec3, h: f32) {
    if v.len() < 3 {
        return;
    }
    let (t, b) = onb(n);
    let inv_h = 1.0 / h as f64;
    let uv: Vec<(f64, f64, f64)> = v
        .iter()
        .map(|q| {
            let d = Vec3::from(nodes[q.node as usize].pos) - x;
            (q.weight as f64, d.dot(t) as f64 * inv_h, d.dot(b) as f64 * inv_h)
        })
        .collect();
    let (mut su, mut sv, mut suu, mut suv, mut svv) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &(w, u, vv) in &uv {
        su += w * u;
        sv += w * vv;
        suu += w * u * u;
        suv += w * u * vv;
        svv += w * vv * vv;
    }
    let (suu, svv) = (suu + LINEAR_RIDGE, svv + LINEAR_RIDGE);
    // λ = M⁻¹ e_0 for M = [1 su sv; su suu suv; sv suv svv] (the weights sum to 1).
    let c00 = suu * svv - suv * suv;
    let c01 = sv * suv - su * svv;
    let c02 = su * suv - sv * suu;
    let det = c00 + su * c01 + sv * c02;
    if !(det > 0.0 && det.is_finite()) {
        return;
    }
    let lin: Vec<f64> = uv.iter().map(|&(w, u, vv)| w * (c00 + c01 * u + c02 * vv) / det).collect();
    let gain: f64 = lin.iter().map(|w| w.abs()).sum();
    // Blend w'' = s w' + (1 - s) w; Σ|w''| ≤ s Σ|w'| + (1 - s), so s = (G - 1) / (gain - 1).
    let s = if gain > MAX_LINEAR_GAIN as f64 {
        (MAX_LINEAR_GAIN as f64 - 1.0) / (gain - 1.0)
    } else {
        1.0
    };
    for (q, (&l, &(w, _, _))) in v.iter_mut().zip(lin.iter().zip(&uv)) {
        q.weight = (s * l + (1.0 - s) * w) as f32;
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
    /// under an object resting on the floor), of those tested: the crevice test runs on
    /// the candidates that no node of an earlier chunk of the dart throwing covers.
    pub crevice_candidates_dropped: usize,
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

/// The Poisson-disk set of every (object, level), object-major, independent and in
/// parallel; candidates in crevices are dropped (the test memoised per candidate).
fn poisson_levels(
    scene: &Scene,
    p: &SolverParams,
    d: &Density,
    pools: &[Vec<Candidate>],
    stats: &mut HierarchyStats,
) -> Vec<Vec<Candidate>> {
    let m = p.levels as usize;
    let jobs: Vec<(usize, usize)> = (0..scene.objects.len())
        .flat_map(|o| (0..m).map(move |l| (o, l)))
        .collect();
    // Crevice test, memoised per candidate across levels: 0 unknown, 1 open, 2 crevice.
    let memo: Vec<Vec<AtomicU8>> = pools
        .iter()
        .map(|p| (0..p.len()).map(|_| AtomicU8::new(0)).collect())
        .collect();
    let d_min = (p.crevice_distance as f64 * d.radius[m - 1]) as f32;
    let sets: Vec<Vec<Candidate>> = jobs
        .par_iter()
        .map(|&(o, l)| {
            let pool = &pools[o];
            let n = d.take(p, o, l, pool.len());
            let r = d.radius[l] / scene.objects[o].transform.scale as f64;
            let usable = |i: usize| {
                if d_min <= 0.0 {
                    return true;
                }
                let state = memo[o][i].load(Ordering::Relaxed);
                if state != 0 {
                    return state == 1;
                }
                let open = !in_crevice(scene, o, &pool[i], d_min, i as u32);
                memo[o][i].store(if open { 1 } else { 2 }, Ordering::Relaxed);
                open
            };
            poisson::dart_throw(&pool[..n], r as f32, usable)
        })
        .collect();
    stats.crevice_candidates_dropped = memo
        .iter()
        .map(|m| m.iter().filter(|s| s.load(Ordering::Relaxed) == 2).count())
        .sum();
    let mut pool_sizes = vec![0u64; m];
    for &(o, l) in &jobs {
        pool_sizes[l] += d.take(p, o, l, pools[o].len()) as u64;
    }
    stats.candidates_per_level = pool_sizes;
    sets
}

/// The node array, level-major then object, with each level's start and each object's
/// ranges and object-space radii.
fn assemble(scene: &Scene, d: &Density, sets: Vec<Vec<Candidate>>) -> (Vec<Node>, Vec<u32>, Vec<ObjectLevels>) {
    let m = d.radius.len();
    let mut nodes = Vec::new();
    let mut level_start = Vec::with_capacity(m + 1);
    let mut objects = vec![
        ObjectLevels {
            start: vec![0; m],
            count: vec![0; m],
            radius: vec![0.0; m],
        };
        scene.objects.len()
    ];
    for l in 0..m {
        level_start.push(nodes.len() as u32);
        for (o, obj) in scene.objects.iter().enumerate() {
            let set = &sets[o * m + l];
            objects[o].start[l] = nodes.len() as u32;
            objects[o].count[l] = set.len() as u32;
            objects[o].radius[l] = (d.radius[l] / obj.transform.scale as f64) as f32;
            nodes.extend(set.iter().map(|c| Node {
                pos: c.pos.into(),
                level: l as u32,
                normal: c.normal.into(),
                object: o as u32,
            }));
        }
    }
    level_start.push(nodes.len() as u32);
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
    /// Builds the hierarchy of `scene` for the solver parameters `p`: reachable sides,
    /// the levels' density, candidate pools, Poisson-disk levels, the level-major node
    /// array with its kd-trees, support clips, and the parent relations.
    pub fn build(scene: &Scene, p: &SolverParams, progress: &Progress) -> Result<Hierarchy> {
        let mut stats = HierarchyStats::default();
        let t = Instant::now();
        progress.stage("reachable surfaces");
        let sides = reach::reachable_sides(scene, p.reach_paths, p.reach_bounces, p.seed);
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
        let sets = poisson_levels(scene, p, &density, &pools, &mut stats);
        stats.seconds_poisson = t.elapsed().as_secs_f64();
        drop(pools);

        let t = Instant::now();
        progress.stage("kd-trees");
        let (mut nodes, level_start, objects) = assemble(scene, &density, sets);
        let splits = kd_trees(&mut nodes, &objects);
        stats.seconds_kdtree = t.elapsed().as_secs_f64();
        stats.nodes_per_level = level_start.windows(2).map(|w| w[1] - w[0]).collect();

        let t = Instant::now();
        progress.stage("support clipping");
        let clips = if p.support_clip {
            support_clips(scene, &nodes, &objects, p.kappa)
        } else {
            vec![weight::NO_CLIP; nodes.len()]
        };
        stats.seconds_clips = t.elapsed().as_secs_f64();
        stats.clipped_nodes = clips.iter().filter(|c| **c != weight::NO_CLIP).count();
        let mut h = Hierarchy {
            levels: p.levels,
            kappa: p.kappa,
            alpha: p.alpha,
            nodes,
            splits,
            clips,
            level_start,
            objects,
            parent_offset: Vec::new(),
            parents: Vec::new(),
            child_offset: Vec::new(),
            children: Vec::new(),
            stats,
        };
        let t = Instant::now();
        progress.stage("parent relations");
        h.build_relations(p.pulldown_linear && !p.variant.is_delta());
        h.stats.seconds_parents = t.elapsed().as_secs_f64();
        Ok(h)
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

    fn build_relations(&mut self, linear: bool) {
        let n = self.nodes.len();
        let lists: Vec<Vec<Parent>> = (0..n)
            .into_par_iter()
            .map(|c| {
                let nd = &self.nodes[c];
                if nd.level == 0 {
                    return Vec::new();
                }
                let (o, l) = (nd.object as usize, nd.level as usize - 1);
                let (p, nrm) = (Vec3::from(nd.pos), Vec3::from(nd.normal));
                let mut v = Vec::new();
                let mut sum = 0.0f32;
                self.for_each_weight(o, l, p, nrm, |j, w| {
                    v.push(Parent {
                        node: j as u32,
                        weight: w,
                    });
                    sum += w;
                });
                if sum > 0.0 {
                    for q in &mut v {
                        q.weight /= sum;
                    }
                    if linear {
                        linear_weights(&mut v, &self.nodes, p, nrm, self.support(o, l));
                    }
                } else if let Some(j) = self.nearest_same_side(o, l, p, nrm) {
                    v.push(Parent {
                        node: j as u32,
                        weight: 1.0,
                    });
                    // Mark the hole: weight exactly 1 with a sum of 0 is recorded below.
                    v.push(Parent {
                        node: u32::MAX,
                        weight: 0.0,
                    });
                }
                v
            })
            .collect();
        if std::env::var("MESHRAD_PSTAT").is_ok() {
            let m = self.levels as usize;
            let mut hist = vec![[0u32; 8]; m];
            let mut tot = vec![0u32; m];
            for (c, v) in lists.iter().enumerate() {
                let l = self.nodes[c].level as usize;
                tot[l] += 1;
                hist[l][v.len().min(7)] += 1;
            }
            for l in 0..m { eprintln!("PSTAT level {l}: {} nodes, parents count hist {:?}", tot[l], hist[l]); }
        }
        let m = self.levels as usize;
        let mut holes = vec![0u32; m];
        let mut orphans = vec![0u32; m];
        self.parent_offset = Vec::with_capacity(n + 1);
        self.parents.clear();
        for (c, mut v) in lists.into_iter().enumerate() {
            let l = self.nodes[c].level as usize;
            if v.last().is_some_and(|q| q.node == u32::MAX) {
                v.pop();
                holes[l] += 1;
            } else if v.is_empty() && l > 0 {
                orphans[l] += 1;
            }
            self.parent_offset.push(self.parents.len() as u32);
            self.parents.extend(v);
        }
        self.parent_offset.push(self.parents.len() as u32);
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
            .map(|(o, ol)| {
                let mut info = ObjectInfo {
                    to_object: o.to_object,
                    to_world: o.to_world,
                    scale: o.transform.scale,
                    tri_offset: o.tri_offset,
                    tri_count: o.tri_count,
                    bvh_offset: o.bvh_root,
                    ..Default::default()
                };
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
