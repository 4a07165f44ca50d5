//! The transport's kernels: one wrapper per GLSL kernel, `glsl/<name>.comp` ↔
//! `src/device/kernels/<name>.rs` ↔ field `Kernels::<name>` ↔ timing label and bench id
//! `<name>`. Each wrapper owns its push-constant struct (mirrored by name in its GLSL
//! file, checked member by member by `tests/layout.rs`), sizes its own dispatch, and
//! records through a [`Recorder`]; the order of the recordings is `super::schedule`'s.

pub mod accumulate;
pub mod batches;
pub mod clips;
pub mod compact;
pub mod delta;
pub mod direct;
pub mod energy;
pub mod gather;
pub mod hemisphere;
pub mod image;
pub mod linked;
pub mod oracle;
pub mod poisson;
pub mod pulldown;
pub mod reconstruct;
pub mod reduce;
pub mod relations;
pub mod scan;
pub mod trace;

use std::sync::Arc;

use crate::constants::{VARIANT_APPROX, VARIANT_ORIGINAL};
use crate::error::Result;
use crate::gpu::context::Context;
use crate::gpu::pipeline::Specialization;
pub use crate::gpu::recorder::{per_element, submit, Recorder};

/// The wrapper type of one kernel: `$ty($name)` built from `shaders::$spv` with push
/// struct `$push`.
macro_rules! kernel {
    ($ty:ident, $name:literal, $spv:ident, $push:ty) => {
        /// The compute pipeline of the kernel of the same name.
        pub struct $ty(pub(crate) $crate::gpu::pipeline::Kernel);

        impl $ty {
            /// The kernel's name: its GLSL file, timing label and bench id.
            pub const NAME: &'static str = $name;

            /// Builds the pipeline for this specialization.
            pub fn new(
                ctx: &std::sync::Arc<$crate::gpu::context::Context>,
                spec: $crate::gpu::pipeline::Specialization,
            ) -> $crate::error::Result<$ty> {
                $crate::gpu::pipeline::Kernel::new(
                    ctx,
                    $name,
                    $crate::gpu::shaders::$spv,
                    spec,
                    std::mem::size_of::<$push>() as u32,
                )
                .map($ty)
            }
        }
    };
}
pub(crate) use kernel;

/// Every compute pipeline of the transport, built once per solve.
pub struct Kernels {
    pub direct: direct::Direct,
    pub hemisphere: hemisphere::Hemisphere,
    pub trace: trace::Trace,
    pub reconstruct: reconstruct::Reconstruct,
    pub reduce: reduce::Reduce,
    /// Built only for the approximate reconstruction (the variant with links).
    pub linked: Option<linked::Linked>,
    /// Built only for the absolute hierarchy.
    pub pulldown: Option<pulldown::Pulldown>,
    /// Built only for the delta hierarchy.
    pub delta: Option<delta::Delta>,
    pub oracle: oracle::Oracle,
    pub compact: compact::Compact,
    pub accumulate: accumulate::Accumulate,
    pub energy: energy::Energy,
    pub batches: batches::Batches,
}

impl Kernels {
    /// Builds the pipelines a solve of this specialization dispatches.
    pub fn new(ctx: &Arc<Context>, spec: Specialization) -> Result<Kernels> {
        let delta = spec.variant == VARIANT_ORIGINAL;
        Ok(Kernels {
            direct: direct::Direct::new(ctx, spec)?,
            hemisphere: hemisphere::Hemisphere::new(ctx, spec)?,
            trace: trace::Trace::new(ctx, spec)?,
            reconstruct: reconstruct::Reconstruct::new(ctx, spec)?,
            reduce: reduce::Reduce::new(ctx, spec)?,
            linked: (spec.variant == VARIANT_APPROX)
                .then(|| linked::Linked::new(ctx, spec))
                .transpose()?,
            pulldown: (!delta).then(|| pulldown::Pulldown::new(ctx, spec)).transpose()?,
            delta: delta.then(|| delta::Delta::new(ctx, spec)).transpose()?,
            oracle: oracle::Oracle::new(ctx, spec)?,
            compact: compact::Compact::new(ctx, spec)?,
            accumulate: accumulate::Accumulate::new(ctx, spec)?,
            energy: energy::Energy::new(ctx, spec)?,
            batches: batches::Batches::new(ctx, spec)?,
        })
    }

    /// The names of the pipelines that were built.
    pub fn built(&self) -> Vec<&'static str> {
        let mut v = vec![
            direct::Direct::NAME,
            hemisphere::Hemisphere::NAME,
            trace::Trace::NAME,
            reconstruct::Reconstruct::NAME,
            reduce::Reduce::NAME,
            oracle::Oracle::NAME,
            compact::Compact::NAME,
            accumulate::Accumulate::NAME,
            energy::Energy::NAME,
            batches::Batches::NAME,
        ];
        v.extend(self.linked.as_ref().map(|_| linked::Linked::NAME));
        v.extend(self.pulldown.as_ref().map(|_| pulldown::Pulldown::NAME));
        v.extend(self.delta.as_ref().map(|_| delta::Delta::NAME));
        v
    }
}

/// Every wrapper's name, for the check that each GLSL kernel has one.
pub const NAMES: &[&str] = &[
    accumulate::Accumulate::NAME,
    batches::Batches::NAME,
    clips::Clips::NAME,
    compact::Compact::NAME,
    delta::Delta::NAME,
    direct::Direct::NAME,
    energy::Energy::NAME,
    hemisphere::Hemisphere::NAME,
    image::Image::NAME,
    linked::Linked::NAME,
    oracle::Oracle::NAME,
    poisson::Poisson::NAME,
    pulldown::Pulldown::NAME,
    reconstruct::Reconstruct::NAME,
    reduce::Reduce::NAME,
    relations::Relations::NAME,
    scan::Scan::NAME,
    trace::Trace::NAME,
];

#[cfg(test)]
mod tests {
    #[test]
    fn every_glsl_kernel_has_a_wrapper() {
        let glsl: Vec<&str> = crate::gpu::shaders::ALL.iter().map(|(n, _)| *n).collect();
        let mut ours = super::NAMES.to_vec();
        ours.sort();
        assert_eq!(glsl, ours);
    }
}
