//! meshrad: meshless hierarchical radiosity (Zollhöfer & Stamminger, VMV 2011, after
//! Lehtinen et al. 2008) on the CPU and on Vulkan compute.
//!
//! Data flow: [`scene`] loads OBJ/MTL into object-space triangles with one BVH per object;
//! [`hierarchy`] builds the per-object Poisson-disk levels, kd-trees and parent relations;
//! [`transport`] runs the bounce loop on a backend (the CPU reference or the GPU);
//! [`output`] evaluates the solution at pixels and probe points.

pub mod analytic;
pub mod bench;
pub mod cli;
pub mod constants;
pub mod device;
pub mod editor;
pub mod engine;
pub mod error;
pub mod geom;
pub mod gpu;
pub mod hierarchy;
pub mod layout;
pub mod limits;
pub mod metrics;
pub mod output;
pub mod params;
pub mod progress;
#[cfg(feature = "python")]
mod python;
pub mod reference;
pub mod run;
pub mod scene;
pub mod transport;

pub use engine::Engine;
pub use error::{Error, Result};
pub use hierarchy::Hierarchy;
pub use params::{SolverParams, Variant};
pub use run::{solve, Run};
pub use scene::Scene;
pub use transport::Solution;
