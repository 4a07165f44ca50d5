//! The build (paper §3, `ALGORITHM.md` §3): reachable sides, the levels' density,
//! candidate pools, Poisson-disk levels (on the host, or elsewhere:
//! [`LevelsElsewhere`]), the level-major node array with its kd-trees; then what depends
//! on the arrangement, the support clips and the relations ([`Hierarchy::arrange`],
//! [`Hierarchy::rearrange`]).

use std::sync::atomic::{AtomicU8, Ordering};
use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use super::clips::{cpu_clips, node_clip_in, world_normals, ClipSelection};
use super::crevice::{in_crevice, in_crevice_within, object_diagonal, CreviceTest};
use super::density::{candidate_pools, Density};
use super::poisson::{self, Candidate};
use super::{kdtree, weight, Arrangement, Hierarchy, HierarchyStats, ObjectLevels, NEAR_CAP};
use crate::error::Result;
use crate::layout::{KdSplit, Node};
use crate::params::{Reach, SolverParams};
use crate::progress::Progress;
use crate::scene::{reach, Scene};

/// One Poisson-disk level of one object: dart throwing over the first `take` candidates of
/// the object's pool with radius `radius` (object space).
#[derive(Clone, Copy, Debug)]
pub struct LevelJob {
    pub object: usize,
    pub level: usize,
    pub take: usize,
    pub radius: f32,
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
        stats.free_path = density.free_path;
        stats.coarsest_nodes = density.coarsest;

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
            plane: p.plane_offset,
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
}
