//! Kernel `linked` (`glsl/linked.comp`): the samples of a gathering batch whose integrals
//! all read links, each the link's albedo times its sender's un-shot value.

use super::gather::{per_ray, Batch, GatherPush};
use super::{kernel, Recorder};

kernel!(Linked, "linked", LINKED, GatherPush);

impl Linked {
    /// Records the kernel over one gathering batch.
    pub fn record(&self, rec: &mut Recorder, batch: &Batch) {
        per_ray(rec, &self.0, batch);
    }
}
