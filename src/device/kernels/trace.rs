//! Kernel `trace` (`glsl/trace.comp`): each gathering ray's closest hit over all objects.

use super::gather::{per_ray, Batch, GatherPush};
use super::{kernel, Recorder};

kernel!(Trace, "trace", TRACE, GatherPush);

impl Trace {
    /// Records the kernel over one gathering batch.
    pub fn record(&self, rec: &mut Recorder, batch: &Batch) {
        per_ray(rec, &self.0, batch);
    }
}
