//! The CPU reference backend: every stage of the transport on plain arrays, parallel over
//! integrals with rayon. It is the oracle the GPU kernels are tested against, so each
//! stage computes exactly what its kernel computes (same formulas, same samples).

use glam::{Vec2, Vec3, Vec4, Vec4Swizzles};
use rayon::prelude::*;

use super::estimator::{Estimator, Gathered};
use super::links::{self, Kept, Link, LinkStats, Links};
use super::{reconstruct, Backend, Energy, NodeValues, Refined};
use crate::error::Result;
use crate::geom::sampling::{cosine_direction, halton_table, integral_rotation, onb};
use crate::geom::transform::{xform_point, xform_vector};
use crate::geom::Ray;
use crate::hierarchy::Hierarchy;
use crate::limits::Limits;
use crate::params::{SolverParams, Variant};
use crate::progress::Progress;
use crate::scene::Scene;

/// World-space position and unit normal of node `j`.
#[inline]
pub fn node_world(scene: &Scene, h: &Hierarchy, j: usize) -> (Vec3, Vec3) {
    let nd = &h.nodes[j];
    let o = &scene.objects[nd.object as usize];
    (
        xform_point(&o.to_world, Vec3::from(nd.pos)),
        xform_vector(&o.to_world, Vec3::from(nd.normal)).normalize(),
    )
}

/// Direct irradiance at node `j` (kernel `direct`) and its standard error (emitting
/// surfaces); `lit[i]` is set when source `i` ([`Scene::sources`]) contributes.
pub fn direct_at_node(scene: &Scene, h: &Hierarchy, j: usize, lit: &mut [bool]) -> (Vec3, Vec3) {
    let (x, n) = node_world(scene, h, j);
    let (mut e, mut se) = (Vec3::ZERO, Vec3::ZERO);
    scene.direct_each_seeded(x, n, crate::scene::emitter::node_seed(j as u32), |i, v, s| {
        lit[i] = true;
        e += v;
        se += s;
    });
    (e, se)
}

/// One gathering integral at node `j` (kernels `hemisphere`, `trace`, `reconstruct`,
/// `reduce`): `(1/N) Σ_r ρ(y_r) ΔE(y_r)` over cosine-weighted Halton directions rotated
/// by the integral's angle, with `ΔE` read from the sender level of `unshot` — or, with
/// `exact_direct` (the first bounce under `exact_first_bounce`), the exact direct
/// irradiance at each hit by shadow rays, the value the first bounce's un-shot field
/// stands for.
pub fn gather_integral(
    scene: &Scene,
    h: &Hierarchy,
    p: &SolverParams,
    halton: &[Vec2],
    unshot: &[Vec4],
    j: usize,
    exact_direct: bool,
) -> Gathered {
    trace_integral(scene, h, p, halton, unshot, j, exact_direct, None)
}

/// [`gather_integral`], recording each ray's link into `record` (the approximate
/// reconstruction; one entry per ray). Under `exact_direct` the sample is still the
/// direct irradiance at the hit (`Scene::direct_one`), and the link is what the later bounces read there: the
/// first bounce's rays are the later bounces' rays (§5.6).
#[allow(clippy::too_many_arguments)]
fn trace_integral(
    scene: &Scene,
    h: &Hierarchy,
    p: &SolverParams,
    halton: &[Vec2],
    unshot: &[Vec4],
    j: usize,
    exact_direct: bool,
    mut record: Option<&mut [Link]>,
) -> Gathered {
    debug_assert!(record.is_none() || p.variant == Variant::Approx);
    let (x, n) = node_world(scene, h, j);
    let o = scene.offset(x, n);
    let (t, b) = onb(n);
    let phi0 = integral_rotation(p.seed, j as u32);
    let sender = reconstruct::Sender::of(p);
    let mut est = Estimator::default();
    for (r, &u) in halton.iter().enumerate() {
        let d = cosine_direction(n, t, b, u, phi0);
        let ray = Ray { o, d };
        let Some(hit) = scene.intersect(&ray, f32::INFINITY) else {
            continue;
        };
        // The world-space point and normal only where the direct light is read there.
        let s = scene.local_surface(&hit, d);
        let mut linked = None;
        if let Some(rec) = record.as_deref_mut() {
            // A side without nodes reads nothing (`Hierarchy::side_has_nodes`).
            let node = if h.side_has_nodes(s.tri, s.back) {
                reconstruct::approx_node(h, s.object as usize, sender.level, s.p_obj, s.n_obj, sender.cos_min)
            } else {
                None
            };
            rec[r] = match node {
                Some(i) => Link {
                    sender: i as u32,
                    albedo: s.albedo,
                    material: scene.plain_material(s.tri).unwrap_or(links::TEXTURED),
                },
                None => Link::NONE,
            };
            linked = Some(node);
        }
        let e = if exact_direct {
            let (x, n) = scene.world_of(&s);
            scene.direct_one_seeded(x, n, crate::scene::emitter::hit_seed(j as u32, r as u32))
        } else if let Some(node) = linked {
            node.map_or(Vec3::ZERO, |i| unshot[i].xyz())
        } else {
            sender.read_hit(h, &s, unshot)
        };
        est.add(s.albedo * e);
    }
    est.finish(halton.len())
}

/// The oracle (`ALGORITHM.md` §5): refine when the gathered value differs from the
/// prediction by more than `max(ε_rel |g|, ε_abs mean E_d) + z σ` in any channel.
#[inline]
pub fn oracle(p: &SolverParams, g: &Gathered, predicted: Vec3, mean_direct: Vec3) -> bool {
    let diff = (g.mean - predicted).abs();
    let tau = (g.mean.abs() * p.eps_rel).max(mean_direct * p.eps_abs) + g.std_err * p.noise_z;
    diff.cmpgt(tau).any()
}

/// Pull-down `Σ_p B_p(x_c) v_p` (paper §5, Fig. 4).
#[inline]
pub fn pull_down(h: &Hierarchy, values: &[Vec4], c: usize) -> Vec4 {
    h.parents_of(c)
        .iter()
        .fold(Vec4::ZERO, |acc, q| acc + values[q.node as usize] * q.weight)
}

/// The CPU backend's state.
pub struct CpuBackend<'a> {
    scene: &'a Scene,
    h: &'a Hierarchy,
    p: SolverParams,
    halton: Vec<Vec2>,
    direct: Vec<Vec4>,
    unshot: Vec<Vec4>,
    next: Vec<Vec4>,
    indirect: Vec<Vec4>,
    gathered: Vec<Gathered>,
    is_active: Vec<bool>,
    active: Vec<u32>,
    mean_direct: Vec3,
    /// The nodes' direct irradiance's sampling error (emitters), from `direct`.
    direct_error: Option<super::DirectError>,
    /// Each gathering ray traced once per solve (`links`); `None` where the variant's
    /// reads depend on more than one node or `link_memory` is 0.
    links: Option<Links>,
    /// The bytes the links may take ([`link_capacity`] within the run's limits).
    link_bytes: u64,
    /// The links were handed over from an earlier solve of the same geometry
    /// ([`CpuBackend::keep_links`]): the next solve reads them instead of dropping them.
    keep_links: bool,
    /// Each node's children with at most `sparse_parents` parents (CSR: offsets, then
    /// children), the ones `refine` activates under a lit node the oracle trusts: found
    /// once, not in every bounce. Empty where `sparse_parents` is 0 or the variant is delta.
    sparse_children: (Vec<u32>, Vec<u32>),
    progress: Progress,
}

/// The bytes the links may take: `link_memory` MiB, at most what the run's memory limit
/// leaves after the planned parts.
fn link_capacity(scene: &Scene, p: &SolverParams, limits: &Limits) -> u64 {
    let left = limits.max_memory as f64 - scene.report.planned_bytes;
    ((p.link_memory as u64) << 20).min(left.max(0.0) as u64)
}

/// Predicted value at node `j` of level `l ≥ 1` from the coarser levels of `next` (the
/// values of the levels above `l`: every index the prediction reads is below `l`'s).
fn predict(h: &Hierarchy, p: &SolverParams, next: &[Vec4], j: usize) -> Vec3 {
    let nd = &h.nodes[j];
    if p.variant.is_delta() {
        reconstruct::delta_sum(
            h,
            nd.object as usize,
            nd.level as usize - 1,
            Vec3::from(nd.pos),
            Vec3::from(nd.normal),
            next,
        )
    } else {
        pull_down(h, next, j).xyz()
    }
}

/// Each node's children with at most `k` parents, as CSR (empty for `k` = 0).
fn sparse_children(h: &Hierarchy, k: u32) -> (Vec<u32>, Vec<u32>) {
    if k == 0 {
        return (Vec::new(), Vec::new());
    }
    let lists: Vec<Vec<u32>> = (0..h.nodes.len())
        .into_par_iter()
        .map(|j| {
            h.children_of(j)
                .iter()
                .copied()
                .filter(|&c| h.parents_of(c as usize).len() <= k as usize)
                .collect()
        })
        .collect();
    let mut offsets = Vec::with_capacity(lists.len() + 1);
    let mut all = Vec::new();
    for l in &lists {
        offsets.push(all.len() as u32);
        all.extend_from_slice(l);
    }
    offsets.push(all.len() as u32);
    (offsets, all)
}

impl<'a> CpuBackend<'a> {
    /// The backend within the default limits ([`Limits::default`]).
    pub fn new(scene: &'a Scene, h: &'a Hierarchy, p: &SolverParams, progress: &Progress) -> Self {
        CpuBackend::within(scene, h, p, &Limits::default(), progress)
    }

    /// The backend within `limits` (the links are planned within `max_memory`).
    pub fn within(scene: &'a Scene, h: &'a Hierarchy, p: &SolverParams, limits: &Limits, progress: &Progress) -> Self {
        let n = h.nodes.len();
        let link_bytes = link_capacity(scene, p, limits);
        CpuBackend {
            scene,
            h,
            p: p.clone(),
            halton: halton_table(p.max_rays()),
            direct: vec![Vec4::ZERO; n],
            unshot: vec![Vec4::ZERO; n],
            next: vec![Vec4::ZERO; n],
            indirect: vec![Vec4::ZERO; n],
            gathered: vec![Gathered::default(); n],
            is_active: vec![false; n],
            active: Vec::new(),
            mean_direct: Vec3::ZERO,
            direct_error: None,
            links: (p.variant == Variant::Approx && p.link_memory > 0)
                .then(|| Links::new(n, p.rays as usize, p.level1_rays as usize, link_bytes)),
            link_bytes,
            keep_links: false,
            sparse_children: sparse_children(h, if p.variant.is_delta() { 0 } else { p.sparse_parents }),
            progress: progress.clone(),
        }
    }

    /// Hands over the links of an earlier solve of the same scene geometry, hierarchy and
    /// rays (an editing session's frame that changed only lights: the hits and the nodes
    /// they read are the same, `ALGORITHM.md` §5.6), for the next solve to read instead of
    /// tracing. Returns whether they were taken (they fit this backend).
    pub fn keep_links(&mut self, links: Links) -> bool {
        let fits = self.links.is_some()
            && links.fits(
                self.h.nodes.len(),
                self.p.rays as usize,
                self.p.level1_rays as usize,
                self.link_bytes,
            );
        if fits {
            self.links = Some(links);
            self.keep_links = true;
        }
        fits
    }

    /// The links, for a later solve of the same geometry ([`CpuBackend::keep_links`]).
    pub fn take_links(&mut self) -> Option<Links> {
        self.keep_links = false;
        self.links.take()
    }

    /// Per-node state: (direct, unshot, next, indirect), for checks against the GPU.
    pub fn state(&self) -> (&[Vec4], &[Vec4], &[Vec4], &[Vec4]) {
        (&self.direct, &self.unshot, &self.next, &self.indirect)
    }

    /// The gathered value of node `j` in the last gather of its level.
    pub fn gathered(&self, j: usize) -> Option<Gathered> {
        self.is_active[j].then_some(self.gathered[j])
    }

    /// The active nodes of `level`.
    fn active_list(&self, level: u32) -> Vec<u32> {
        if level <= 1 {
            self.h.level_range(level as usize).map(|j| j as u32).collect()
        } else {
            self.active.clone()
        }
    }
}

impl Backend for CpuBackend<'_> {
    fn name(&self) -> String {
        "cpu".into()
    }

    fn direct(&mut self) -> Result<Vec<u32>> {
        let (scene, h) = (self.scene, self.h);
        let bar = self.progress.bar(h.nodes.len() as u64, "direct");
        let nl = scene.sources();
        let lit: Vec<(Vec<bool>, f64)> = self
            .direct
            .par_iter_mut()
            .enumerate()
            .map(|(j, e)| {
                let mut lit = vec![false; nl];
                let (v, se) = direct_at_node(scene, h, j, &mut lit);
                *e = v.extend(0.0);
                if j % 1024 == 0 {
                    bar.inc(1024);
                }
                let lum = |c: Vec3| (c.x as f64 + c.y as f64 + c.z as f64) / 3.0;
                (lit, if lum(v) > 0.0 { lum(se) / lum(v) } else { -1.0 })
            })
            .collect();
        bar.finish();
        self.direct_error = (scene.emitters.any() || scene.sky.is_some()).then(|| {
            let rel: Vec<f64> = lit.iter().map(|l| l.1).filter(|&r| r >= 0.0).collect();
            super::DirectError {
                samples: scene.emitters.samples() as u32,
                shadow_rays: h.nodes.len() as u64
                    * scene.emitters.samples() as u64
                    * (scene.emitters.any() as u64 + scene.sky.is_some() as u64),
                lit_nodes: rel.len() as u64,
                mean_rel_std_err: rel.iter().sum::<f64>() / rel.len().max(1) as f64,
                max_rel_std_err: rel.iter().copied().fold(0.0, f64::max),
            }
        });
        let lit: Vec<Vec<bool>> = lit.into_iter().map(|l| l.0).collect();
        let counts = (0..nl).map(|i| lit.iter().filter(|l| l[i]).count() as u32).collect();
        let l0 = h.level_range(0);
        let count = l0.len().max(1) as f32;
        self.mean_direct = self.direct[l0].iter().map(|v| v.xyz()).sum::<Vec3>() / count;
        Ok(counts)
    }

    fn init_unshot(&mut self) -> Result<()> {
        self.indirect.fill(Vec4::ZERO);
        // Each solve records its own links: a warm solve (benchmarks) costs what a cold one
        // does, and its statistics count its own integrals. Links handed over for a
        // relighting frame are kept (their counts start again).
        if let Some(l) = self.links.as_mut() {
            if std::mem::take(&mut self.keep_links) {
                l.new_solve();
            } else {
                l.clear();
            }
        }
        if !self.p.variant.is_delta() {
            self.unshot.copy_from_slice(&self.direct);
            return Ok(());
        }
        // Delta coefficients of E_d: α^0 = f, α^l = f − F_{l−1}(x_j) (paper §3).
        for l in 0..self.h.levels as usize {
            let range = self.h.level_range(l);
            let vals: Vec<Vec4> = range
                .clone()
                .into_par_iter()
                .map(|j| {
                    let nd = &self.h.nodes[j];
                    let f = self.direct[j].xyz();
                    if l == 0 {
                        return f.extend(0.0);
                    }
                    let pred = reconstruct::delta_sum(
                        self.h,
                        nd.object as usize,
                        l - 1,
                        Vec3::from(nd.pos),
                        Vec3::from(nd.normal),
                        &self.unshot,
                    );
                    (f - pred).extend(0.0)
                })
                .collect();
            self.unshot[range].copy_from_slice(&vals);
        }
        Ok(())
    }

    fn gather(&mut self, level: u32, exact: bool) -> Result<u32> {
        let list = self.active_list(level);
        // Links serve the sender reads. The exact first bounce traces every integral (its
        // samples are the direct irradiance at the hits) and records the links of the
        // nodes that have none, for the later bounces.
        // Level 1 takes more rays (`level1_rays`): the first ones of the same Halton
        // sequence, so the other levels' integrals are unchanged.
        let rays = self.p.rays_at(level);
        let record = match self.links.as_mut() {
            Some(l) => l.plan(&list, exact, self.p.slots_at(level) as u64),
            None => vec![false; list.len()],
        };
        let links = self.links.as_ref().filter(|_| !exact);
        let (scene, h, p, unshot) = (self.scene, self.h, &self.p, &self.unshot);
        let halton = &self.halton[..rays as usize];
        let bar = self.progress.bar(list.len() as u64, &format!("level {level}"));
        let results: Vec<(Gathered, Option<Kept>)> = list
            .par_iter()
            .zip(&record)
            .map_init(Vec::new, |buf: &mut Vec<Link>, (&j, &rec)| {
                let j = j as usize;
                let out = match links.and_then(|l| l.of(j)) {
                    Some(l) => (links::gather(l, unshot, scene), None),
                    None if rec => {
                        // A scratch record per thread; the node keeps it in its own form.
                        buf.clear();
                        buf.resize(halton.len(), Link::NONE);
                        let g = trace_integral(scene, h, p, halton, unshot, j, exact, Some(buf));
                        (g, Some(Kept::of(buf)))
                    }
                    None => (gather_integral(scene, h, p, halton, unshot, j, exact), None),
                };
                bar.inc(1);
                out
            })
            .collect();
        bar.finish();
        self.is_active[h.level_range(level as usize)].fill(false);
        for (&j, (g, rec)) in list.iter().zip(results) {
            self.gathered[j as usize] = g;
            self.is_active[j as usize] = true;
            if let (Some(l), Some(rec)) = (self.links.as_mut(), rec) {
                l.store(j as usize, rec);
            }
        }
        Ok(list.len() as u32)
    }

    fn refine(&mut self, level: u32, activate: bool, sparse: u32) -> Result<Refined> {
        let range = self.h.level_range(level as usize);
        let delta = self.p.variant.is_delta();
        let sparse = if delta { 0 } else { sparse as usize };
        let floor = self.mean_direct * self.p.eps_abs;
        // The level's new values go straight into `next`; predictions read the coarser
        // levels only. Per node: 1 refined, 2 a lit node whose sparse children are gathered
        // even where the oracle trusts the pull-down (kernel `oracle` does the same), 0.
        let (coarse, rest) = self.next.split_at_mut(range.start);
        let (h, p, gathered, is_active, mean_direct) =
            (self.h, &self.p, &self.gathered, &self.is_active, self.mean_direct);
        let marks: Vec<u8> = rest[..range.len()]
            .par_iter_mut()
            .enumerate()
            .map(|(k, next)| {
                let j = range.start + k;
                let g = &gathered[j];
                let (v, r) = match (level, is_active[j], delta) {
                    (0, _, _) => (g.mean.extend(0.0), false),
                    (_, false, true) => (Vec4::ZERO, false),
                    (_, active, _) => {
                        let pred = predict(h, p, coarse, j);
                        match (active, delta) {
                            (true, false) => (g.mean.extend(0.0), oracle(p, g, pred, mean_direct)),
                            (true, true) => ((g.mean - pred).extend(0.0), oracle(p, g, pred, mean_direct)),
                            _ => (pred.extend(0.0), false),
                        }
                    }
                };
                *next = v;
                if r {
                    1
                } else if activate && sparse > 0 && v.xyz().cmpgt(floor).any() {
                    2
                } else {
                    0
                }
            })
            .collect();
        let refined = marks.iter().filter(|&&m| m == 1).count() as u32;
        if activate {
            let mut flags = vec![false; self.h.nodes.len()];
            // The lists made for the backend's `sparse_parents`; another bound (a caller's
            // own) counts parents here.
            let (offsets, listed) = &self.sparse_children;
            let listed = (sparse == self.p.sparse_parents as usize && !offsets.is_empty()).then_some((offsets, listed));
            for (j, &m) in range.zip(&marks) {
                let children = match (m, listed) {
                    (1, _) => self.h.children_of(j),
                    (2, Some((offsets, listed))) => &listed[offsets[j] as usize..offsets[j + 1] as usize],
                    (2, None) => {
                        for &c in self.h.children_of(j) {
                            if self.h.parents_of(c as usize).len() <= sparse {
                                flags[c as usize] = true;
                            }
                        }
                        continue;
                    }
                    _ => continue,
                };
                for &c in children {
                    flags[c as usize] = true;
                }
            }
            let next_range = self.h.level_range(level as usize + 1);
            self.active = next_range.filter(|&c| flags[c]).map(|c| c as u32).collect();
        }
        Ok(Refined {
            refined,
            activated: if activate { self.active.len() as u32 } else { 0 },
        })
    }

    fn fill(&mut self, from: u32) -> Result<()> {
        for l in from as usize..self.h.levels as usize {
            let range = self.h.level_range(l);
            if self.p.variant == Variant::Original {
                self.next[range].fill(Vec4::ZERO);
            } else {
                let vals: Vec<Vec4> = range
                    .clone()
                    .into_par_iter()
                    .map(|c| pull_down(self.h, &self.next, c))
                    .collect();
                self.next[range].copy_from_slice(&vals);
            }
        }
        Ok(())
    }

    fn end_bounce(&mut self) -> Result<Energy> {
        for (e, n) in self.indirect.iter_mut().zip(&self.next) {
            *e += *n;
        }
        std::mem::swap(&mut self.unshot, &mut self.next);
        let l0 = self.h.level_range(0);
        let lum = |v: &Vec4| (v.x as f64 + v.y as f64 + v.z as f64) / 3.0;
        Ok(Energy {
            unshot: self.unshot[l0.clone()].iter().map(lum).sum(),
            direct: self.direct[l0].iter().map(lum).sum(),
        })
    }

    fn values(&mut self) -> Result<NodeValues> {
        Ok(NodeValues {
            direct: self.direct.clone(),
            indirect: self.indirect.clone(),
        })
    }

    fn link_stats(&self) -> Option<LinkStats> {
        self.links.as_ref().map(|l| l.stats.clone())
    }

    fn direct_error(&self) -> Option<super::DirectError> {
        self.direct_error.clone()
    }
}
