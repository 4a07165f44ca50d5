//! Kernel `reconstruct` (`glsl/reconstruct.comp`): `ρ(y) ΔE(y)` at each hit point, by the variant's
//! reconstruction from the sender level.

use super::gather::{per_ray, Batch, GatherPush};
use super::{kernel, Recorder};

kernel!(Reconstruct, "reconstruct", RECONSTRUCT, GatherPush);

impl Reconstruct {
    /// Records the kernel over one gathering batch.
    pub fn record(&self, rec: &mut Recorder, batch: &Batch) {
        per_ray(rec, &self.0, batch);
    }
}
