//! Compute pipelines from embedded SPIR-V. There are no descriptor sets: each kernel has
//! its own push-constant struct (`crate::device::kernels::<name>`), whose first field is the
//! address of the `Globals` block. The variant, texturing and the BVH kind are
//! specialization constants.

use std::sync::Arc;

use ash::vk;
use bytemuck::Pod;

use super::context::Context;
use super::VkCheck;
use crate::error::{Error, Result};

/// Values of the specialization constants (ids `SPEC_*` in `crate::constants`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Specialization {
    pub variant: u32,
    pub textured: bool,
    pub bvh: u32,
}

/// A compute pipeline.
pub struct Kernel {
    ctx: Arc<Context>,
    pub name: &'static str,
    pub pipeline: vk::Pipeline,
    pub layout: vk::PipelineLayout,
}

impl Kernel {
    /// Builds kernel `name` from its SPIR-V, with a push-constant range of `push_bytes`.
    pub fn new(
        ctx: &Arc<Context>,
        name: &'static str,
        spirv: &[u8],
        spec: Specialization,
        push_bytes: u32,
    ) -> Result<Kernel> {
        let code = ash::util::read_spv(&mut std::io::Cursor::new(spirv))
            .map_err(|e| Error::Gpu(format!("kernel {name}: bad SPIR-V: {e}")))?;
        let d = &ctx.device;
        let module_info = vk::ShaderModuleCreateInfo::default().code(&code);
        // SAFETY: valid device; the code is SPIR-V produced by glslc at build time.
        let module = unsafe { d.create_shader_module(&module_info, None) }.vk("vkCreateShaderModule")?;
        let ranges = [vk::PushConstantRange::default()
            .stage_flags(vk::ShaderStageFlags::COMPUTE)
            .offset(0)
            .size(push_bytes)];
        let layout_info = vk::PipelineLayoutCreateInfo::default().push_constant_ranges(&ranges);
        // SAFETY: valid device.
        let layout = match unsafe { d.create_pipeline_layout(&layout_info, None) } {
            Ok(l) => l,
            Err(r) => {
                // SAFETY: the module is unused.
                unsafe { d.destroy_shader_module(module, None) };
                return Err(super::vk_err("vkCreatePipelineLayout", r));
            }
        };
        let data: [u32; 3] = [spec.variant, spec.textured as u32, spec.bvh];
        let entries = [
            vk::SpecializationMapEntry::default()
                .constant_id(crate::constants::SPEC_VARIANT)
                .offset(0)
                .size(4),
            vk::SpecializationMapEntry::default()
                .constant_id(crate::constants::SPEC_TEXTURED)
                .offset(4)
                .size(4),
            vk::SpecializationMapEntry::default()
                .constant_id(crate::constants::SPEC_BVH_KIND)
                .offset(8)
                .size(4),
        ];
        let spec_info = vk::SpecializationInfo::default()
            .map_entries(&entries)
            .data(bytemuck::cast_slice(&data));
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main")
            .specialization_info(&spec_info);
        let info = [vk::ComputePipelineCreateInfo::default().stage(stage).layout(layout)];
        // SAFETY: valid device, module and layout.
        let pipeline = unsafe { d.create_compute_pipelines(vk::PipelineCache::null(), &info, None) };
        // SAFETY: the module is no longer needed once the pipeline exists (or failed).
        unsafe { d.destroy_shader_module(module, None) };
        let pipeline = match pipeline {
            Ok(p) => p[0],
            Err((_, r)) => {
                // SAFETY: the layout is unused.
                unsafe { d.destroy_pipeline_layout(layout, None) };
                return Err(super::vk_err(&format!("vkCreateComputePipelines ({name})"), r));
            }
        };
        Ok(Kernel {
            ctx: ctx.clone(),
            name,
            pipeline,
            layout,
        })
    }

    /// Records a dispatch of `groups` workgroups (laid out in 2-D when they exceed the
    /// device's x limit) with push constants `push`.
    pub fn dispatch<T: Pod>(&self, cmd: vk::CommandBuffer, push: &T, groups: u64) {
        if groups == 0 {
            return;
        }
        let max_x = self.ctx.info.max_workgroup_count_x.clamp(1, 65535) as u64;
        let x = groups.min(max_x);
        let y = groups.div_ceil(x);
        self.bind(cmd, push);
        // SAFETY: recording state, pipeline bound.
        unsafe { self.ctx.device.cmd_dispatch(cmd, x as u32, y as u32, 1) };
    }

    /// Records a dispatch whose grid the device wrote at byte `offset` of `args`.
    pub fn dispatch_indirect<T: Pod>(&self, cmd: vk::CommandBuffer, push: &T, args: vk::Buffer, offset: u64) {
        self.bind(cmd, push);
        // SAFETY: recording state; `args` holds a VkDispatchIndirectCommand at `offset`.
        unsafe { self.ctx.device.cmd_dispatch_indirect(cmd, args, offset) };
    }

    fn bind<T: Pod>(&self, cmd: vk::CommandBuffer, push: &T) {
        let d = &self.ctx.device;
        // SAFETY: recording state; the push range matches the layout.
        unsafe {
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.pipeline);
            d.cmd_push_constants(
                cmd,
                self.layout,
                vk::ShaderStageFlags::COMPUTE,
                0,
                bytemuck::bytes_of(push),
            );
        }
    }
}

impl Drop for Kernel {
    fn drop(&mut self) {
        // SAFETY: no submission using the pipeline is pending (all are waited for).
        unsafe {
            self.ctx.device.destroy_pipeline(self.pipeline, None);
            self.ctx.device.destroy_pipeline_layout(self.layout, None);
        }
    }
}
