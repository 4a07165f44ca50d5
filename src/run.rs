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

/// No inf or NaN reaches an output with exit 0 (issue #35): values that overflowed f32
/// (a scene a few 1e-17 across, whose lights' irradiance grows as 1/distance²) are an
/// error naming the scene and its size.
pub(crate) fn check_finite(scene: &Scene, what: &str, values: impl IntoIterator<Item = glam::Vec3>) -> Result<()> {
    if values.into_iter().all(|v| v.is_finite()) {
        return Ok(());
    }
    Err(crate::error::Error::SceneValue {
        path: scene.path.clone(),
        key: "object".into(),
        message: format!(
            "the {what} overflowed single precision (inf or NaN): the geometry is {:.3e} across, and light from a \
             source grows as 1/distance²; scale the scene (an object's `scale`) or the lights' power into a \
             range f32 holds",
            scene.scale
        ),
    })
}
