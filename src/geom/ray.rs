//! Rays, the watertight ray–triangle test (Woop, Benthin & Wald 2013) and the
//! scale-aware origin offset (Wächter & Binder, Ray Tracing Gems ch. 6).
//! GLSL twin: `glsl/include/geometry.glsl`.

use glam::Vec3;

use crate::layout::Tri;

/// A ray. `d` need not be unit length: `t` is in units of `|d|`.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub o: Vec3,
    pub d: Vec3,
}

/// The closest hit of a ray: object, object-local triangle, distance, barycentrics of
/// `v1` and `v2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub object: u32,
    pub tri: u32,
    pub t: f32,
    pub b1: f32,
    pub b2: f32,
}

/// Per-ray constants of the watertight test.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    pub o: Vec3,
    pub k: [usize; 3],
    pub s: Vec3,
}

impl WatertightRay {
    pub fn new(ray: &Ray) -> Self {
        let d = ray.d;
        let a = d.abs();
        let kz = if a.x > a.y {
            if a.x > a.z {
                0
            } else {
                2
            }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        WatertightRay {
            o: ray.o,
            k: [kx, ky, kz],
            s: Vec3::new(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]),
        }
    }

    /// Hit distance and barycentrics of (v1, v2) if the ray hits `tri` in (0, tmax).
    #[inline]
    pub fn intersect(&self, tri: &Tri, tmax: f32) -> Option<(f32, f32, f32)> {
        let [kx, ky, kz] = self.k;
        let a = Vec3::from(tri.v0) - self.o;
        let b = Vec3::from(tri.v1) - self.o;
        let c = Vec3::from(tri.v2) - self.o;
        let ax = a[kx] - self.s.x * a[kz];
        let ay = a[ky] - self.s.y * a[kz];
        let bx = b[kx] - self.s.x * b[kz];
        let by = b[ky] - self.s.y * b[kz];
        let cx = c[kx] - self.s.x * c[kz];
        let cy = c[ky] - self.s.y * c[kz];
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let az = self.s.z * a[kz];
        let bz = self.s.z * b[kz];
        let cz = self.s.z * c[kz];
        let t = (u * az + v * bz + w * cz) / det;
        if !(t > 0.0 && t < tmax) {
            return None;
        }
        Some((t, v / det, w / det))
    }
}

/// Geometric normal (unit) of a triangle, by the right-hand rule.
#[inline]
pub fn tri_normal(t: &Tri) -> Vec3 {
    let v0 = Vec3::from(t.v0);
    (Vec3::from(t.v1) - v0).cross(Vec3::from(t.v2) - v0).normalize_or_zero()
}

/// Point on a triangle from barycentrics of (v1, v2).
#[inline]
pub fn tri_point(t: &Tri, b1: f32, b2: f32) -> Vec3 {
    let v0 = Vec3::from(t.v0);
    v0 + (Vec3::from(t.v1) - v0) * b1 + (Vec3::from(t.v2) - v0) * b2
}

/// Moves a surface point off its surface along `n` by 32 ulps of its coordinates (a hit
/// point computed from barycentrics is a few ulps off), or by `scale · 2^-21` near the
/// origin (`scale`: the scene's size): scale-aware, never a fixed epsilon in scene units.
/// (Wächter & Binder use 256 ulps; at 1e5 from the origin that is 2 units, more than a
/// small object.)
#[inline]
pub fn offset_origin(p: Vec3, n: Vec3, scale: f32) -> Vec3 {
    use crate::constants::{OFFSET_FINE_DIV, OFFSET_NEAR_DIV, OFFSET_ULPS};
    let near = scale * (1.0 / OFFSET_NEAR_DIV);
    let fine = scale * (1.0 / OFFSET_FINE_DIV);
    let mut out = [0.0f32; 3];
    for i in 0..3 {
        // `as` saturates a non-finite or huge product (a normal of degenerate geometry, such
        // as an object scaled into subnormals) to i32::MIN, whose negation wraps (found by
        // the fuzzer; an overflow panic where overflow is checked).
        let of = (OFFSET_ULPS * n[i]) as i32;
        let bits = p[i].to_bits() as i32;
        let moved = f32::from_bits(bits.wrapping_add(if p[i] < 0.0 { of.wrapping_neg() } else { of }) as u32);
        out[i] = if p[i].abs() < near { p[i] + fine * n[i] } else { moved };
    }
    Vec3::from(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A normal that is not finite (degenerate geometry) moves nothing into a panic: the
    /// offset wraps as it does where overflow is unchecked.
    #[test]
    fn offset_origin_takes_a_normal_that_is_not_finite() {
        for n in [
            Vec3::new(f32::NEG_INFINITY, 0.0, 0.0),
            Vec3::new(-1e30, 0.0, 0.0),
            Vec3::NAN,
        ] {
            let _ = offset_origin(Vec3::new(-5.0, 3.0, 1.0), n, 1.0);
        }
    }

    fn tri(v0: [f32; 3], v1: [f32; 3], v2: [f32; 3]) -> Tri {
        Tri {
            v0,
            v1,
            v2,
            ..Default::default()
        }
    }

    #[test]
    fn hits_and_misses() {
        let t = tri([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        let r = Ray {
            o: Vec3::new(0.25, 0.25, 1.0),
            d: Vec3::new(0.0, 0.0, -2.0),
        };
        let (th, b1, b2) = WatertightRay::new(&r).intersect(&t, f32::INFINITY).unwrap();
        assert!((th - 0.5).abs() < 1e-6 && (b1 - 0.25).abs() < 1e-6 && (b2 - 0.25).abs() < 1e-6);
        let miss = Ray {
            o: Vec3::new(0.75, 0.75, 1.0),
            d: Vec3::new(0.0, 0.0, -1.0),
        };
        assert!(WatertightRay::new(&miss).intersect(&t, f32::INFINITY).is_none());
        assert!(WatertightRay::new(&r).intersect(&t, 0.4).is_none());
    }

    /// Rays through the shared edge of two triangles hit one of them: no cracks.
    #[test]
    fn watertight_on_shared_edge() {
        let a = tri([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]);
        let b = tri([0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]);
        let d = Vec3::new(0.01, -0.013, -1.0);
        for i in 0..=1000 {
            let s = i as f32 / 1000.0;
            let r = Ray {
                o: Vec3::new(s, s, 0.0) - d * 3.7,
                d,
            };
            let w = WatertightRay::new(&r);
            let hit = w.intersect(&a, f32::INFINITY).is_some() || w.intersect(&b, f32::INFINITY).is_some();
            assert!(hit, "crack at s = {s}");
        }
    }

    #[test]
    fn offset_scales_with_magnitude() {
        let n = Vec3::Y;
        let near = offset_origin(Vec3::new(0.0, 0.0, 0.0), n, 1.0);
        assert!(near.y > 0.0 && near.y < 1e-5);
        let far = offset_origin(Vec3::new(1e5, 1e5, 1e5), n, 1.0);
        assert!(far.y > 1e5 && far.x == 1e5);
        let neg = offset_origin(Vec3::new(-3.0, -3.0, -3.0), n, 1.0);
        assert!(neg.y > -3.0);
    }
}
