//! The library's entry point: a loaded scene → its hierarchy → the bounce loop, where the
//! [`Engine`] runs them (the CPU or a Vulkan device). The CLI, the benchmarks and the
//! tests all solve through here.

use std::time::Instant;

use crate::device::GpuReport;
use crate::engine::Engine;
use crate::error::Result;
use crate::hierarchy::Hierarchy;
use crate::params::SolverParams;
use crate::progress::Progress;
use crate::scene::Scene;
use crate::transport::Solution;

/// A solve's results.
pub struct Run {
    pub hierarchy: Hierarchy,
    pub solution: Solution,
    /// What the GPU backend did (`None` on the CPU).
    pub gpu: Option<GpuReport>,
    pub seconds_hierarchy: f64,
    pub seconds_solve: f64,
}

/// Builds the hierarchy of `scene` for `params` and solves it where `engine` runs. The
/// parameters are checked here (a library caller may build them by hand; `Scene::load`
/// has checked a file's already). What the solve leaves resident stays in `engine`.
pub fn solve(scene: &Scene, params: &SolverParams, engine: &mut Engine, progress: &Progress) -> Result<Run> {
    params.validate()?;
    let t = Instant::now();
    let mut hierarchy = engine.build(scene, params, progress)?;
    let seconds_hierarchy = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let (solution, gpu) = engine.solve(scene, &mut hierarchy, params, false, progress)?;
    Ok(Run {
        hierarchy,
        solution,
        gpu,
        seconds_hierarchy,
        seconds_solve: t.elapsed().as_secs_f64(),
    })
}
