//! The Poisson-disk levels thrown on the device (`ALGORITHM.md` §3.2): the GPU backend's
//! twin of the host's dart throwing, [`crate::hierarchy::LevelsElsewhere`] for
//! [`crate::hierarchy::Hierarchy::build_unarranged_with`]. The result is the host's node
//! set: the same candidates, the same distance and side test in the same float
//! arithmetic, the same order; only a crevice ray that the device's rounding turns from a
//! hit into a miss (or back) can change a node.
//!
//! Data flow: up go the scene's triangles, BVHs and object transforms (a `Globals` block
//! naming only those) and each object's candidate pool, once (24 bytes per candidate of
//! its largest level); per (object, level) the device builds a hashed grid of the
//! candidates and runs rounds of decisions, 4 per submission, with one word read back
//! between submissions (the candidates still undecided); then the level's states come
//! back (4 bytes per candidate) and the host keeps the accepted candidates, in order. The
//! crevice tests are memoised on the device across an object's levels.

use std::sync::Arc;

use gpu_allocator::MemoryLocation;

use super::globals::Globals;
use super::kernels::poisson::{Poisson, PoissonPush, COUNT, IN, RESOLVE, SCATTER};
use super::kernels::scan::Scan;
use super::kernels::submit;
use super::resources::cwbvh_of;
use crate::error::{Error, Result};
use crate::gpu::buffer::Buffer;
use crate::gpu::context::Context;
use crate::gpu::profiler::Profiler;
use crate::hierarchy::poisson::Candidate;
use crate::hierarchy::{CreviceTest, LevelJob, Thrown};
use crate::layout::ObjectInfo;
use crate::params::SolverParams;
use crate::progress::Progress;
use crate::scene::Scene;

/// Rounds of decisions per submission (then one word is read back).
const ROUNDS: usize = 4;

/// The largest buffer and the device memory in all that [`levels_on_device`] needs for
/// `jobs` (scene buffers aside): per candidate of the largest level 32 bytes listed by
/// bucket, 24 of the pool, 4 of state, 4 of crevice tests, and 8 per bucket.
pub fn device_bytes(jobs: &[LevelJob]) -> (u64, u64) {
    let most = jobs.iter().map(|j| j.take).max().unwrap_or(0).max(1) as u64;
    let buckets = most.next_power_of_two();
    let largest = (32 * most).max(4 * (buckets + 1));
    (largest, (32 + 24 + 4 + 4) * most + 8 * buckets)
}

/// Whether the device can hold what [`levels_on_device`] needs for `jobs`, with room to
/// spare: at most half its memory, each buffer within its largest allocation.
pub fn fits(ctx: &Context, jobs: &[LevelJob]) -> bool {
    let (largest, all) = device_bytes(jobs);
    let max = ctx.info.max_allocation_bytes;
    all <= ctx.info.device_local_bytes / 2 && (max == 0 || largest <= max)
}

/// The scene as the crevice rays read it (triangles, BVHs, transforms) and a `Globals`
/// block naming only these; kept alive while the darts are thrown.
struct SceneUp {
    _buffers: [Buffer; 5],
    globals: Buffer,
}

impl SceneUp {
    fn new(ctx: &Arc<Context>, scene: &Scene, p: &SolverParams) -> Result<SceneUp> {
        let (cw_nodes, cw_prims) = cwbvh_of(scene, p);
        let objects: Vec<ObjectInfo> = scene
            .objects
            .iter()
            .zip(&scene.cw.roots)
            .map(|(o, &root)| o.info(root))
            .collect();
        let tris = Buffer::upload(ctx, "triangles", &scene.tris[..])?;
        let bvh = Buffer::upload(ctx, "bvh", &scene.bvh[..])?;
        let cw_nodes = Buffer::upload(ctx, "cwbvh nodes", cw_nodes)?;
        let cw_prims = Buffer::upload(ctx, "cwbvh primitives", cw_prims)?;
        let object_buf = Buffer::upload(ctx, "objects", &objects[..])?;
        let g = Globals {
            tris: tris.address,
            bvh: bvh.address,
            cw_nodes: cw_nodes.address,
            cw_prims: cw_prims.address,
            objects: object_buf.address,
            num_objects: scene.objects.len() as u32,
            scene_scale: scene.scale,
            ..Default::default()
        };
        let globals = Buffer::upload(ctx, "globals (dart throwing)", bytemuck::bytes_of(&g))?;
        Ok(SceneUp {
            _buffers: [tris, bvh, cw_nodes, cw_prims, object_buf],
            globals,
        })
    }
}

/// Scratch for the largest level, reused by every job.
struct Scratch {
    state: Buffer,
    table: Buffer,
    fill: Buffer,
    sorted: Buffer,
    counters: Buffer,
    sums: Buffer,
}

impl Scratch {
    fn new(ctx: &Arc<Context>, jobs: &[LevelJob]) -> Result<Scratch> {
        let most = jobs.iter().map(|j| j.take).max().unwrap_or(0).max(1);
        let buckets = most.next_power_of_two();
        let words = |name: &str, n: usize| Buffer::zeroed(ctx, name, 4 * n.max(1) as u64);
        Ok(Scratch {
            state: words("dart states", most)?,
            table: words("dart buckets", buckets + 1)?,
            fill: words("dart bucket fill", buckets)?,
            sorted: Buffer::new(ctx, "darts by bucket", 32 * most as u64, MemoryLocation::GpuOnly)?,
            counters: words("dart counters", 1 + ROUNDS)?,
            sums: words("dart scan sums", Scan::blocks(buckets as u64 + 1) as usize)?,
        })
    }
}

/// What throwing one object's levels needs: the pipelines, the profiler, the scene on
/// the device and the scratch.
struct Thrower<'a> {
    ctx: &'a Arc<Context>,
    kernel: Poisson,
    scan: Scan,
    prof: Profiler,
    up: SceneUp,
    x: Scratch,
}

/// Every job's accepted candidates, in pool order, the count of candidates found in a
/// crevice and the rounds taken; see the module's documentation.
pub fn levels_on_device(
    ctx: &Arc<Context>,
    scene: &Scene,
    p: &SolverParams,
    pools: &[Vec<Candidate>],
    jobs: &[LevelJob],
    crevice: &CreviceTest,
    progress: &Progress,
) -> Result<Thrown> {
    let spec = super::backend::specialization(p, scene);
    let mut t = Thrower {
        ctx,
        kernel: Poisson::new(ctx, spec)?,
        scan: Scan::new(ctx, spec)?,
        prof: Profiler::new(ctx)?,
        up: SceneUp::new(ctx, scene, p)?,
        x: Scratch::new(ctx, jobs)?,
    };
    let mut sets = vec![Vec::new(); jobs.len()];
    let mut rounds_taken = 0;
    let bar = progress.bar(
        jobs.iter().map(|j| j.take as u64).sum(),
        "Poisson-disk levels on the device",
    );
    for (o, pool) in pools.iter().enumerate() {
        let mine: Vec<usize> = (0..jobs.len())
            .filter(|&k| jobs[k].object == o && jobs[k].take > 0)
            .collect();
        let Some(largest) = mine.iter().map(|&k| jobs[k].take).max() else {
            continue;
        };
        let flat: Vec<[f32; 6]> = pool[..largest]
            .iter()
            .map(|c| [c.pos.x, c.pos.y, c.pos.z, c.normal.x, c.normal.y, c.normal.z])
            .collect();
        let cands = Buffer::upload(ctx, "dart candidates", &flat[..])?;
        drop(flat);
        let memo = Buffer::zeroed(ctx, "crevice tests", 4 * largest.max(1) as u64)?;
        for k in mine {
            let job = &jobs[k];
            let r = job.radius;
            let push = PoissonPush {
                cands: cands.address,
                state: t.x.state.address,
                memo: memo.address,
                table: t.x.table.address,
                fill: t.x.fill.address,
                sorted: t.x.sorted.address,
                counters: t.x.counters.address,
                count: job.take as u32,
                mask: job.take.next_power_of_two() as u32 - 1,
                r,
                r2: r * r,
                inv_cell: 0.5 / r,
                d_min: crevice.d_min_in(scene, o),
                diag: crevice.diags[o],
                object: o as u32,
                within: crevice.within as u32,
                ..Default::default()
            };
            let (states, rounds) = t.throw(job, &push)?;
            rounds_taken += rounds;
            bar.inc(job.take as u64);
            sets[k] = states
                .iter()
                .zip(pool)
                .filter(|(&s, _)| s == IN)
                .map(|(_, c)| *c)
                .collect();
        }
    }
    bar.finish();
    let crevices = t.x.counters.download::<u32>(0, 1)?[0] as usize;
    Ok(Thrown {
        sets,
        crevices,
        rounds: rounds_taken,
    })
}

impl Thrower<'_> {
    /// Throws one level's darts (`push` names its candidates): bucket them, then rounds
    /// of decisions until none is undecided. Returns each candidate's state and the
    /// rounds taken.
    fn throw(&mut self, job: &LevelJob, push: &PoissonPush) -> Result<(Vec<u32>, usize)> {
        let (ctx, kernel, x) = (self.ctx, &self.kernel, &self.x);
        let n = job.take;
        let bk = n.next_power_of_two();
        let globals = self.up.globals.address;
        let rounds = |rec: &mut super::kernels::Recorder| {
            rec.fill(&x.counters, 4, 4 * ROUNDS as u64, 0);
            rec.barrier();
            for round in 0..ROUNDS {
                kernel.record(
                    rec,
                    &PoissonPush {
                        round: round as u32,
                        ..*push
                    },
                    RESOLVE,
                );
                rec.barrier();
            }
        };
        submit(ctx, &mut self.prof, globals, |rec| {
            rec.fill(&x.state, 0, 4 * n as u64, 0);
            rec.fill(&x.table, 0, 4 * (bk as u64 + 1), 0);
            rec.fill(&x.fill, 0, 4 * bk as u64, 0);
            rec.barrier();
            kernel.record(rec, push, COUNT);
            rec.barrier();
            self.scan.record(rec, x.table.address, x.sums.address, bk as u32 + 1);
            kernel.record(rec, push, SCATTER);
            rec.barrier();
            rounds(rec);
        })?;
        // Each round decides at least the first undecided candidate.
        let mut done = ROUNDS;
        while x.counters.download::<u32>(ROUNDS, 1)?[0] > 0 {
            if done > n + ROUNDS {
                return Err(Error::Gpu(format!(
                    "dart throwing on the device: object {} level {} still undecided after {done} rounds",
                    job.object, job.level
                )));
            }
            submit(ctx, &mut self.prof, globals, rounds)?;
            done += ROUNDS;
        }
        Ok((x.state.download(0, n)?, done))
    }
}
