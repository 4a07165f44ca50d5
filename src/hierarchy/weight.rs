//! The weight function of the Shepard basis (`ALGORITHM.md` §3):
//! `δ = |x − x_j| / h + α (1 − n · n_j)`, `w = (1 − δ²)³` for `δ < 1`.
//! GLSL twin: `node_weight` in `glsl/include/hierarchy.glsl`.

use glam::Vec3;

/// `w_j(p)` for a node at `xj` with normal `nj`, support `h`, normal weight `alpha`.
#[inline]
pub fn node_weight(p: Vec3, n: Vec3, xj: Vec3, nj: Vec3, h: f32, alpha: f32) -> f32 {
    let d = (p - xj).length() / h + alpha * (1.0 - n.dot(nj));
    if d >= 1.0 {
        0.0
    } else {
        let q = 1.0 - d * d;
        q * q * q
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shape() {
        let n = Vec3::Z;
        assert_eq!(node_weight(Vec3::ZERO, n, Vec3::ZERO, n, 1.0, 1.0), 1.0);
        assert_eq!(node_weight(Vec3::X, n, Vec3::ZERO, n, 1.0, 1.0), 0.0);
        let half = node_weight(Vec3::X * 0.5, n, Vec3::ZERO, n, 1.0, 1.0);
        assert!((half - 0.421_875).abs() < 1e-6);
        // A crease of 90° or more gets no weight, whatever the distance.
        assert_eq!(node_weight(Vec3::ZERO, n, Vec3::ZERO, Vec3::X, 1.0, 1.0), 0.0);
        assert_eq!(node_weight(Vec3::ZERO, n, Vec3::ZERO, -n, 1.0, 1.0), 0.0);
    }
}
