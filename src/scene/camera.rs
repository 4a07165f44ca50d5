//! A pinhole camera. The field of view is measured along the image's smaller axis
//! (Mitsuba's `fovAxis = smaller`), so the Cornell box camera matches Mitsuba's.

use glam::Vec3;
use serde::Deserialize;

use super::config::CameraEntry;
use crate::error::{Error, Result};
use crate::geom::Ray;

/// Samples per pixel when `[camera] spp` is not given: the knee of the Cornell box's
/// image error-vs-time front (docs/BENCHMARKS.md, "Images").
pub const DEFAULT_SPP: u32 = 16;
/// Most samples per pixel.
pub const MAX_SPP: u32 = 4096;

/// How the samples of one pixel are spread over the image plane. Every sample weighs the
/// same; the Gaussian's shape comes from where its samples fall (filter importance
/// sampling).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase", deny_unknown_fields)]
pub enum Filter {
    /// Uniform over the pixel's square, as Mitsuba's and PBRT's `box`.
    #[default]
    Box,
    /// A Gaussian of standard deviation 0.5 pixel, cut at 2 pixels (Mitsuba's
    /// `gaussian`).
    Gaussian,
}

#[derive(Clone, Debug)]
pub struct Camera {
    pub position: Vec3,
    pub forward: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    pub tan_half: f32,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel (1: one ray through the pixel's centre).
    pub spp: u32,
    pub filter: Filter,
}

impl Camera {
    /// From a `[camera]` entry; errors name the key.
    pub fn from_entry(e: &CameraEntry, path: &std::path::Path) -> Result<Camera> {
        let bad = |key: &str, message: &str| Error::SceneValue {
            path: path.into(),
            key: format!("camera.{key}"),
            message: message.into(),
        };
        for (key, v) in [("position", e.position), ("target", e.target), ("up", e.up)] {
            if v.iter().any(|c| !c.is_finite()) {
                return Err(bad(key, &format!("{v:?} must be finite")));
            }
        }
        if !(e.fov > 0.0 && e.fov < 180.0) {
            return Err(bad("fov", "must be in (0, 180) degrees"));
        }
        for (key, v) in [("width", e.width), ("height", e.height)] {
            if v == 0 || v > 16384 {
                return Err(bad(key, &format!("{v} is outside 1..=16384 pixels")));
            }
        }
        let spp = check_spp(e.spp.unwrap_or(DEFAULT_SPP)).map_err(|m| bad("spp", &m))?;
        let d = Vec3::from(e.target).as_dvec3() - Vec3::from(e.position).as_dvec3();
        let Some(forward) = crate::geom::unit_vector(d) else {
            return Err(bad("target", "must differ from position"));
        };
        let Some(up) = crate::geom::unit_vector(Vec3::from(e.up).as_dvec3()) else {
            return Err(bad("up", "has zero length"));
        };
        let right = forward.cross(up).normalize_or_zero();
        if right == Vec3::ZERO || forward.cross(up).length() < 1e-6 {
            return Err(bad("up", "must not be parallel to the viewing direction"));
        }
        Ok(Camera {
            position: e.position.into(),
            forward,
            right,
            up: right.cross(forward),
            tan_half: (e.fov.to_radians() * 0.5).tan(),
            width: e.width,
            height: e.height,
            spp,
            filter: e.filter.unwrap_or_default(),
        })
    }

    /// A camera looking at a bounding box from its −z side.
    /// An error naming `path` where the box is too small for its distance from the
    /// origin to be framed in single precision (the camera's position would round onto
    /// its target).
    pub fn framing(lo: Vec3, hi: Vec3, path: &std::path::Path) -> Result<Camera> {
        let c = (lo + hi) * 0.5;
        let r = (hi - lo).length() * 0.5;
        let e = CameraEntry {
            position: (c - Vec3::Z * (r * 2.8)).into(),
            target: c.into(),
            up: [0.0, 1.0, 0.0],
            fov: 40.0,
            width: 256,
            height: 256,
            spp: None,
            filter: None,
        };
        Camera::from_entry(&e, path).map_err(|_| Error::SceneValue {
            path: path.into(),
            key: "camera".into(),
            message: format!(
                "the scene has no [camera] and its geometry, {:.3e} across at {:.3e} from the origin, is too small \
                 for its distance to be framed in single precision: give a [camera] (position, target), or \
                 move the geometry nearer the origin",
                2.0 * r,
                c.length()
            ),
        })
    }

    /// Where sample `k` of [`Camera::spp`] falls for pixel `(x, y)` (pixel units, y down).
    /// One sample is the pixel's centre; more are a Hammersley set over the filter's
    /// footprint, shifted per pixel (Cranley–Patterson) so neighbours do not repeat one
    /// pattern: each row and column of sub-pixel strata holds one sample.
    pub fn sample_position(&self, x: u32, y: u32, k: u32) -> (f32, f32) {
        let (cx, cy) = (x as f32 + 0.5, y as f32 + 0.5);
        if self.spp <= 1 {
            return (cx, cy);
        }
        let h = pixel_hash(x, y);
        let shift = |v: f32, s: u32| {
            let w = v + (s >> 8) as f32 * (1.0 / (1u32 << 24) as f32);
            w - w.floor()
        };
        let u = shift((k as f32 + 0.5) / self.spp as f32, h);
        let v = shift(
            crate::geom::sampling::radical_inverse(k, 2) as f32,
            h.rotate_left(16) ^ 0x9e37_79b9,
        );
        match self.filter {
            Filter::Box => (x as f32 + u, y as f32 + v),
            Filter::Gaussian => {
                // The radius by inversion of the Gaussian's radial distribution, cut at
                // 2 pixels (4 σ, σ = 0.5).
                const SIGMA: f32 = 0.5;
                const CUT: f32 = 2.0;
                let tail = (-CUT * CUT / (2.0 * SIGMA * SIGMA)).exp();
                let r = SIGMA * (-2.0 * (1.0 - u * (1.0 - tail)).ln()).sqrt();
                let a = std::f32::consts::TAU * v;
                (cx + r * a.cos(), cy + r * a.sin())
            }
        }
    }

    /// The primary ray through the point `(px, py)` of the image (pixel units, y down).
    pub fn ray(&self, px: f32, py: f32) -> Ray {
        let m = self.width.min(self.height) as f32;
        let x = (2.0 * px - self.width as f32) / m * self.tan_half;
        let y = (self.height as f32 - 2.0 * py) / m * self.tan_half;
        Ray {
            o: self.position,
            d: (self.forward + self.right * x + self.up * y).normalize(),
        }
    }
}

/// `spp` if it is a valid count of samples per pixel (1..=[`MAX_SPP`]), else why not.
pub fn check_spp(spp: u32) -> std::result::Result<u32, String> {
    if spp == 0 || spp > MAX_SPP {
        return Err(format!("{spp} is outside 1..={MAX_SPP} samples per pixel"));
    }
    Ok(spp)
}

/// A well-mixed 32-bit hash of a pixel (lowbias32).
fn pixel_hash(x: u32, y: u32) -> u32 {
    let mut h = x.wrapping_mul(0x9e37_79b1) ^ y.wrapping_mul(0x85eb_ca77);
    h ^= h >> 16;
    h = h.wrapping_mul(0x7feb_352d);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846c_a68b);
    h ^ (h >> 16)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(spp: u32, filter: Filter) -> Camera {
        let mut c = Camera::framing(Vec3::ZERO, Vec3::ONE, std::path::Path::new("")).unwrap();
        c.spp = spp;
        c.filter = filter;
        c
    }

    #[test]
    fn box_samples_fill_every_stratum_of_the_pixel_once() {
        let c = camera(16, Filter::Box);
        for (x, y) in [(0, 0), (7, 3), (255, 255)] {
            let mut cols = [0; 16];
            let mut rows = [0; 16];
            for k in 0..16 {
                let (px, py) = c.sample_position(x, y, k);
                let (u, v) = (px - x as f32, py - y as f32);
                assert!((0.0..1.0).contains(&u) && (0.0..1.0).contains(&v), "{u} {v}");
                cols[(u * 16.0) as usize] += 1;
                rows[(v * 16.0) as usize] += 1;
            }
            assert_eq!(cols, [1; 16], "pixel ({x}, {y})");
            assert_eq!(rows, [1; 16], "pixel ({x}, {y})");
        }
        assert_eq!(camera(1, Filter::Box).sample_position(4, 5, 0), (4.5, 5.5));
    }

    #[test]
    fn gaussian_samples_have_half_a_pixel_of_spread() {
        let c = camera(4096, Filter::Gaussian);
        let (mut sx, mut sxx) = (0.0f64, 0.0f64);
        for k in 0..4096 {
            let (px, py) = c.sample_position(10, 20, k);
            let (dx, dy) = (px as f64 - 10.5, py as f64 - 20.5);
            assert!(dx.hypot(dy) <= 2.0 + 1e-5);
            sx += dx;
            sxx += dx * dx;
        }
        let mean = sx / 4096.0;
        let sd = (sxx / 4096.0 - mean * mean).sqrt();
        assert!(mean.abs() < 0.02, "{mean}");
        assert!((sd - 0.5).abs() < 0.02, "{sd}");
    }
}
