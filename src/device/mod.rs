//! The method on a Vulkan device, over the wrapper in `crate::gpu`: the transport backend
//! that runs the whole bounce loop on the device ([`GpuBackend`]) and what stays resident
//! between solves ([`GpuResident`]), every buffer by name (`resources`, `globals`), the
//! order of kernels and barriers (`schedule`), one wrapper per kernel (`kernels`), and the
//! two steps of the hierarchy's build that run where the transport runs: the arrangement
//! (`arrange`, twin of `crate::hierarchy::clips` and the relations) and dart throwing
//! (`poisson`, twin of `crate::hierarchy::poisson`). `crate::engine` decides when they run.

pub mod arrange;
pub mod backend;
pub mod globals;
pub mod image;
pub mod kernels;
pub mod poisson;
pub mod resources;
pub mod schedule;

pub use backend::{GpuBackend, GpuReport, GpuResident};
