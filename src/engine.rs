//! Where the work runs: the CPU reference backend, or a Vulkan device with what stays
//! resident on it between solves. [`Engine`] owns the choice; the hierarchy's build, its
//! arrangement after edits and the solve are its methods, so the CPU/GPU branching
//! happens here and nowhere else. It also carries the run's [`Limits`], beside the scene
//! (the CPU's links are planned within `--max-memory`).

use std::sync::Arc;

use crate::device::image::Pixels;
use crate::device::poisson as device_poisson;
use crate::device::{GpuBackend, GpuReport, GpuResident};
use crate::error::Result;
use crate::gpu::Context;
use crate::hierarchy::poisson::Candidate;
use crate::hierarchy::{Arrangement, CreviceTest, Hierarchy, LevelJob, LevelsElsewhere};
use crate::limits::Limits;
use crate::params::{DartThrowing, SolverParams};
use crate::progress::Progress;
use crate::scene::Scene;
use crate::transport::cpu::CpuBackend;
use crate::transport::links::Links;
use crate::transport::{self, Solution};

/// Where the work runs, and what it keeps there between solves.
pub struct Engine {
    place: Place,
    limits: Limits,
}

enum Place {
    /// The CPU reference backend; the last solve's links, for a solve that changes only
    /// lights.
    Cpu { links: Option<Links> },
    /// A Vulkan device; what stays on it between solves (`None` before the first build,
    /// and after a failure, which leaves nothing usable there).
    Gpu {
        ctx: Arc<Context>,
        resident: Option<Box<GpuResident>>,
    },
}

impl Engine {
    /// The CPU backend, within the default limits ([`Limits::default`]).
    pub fn cpu() -> Engine {
        Engine {
            place: Place::Cpu { links: None },
            limits: Limits::default(),
        }
    }

    /// The device of `ctx`, within the default limits.
    pub fn gpu(ctx: Arc<Context>) -> Engine {
        Engine {
            place: Place::Gpu { ctx, resident: None },
            limits: Limits::default(),
        }
    }

    /// The CPU (`None`) or the device of `ctx`.
    pub fn on(ctx: Option<Arc<Context>>) -> Engine {
        ctx.map_or_else(Engine::cpu, Engine::gpu)
    }

    /// The same engine within `limits`.
    pub fn within(mut self, limits: Limits) -> Engine {
        self.limits = limits;
        self
    }

    /// The same place and limits, with nothing resident (for a comparison that must not
    /// share state with this engine's solves).
    pub fn fresh(&self) -> Engine {
        Engine {
            place: match &self.place {
                Place::Cpu { .. } => Place::Cpu { links: None },
                Place::Gpu { ctx, .. } => Place::Gpu {
                    ctx: ctx.clone(),
                    resident: None,
                },
            },
            limits: self.limits,
        }
    }

    /// The device's context (`None` on the CPU).
    pub fn context(&self) -> Option<&Arc<Context>> {
        match &self.place {
            Place::Cpu { .. } => None,
            Place::Gpu { ctx, .. } => Some(ctx),
        }
    }

    pub fn is_gpu(&self) -> bool {
        self.context().is_some()
    }

    pub fn limits(&self) -> &Limits {
        &self.limits
    }

    /// Drops what the last build and solve left (the hierarchy is built again next).
    pub fn forget(&mut self) {
        match &mut self.place {
            Place::Cpu { links } => *links = None,
            Place::Gpu { resident, .. } => *resident = None,
        }
    }

    /// The hierarchy of `scene` for solves here. On the CPU, [`Hierarchy::build`]. On a
    /// device the scene and the hierarchy's nodes are uploaded and the support clips and
    /// relations computed where the transport runs ([`GpuResident::arranged`]), and that
    /// state stays resident for [`Engine::solve`]. The Poisson-disk levels are thrown on
    /// the device too ([`crate::device::poisson`]) where `dart_throwing` says so or,
    /// unset, where the device is not a CPU and has room for them.
    pub fn build(&mut self, scene: &Scene, params: &SolverParams, progress: &Progress) -> Result<Hierarchy> {
        let Place::Gpu { ctx, resident } = &mut self.place else {
            return Hierarchy::build(scene, params, progress);
        };
        *resident = None;
        let on_device = match params.dart_throwing {
            Some(d) => d == DartThrowing::Device,
            None => ctx.info.device_type != "CPU",
        };
        // Unset, `dart_throwing` leaves to the host what the device has no room for.
        let device =
            |scene: &Scene, pools: &[Vec<Candidate>], jobs: &[LevelJob], crevice: &CreviceTest, pr: &Progress| {
                if params.dart_throwing.is_none() && !device_poisson::fits(ctx, jobs) {
                    return Ok(None);
                }
                device_poisson::levels_on_device(ctx, scene, params, pools, jobs, crevice, pr).map(Some)
            };
        let elsewhere: Option<LevelsElsewhere> = if on_device { Some(&device) } else { None };
        let mut h = Hierarchy::build_unarranged_with(scene, params, progress, elsewhere)?;
        progress.stage("uploading to the GPU");
        let params = &h.gather_params(params);
        *resident = Some(Box::new(GpuResident::arranged(ctx, scene, &mut h, params, progress)?));
        Ok(h)
    }

    /// Brings `h` from arrangement `before` to `scene`'s after the objects `moved` were
    /// placed anew, where the transport runs: [`Hierarchy::rearrange`] on the CPU,
    /// [`GpuResident::arrange`] on the device. Returns how many clips and parent lists
    /// were computed. A failure on the device leaves nothing resident there: the caller
    /// builds the hierarchy again.
    pub fn arrange(
        &mut self,
        scene: &Scene,
        h: &mut Hierarchy,
        params: &SolverParams,
        before: &Arrangement,
        moved: &[usize],
        progress: &Progress,
    ) -> Result<(usize, usize)> {
        match &mut self.place {
            Place::Gpu { ctx, resident: Some(r) } => {
                match r.arrange(ctx, scene, h, params, Some((before, moved)), progress) {
                    Ok(a) => Ok((a.clips_computed, a.parents_computed)),
                    Err(e) => {
                        // Half arranged: nothing on the device can be trusted.
                        self.forget();
                        Err(e)
                    }
                }
            }
            _ => Ok(h.rearrange(scene, before, moved, params, progress)),
        }
    }

    /// The bounce loop over `h` as [`Engine::build`] (and [`Engine::arrange`]) left it.
    /// With `reuse_links` (nothing moved since the last solve: every gathering ray hits
    /// what it hit and reads the node it read), the last solve's links serve this one.
    /// On a device only the lights go up (and, after a failure, everything again).
    pub fn solve(
        &mut self,
        scene: &Scene,
        h: &mut Hierarchy,
        params: &SolverParams,
        reuse_links: bool,
        progress: &Progress,
    ) -> Result<(Solution, Option<GpuReport>)> {
        let params = &h.gather_params(params);
        match &mut self.place {
            Place::Gpu { ctx, resident } => {
                let r = match resident.take() {
                    Some(r) => *r,
                    // A failed solve left nothing on the device: upload and arrange again.
                    None => GpuResident::arranged(ctx, scene, h, params, progress)?,
                };
                let mut b = GpuBackend::resume(ctx.clone(), r, scene, h, params)?;
                if reuse_links {
                    b.keep_links();
                }
                let s = transport::solve(params, &mut b, progress)?;
                let report = b.report.clone();
                *resident = Some(Box::new(b.suspend()));
                Ok((s, Some(report)))
            }
            Place::Cpu { links } => {
                let mut b = CpuBackend::within(scene, h, params, &self.limits, progress);
                match links.take() {
                    Some(l) if reuse_links => {
                        b.keep_links(l);
                    }
                    _ => {}
                }
                let s = transport::solve(params, &mut b, progress)?;
                *links = b.take_links();
                Ok((s, None))
            }
        }
    }

    /// The camera's view of the last [`Engine::solve`] drawn where it ran, if that was a
    /// device whose state is still resident (`device::image`): `None` on the CPU or with
    /// nothing resident, where the caller draws it on the CPU (`output::image::render`).
    pub fn render_on_device(
        &mut self,
        scene: &Scene,
        params: &SolverParams,
        progress: &Progress,
    ) -> Option<Result<Pixels>> {
        match &mut self.place {
            Place::Gpu { ctx, resident: Some(r) } => Some(r.render(ctx, scene, params, progress)),
            _ => None,
        }
    }

    /// The bounce loop for a hierarchy built elsewhere (as arranged on the host), on a
    /// backend of its own, after `warmups` discarded solves on that backend (lavapipe
    /// compiles pipelines at their first dispatch; benchmarks warm up). Nothing is kept.
    pub fn transport(
        &self,
        scene: &Scene,
        params: &SolverParams,
        h: &Hierarchy,
        warmups: u32,
        progress: &Progress,
    ) -> Result<(Solution, Option<GpuReport>)> {
        let params = &h.gather_params(params);
        let hidden = Progress::hidden();
        match &self.place {
            Place::Gpu { ctx, .. } => {
                progress.stage("uploading to the GPU");
                let mut b = GpuBackend::new(ctx.clone(), scene, h, params)?;
                for _ in 0..warmups {
                    transport::solve(params, &mut b, &hidden)?;
                }
                let s = transport::solve(params, &mut b, progress)?;
                Ok((s, Some(b.report.clone())))
            }
            Place::Cpu { .. } => {
                let mut b = CpuBackend::within(scene, h, params, &self.limits, progress);
                for _ in 0..warmups {
                    transport::solve(params, &mut b, &hidden)?;
                }
                Ok((transport::solve(params, &mut b, progress)?, None))
            }
        }
    }
}
