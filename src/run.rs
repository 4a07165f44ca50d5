//! The library's entry point: a loaded scene → its hierarchy → the bounce loop on the CPU
//! or a Vulkan device. The CLI, the benchmarks and the tests all solve through here.

use std::sync::Arc;
use std::time::Instant;

use crate::device::backend::{GpuReport, GpuResident};
use crate::device::GpuBackend;
use crate::error::Result;
use crate::gpu::Context;
use crate::hierarchy::poisson::Candidate;
use crate::hierarchy::{CreviceTest, Hierarchy, LevelJob, LevelsElsewhere};
use crate::params::{DartThrowing, SolverParams};
use crate::progress::Progress;
use crate::scene::Scene;
use crate::transport::{self, cpu::CpuBackend, Solution};

/// A solve's results.
pub struct Run {
    pub hierarchy: Hierarchy,
    pub solution: Solution,
    /// What the GPU backend did (`None` on the CPU).
    pub gpu: Option<GpuReport>,
    pub seconds_hierarchy: f64,
    pub seconds_solve: f64,
}

/// Builds the hierarchy of `scene` for `params` and solves it on the CPU (`ctx = None`) or
/// on the device of `ctx`. The parameters are checked here (a library caller may build
/// them by hand; `Scene::load` has checked a file's already).
pub fn solve(scene: &Scene, params: &SolverParams, ctx: Option<Arc<Context>>, progress: &Progress) -> Result<Run> {
    params.validate()?;
    let t = Instant::now();
    let (hierarchy, resident) = build_hierarchy(scene, params, ctx.as_ref(), progress)?;
    let seconds_hierarchy = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let (solution, gpu) = match (ctx, resident) {
        (Some(ctx), Some(r)) => {
            let mut b = GpuBackend::resume(ctx, r, scene, &hierarchy, params)?;
            let s = transport::solve(params, &mut b, progress)?;
            (s, Some(b.report.clone()))
        }
        _ => transport_on(scene, params, &hierarchy, None, 0, progress)?,
    };
    Ok(Run {
        hierarchy,
        solution,
        gpu,
        seconds_hierarchy,
        seconds_solve: t.elapsed().as_secs_f64(),
    })
}

/// The hierarchy of `scene` for solves on the CPU (`ctx = None`: [`Hierarchy::build`])
/// or on the device of `ctx`: there the scene and the hierarchy's nodes are uploaded and
/// the support clips computed where the transport runs ([`GpuResident::arrange`]), and
/// what stays on the device comes back with the hierarchy. The Poisson-disk levels are
/// thrown on the device too ([`crate::device::poisson`]) where `dart_throwing` says so or,
/// unset, where the device is not a CPU and has room for them.
pub fn build_hierarchy(
    scene: &Scene,
    params: &SolverParams,
    ctx: Option<&Arc<Context>>,
    progress: &Progress,
) -> Result<(Hierarchy, Option<GpuResident>)> {
    let Some(ctx) = ctx else {
        return Ok((Hierarchy::build(scene, params, progress)?, None));
    };
    let on_device = match params.dart_throwing {
        Some(d) => d == DartThrowing::Device,
        None => ctx.info.device_type != "CPU",
    };
    // Unset, `dart_throwing` leaves to the host what the device has no room for.
    let device = |scene: &Scene, pools: &[Vec<Candidate>], jobs: &[LevelJob], crevice: &CreviceTest, pr: &Progress| {
        if params.dart_throwing.is_none() && !crate::device::poisson::fits(ctx, jobs) {
            return Ok(None);
        }
        crate::device::poisson::levels_on_device(ctx, scene, params, pools, jobs, crevice, pr).map(Some)
    };
    let elsewhere: Option<LevelsElsewhere> = if on_device { Some(&device) } else { None };
    let mut h = Hierarchy::build_unarranged_with(scene, params, progress, elsewhere)?;
    progress.stage("uploading to the GPU");
    let r = GpuResident::arranged(ctx, scene, &mut h, params, progress)?;
    Ok((h, Some(r)))
}

/// The bounce loop for a built hierarchy on the CPU (`ctx = None`) or a device, after
/// `warmups` discarded solves on the same backend (lavapipe compiles pipelines at their
/// first dispatch; benchmarks warm up).
pub fn transport_on(
    scene: &Scene,
    params: &SolverParams,
    h: &Hierarchy,
    ctx: Option<Arc<Context>>,
    warmups: u32,
    progress: &Progress,
) -> Result<(Solution, Option<GpuReport>)> {
    let hidden = Progress::hidden();
    match ctx {
        Some(ctx) => {
            progress.stage("uploading to the GPU");
            let mut b = GpuBackend::new(ctx, scene, h, params)?;
            for _ in 0..warmups {
                transport::solve(params, &mut b, &hidden)?;
            }
            let s = transport::solve(params, &mut b, progress)?;
            Ok((s, Some(b.report.clone())))
        }
        None => {
            let mut b = CpuBackend::new(scene, h, params, progress);
            for _ in 0..warmups {
                transport::solve(params, &mut b, &hidden)?;
            }
            Ok((transport::solve(params, &mut b, progress)?, None))
        }
    }
}
