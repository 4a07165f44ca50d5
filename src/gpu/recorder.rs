//! One command buffer being recorded ([`Recorder`]): dispatches timed under their
//! kernels' names, fills, copies and barriers; [`submit`] records one, submits it and
//! waits. What is recorded, and in which order, is the caller's (`crate::device`).

use ash::vk;
use bytemuck::Pod;

use super::buffer::{compute_barrier, host_barrier, indirect_barrier, Buffer};
use super::context::Context;
use super::pipeline::Kernel;
use super::profiler::Profiler;
use crate::constants::LINEAR_GROUP;
use crate::error::Result;

/// One command buffer being recorded: where dispatches, fills, copies and barriers go,
/// each dispatch timed under its kernel's name.
pub struct Recorder<'a> {
    pub ctx: &'a Context,
    pub prof: &'a mut Profiler,
    pub cmd: vk::CommandBuffer,
    /// Device address of the solve's `Globals` block (every push struct's first field).
    pub globals: u64,
}

impl Recorder<'_> {
    /// Records `groups` workgroups of `kernel` with push constants `push`.
    pub fn dispatch<T: Pod>(&mut self, kernel: &Kernel, push: &T, groups: u64) {
        let cmd = self.cmd;
        self.prof.time(cmd, kernel.name, || kernel.dispatch(cmd, push, groups));
    }

    /// Records a dispatch of `kernel` whose grid the device wrote at byte `offset` of `args`.
    pub fn dispatch_indirect<T: Pod>(&mut self, kernel: &Kernel, push: &T, args: &Buffer, offset: u64) {
        let cmd = self.cmd;
        self.prof.time(cmd, kernel.name, || {
            kernel.dispatch_indirect(cmd, push, args.buffer, offset)
        });
    }

    /// Fills `size` bytes of `buffer` from byte `offset` with the word `value`.
    pub fn fill(&self, buffer: &Buffer, offset: u64, size: u64, value: u32) {
        buffer.fill(self.cmd, offset, size, value);
    }

    /// Copies byte regions of `src` into `dst`.
    pub fn copy(&self, src: &Buffer, dst: &Buffer, regions: &[vk::BufferCopy]) {
        // SAFETY: recording state; callers give regions within both buffers.
        unsafe {
            self.ctx
                .device
                .cmd_copy_buffer(self.cmd, src.buffer, dst.buffer, regions)
        };
    }

    /// Between two dependent dispatches (or a fill or copy and a dispatch).
    pub fn barrier(&self) {
        compute_barrier(self.ctx, self.cmd);
    }

    /// After a dispatch that wrote indirect dispatch arguments.
    pub fn indirect_barrier(&self) {
        indirect_barrier(self.ctx, self.cmd);
    }

    /// After copies that the host reads once the submission completed.
    pub fn host_barrier(&self) {
        host_barrier(self.ctx, self.cmd);
    }
}

/// Records `f` into one command buffer on `ctx`'s queue, submits it and waits; its
/// dispatches are timed under their kernels' names (`prof`), against the `Globals` block
/// at address `globals`.
pub fn submit(ctx: &Context, prof: &mut Profiler, globals: u64, f: impl FnOnce(&mut Recorder)) -> Result<()> {
    ctx.run(|cmd| {
        prof.begin_frame(cmd);
        let mut rec = Recorder {
            ctx,
            prof,
            cmd,
            globals,
        };
        f(&mut rec);
        Ok(())
    })?;
    prof.end_frame()
}

/// Workgroups for one thread per element.
pub fn per_element(count: u64) -> u64 {
    count.div_ceil(LINEAR_GROUP as u64)
}
