//! Kernel `reduce` (`glsl/reduce.comp`): the Monte Carlo reduction, one workgroup per integral:
//! mean and standard error of its samples, in a fixed order.

use super::gather::{per_integral, Batch, GatherPush};
use super::{kernel, Recorder};

kernel!(Reduce, "reduce", REDUCE, GatherPush);

impl Reduce {
    /// Records the kernel over one gathering batch.
    pub fn record(&self, rec: &mut Recorder, batch: &Batch) {
        per_integral(rec, &self.0, batch);
    }
}
