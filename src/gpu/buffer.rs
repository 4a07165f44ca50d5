//! Device buffers reached by address (`VK_KHR_buffer_device_address`, core in 1.2), with
//! staging uploads and readbacks. RAII: each buffer frees its allocation in `Drop`.

use std::sync::Arc;

use ash::vk;
use bytemuck::Pod;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

use super::context::Context;
use super::VkCheck;
use crate::error::{Error, Result};

/// A buffer and its memory.
pub struct Buffer {
    ctx: Arc<Context>,
    pub buffer: vk::Buffer,
    allocation: Option<Allocation>,
    pub size: u64,
    pub address: u64,
    pub name: String,
}

impl Buffer {
    /// A buffer of `size` bytes (at least 16) usable as storage, copy source and target.
    pub fn new(ctx: &Arc<Context>, name: &str, size: u64, location: MemoryLocation) -> Result<Buffer> {
        let size = size.max(16);
        if ctx.info.max_allocation_bytes > 0 && size > ctx.info.max_allocation_bytes {
            return Err(Error::Gpu(format!(
                "buffer `{name}` needs {size} bytes, above the device's largest allocation of {} bytes",
                ctx.info.max_allocation_bytes
            )));
        }
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_SRC
                    | vk::BufferUsageFlags::TRANSFER_DST
                    | vk::BufferUsageFlags::INDIRECT_BUFFER
                    | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            )
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        let d = &ctx.device;
        // SAFETY: valid device and create info.
        let buffer = unsafe { d.create_buffer(&info, None) }.vk("vkCreateBuffer")?;
        // SAFETY: `buffer` was just created from `d`.
        let requirements = unsafe { d.get_buffer_memory_requirements(buffer) };
        let allocation = ctx
            .allocator
            .lock()
            .map_err(|_| Error::Gpu("allocator lock poisoned".into()))?
            .allocate(&AllocationCreateDesc {
                name,
                requirements,
                location,
                linear: true,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            });
        let allocation = match allocation {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: the buffer has no memory bound and is not in use.
                unsafe { d.destroy_buffer(buffer, None) };
                return Err(Error::Gpu(format!(
                    "allocating {size} bytes for `{name}` failed: {e} (out of device memory?)"
                )));
            }
        };
        // SAFETY: the allocation satisfies the buffer's requirements.
        let bound = unsafe { d.bind_buffer_memory(buffer, allocation.memory(), allocation.offset()) };
        let mut b = Buffer {
            ctx: ctx.clone(),
            buffer,
            allocation: Some(allocation),
            size,
            address: 0,
            name: name.to_string(),
        };
        bound.vk("vkBindBufferMemory")?;
        // SAFETY: the buffer has SHADER_DEVICE_ADDRESS usage and bound memory.
        b.address = unsafe { d.get_buffer_device_address(&vk::BufferDeviceAddressInfo::default().buffer(buffer)) };
        Ok(b)
    }

    /// A device-local buffer holding `data` (through a staging buffer).
    pub fn upload<T: Pod>(ctx: &Arc<Context>, name: &str, data: &[T]) -> Result<Buffer> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let dst = Buffer::new(ctx, name, bytes.len() as u64, MemoryLocation::GpuOnly)?;
        if bytes.is_empty() {
            return Ok(dst);
        }
        let mut staging = Buffer::new(
            ctx,
            &format!("{name} (staging)"),
            bytes.len() as u64,
            MemoryLocation::CpuToGpu,
        )?;
        staging.write(0, bytes)?;
        ctx.run(|cmd| {
            let region = [vk::BufferCopy::default().size(bytes.len() as u64)];
            // SAFETY: both buffers are valid and large enough.
            unsafe {
                ctx.device.cmd_copy_buffer(cmd, staging.buffer, dst.buffer, &region);
            }
            transfer_barrier(ctx, cmd);
            Ok(())
        })?;
        Ok(dst)
    }

    /// A zero-filled device-local buffer.
    pub fn zeroed(ctx: &Arc<Context>, name: &str, size: u64) -> Result<Buffer> {
        let b = Buffer::new(ctx, name, size, MemoryLocation::GpuOnly)?;
        ctx.run(|cmd| {
            b.fill(cmd, 0, b.size, 0);
            transfer_barrier(ctx, cmd);
            Ok(())
        })?;
        Ok(b)
    }

    /// Writes into a host-visible buffer at byte `offset`.
    pub fn write(&mut self, offset: usize, bytes: &[u8]) -> Result<()> {
        let name = self.name.clone();
        let slice = self
            .allocation
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .ok_or_else(|| Error::Gpu(format!("buffer `{name}` is not host-visible")))?;
        slice[offset..offset + bytes.len()].copy_from_slice(bytes);
        Ok(())
    }

    /// The contents of a host-visible buffer (after a submission that wrote it completed).
    pub fn mapped(&self) -> Result<&[u8]> {
        self.allocation
            .as_ref()
            .and_then(|a| a.mapped_slice())
            .ok_or_else(|| Error::Gpu(format!("buffer `{}` is not host-visible", self.name)))
    }

    /// Records a fill of `size` bytes at `offset` with the word `value`.
    pub fn fill(&self, cmd: vk::CommandBuffer, offset: u64, size: u64, value: u32) {
        if size == 0 {
            return;
        }
        // SAFETY: offset and size are multiples of 4 within the buffer (callers use u32/vec4 ranges).
        unsafe { self.ctx.device.cmd_fill_buffer(cmd, self.buffer, offset, size, value) };
    }

    /// Reads `count` elements of `T` starting at element `first` (through a staging buffer).
    pub fn download<T: Pod>(&self, first: usize, count: usize) -> Result<Vec<T>> {
        let sz = std::mem::size_of::<T>();
        let bytes = (count * sz) as u64;
        if count == 0 {
            return Ok(Vec::new());
        }
        let staging = Buffer::new(
            &self.ctx,
            &format!("{} (readback)", self.name),
            bytes,
            MemoryLocation::GpuToCpu,
        )?;
        self.ctx.run(|cmd| {
            barrier(
                &self.ctx,
                cmd,
                vk::PipelineStageFlags::COMPUTE_SHADER,
                vk::AccessFlags::SHADER_WRITE,
            );
            let region = [vk::BufferCopy::default().src_offset((first * sz) as u64).size(bytes)];
            // SAFETY: both buffers are valid and large enough.
            unsafe {
                self.ctx
                    .device
                    .cmd_copy_buffer(cmd, self.buffer, staging.buffer, &region)
            };
            host_barrier(&self.ctx, cmd);
            Ok(())
        })?;
        let slice = staging
            .allocation
            .as_ref()
            .and_then(|a| a.mapped_slice())
            .ok_or_else(|| Error::Gpu("readback buffer is not host-visible".into()))?;
        Ok(bytemuck::pod_collect_to_vec(&slice[..bytes as usize]))
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        // SAFETY: the buffer is not in use (every submission is waited for) and its
        // allocation came from this context's allocator.
        unsafe { self.ctx.device.destroy_buffer(self.buffer, None) };
        if let Some(a) = self.allocation.take() {
            if let Ok(mut al) = self.ctx.allocator.lock() {
                let _ = al.free(a);
            }
        }
    }
}

/// A global memory barrier from `(src stages, src accesses)` to `(dst stages, dst accesses)`.
pub fn memory_barrier(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    src: (vk::PipelineStageFlags, vk::AccessFlags),
    dst: (vk::PipelineStageFlags, vk::AccessFlags),
) {
    let b = [vk::MemoryBarrier::default()
        .src_access_mask(src.1)
        .dst_access_mask(dst.1)];
    // SAFETY: recording into a command buffer in the recording state.
    unsafe {
        ctx.device
            .cmd_pipeline_barrier(cmd, src.0, dst.0, vk::DependencyFlags::empty(), &b, &[], &[]);
    }
}

/// A global barrier: everything written by `src` stages/accesses becomes visible to
/// compute shaders and transfers that follow.
pub fn barrier(ctx: &Context, cmd: vk::CommandBuffer, src: vk::PipelineStageFlags, access: vk::AccessFlags) {
    memory_barrier(
        ctx,
        cmd,
        (src, access),
        (
            vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
            vk::AccessFlags::SHADER_READ
                | vk::AccessFlags::SHADER_WRITE
                | vk::AccessFlags::TRANSFER_READ
                | vk::AccessFlags::TRANSFER_WRITE,
        ),
    );
}

/// The barrier after copies and fills that kernels and transfers read next.
pub fn transfer_barrier(ctx: &Context, cmd: vk::CommandBuffer) {
    barrier(
        ctx,
        cmd,
        vk::PipelineStageFlags::TRANSFER,
        vk::AccessFlags::TRANSFER_WRITE,
    );
}

/// The barrier after a kernel wrote indirect dispatch arguments.
pub fn indirect_barrier(ctx: &Context, cmd: vk::CommandBuffer) {
    memory_barrier(
        ctx,
        cmd,
        (vk::PipelineStageFlags::COMPUTE_SHADER, vk::AccessFlags::SHADER_WRITE),
        (
            vk::PipelineStageFlags::DRAW_INDIRECT | vk::PipelineStageFlags::COMPUTE_SHADER,
            vk::AccessFlags::INDIRECT_COMMAND_READ | vk::AccessFlags::SHADER_READ,
        ),
    );
}

/// The barrier after copies that the host reads once the submission completed.
pub fn host_barrier(ctx: &Context, cmd: vk::CommandBuffer) {
    memory_barrier(
        ctx,
        cmd,
        (vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::TRANSFER_WRITE),
        (vk::PipelineStageFlags::HOST, vk::AccessFlags::HOST_READ),
    );
}

/// The barrier between two dependent compute dispatches (or a fill and a dispatch).
pub fn compute_barrier(ctx: &Context, cmd: vk::CommandBuffer) {
    barrier(
        ctx,
        cmd,
        vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
        vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE,
    );
}
