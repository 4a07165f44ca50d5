//! The GPU transport backend: the whole bounce loop on the device. The scene, the
//! hierarchy and the per-node state are uploaded once and stay resident
//! (`super::resources`); rays, hits and samples live only on the device; between stages
//! only counts come back. What is recorded, in which order, is `super::schedule`'s.

use std::sync::Arc;
use std::time::Instant;

use glam::Vec4;

use super::arrange::{ArrangeKernels, Arranged};
use super::globals::{LINK_RECORD_BYTES, RAY_BYTES};
use super::image::ImageState;
use super::kernels::{Kernels, Recorder};
use super::resources::{cwbvh_of, Resources, ENERGY_READ_BYTES, LEVEL_COUNTER_BYTES};
use super::schedule::{Active, Schedule};
use crate::constants::{
    BVH_BVH2, BVH_CWBVH, COUNTERS_PER_LEVEL, COUNTER_ACTIVATED, COUNTER_LINKED, COUNTER_REFINED, ENERGY_DIRECT,
    ENERGY_UNSHOT, LIGHT_COUNTERS, LINK_COUNTERS, LINK_LINKED, LINK_LINKED_SLOTS, LINK_NODES, LINK_TAKEN, LINK_TRACED,
    LINK_TRACED_FULL, VARIANT_APPROX, VARIANT_MODIFIED, VARIANT_ORIGINAL,
};
use crate::error::{Error, Result};
use crate::gpu::context::Context;
use crate::gpu::pipeline::Specialization;
use crate::gpu::profiler::Profiler;
use crate::hierarchy::{Arrangement, ClipSelection, Hierarchy};
use crate::params::{BvhKind, SolverParams, Variant};
use crate::progress::Progress;
use crate::scene::Scene;
use crate::transport::links::LinkStats;
use crate::transport::{Backend, Energy, FusedBounce, NodeValues, Refined};

/// Rays (origin, direction), hit records (object, triangle, b1 bits, b2 bits) and samples.
pub type BatchReadback = (Vec<[Vec4; 2]>, Vec<[u32; 4]>, Vec<Vec4>);

/// Per-node arrays that can be read back for checks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum State {
    Direct,
    Unshot,
    Next,
    Indirect,
    Pred,
    GatheredMean,
    GatheredErr,
}

/// What the backend did, beyond the transport's own statistics.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct GpuReport {
    pub device: String,
    pub driver: String,
    pub api_version: String,
    pub batch_integrals: u32,
    /// Bytes sent to the device for this solve (the whole scene for a fresh one; after
    /// an edit the lights, `Globals`, and after a move the transforms and the clip
    /// selection).
    pub bytes_uploaded: u64,
    /// Bytes the arrangement on the device read back before this solve (the changed
    /// clips and the relations: `super::arrange`; 0 when nothing moved).
    pub arrange_bytes_read_back: u64,
    /// CWBVH nodes built (0 unless `bvh = "cwbvh"`).
    pub cwbvh_nodes: usize,
    pub seconds_upload: f64,
    pub seconds_pipelines: f64,
    pub validation_errors: u32,
    /// Kernels that were built but never dispatched in this solve.
    pub kernels_never_dispatched: Vec<String>,
    /// Launches past the timestamp pool's capacity in one submission: dispatched, not in
    /// the per-kernel times (0 unless a bounce records more than 4096 launches).
    pub untimed_launches: u64,
    /// Work left out of this solve by construction, and why.
    pub skipped: Vec<String>,
}

/// Vulkan compute backend.
pub struct GpuBackend<'a> {
    ctx: Arc<Context>,
    h: &'a Hierarchy,
    p: SolverParams,
    k: Kernels,
    arrange: ArrangeKernels,
    prof: Profiler,
    res: Resources,
    batch: u32,
    /// The active count of the next level to gather, from the last `refine`.
    active_count: u32,
    /// Light sources (`Scene::sources`): the lights, the emitters as one, the sky.
    lights: usize,
    /// How many sources are sampled (the emitters, the sky), and with how many samples.
    sampled_sources: u32,
    samples: u32,
    /// The nodes' direct-light sampling error, from the last `direct`.
    direct_error: Option<crate::transport::DirectError>,
    /// The next solve reads the last solve's links ([`GpuBackend::keep_links`]).
    keep_links: bool,
    /// The link counters when the last solve ended (a kept solve counts from there).
    link_base: Option<[u32; LINK_COUNTERS as usize]>,
    /// A solve ran to its end (its links are whole).
    solved: bool,
    /// Bounces this solve has ended (`Schedule::linked_levels` reads it).
    bounces_done: u32,
    /// The `image` kernel, once an image was drawn on this state (`super::image`).
    image: Option<ImageState>,
    pub report: GpuReport,
}

/// What stays on the device between the solves of an editing session (`crate::editor`):
/// pipelines, the scene's triangles, BVHs and textures, the hierarchy's nodes and
/// kd-trees, the per-node state. [`GpuBackend::resume`] uploads only what an edit changed.
pub struct GpuResident {
    k: Kernels,
    /// The arrangement's kernels (run by [`GpuResident::arrange`], before a solve).
    arrange: ArrangeKernels,
    pub(super) prof: Profiler,
    pub(super) res: Resources,
    /// The `image` kernel, built at the first image drawn on this state (`super::image`).
    pub(super) image: Option<ImageState>,
    batch: u32,
    /// The link counters when the last solve ended (`None` before the first solve).
    link_base: Option<[u32; LINK_COUNTERS as usize]>,
    report: GpuReport,
}

/// The specialization constants of a solve.
pub(crate) fn specialization(p: &SolverParams, scene: &Scene) -> Specialization {
    Specialization {
        variant: match p.variant {
            Variant::Original => VARIANT_ORIGINAL,
            Variant::Modified => VARIANT_MODIFIED,
            Variant::Approx => VARIANT_APPROX,
        },
        textured: scene.textured(),
        bvh: match p.bvh {
            BvhKind::Bvh2 => BVH_BVH2,
            BvhKind::Cwbvh => BVH_CWBVH,
        },
    }
}

impl GpuResident {
    /// Builds the pipelines, the CWBVH if `p` asks for it, and uploads the scene and
    /// hierarchy (its clips and relations as they are: [`GpuResident::arrange`] computes
    /// them on the device).
    pub fn new(ctx: &Arc<Context>, scene: &Scene, h: &Hierarchy, p: &SolverParams) -> Result<GpuResident> {
        let t = Instant::now();
        let spec = specialization(p, scene);
        let k = Kernels::new(ctx, spec)?;
        let arrange = ArrangeKernels::new(ctx, spec)?;
        let seconds_pipelines = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let batch = batch_size(ctx, p);
        let res = Resources::new(ctx, scene, h, p, batch)?;
        let report = GpuReport {
            device: ctx.info.name.clone(),
            driver: format!("{} {}", ctx.info.driver_name, ctx.info.driver_info),
            api_version: ctx.info.api_version.clone(),
            batch_integrals: batch,
            bytes_uploaded: res.scene.bytes(),
            cwbvh_nodes: cwbvh_of(scene, p).0.len(),
            seconds_upload: t.elapsed().as_secs_f64(),
            seconds_pipelines,
            skipped: skipped_by_construction(p, scene),
            ..Default::default()
        };
        Ok(GpuResident {
            prof: Profiler::new(ctx)?,
            k,
            arrange,
            res,
            image: None,
            batch,
            link_base: None,
            report,
        })
    }

    /// [`GpuResident::new`] for a hierarchy from [`Hierarchy::build_unarranged`] (or one
    /// to arrange again from scratch), then arranged on the device
    /// ([`GpuResident::arrange`] of every node).
    pub fn arranged(
        ctx: &Arc<Context>,
        scene: &Scene,
        h: &mut Hierarchy,
        p: &SolverParams,
        progress: &Progress,
    ) -> Result<GpuResident> {
        let mut r = GpuResident::new(ctx, scene, h, p)?;
        r.arrange(ctx, scene, h, p, None, progress)?;
        Ok(r)
    }

    /// Brings `h` (and its copy on the device) to `scene`'s arrangement on the device
    /// ([`super::arrange::arrange`]), where the transport runs: every node's clip and
    /// parent list (`moved = None`: a hierarchy from [`Hierarchy::build_unarranged`]), or
    /// after the objects `moved` were placed anew (`before`: the arrangement `h` has)
    /// those the move can change ([`ClipSelection::after`]). Uploads the moved objects'
    /// transforms first.
    pub fn arrange(
        &mut self,
        ctx: &Arc<Context>,
        scene: &Scene,
        h: &mut Hierarchy,
        p: &SolverParams,
        moved: Option<(&Arrangement, &[usize])>,
        progress: &Progress,
    ) -> Result<Arranged> {
        // The hits and the nodes they read change: no links survive.
        self.link_base = None;
        let mut up = 0;
        let sel = match moved {
            None => ClipSelection::All,
            Some((before, objects)) => {
                up += self.res.upload_objects(ctx, scene, h)?;
                ClipSelection::after(scene, before, objects)
            }
        };
        up += self.res.write_globals(ctx, scene, h, p)?;
        let mut device = super::arrange::Device {
            ctx,
            kernels: &self.arrange,
            prof: &mut self.prof,
            res: &mut self.res,
        };
        let mut a = super::arrange::arrange(&mut device, scene, h, p, &sel, progress)?;
        if matches!(sel, ClipSelection::All) {
            a.clips_computed = h.nodes.len();
            a.parents_computed = h.nodes.len();
        }
        a.bytes_up += up;
        self.report.bytes_uploaded += a.bytes_up;
        self.report.arrange_bytes_read_back += a.bytes_down;
        Ok(a)
    }
}

impl<'a> GpuBackend<'a> {
    /// Builds the pipelines, the CWBVH if `p` asks for it, and uploads the scene and
    /// hierarchy (as arranged on the host).
    pub fn new(ctx: Arc<Context>, scene: &'a Scene, h: &'a Hierarchy, p: &SolverParams) -> Result<GpuBackend<'a>> {
        let r = GpuResident::new(&ctx, scene, h, p)?;
        GpuBackend::resume(ctx, r, scene, h, p)
    }

    /// Keeps what is on the device for the next solve of an editing session (its report
    /// counts what the next solve sends anew).
    pub fn suspend(self) -> GpuResident {
        let mut report = self.report;
        report.bytes_uploaded = 0;
        report.arrange_bytes_read_back = 0;
        report.seconds_upload = 0.0;
        report.seconds_pipelines = 0.0;
        let link_base = (self.solved && self.res.state.link_capacity > 0)
            .then(|| {
                self.res
                    .state
                    .link_counters
                    .download::<u32>(0, LINK_COUNTERS as usize)
                    .ok()
            })
            .flatten()
            .and_then(|c| c.try_into().ok());
        GpuResident {
            link_base,
            k: self.k,
            arrange: self.arrange,
            prof: self.prof,
            res: self.res,
            image: self.image,
            batch: self.batch,
            report,
        }
    }

    /// The backend over resident state `r`, for the same hierarchy's nodes `h` (as
    /// [`GpuResident::arrange`] left it, if objects moved), after uploading the lights
    /// (and rewriting `Globals`). Its report counts what was sent since `r` was made or
    /// suspended.
    pub fn resume(
        ctx: Arc<Context>,
        r: GpuResident,
        scene: &Scene,
        h: &'a Hierarchy,
        p: &SolverParams,
    ) -> Result<GpuBackend<'a>> {
        let mut r = r;
        let t = Instant::now();
        r.report.bytes_uploaded += r.res.relight(&ctx, scene, h, p)?;
        r.report.seconds_upload += t.elapsed().as_secs_f64();
        Ok(GpuBackend {
            ctx,
            h,
            p: p.clone(),
            k: r.k,
            arrange: r.arrange,
            prof: r.prof,
            res: r.res,
            batch: r.batch,
            active_count: 0,
            lights: scene.sources(),
            sampled_sources: scene.emitters.any() as u32 + scene.sky.is_some() as u32,
            samples: scene.emitters.samples() as u32,
            direct_error: None,
            keep_links: false,
            link_base: r.link_base,
            solved: false,
            bounces_done: 0,
            image: r.image,
            report: r.report,
        })
    }

    /// Keeps the links of the last solve on this resident state for the next solve: the
    /// caller promises the same geometry, transforms, hierarchy (clips included) and
    /// parameters (an editing session's frame that changed only lights: the hits and the
    /// nodes they read are the same, `ALGORITHM.md` §5.6). Returns whether there are
    /// links to keep.
    pub fn keep_links(&mut self) -> bool {
        self.keep_links = self.link_base.is_some();
        self.keep_links
    }

    /// The levels whose nodes all hold links now: after a solve's first bounce, levels
    /// 0 and 1 (those of them that are gathered), when there are slots for all their
    /// nodes. Every bounce gathers every node of those levels, and the first bounce's
    /// first slot requests are theirs (a solve starts with no links, or keeps a solve's
    /// whose first bounce linked the same nodes), so each got one and recorded its links
    /// (the exact first bounce records them too).
    fn linked_levels(&self) -> u32 {
        let levels = self.p.gather_levels().min(2);
        // Their slots: one a node, `level1_rays` a node of level 1.
        let slots = (0..levels)
            .map(|l| self.h.level_range(l as usize).len() as u64 * self.p.slots_at(l) as u64)
            .sum::<u64>();
        // `linked` is built for the variant that keeps links (as `Schedule::splits` asks).
        let links = self.k.linked.is_some() && self.res.state.link_capacity > 0;
        if links && self.bounces_done >= 1 && slots <= self.res.state.link_capacity as u64 {
            levels
        } else {
            0
        }
    }

    /// Records stages of the schedule into one command buffer, submits it, waits, and
    /// collects the timestamps.
    fn submit(&mut self, f: impl FnOnce(&Schedule, &mut Recorder)) -> Result<()> {
        let linked_levels = self.linked_levels();
        let schedule = Schedule {
            k: &self.k,
            res: &self.res,
            h: self.h,
            batch: self.batch,
            p: &self.p,
            delta: self.p.variant.is_delta(),
            max_groups_x: self.ctx.info.max_workgroup_count_x.clamp(1, 65535),
            reset_links: !self.keep_links,
            linked_levels,
        };
        super::kernels::submit(&self.ctx, &mut self.prof, self.res.globals.address, |rec| {
            f(&schedule, rec)
        })
    }

    /// Reads a per-node state array (tests and diagnostics).
    pub fn read_state(&self, which: State) -> Result<Vec<Vec4>> {
        let st = &self.res.state;
        let b = match which {
            State::Direct => &st.direct,
            State::Unshot => &st.unshot,
            State::Next => &st.next,
            State::Indirect => &st.indirect,
            State::Pred => &st.pred,
            State::GatheredMean => &st.gathered_mean,
            State::GatheredErr => &st.gathered_err,
        };
        b.download(0, self.h.nodes.len())
    }

    /// Reads the first `n` rays (origin, direction), hits and samples of the last batch.
    pub fn read_batch(&self, n: usize) -> Result<BatchReadback> {
        let b = &self.res.batch;
        Ok((
            b.rays.download(0, n)?,
            b.hits.download(0, n)?,
            b.samples.download(0, n)?,
        ))
    }

    /// Validation errors so far (0 unless validation is on).
    pub fn validation_errors(&self) -> u32 {
        self.ctx.validation_errors()
    }
}

fn skipped_by_construction(p: &SolverParams, scene: &Scene) -> Vec<String> {
    let mut v = vec![if p.variant.is_delta() {
        "pipeline `pulldown` not built: the delta hierarchy fills levels with zero deltas".to_string()
    } else {
        "pipeline `delta` not built: the absolute hierarchy needs no delta coefficients".to_string()
    }];
    if !scene.textured() {
        v.push("texture sampling compiled out (specialization constant): no textured material".into());
    }
    v
}

/// Integrals in flight: the rays buffer gets at most an eighth of device memory, 512 MiB
/// and the device's largest allocation (the paper: 1000 integrals = 512k rays on 1.5 GB).
fn batch_size(ctx: &Context, p: &SolverParams) -> u32 {
    if p.batch_integrals > 0 {
        return p.batch_integrals;
    }
    let mut budget = (ctx.info.device_local_bytes / 8).min(512 << 20);
    if ctx.info.max_allocation_bytes > 0 {
        budget = budget.min(ctx.info.max_allocation_bytes);
    }
    (budget / (p.rays as u64 * RAY_BYTES)).clamp(1, 1 << 20) as u32
}

impl Backend for GpuBackend<'_> {
    fn name(&self) -> String {
        format!("gpu ({})", self.ctx.info.name)
    }

    fn direct(&mut self) -> Result<Vec<u32>> {
        // A solve starts here: its kernel times start from zero.
        self.prof.clear();
        self.bounces_done = 0;
        self.submit(|s, rec| s.direct(rec))?;
        if self.sampled_sources > 0 {
            // Each node's relative standard error (-1: unlit).
            let d: Vec<f32> = self.res.state.direct_err.download(0, self.h.nodes.len())?;
            let rel: Vec<f64> = d.iter().map(|&v| v as f64).filter(|&r| r >= 0.0).collect();
            self.direct_error = Some(crate::transport::DirectError {
                samples: self.samples,
                shadow_rays: self.h.nodes.len() as u64 * self.samples as u64 * self.sampled_sources as u64,
                lit_nodes: rel.len() as u64,
                mean_rel_std_err: rel.iter().sum::<f64>() / rel.len().max(1) as f64,
                max_rel_std_err: rel.iter().copied().fold(0.0, f64::max),
            });
        }
        self.res.state.counters.download(LIGHT_COUNTERS as usize, self.lights)
    }

    fn direct_error(&self) -> Option<crate::transport::DirectError> {
        self.direct_error.clone()
    }

    fn init_unshot(&mut self) -> Result<()> {
        self.submit(|s, rec| s.init_unshot(rec))
    }

    fn gather(&mut self, level: u32, exact_direct: bool) -> Result<u32> {
        let (active, count) = if level <= 1 {
            (Active::Level, self.h.level_range(level as usize).len() as u32)
        } else {
            (Active::Listed(self.active_count), self.active_count)
        };
        self.submit(|s, rec| s.gather(rec, level, active, exact_direct))?;
        Ok(count)
    }

    fn refine(&mut self, level: u32, activate: bool, sparse: u32) -> Result<Refined> {
        self.submit(|s, rec| s.refine(rec, level, activate, sparse, false, false))?;
        let c: Vec<u32> = self
            .res
            .state
            .counters
            .download((COUNTERS_PER_LEVEL * level) as usize, COUNTERS_PER_LEVEL as usize)?;
        self.active_count = if activate { c[COUNTER_ACTIVATED as usize] } else { 0 };
        Ok(Refined {
            refined: c[COUNTER_REFINED as usize],
            activated: self.active_count,
        })
    }

    fn fill(&mut self, from: u32) -> Result<()> {
        self.submit(|s, rec| s.fill(rec, from))
    }

    fn end_bounce(&mut self) -> Result<Energy> {
        self.submit(|s, rec| s.end_bounce(rec))?;
        self.bounces_done += 1;
        let v: Vec<f32> = self.res.state.energy.download(0, ENERGY_DIRECT as usize + 1)?;
        Ok(Energy {
            unshot: v[ENERGY_UNSHOT as usize] as f64,
            direct: v[ENERGY_DIRECT as usize] as f64,
        })
    }

    /// One bounce in one submission ([`Schedule::bounce`]); the counts and energies come
    /// back once, at the end.
    fn bounce_fused(&mut self, exact_direct: bool, sparse: u32) -> Result<Option<FusedBounce>> {
        let g = self.p.gather_levels();
        self.submit(|s, rec| s.bounce(rec, g, exact_direct, sparse))?;
        self.bounces_done += 1;
        let bytes = self.res.readback.mapped()?;
        let c: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes[..LEVEL_COUNTER_BYTES as usize]);
        let e: Vec<f32> =
            bytemuck::pod_collect_to_vec(&bytes[LEVEL_COUNTER_BYTES as usize..][..ENERGY_READ_BYTES as usize]);
        let slot = |l: u32, which: u32| c[(COUNTERS_PER_LEVEL * l + which) as usize];
        Ok(Some(FusedBounce {
            integrals: (0..g)
                .map(|l| {
                    if l <= 1 {
                        self.h.level_range(l as usize).len() as u32
                    } else {
                        // Split where the bounce reads links: the nodes without links and
                        // those with.
                        slot(l - 1, COUNTER_ACTIVATED) + slot(l - 1, COUNTER_LINKED)
                    }
                })
                .collect(),
            refined: (0..g).map(|l| slot(l, COUNTER_REFINED)).collect(),
            energy: Energy {
                unshot: e[ENERGY_UNSHOT as usize] as f64,
                direct: e[ENERGY_DIRECT as usize] as f64,
            },
        }))
    }

    fn values(&mut self) -> Result<NodeValues> {
        self.solved = true;
        let n = self.h.nodes.len();
        let direct: Vec<Vec4> = self.res.state.direct.download(0, n)?;
        let indirect: Vec<Vec4> = self.res.state.indirect.download(0, n)?;
        self.report.validation_errors = self.ctx.validation_errors();
        self.report.kernels_never_dispatched = self
            .k
            .built()
            .into_iter()
            .filter(|name| !self.prof.launched(name))
            .map(String::from)
            .collect();
        self.report.untimed_launches = self.prof.untimed.values().sum();
        if self.report.validation_errors > 0 {
            return Err(Error::Gpu(format!(
                "the validation layer reported {} error(s); see stderr",
                self.report.validation_errors
            )));
        }
        Ok(NodeValues { direct, indirect })
    }

    fn link_stats(&self) -> Option<LinkStats> {
        let st = &self.res.state;
        if st.link_capacity == 0 {
            return None;
        }
        let c: Vec<u32> = st.link_counters.download(0, LINK_COUNTERS as usize).ok()?;
        // A solve that kept the last one's links counts its own integrals from there.
        let base = match self.link_base {
            Some(b) if self.keep_links => b,
            _ => [0; LINK_COUNTERS as usize],
        };
        let count = |i: u32| (c[i as usize] - base[i as usize]) as u64;
        // Slots handed out beyond the capacity found none free (`hemisphere`).
        let slots = (c[LINK_TAKEN as usize].min(st.link_capacity)) as u64;
        let per_slot = self.p.rays as u64 * LINK_RECORD_BYTES;
        Some(LinkStats {
            capacity_bytes: st.link_capacity as u64 * per_slot,
            bytes: slots * per_slot,
            nodes: c[LINK_NODES as usize] as u64,
            integrals_linked: count(LINK_LINKED),
            rays_linked: count(LINK_LINKED_SLOTS) * self.p.rays as u64,
            integrals_traced: count(LINK_TRACED),
            integrals_traced_full: count(LINK_TRACED_FULL),
        })
    }

    fn kernel_times(&mut self) -> Vec<(String, f64)> {
        self.prof.totals.iter().map(|(k, (t, _))| (k.to_string(), *t)).collect()
    }
}
