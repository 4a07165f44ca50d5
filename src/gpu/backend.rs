//! The GPU transport backend: the whole bounce loop on the device. The scene, the
//! hierarchy and the per-node state are uploaded once and stay resident; rays, hits and
//! samples live only on the device; between stages only counts come back.

use std::sync::Arc;
use std::time::Instant;

use ash::vk;
use glam::Vec4;
use gpu_allocator::MemoryLocation;

use super::buffer::{compute_barrier, host_barrier, indirect_barrier, Buffer};
use super::context::Context;
use super::globals::{Globals, Push, CONTRIB_BYTES, HIT_BYTES, RAY_BYTES};
use super::kernels::Kernels;
use super::pipeline::Specialization;
use super::profiler::Profiler;
use crate::constants::{
    BVH_BVH2, BVH_CWBVH, LIGHT_COUNTERS, MAX_LEVELS, NONE, VARIANT_APPROX, VARIANT_MODIFIED, VARIANT_ORIGINAL,
};
use crate::error::{Error, Result};
use crate::geom::sampling::halton_table;
use crate::hierarchy::Hierarchy;
use crate::params::{BvhKind, SolverParams, Variant};
use crate::scene::Scene;
use crate::transport::{Backend, BounceStats, Energy, NodeValues, Refined};

/// The buffers of a solve.
struct Buffers {
    _scene: Vec<Buffer>,
    direct: Buffer,
    unshot: Buffer,
    next: Buffer,
    indirect: Buffer,
    active_flag: Buffer,
    child_flag: Buffer,
    counters: Buffer,
    energy: Buffer,
    dispatch_args: Buffer,
    readback: Buffer,
    _state: Vec<Buffer>,
}

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
    pub bytes_uploaded: u64,
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
    prof: Profiler,
    b: Buffers,
    _globals: Buffer,
    addr: u64,
    batch: u32,
    active_count: u32,
    lights: usize,
    pub report: GpuReport,
}

fn vec4_bytes(n: usize) -> u64 {
    (n * 16) as u64
}

impl<'a> GpuBackend<'a> {
    /// Uploads the scene and hierarchy and builds the pipelines.
    pub fn new(ctx: Arc<Context>, scene: &'a Scene, h: &'a Hierarchy) -> Result<GpuBackend<'a>> {
        let p = scene.params.clone();
        let t = Instant::now();
        let spec = Specialization {
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
        };
        let k = Kernels::new(&ctx, spec)?;
        let seconds_pipelines = t.elapsed().as_secs_f64();

        let t = Instant::now();
        let n = h.nodes.len();
        let max_level = (0..h.levels as usize)
            .map(|l| h.level_range(l).len())
            .max()
            .unwrap_or(0);
        let batch = batch_size(&ctx, &p);
        let up = |name: &str, bytes: &[u8]| Buffer::upload(&ctx, name, bytes);
        let objects = h.object_infos(scene);
        let halton = halton_table(p.rays);
        let scene_bufs = vec![
            up("triangles", bytemuck::cast_slice(&scene.tris))?,
            up("uvs", bytemuck::cast_slice(&scene.uvs))?,
            up("bvh", bytemuck::cast_slice(&scene.bvh))?,
            up("materials", bytemuck::cast_slice(&scene.materials))?,
            up("textures", bytemuck::cast_slice(&scene.textures))?,
            up("texels", bytemuck::cast_slice(&scene.texels))?,
            up("srgb", bytemuck::cast_slice(&scene.srgb))?,
            up("lights", bytemuck::cast_slice(&scene.lights))?,
            up("objects", bytemuck::cast_slice(&objects))?,
            up("nodes", bytemuck::cast_slice(&h.nodes))?,
            up("kd splits", bytemuck::cast_slice(&h.splits))?,
            up("parent offsets", bytemuck::cast_slice(&h.parent_offset))?,
            up("parents", bytemuck::cast_slice(&h.parents))?,
            up("child offsets", bytemuck::cast_slice(&h.child_offset))?,
            up("children", bytemuck::cast_slice(&h.children))?,
            up("halton", bytemuck::cast_slice(&halton))?,
            up("cwbvh nodes", bytemuck::cast_slice(&scene.cw_nodes))?,
            up("cwbvh primitives", bytemuck::cast_slice(&scene.cw_prims))?,
            up("support clips", bytemuck::cast_slice(&h.clips))?,
        ];
        let bytes_uploaded = scene_bufs.iter().map(|b| b.size).sum();
        let z = |name: &str, size: u64| Buffer::zeroed(&ctx, name, size);
        let rays_in_flight = batch as u64 * p.rays as u64;
        let state = vec![
            z("pred", vec4_bytes(n))?,
            z("gathered mean", vec4_bytes(n))?,
            z("gathered error", vec4_bytes(n))?,
            z("active", (max_level.max(1) * 4) as u64)?,
            Buffer::new(&ctx, "rays", rays_in_flight * RAY_BYTES, MemoryLocation::GpuOnly)?,
            Buffer::new(&ctx, "hits", rays_in_flight * HIT_BYTES, MemoryLocation::GpuOnly)?,
            Buffer::new(&ctx, "samples", rays_in_flight * CONTRIB_BYTES, MemoryLocation::GpuOnly)?,
        ];
        let b = Buffers {
            direct: z("direct", vec4_bytes(n))?,
            unshot: z("unshot", vec4_bytes(n))?,
            next: z("next", vec4_bytes(n))?,
            indirect: z("indirect", vec4_bytes(n))?,
            active_flag: z("active flags", (n * 4) as u64)?,
            child_flag: z("child flags", (n * 4) as u64)?,
            counters: z("counters", 4 * (LIGHT_COUNTERS as u64 + scene.lights.len() as u64))?,
            energy: z("energy", 32)?,
            dispatch_args: z(
                "dispatch arguments",
                24 * (max_level.div_ceil(batch as usize) as u64 + 1),
            )?,
            readback: Buffer::new(
                &ctx,
                "bounce readback",
                4 * (2 * MAX_LEVELS as u64 + 2),
                MemoryLocation::GpuToCpu,
            )?,
            _scene: scene_bufs,
            _state: state,
        };
        let s = &b._scene;
        let st = &b._state;
        let g = Globals {
            tris: s[0].address,
            uvs: s[1].address,
            bvh: s[2].address,
            cw_nodes: s[16].address,
            cw_prims: s[17].address,
            materials: s[3].address,
            textures: s[4].address,
            texels: s[5].address,
            srgb: s[6].address,
            lights: s[7].address,
            objects: s[8].address,
            nodes: s[9].address,
            splits: s[10].address,
            clips: s[18].address,
            parent_offset: s[11].address,
            parents: s[12].address,
            child_offset: s[13].address,
            children: s[14].address,
            halton: s[15].address,
            direct: b.direct.address,
            unshot: b.unshot.address,
            next: b.next.address,
            indirect: b.indirect.address,
            pred: st[0].address,
            gathered_mean: st[1].address,
            gathered_err: st[2].address,
            active_flag: b.active_flag.address,
            child_flag: b.child_flag.address,
            active_list: st[3].address,
            counters: b.counters.address,
            rays: st[4].address,
            hits: st[5].address,
            contrib: st[6].address,
            energy: b.energy.address,
            dispatch_args: b.dispatch_args.address,
            num_objects: scene.objects.len() as u32,
            num_lights: scene.lights.len() as u32,
            rays_per_integral: p.rays,
            seed: p.seed,
            scene_scale: scene.scale,
            kappa: p.kappa,
            alpha: p.alpha,
            approx_cos: p.approx_cos,
            eps_rel: p.eps_rel,
            eps_abs: p.eps_abs,
            noise_z: p.noise_z,
            levels: p.levels,
            sender_level: p.sender_level,
            pad0: 0,
        };
        let globals = Buffer::upload(&ctx, "globals", bytemuck::bytes_of(&g))?;
        let addr = globals.address;
        let report = GpuReport {
            device: ctx.info.name.clone(),
            driver: format!("{} {}", ctx.info.driver_name, ctx.info.driver_info),
            api_version: ctx.info.api_version.clone(),
            batch_integrals: batch,
            bytes_uploaded,
            seconds_upload: t.elapsed().as_secs_f64(),
            seconds_pipelines,
            skipped: skipped_by_construction(&p, scene),
            ..Default::default()
        };
        Ok(GpuBackend {
            prof: Profiler::new(&ctx)?,
            ctx,
            h,
            p,
            k,
            b,
            _globals: globals,
            addr,
            batch,
            active_count: 0,
            lights: scene.lights.len(),
            report,
        })
    }

    fn push(&self, first: usize, count: usize) -> Push {
        Push {
            globals: self.addr,
            first: first as u32,
            count: count as u32,
            count_at: NONE,
            ..Default::default()
        }
    }

    /// Records `f` into one command buffer, submits it, waits, and collects timestamps.
    fn submit(&mut self, f: impl FnOnce(&Kernels, &mut Profiler, vk::CommandBuffer, &Buffers, &Context)) -> Result<()> {
        let (ctx, k, prof, b) = (&self.ctx, &self.k, &mut self.prof, &self.b);
        ctx.run(|cmd| {
            prof.begin_frame(cmd);
            f(k, prof, cmd, b, ctx);
            Ok(())
        })?;
        self.prof.end_frame()
    }

    /// Reads a per-node state array (tests and diagnostics).
    pub fn read_state(&self, which: State) -> Result<Vec<Vec4>> {
        let n = self.h.nodes.len();
        let b = match which {
            State::Direct => &self.b.direct,
            State::Unshot => &self.b.unshot,
            State::Next => &self.b.next,
            State::Indirect => &self.b.indirect,
            State::Pred => &self.b._state[0],
            State::GatheredMean => &self.b._state[1],
            State::GatheredErr => &self.b._state[2],
        };
        b.download(0, n)
    }

    /// Reads the first `n` rays (origin, direction), hits and samples of the last batch.
    pub fn read_batch(&self, n: usize) -> Result<BatchReadback> {
        Ok((
            self.b._state[4].download(0, n)?,
            self.b._state[5].download(0, n)?,
            self.b._state[6].download(0, n)?,
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

fn range_bytes(r: &std::ops::Range<usize>, elem: u64) -> (u64, u64) {
    (r.start as u64 * elem, r.len() as u64 * elem)
}

impl Backend for GpuBackend<'_> {
    fn name(&self) -> String {
        format!("gpu ({})", self.ctx.info.name)
    }

    fn direct(&mut self) -> Result<Vec<u32>> {
        // A solve starts here: its kernel times start from zero.
        self.prof.clear();
        let all = self.push(0, self.h.nodes.len());
        let l0 = self.h.level_range(0);
        let mut e = self.push(l0.start, l0.len());
        e.flag = 1;
        self.submit(|k, prof, cmd, _, ctx| {
            k.direct.record(prof, cmd, &all);
            compute_barrier(ctx, cmd);
            k.energy.record(prof, cmd, &e);
            compute_barrier(ctx, cmd);
        })?;
        self.b.counters.download(LIGHT_COUNTERS as usize, self.lights)
    }

    fn init_unshot(&mut self) -> Result<()> {
        let delta = self.p.variant.is_delta();
        let levels: Vec<Push> = (0..self.h.levels as usize)
            .map(|l| {
                let r = self.h.level_range(l);
                let mut p = self.push(r.start, r.len());
                p.level = l as u32;
                p.flag = 1;
                p
            })
            .collect();
        let n = vec4_bytes(self.h.nodes.len());
        self.submit(|k, prof, cmd, b, ctx| {
            b.indirect.fill(cmd, 0, b.indirect.size, 0);
            if delta {
                for p in &levels {
                    if let Some(d) = &k.delta {
                        d.record(prof, cmd, p);
                    }
                    compute_barrier(ctx, cmd);
                }
            } else {
                let region = [vk::BufferCopy::default().size(n)];
                // SAFETY: both buffers hold n bytes.
                unsafe {
                    ctx.device
                        .cmd_copy_buffer(cmd, b.direct.buffer, b.unshot.buffer, &region)
                };
            }
            compute_barrier(ctx, cmd);
        })
    }

    fn gather(&mut self, level: u32) -> Result<u32> {
        let range = self.h.level_range(level as usize);
        let (count, listed) = if level <= 1 {
            (range.len() as u32, false)
        } else {
            (self.active_count, true)
        };
        let batch = self.batch;
        let base = self.push(range.start, 0);
        let rays = self.p.rays;
        let (off, size) = range_bytes(&range, 4);
        self.submit(|k, prof, cmd, b, ctx| {
            b.active_flag.fill(cmd, off, size, 0);
            compute_barrier(ctx, cmd);
            let mut offset = 0;
            while offset < count {
                let n = batch.min(count - offset);
                let p = Push {
                    count: n,
                    offset,
                    flag: listed as u32,
                    aux: rays,
                    ..base
                };
                k.hemisphere.record(prof, cmd, &p);
                compute_barrier(ctx, cmd);
                k.trace.record(prof, cmd, &p);
                compute_barrier(ctx, cmd);
                k.reconstruct.record(prof, cmd, &p);
                compute_barrier(ctx, cmd);
                k.reduce.record(prof, cmd, &p);
                compute_barrier(ctx, cmd);
                offset += n;
            }
        })?;
        Ok(count)
    }

    fn refine(&mut self, level: u32, activate: bool) -> Result<Refined> {
        let l = level as usize;
        let range = self.h.level_range(l);
        let mut p = self.push(range.start, range.len());
        p.level = level;
        p.flag = activate as u32;
        let next_range = if activate { self.h.level_range(l + 1) } else { 0..0 };
        let mut cp = self.push(next_range.start, next_range.len());
        cp.level = level;
        let delta = self.p.variant.is_delta();
        let (coff, csize) = range_bytes(&next_range, 4);
        self.submit(|k, prof, cmd, b, ctx| {
            b.counters.fill(cmd, 0, 8 * MAX_LEVELS as u64, 0);
            if activate {
                b.child_flag.fill(cmd, coff, csize, 0);
            }
            compute_barrier(ctx, cmd);
            if level >= 1 {
                let pred = Push { flag: 0, ..p };
                if let Some(launch) = if delta { &k.delta } else { &k.pulldown } {
                    launch.record(prof, cmd, &pred);
                }
                compute_barrier(ctx, cmd);
            }
            k.oracle.record(prof, cmd, &p);
            compute_barrier(ctx, cmd);
            if activate {
                k.compact.record(prof, cmd, &cp);
                compute_barrier(ctx, cmd);
            }
        })?;
        let c: Vec<u32> = self.b.counters.download(2 * l, 2)?;
        self.active_count = if activate { c[1] } else { 0 };
        Ok(Refined {
            refined: c[0],
            activated: self.active_count,
        })
    }

    fn fill(&mut self, from: u32) -> Result<()> {
        let delta = self.p.variant.is_delta();
        let levels: Vec<(Push, std::ops::Range<usize>)> = (from as usize..self.h.levels as usize)
            .map(|l| {
                let r = self.h.level_range(l);
                let mut p = self.push(r.start, r.len());
                p.level = l as u32;
                p.flag = 1;
                (p, r)
            })
            .collect();
        self.submit(|k, prof, cmd, b, ctx| {
            for (p, r) in &levels {
                match &k.pulldown {
                    Some(launch) if !delta => launch.record(prof, cmd, p),
                    _ => {
                        let (off, size) = range_bytes(r, 16);
                        b.next.fill(cmd, off, size, 0);
                    }
                }
                compute_barrier(ctx, cmd);
            }
        })
    }

    fn end_bounce(&mut self) -> Result<Energy> {
        let all = self.push(0, self.h.nodes.len());
        let l0 = self.h.level_range(0);
        let e = self.push(l0.start, l0.len());
        self.submit(|k, prof, cmd, _, ctx| {
            k.accumulate.record(prof, cmd, &all);
            compute_barrier(ctx, cmd);
            k.energy.record(prof, cmd, &e);
            compute_barrier(ctx, cmd);
        })?;
        let v: Vec<f32> = self.b.energy.download(0, 2)?;
        Ok(Energy {
            unshot: v[0] as f64,
            direct: v[1] as f64,
        })
    }

    /// One bounce in one submission: levels 0 and 1 in batches of known size, finer
    /// levels in as many indirect batches as the level could need, their grids written by
    /// `batches` from the active count that `compact` leaves on the device. The counts and
    /// energies come back once, at the end.
    fn bounce_fused(&mut self, k: u32) -> Result<Option<BounceStats>> {
        let t = Instant::now();
        let (h, batch, rays) = (self.h, self.batch, self.p.rays);
        let g = self.p.gather_levels() as usize;
        let delta = self.p.variant.is_delta();
        let max_x = self.ctx.info.max_workgroup_count_x.clamp(1, 65535);
        let base = self.push(0, 0);
        let levels = h.levels as usize;
        let n_all = h.nodes.len();
        let l0 = h.level_range(0);
        let args = self.b.dispatch_args.buffer;
        self.submit(|kk, prof, cmd, b, ctx| {
            b.counters.fill(cmd, 0, 8 * MAX_LEVELS as u64, 0);
            for l in 0..g {
                let r = h.level_range(l);
                b.active_flag.fill(cmd, 4 * r.start as u64, 4 * r.len() as u64, 0);
                compute_barrier(ctx, cmd);
                let lp = Push {
                    first: r.start as u32,
                    level: l as u32,
                    aux: rays,
                    ..base
                };
                let gather = |prof: &mut Profiler, p: &Push, indirect: Option<u64>| {
                    for (i, launch) in [&kk.hemisphere, &kk.trace, &kk.reconstruct, &kk.reduce]
                        .into_iter()
                        .enumerate()
                    {
                        match indirect {
                            Some(at) => launch.record_indirect(prof, cmd, p, args, at + if i == 3 { 12 } else { 0 }),
                            None => launch.record(prof, cmd, p),
                        }
                        compute_barrier(ctx, cmd);
                    }
                };
                if l <= 1 {
                    let mut offset = 0;
                    while offset < r.len() as u32 {
                        let n = batch.min(r.len() as u32 - offset);
                        gather(prof, &Push { count: n, offset, ..lp }, None);
                        offset += n;
                    }
                } else {
                    for bi in 0..r.len().div_ceil(batch as usize) as u32 {
                        let p = Push {
                            count: batch,
                            offset: bi * batch,
                            flag: 1,
                            count_at: 2 * (l as u32 - 1) + 1,
                            ..lp
                        };
                        gather(prof, &p, Some(24 * bi as u64));
                    }
                }
                let activate = l >= 1 && l + 1 < g;
                let rp = Push {
                    count: r.len() as u32,
                    flag: activate as u32,
                    ..lp
                };
                if l >= 1 {
                    if let Some(launch) = if delta { &kk.delta } else { &kk.pulldown } {
                        launch.record(prof, cmd, &Push { flag: 0, ..rp });
                    }
                }
                let next = if activate { h.level_range(l + 1) } else { 0..0 };
                b.child_flag.fill(cmd, 4 * next.start as u64, 4 * next.len() as u64, 0);
                compute_barrier(ctx, cmd);
                kk.oracle.record(prof, cmd, &rp);
                compute_barrier(ctx, cmd);
                if activate {
                    kk.compact.record(
                        prof,
                        cmd,
                        &Push {
                            first: next.start as u32,
                            count: next.len() as u32,
                            ..lp
                        },
                    );
                    compute_barrier(ctx, cmd);
                    kk.batches.record(
                        prof,
                        cmd,
                        &Push {
                            count: next.len().div_ceil(batch as usize) as u32,
                            offset: batch,
                            aux: 2 * l as u32 + 1,
                            level: max_x,
                            ..base
                        },
                    );
                    indirect_barrier(ctx, cmd);
                }
            }
            for l in g..levels {
                let r = h.level_range(l);
                match &kk.pulldown {
                    Some(launch) if !delta => launch.record(
                        prof,
                        cmd,
                        &Push {
                            first: r.start as u32,
                            count: r.len() as u32,
                            level: l as u32,
                            flag: 1,
                            ..base
                        },
                    ),
                    _ => b.next.fill(cmd, 16 * r.start as u64, 16 * r.len() as u64, 0),
                }
                compute_barrier(ctx, cmd);
            }
            kk.accumulate.record(
                prof,
                cmd,
                &Push {
                    count: n_all as u32,
                    ..base
                },
            );
            compute_barrier(ctx, cmd);
            kk.energy.record(
                prof,
                cmd,
                &Push {
                    first: l0.start as u32,
                    count: l0.len() as u32,
                    ..base
                },
            );
            compute_barrier(ctx, cmd);
            let regions = [
                vk::BufferCopy::default().size(8 * MAX_LEVELS as u64),
                vk::BufferCopy::default().dst_offset(8 * MAX_LEVELS as u64).size(8),
            ];
            // SAFETY: all three buffers are valid and large enough.
            unsafe {
                ctx.device
                    .cmd_copy_buffer(cmd, b.counters.buffer, b.readback.buffer, &regions[..1]);
                ctx.device
                    .cmd_copy_buffer(cmd, b.energy.buffer, b.readback.buffer, &regions[1..]);
            }
            host_barrier(ctx, cmd);
        })?;
        let bytes = self.b.readback.mapped()?;
        let c: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes[..8 * MAX_LEVELS as usize]);
        let e: Vec<f32> = bytemuck::pod_collect_to_vec(&bytes[8 * MAX_LEVELS as usize..8 * MAX_LEVELS as usize + 8]);
        let mut st = BounceStats {
            bounce: k,
            ..Default::default()
        };
        for l in 0..g {
            let n = if l <= 1 {
                h.level_range(l).len() as u32
            } else {
                c[2 * (l - 1) + 1]
            };
            if l >= 2 && n == 0 {
                st.empty_from = Some(l as u32);
                break;
            }
            st.integrals_per_level.push(n);
            st.refined_per_level.push(c[2 * l]);
        }
        st.seconds = t.elapsed().as_secs_f64();
        st.unshot_ratio = if e[1] > 0.0 { e[0] as f64 / e[1] as f64 } else { 0.0 };
        Ok(Some(st))
    }

    fn values(&mut self) -> Result<NodeValues> {
        let n = self.h.nodes.len();
        let direct: Vec<Vec4> = self.b.direct.download(0, n)?;
        let indirect: Vec<Vec4> = self.b.indirect.download(0, n)?;
        self.report.validation_errors = self.ctx.validation_errors();
        self.report.kernels_never_dispatched = self
            .k
            .all()
            .iter()
            .map(|l| l.kernel.name)
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

    fn kernel_times(&mut self) -> Vec<(String, f64)> {
        self.prof.totals.iter().map(|(k, (t, _))| (k.to_string(), *t)).collect()
    }
}
