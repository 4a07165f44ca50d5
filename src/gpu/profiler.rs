//! GPU timestamps around each kernel launch, summed per kernel name.

use std::collections::BTreeMap;
use std::sync::Arc;

use ash::vk;

use super::context::Context;
use super::VkCheck;
use crate::error::Result;

const CAPACITY: u32 = 8192;

/// A timestamp query pool and the labels of the queries written into it.
pub struct Profiler {
    ctx: Arc<Context>,
    pool: Option<vk::QueryPool>,
    labels: Vec<&'static str>,
    pub totals: BTreeMap<&'static str, (f64, u64)>,
    /// Launches recorded past the pool's capacity in one command buffer: dispatched but
    /// not timed (reported, so that `totals` is never silently short).
    pub untimed: BTreeMap<&'static str, u64>,
}

impl Profiler {
    pub fn new(ctx: &Arc<Context>) -> Result<Profiler> {
        let pool = if ctx.timestamps {
            let info = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::TIMESTAMP)
                .query_count(CAPACITY);
            // SAFETY: valid device.
            Some(unsafe { ctx.device.create_query_pool(&info, None) }.vk("vkCreateQueryPool")?)
        } else {
            None
        };
        Ok(Profiler {
            ctx: ctx.clone(),
            pool,
            labels: Vec::new(),
            totals: BTreeMap::new(),
            untimed: BTreeMap::new(),
        })
    }

    /// Forgets the totals (a new solve starts).
    pub fn clear(&mut self) {
        self.totals.clear();
        self.untimed.clear();
    }

    /// Whether `label` was launched (timed or not) since the last [`Profiler::clear`].
    pub fn launched(&self, label: &str) -> bool {
        self.totals.contains_key(label) || self.untimed.contains_key(label)
    }

    /// Resets the pool at the start of a command buffer.
    pub fn begin_frame(&mut self, cmd: vk::CommandBuffer) {
        self.labels.clear();
        if let Some(p) = self.pool {
            // SAFETY: recording state, valid pool.
            unsafe { self.ctx.device.cmd_reset_query_pool(cmd, p, 0, CAPACITY) };
        }
    }

    /// Wraps the commands `f` records in two timestamps labelled `label`.
    pub fn time(&mut self, cmd: vk::CommandBuffer, label: &'static str, f: impl FnOnce()) {
        let Some(p) = self.pool else {
            f();
            return;
        };
        if (self.labels.len() as u32 + 1) * 2 > CAPACITY {
            *self.untimed.entry(label).or_insert(0) += 1;
            f();
            return;
        }
        let q = self.labels.len() as u32 * 2;
        // SAFETY: recording state; query indices are within the pool and were reset.
        unsafe {
            self.ctx
                .device
                .cmd_write_timestamp(cmd, vk::PipelineStageFlags::TOP_OF_PIPE, p, q);
            f();
            self.ctx
                .device
                .cmd_write_timestamp(cmd, vk::PipelineStageFlags::BOTTOM_OF_PIPE, p, q + 1);
        }
        self.labels.push(label);
    }

    /// After the command buffer completed: adds its queries to the totals.
    pub fn end_frame(&mut self) -> Result<()> {
        let Some(p) = self.pool else {
            return Ok(());
        };
        if self.labels.is_empty() {
            return Ok(());
        }
        let n = self.labels.len() * 2;
        let mut data = vec![0u64; n];
        // SAFETY: the queries were written by a completed submission.
        unsafe {
            self.ctx.device.get_query_pool_results(
                p,
                0,
                &mut data,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .vk("vkGetQueryPoolResults")?;
        let period = self.ctx.info.timestamp_period_ns as f64 * 1e-9;
        for (i, l) in self.labels.iter().enumerate() {
            let dt = data[2 * i + 1].saturating_sub(data[2 * i]) as f64 * period;
            let e = self.totals.entry(l).or_insert((0.0, 0));
            e.0 += dt;
            e.1 += 1;
        }
        self.labels.clear();
        Ok(())
    }
}

impl Drop for Profiler {
    fn drop(&mut self) {
        if let Some(p) = self.pool.take() {
            // SAFETY: no pending submission uses the pool.
            unsafe { self.ctx.device.destroy_query_pool(p, None) };
        }
    }
}
