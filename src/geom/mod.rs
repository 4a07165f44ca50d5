//! Geometry shared by every part of the solver: random numbers, hemisphere sampling,
//! rays, triangles and BVH traversal. Each function here has a GLSL twin of the same name
//! in `glsl/include/`; `tests/kernels.rs` holds the two together.

pub mod bvh;
pub mod ray;
pub mod rng;
pub mod sampling;
pub mod transform;

pub use ray::{Hit, Ray};
pub use transform::Transform;
