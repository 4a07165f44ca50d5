//! Light transport (paper §3–§5, `ALGORITHM.md` §5): the bounce loop gathering the
//! un-shot energy, breadth-first over levels, with the refinement oracle and pull-down.
//!
//! The loop is written once, here; a [`Backend`] owns the per-node arrays and runs each
//! stage where they live (the CPU reference in [`cpu`], Vulkan compute in `crate::device`).
//! Per-ray state never leaves a backend; between stages only counts cross.

pub mod coverage;
pub mod cpu;
pub mod estimator;
pub mod links;
pub mod readout;
pub mod reconstruct;

use std::time::Instant;

use glam::{Vec3, Vec4};
use serde::Serialize;

use crate::error::Result;
use crate::geom::transform::xform_point;
use crate::geom::transform::xform_vector;
use crate::hierarchy::Hierarchy;
use crate::params::{SolverParams, Variant};
use crate::progress::Progress;
use crate::scene::Scene;

/// Energy of a bounce's un-shot irradiance and of the direct irradiance, summed over the
/// level-0 nodes (absolute in both hierarchies), mean of the RGB channels.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Energy {
    pub unshot: f64,
    pub direct: f64,
}

/// What the oracle decided on a level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Refined {
    /// Gathered nodes whose value the oracle refines.
    pub refined: u32,
    /// Nodes of the next level activated (children of refined nodes), if asked.
    pub activated: u32,
}

/// Per-node results, in the hierarchy's global node order.
#[derive(Clone, Debug)]
pub struct NodeValues {
    /// Exact direct irradiance `E_d` at every node.
    pub direct: Vec<Vec4>,
    /// Indirect irradiance: absolute per node (modified), delta coefficients (original).
    pub indirect: Vec<Vec4>,
}

/// One stage-by-stage implementation of the transport.
pub trait Backend {
    /// Device or "cpu", for stats.
    fn name(&self) -> String;
    /// `E_d` at every node by shadow rays; returns, per light, how many nodes it lights.
    fn direct(&mut self) -> Result<Vec<u32>>;
    /// Un-shot := `E_d` in the variant's representation; indirect := 0.
    fn init_unshot(&mut self) -> Result<()>;
    /// Gathering integrals for the active nodes of `level` (all nodes on levels 0 and 1,
    /// else those activated by `refine(level − 1, true)`); returns their count. With
    /// `exact_direct` (the first bounce under `exact_first_bounce`) the hits read the
    /// exact direct irradiance instead of the sender level.
    fn gather(&mut self, level: u32, exact_direct: bool) -> Result<u32>;
    /// Prediction, oracle and new values of `level`; with `activate`, the children of the
    /// refined nodes become the active set of `level + 1`, and so do the children with at
    /// most `sparse` parents of the lit nodes that are not refined (`sparse_parents` in
    /// the bounces it applies to, else 0; ignored by the delta hierarchy).
    fn refine(&mut self, level: u32, activate: bool, sparse: u32) -> Result<Refined>;
    /// Levels `from..m` without integrals: pull-down (modified) or zero deltas (original).
    fn fill(&mut self, from: u32) -> Result<()>;
    /// Indirect += new; un-shot := new.
    fn end_bounce(&mut self) -> Result<Energy>;
    /// Reads the per-node results.
    fn values(&mut self) -> Result<NodeValues>;
    /// A whole bounce at once, when the backend can do better than stage by stage (the
    /// GPU: one submission, the active sets' sizes never leave the device until the end).
    /// It must compute exactly what [`bounce`]'s stages compute, gathering every level
    /// `0..gather_levels()` (an empty level's integrals are 0).
    fn bounce_fused(&mut self, _exact_direct: bool, _sparse: u32) -> Result<Option<FusedBounce>> {
        Ok(None)
    }
    /// Per-kernel times in seconds (GPU timestamps), if the backend measures them.
    fn kernel_times(&mut self) -> Vec<(String, f64)> {
        Vec::new()
    }
    /// What the links did (`links`), if the backend keeps them.
    fn link_stats(&self) -> Option<links::LinkStats> {
        None
    }
    /// The sampling error of the nodes' direct irradiance (emitting surfaces), if any.
    fn direct_error(&self) -> Option<DirectError> {
        None
    }
}

/// The Monte Carlo error of the direct irradiance at the nodes (emitting surfaces and the
/// sky are sampled; lights are exact): `stats.json` `solve.direct_error`.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct DirectError {
    /// Rays per node to the emitters and to the sky (`emitter_samples` each), and in all.
    pub samples: u32,
    pub shadow_rays: u64,
    /// Nodes with direct light.
    pub lit_nodes: u64,
    /// Mean and largest standard error relative to the value (luminance), over those.
    pub mean_rel_std_err: f64,
    pub max_rel_std_err: f64,
}

/// What a fused bounce reports, per gathered level: integrals and refined nodes; and the
/// energies after it.
#[derive(Clone, Debug, Default)]
pub struct FusedBounce {
    pub integrals: Vec<u32>,
    pub refined: Vec<u32>,
    pub energy: Energy,
}

impl Energy {
    /// Un-shot energy relative to the direct energy.
    pub fn ratio(&self) -> f64 {
        if self.direct > 0.0 {
            self.unshot / self.direct
        } else {
            0.0
        }
    }
}

/// Statistics of one bounce.
#[derive(Clone, Debug, Default, Serialize)]
pub struct BounceStats {
    pub bounce: u32,
    pub integrals_per_level: Vec<u32>,
    pub refined_per_level: Vec<u32>,
    pub seconds: f64,
    /// Un-shot energy after this bounce relative to the direct energy.
    pub unshot_ratio: f64,
    /// The first gathered level that had no active node (skipped with the finer ones).
    pub empty_from: Option<u32>,
}

/// Statistics of a solve.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SolveStats {
    pub backend: String,
    pub variant: String,
    pub seconds_direct: f64,
    pub seconds_init: f64,
    pub seconds_bounces: f64,
    pub bounces: Vec<BounceStats>,
    pub integrals: u64,
    /// Rays per gathering integral (`rays`, or fewer where the mean free path raised the
    /// node count: `Hierarchy::gather_params`); level 1's take `level1_rays` times that.
    pub rays_per_integral: u32,
    /// Gathering rays the integrals stand for (integrals × rays), traced or read from links.
    pub rays_gathered: u64,
    /// Gathering rays actually traced: `rays_gathered` less those served by links.
    pub rays_traced: u64,
    pub stopped_early: Option<String>,
    /// Set when the bounce cap was reached before the un-shot energy fell below
    /// `stop_threshold`: the series is cut, light is missing.
    pub unconverged: Option<String>,
    /// Work a scene did not need, and why.
    pub skipped: Vec<String>,
    /// Nodes lit by each light source (`Scene::sources`: the lights in file order, then the
    /// emitting surfaces as one entry when there are any).
    pub nodes_lit_per_light: Vec<u32>,
    pub kernel_seconds: Vec<(String, f64)>,
    /// The gathering rays' links: memory, nodes, integrals served (`links`); `None` where
    /// the backend or the variant keeps none.
    pub links: Option<links::LinkStats>,
    /// The direct irradiance's sampling error at the nodes; `None` without emitters.
    pub direct_error: Option<DirectError>,
}

/// The solved hierarchy values.
#[derive(Clone, Debug)]
pub struct Solution {
    pub variant: Variant,
    pub values: NodeValues,
    pub stats: SolveStats,
}

/// Runs the bounce loop of `ALGORITHM.md` §5 on `backend`.
pub fn solve(p: &SolverParams, backend: &mut dyn Backend, progress: &Progress) -> Result<Solution> {
    let mut stats = SolveStats {
        backend: backend.name(),
        variant: p.variant.name().into(),
        rays_per_integral: p.rays,
        ..Default::default()
    };
    let t = Instant::now();
    progress.stage("direct irradiance at nodes");
    stats.nodes_lit_per_light = backend.direct()?;
    stats.seconds_direct = t.elapsed().as_secs_f64();
    for (i, &n) in stats.nodes_lit_per_light.iter().enumerate() {
        if n == 0 {
            stats.skipped.push(format!(
                "light {i} reaches no node (outside its cone, facing away, or blocked): its direct light is in the \
                 images and probes, but it adds no indirect light (raise coarsest or levels if its beam falls between nodes)"
            ));
        }
    }
    let t = Instant::now();
    backend.init_unshot()?;
    stats.seconds_init = t.elapsed().as_secs_f64();
    let all = Instant::now();
    for k in 1..=p.bounces {
        progress.stage(&format!("bounce {k}/{}", p.bounces));
        let b = bounce(backend, p, k)?;
        if let Some(l) = b.empty_from {
            stats.skipped.push(format!(
                "bounce {k}: levels {l}..{} had no active node: no integrals, filled by {}",
                p.gather_levels(),
                if p.variant.is_delta() {
                    "zero deltas"
                } else {
                    "pull-down"
                }
            ));
        }
        let integrals: u64 = b.integrals_per_level.iter().map(|&n| n as u64).sum();
        stats.integrals += integrals;
        stats.rays_gathered += b
            .integrals_per_level
            .iter()
            .enumerate()
            .map(|(l, &n)| n as u64 * p.rays_at(l as u32) as u64)
            .sum::<u64>();
        let ratio = b.unshot_ratio;
        stats.bounces.push(b);
        if ratio < p.stop_threshold as f64 && k < p.bounces {
            stats.stopped_early = Some(format!(
                "after bounce {k}: un-shot energy {ratio:.3e} of the direct energy is below stop_threshold {}",
                p.stop_threshold
            ));
            break;
        }
        if k == p.bounces && ratio >= p.stop_threshold as f64 && p.stop_threshold > 0.0 {
            stats.unconverged = Some(format!(
                "the bounce cap {k} (solver key bounces) was reached with un-shot energy {ratio:.3e} of the direct \
                 energy, above stop_threshold {}: about that fraction of the indirect light is missing; raise bounces",
                p.stop_threshold
            ));
        }
    }
    stats.seconds_bounces = all.elapsed().as_secs_f64();
    let values = backend.values()?;
    stats.kernel_seconds = backend.kernel_times();
    stats.links = backend.link_stats();
    stats.direct_error = backend.direct_error();
    let linked = stats.links.as_ref().map_or(0, |l| l.rays_linked);
    stats.rays_traced = stats.rays_gathered.saturating_sub(linked);
    Ok(Solution {
        variant: p.variant,
        values,
        stats,
    })
}

impl BounceStats {
    /// Whether level `l` is empty given the active count the level above left it (no
    /// node of a level ≥ 2 active: nothing to gather; the level and the finer ones take
    /// their predictions, exactly what `refine` would give them). Marks where the
    /// emptiness starts.
    fn stops_at(&mut self, l: u32, active: u32) -> bool {
        let empty = l >= 2 && active == 0;
        if empty {
            self.empty_from = Some(l);
        }
        empty
    }
}

/// One bounce: gather levels `0..G` breadth-first with the oracle between them, fill the
/// finer levels, accumulate — stage by stage, or fused where the backend can. Which level
/// comes next, when a level is empty and the statistics are decided here for both.
pub fn bounce(backend: &mut dyn Backend, p: &SolverParams, k: u32) -> Result<BounceStats> {
    let t = Instant::now();
    let g = p.gather_levels();
    let mut b = BounceStats {
        bounce: k,
        ..Default::default()
    };
    // In the first bounce the un-shot field is E_d itself: read exactly at the hits.
    let exact_direct = k == 1 && p.exact_first_bounce;
    let sparse = if k <= p.sparse_bounces { p.sparse_parents } else { 0 };
    let e = if let Some(f) = backend.bounce_fused(exact_direct, sparse)? {
        for l in 0..g {
            if b.stops_at(l, f.integrals[l as usize]) {
                break;
            }
            b.integrals_per_level.push(f.integrals[l as usize]);
            b.refined_per_level.push(f.refined[l as usize]);
        }
        f.energy
    } else {
        let mut next_active = u32::MAX;
        for l in 0..g {
            if b.stops_at(l, next_active) {
                break;
            }
            b.integrals_per_level.push(backend.gather(l, exact_direct)?);
            let r = backend.refine(l, l >= 1 && l + 1 < g, sparse)?;
            b.refined_per_level.push(r.refined);
            next_active = r.activated;
        }
        backend.fill(b.empty_from.unwrap_or(g))?;
        backend.end_bounce()?
    };
    b.seconds = t.elapsed().as_secs_f64();
    b.unshot_ratio = e.ratio();
    Ok(b)
}

impl Solution {
    /// Indirect irradiance at an object-space surface point of object `o`.
    pub fn indirect_on(&self, h: &Hierarchy, o: usize, p_obj: Vec3, n_obj: Vec3, level: u32) -> Vec3 {
        reconstruct::output(
            h,
            self.variant.is_delta(),
            o,
            level as usize,
            p_obj,
            n_obj,
            &self.values.indirect,
        )
    }

    /// Indirect irradiance at a world-space point `(x, n)` near some surface: the object
    /// with the most basis weight there on the finest level that covers it answers.
    pub fn indirect_at(&self, scene: &Scene, h: &Hierarchy, x: Vec3, n: Vec3, level: u32) -> Vec3 {
        match self.locate(scene, h, x, n, level) {
            Some((o, p, nn)) => self.indirect_on(h, o, p, nn, level),
            None => Vec3::ZERO,
        }
    }

    /// The object that answers at a world-space point `(x, n)` near some surface (the one
    /// with the most basis weight there on the finest level ≤ `level` that covers it), and
    /// the point and normal in its space; `None` where no level of any object covers it.
    pub fn locate(&self, scene: &Scene, h: &Hierarchy, x: Vec3, n: Vec3, level: u32) -> Option<(usize, Vec3, Vec3)> {
        let local: Vec<(Vec3, Vec3)> = scene
            .objects
            .iter()
            .map(|o| {
                let p = xform_point(&o.to_object, x);
                (p, xform_vector(&o.to_object, n).normalize_or_zero())
            })
            .collect();
        for l in (0..=level as usize).rev() {
            let best = local
                .iter()
                .enumerate()
                .map(|(o, &(p, nn))| (o, reconstruct::shepard_sums(h, o, l, p, nn, &self.values.indirect).1))
                .filter(|&(_, w)| w > 0.0)
                .max_by(|a, b| a.1.total_cmp(&b.1));
            if let Some((o, _)) = best {
                let (p, nn) = local[o];
                return Some((o, p, nn));
            }
        }
        None
    }
}
