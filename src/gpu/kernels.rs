//! The transport's kernels: one entry per GLSL kernel (`glsl/<name>.comp` ↔ field
//! `<name>` ↔ timing label `<name>` ↔ bench id `<name>`), each with how its dispatch is
//! sized from the push constants.

use std::sync::Arc;

use ash::vk;

use super::context::Context;
use super::globals::Push;
use super::pipeline::{Kernel, Specialization};
use super::profiler::Profiler;
use super::shaders;
use crate::constants::LINEAR_GROUP;
use crate::error::Result;

/// How many workgroups a dispatch needs.
#[derive(Clone, Copy, Debug)]
pub enum Size {
    /// One thread per element: `count` elements.
    Elements,
    /// One thread per ray: `count` integrals × `aux` rays.
    Rays,
    /// One workgroup per integral: `count` workgroups.
    Groups,
    /// A single workgroup.
    Single,
}

/// A kernel and its dispatch size rule.
pub struct Launch {
    pub kernel: Kernel,
    pub size: Size,
}

impl Launch {
    /// Records one dispatch, timed under the kernel's name.
    pub fn record(&self, prof: &mut Profiler, cmd: vk::CommandBuffer, push: &Push) {
        let groups = match self.size {
            Size::Elements => (push.count as u64).div_ceil(LINEAR_GROUP as u64),
            Size::Rays => (push.count as u64 * push.aux as u64).div_ceil(LINEAR_GROUP as u64),
            Size::Groups => push.count as u64,
            Size::Single => 1,
        };
        prof.time(cmd, self.kernel.name, || self.kernel.dispatch(cmd, push, groups));
    }

    /// Records one dispatch with a device-written grid, timed under the kernel's name.
    pub fn record_indirect(
        &self,
        prof: &mut Profiler,
        cmd: vk::CommandBuffer,
        push: &Push,
        args: vk::Buffer,
        offset: u64,
    ) {
        prof.time(cmd, self.kernel.name, || {
            self.kernel.dispatch_indirect(cmd, push, args, offset)
        });
    }
}

/// Every compute pipeline of the transport, built once per solve.
pub struct Kernels {
    /// Exact direct irradiance at nodes (`ALGORITHM.md` §2).
    pub direct: Launch,
    /// Halton rays of a batch of integrals, cosine-weighted and rotated (paper §4.2).
    pub hemisphere: Launch,
    /// Closest hits over all objects' BVHs.
    pub trace: Launch,
    /// `ρ(y) ΔE(y)` at hit points, by the variant's reconstruction.
    pub reconstruct: Launch,
    /// The Monte Carlo reduction, one workgroup per integral.
    pub reduce: Launch,
    /// Pull-down from the parents (prediction, or filling levels without integrals);
    /// built only for the absolute hierarchy.
    pub pulldown: Option<Launch>,
    /// The delta hierarchy's prediction and initial coefficients; built only for it.
    pub delta: Option<Launch>,
    /// New values and the refinement decision.
    pub oracle: Launch,
    /// The next level's active set, appended through an atomic counter.
    pub compact: Launch,
    /// Indirect += new; un-shot = new.
    pub accumulate: Launch,
    /// Level-0 energy sums.
    pub energy: Launch,
    /// Indirect grids for the batches of a level whose size the device computed.
    pub batches: Launch,
}

impl Kernels {
    /// Every pipeline that was built.
    pub fn all(&self) -> Vec<&Launch> {
        let mut v = vec![
            &self.direct,
            &self.hemisphere,
            &self.trace,
            &self.reconstruct,
            &self.reduce,
            &self.oracle,
            &self.compact,
            &self.accumulate,
            &self.energy,
            &self.batches,
        ];
        v.extend(self.pulldown.iter().chain(&self.delta));
        v
    }

    /// Builds the pipelines a solve of this specialization dispatches.
    pub fn new(ctx: &Arc<Context>, spec: Specialization) -> Result<Kernels> {
        let delta = spec.variant == crate::constants::VARIANT_ORIGINAL;
        let k = |name, spv, size| -> Result<Launch> {
            Ok(Launch {
                kernel: Kernel::new(ctx, name, spv, spec)?,
                size,
            })
        };
        Ok(Kernels {
            direct: k("direct", shaders::DIRECT, Size::Elements)?,
            hemisphere: k("hemisphere", shaders::HEMISPHERE, Size::Rays)?,
            trace: k("trace", shaders::TRACE, Size::Rays)?,
            reconstruct: k("reconstruct", shaders::RECONSTRUCT, Size::Rays)?,
            reduce: k("reduce", shaders::REDUCE, Size::Groups)?,
            pulldown: (!delta)
                .then(|| k("pulldown", shaders::PULLDOWN, Size::Elements))
                .transpose()?,
            delta: delta.then(|| k("delta", shaders::DELTA, Size::Elements)).transpose()?,
            oracle: k("oracle", shaders::ORACLE, Size::Elements)?,
            compact: k("compact", shaders::COMPACT, Size::Elements)?,
            accumulate: k("accumulate", shaders::ACCUMULATE, Size::Elements)?,
            energy: k("energy", shaders::ENERGY, Size::Single)?,
            batches: k("batches", shaders::BATCHES, Size::Elements)?,
        })
    }
}
