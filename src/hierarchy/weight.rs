//! The weight function of the Shepard basis (`ALGORITHM.md` §3):
//! `δ = |x − x_j| / h + α (1 − n · n_j)`, `w = (1 − δ²)³` for `δ < 1`.
//! GLSL twin: `node_weight` in `glsl/include/hierarchy.glsl`.

use glam::Vec3;

use crate::geom::sampling::onb;

/// Scale of a clip plane's distance: `d / CLIP_SCALE · h`.
pub const CLIP_SCALE: f32 = crate::constants::CLIP_SCALE as f32;
/// A node's clip: up to two planes, 8 bytes each, little endian: `ux, uy` (i16, the
/// plane's direction in the node's tangent frame, /32767), `d` (u16, distance
/// `d / CLIP_SCALE · h`, rounded down so nothing behind the plane gets through; 0xffff:
/// no plane), `mask` (u16: the tangent directions, of the 8 at k·45°, in whose sectors
/// the plane comes within the support).
pub type Clip = [u8; 16];
/// A clip without planes.
pub const NO_CLIP: Clip = [0, 0, 0, 0, 0xff, 0xff, 0, 0, 0, 0, 0, 0, 0xff, 0xff, 0, 0];
/// Scale of a clip plane's direction components.
pub const CLIP_DIR: f32 = crate::constants::CLIP_DIR;

/// The nearest of the 8 tangent directions at k·45° to `(x, y)`, without trigonometry
/// (the same arithmetic on the GPU).
#[inline]
pub fn direction8(x: f32, y: f32) -> u32 {
    const T: f32 = 0.414_213_57; // tan 22.5°
    if y.abs() <= T * x.abs() {
        if x >= 0.0 {
            0
        } else {
            4
        }
    } else if x.abs() <= T * y.abs() {
        if y >= 0.0 {
            2
        } else {
            6
        }
    } else {
        match (x >= 0.0, y >= 0.0) {
            (true, true) => 1,
            (false, true) => 3,
            (false, false) => 5,
            (true, false) => 7,
        }
    }
}

/// Whether a point at offset `v` from a node (normal `n`, support `h`) is admitted by the
/// node's clip: not behind a plane met in the point's direction.
#[inline]
pub fn clip_ok(clip: &Clip, v: Vec3, n: Vec3, h: f32) -> bool {
    if clip[4] == 0xff && clip[5] == 0xff {
        return true;
    }
    let (t, b) = onb(n);
    let (x, y) = (v.dot(t), v.dot(b));
    let k = direction8(x, y);
    for c in [&clip[0..8], &clip[8..16]] {
        let d = u16::from_le_bytes([c[4], c[5]]);
        if d == 0xffff || c[6] & (1 << k) == 0 {
            continue;
        }
        let ux = i16::from_le_bytes([c[0], c[1]]) as f32 * (1.0 / CLIP_DIR);
        let uy = i16::from_le_bytes([c[2], c[3]]) as f32 * (1.0 / CLIP_DIR);
        if x * ux + y * uy > d as f32 * (1.0 / CLIP_SCALE) * h {
            return false;
        }
    }
    true
}

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
