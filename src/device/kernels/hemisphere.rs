//! Kernel `hemisphere` (`glsl/hemisphere.comp`): the gathering rays of a batch of integrals: Halton
//! points on the cosine-weighted hemisphere, rotated per integral (paper §4.2).

use super::gather::{per_ray, Batch, GatherPush};
use super::{kernel, Recorder};

kernel!(Hemisphere, "hemisphere", HEMISPHERE, GatherPush);

impl Hemisphere {
    /// Records the kernel over one gathering batch.
    pub fn record(&self, rec: &mut Recorder, batch: &Batch) {
        per_ray(rec, &self.0, batch);
    }
}
