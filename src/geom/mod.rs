//! Geometry shared by every part of the solver: random numbers, hemisphere sampling,
//! rays, triangles and BVH traversal. Each function here has a GLSL twin of the same name
//! in `glsl/include/`; `tests/gpu.rs` holds the two together.

pub mod bvh;
pub mod ray;
pub mod rng;
pub mod sampling;
pub mod transform;

pub use ray::{Hit, Ray};
pub use transform::Transform;

/// `v` scaled to unit length, computed so that neither huge (`[1e30, -1e30, 0]`) nor tiny
/// components overflow or underflow on the way; `None` for a zero or non-finite vector.
pub fn unit_vector(v: glam::DVec3) -> Option<glam::Vec3> {
    let m = v.abs().max_element();
    if !(m.is_finite() && m > 0.0) {
        return None;
    }
    let u = (v / m).normalize();
    u.is_finite().then(|| u.as_vec3())
}
