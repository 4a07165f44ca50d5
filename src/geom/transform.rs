//! Rigid transforms with uniform scale (paper §6: per-object hierarchies survive them).
//! Stored as two 3×4 row matrices that both the CPU and the GPU apply the same way
//! (`xform_point` / `xform_vector` in `glsl/include/geometry.glsl`).

use glam::{Mat3, Vec3};

/// Scale, then rotate (degrees about x, then y, then z), then translate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    pub scale: f32,
    pub rotate_deg: Vec3,
    pub translate: Vec3,
}

impl Default for Transform {
    fn default() -> Self {
        Transform {
            scale: 1.0,
            rotate_deg: Vec3::ZERO,
            translate: Vec3::ZERO,
        }
    }
}

/// Rows of a 3×4 affine matrix.
pub type Affine = [[f32; 4]; 3];

impl Transform {
    /// The rotation matrix: x first, then y, then z.
    pub fn rotation(&self) -> Mat3 {
        let r = self.rotate_deg * (std::f32::consts::PI / 180.0);
        Mat3::from_rotation_z(r.z) * Mat3::from_rotation_y(r.y) * Mat3::from_rotation_x(r.x)
    }

    /// Whether this is the identity (then matrices are exact).
    pub fn is_identity(&self) -> bool {
        *self == Transform::default()
    }

    /// Object → world.
    pub fn to_world(&self) -> Affine {
        let m = self.rotation() * self.scale;
        affine(m, self.translate)
    }

    /// World → object.
    pub fn to_object(&self) -> Affine {
        let m = self.rotation().transpose() * (1.0 / self.scale);
        affine(m, -(m * self.translate))
    }
}

fn affine(m: Mat3, t: Vec3) -> Affine {
    if m == Mat3::IDENTITY && t == Vec3::ZERO {
        return [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]];
    }
    let r = m.transpose(); // rows of m are columns of the transpose
    [
        [r.x_axis.x, r.x_axis.y, r.x_axis.z, t.x],
        [r.y_axis.x, r.y_axis.y, r.y_axis.z, t.y],
        [r.z_axis.x, r.z_axis.y, r.z_axis.z, t.z],
    ]
}

/// `m · (p, 1)`.
#[inline]
pub fn xform_point(m: &Affine, p: Vec3) -> Vec3 {
    Vec3::new(
        m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3],
        m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3],
        m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3],
    )
}

/// `m · (v, 0)`: directions (not normalised: ray parameters stay valid across spaces).
#[inline]
pub fn xform_vector(m: &Affine, v: Vec3) -> Vec3 {
    Vec3::new(
        m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
        m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
        m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip() {
        let t = Transform {
            scale: 2.5,
            rotate_deg: Vec3::new(10.0, 180.0, -33.0),
            translate: Vec3::new(1.0, -2.0, 3e3),
        };
        let p = Vec3::new(0.3, 4.0, -7.0);
        let w = xform_point(&t.to_world(), p);
        let back = xform_point(&t.to_object(), w);
        assert!((back - p).length() < 1e-3, "{back} vs {p}");
        let expected = t.rotation() * (p * 2.5) + t.translate;
        assert!((w - expected).length() < 1e-3);
    }
}
