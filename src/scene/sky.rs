//! The sky (`[sky]`, `ALGORITHM.md` §2.3): light from every direction that leaves the
//! scene, constant (Mitsuba's `constant` emitter) or an equirectangular environment map
//! (Mitsuba's `envmap`: linear RGB, `+y` up at the image's top row, the image's u =
//! atan2(d.x, −d.z) / 2π and v = acos(d.y) / π for a direction `d` leaving the scene),
//! scaled by `scale` and turned by `rotate` degrees about `+y`. An envmap's direct light
//! is estimated by sampling directions from an even mixture of the map's luminance (a
//! piecewise-constant density over its pixels, each weighted by its solid angle) and the
//! receiver's cosine (`Scene::direct`): the balance heuristic of the two, so that
//! neither a bright sun nor a receiver facing away from it wastes the samples.

use std::path::{Path, PathBuf};

use glam::{DVec3, Vec3};

use super::source::Source;
use crate::error::{Error, Result};

/// The sky.
#[derive(Clone, Debug)]
pub enum Sky {
    /// Constant radiance (W/(m²·sr), RGB).
    Constant(Vec3),
    /// An environment map.
    Map(Box<EnvMap>),
}

/// An equirectangular environment map and its sampling tables.
#[derive(Clone, Debug)]
pub struct EnvMap {
    /// The file it came from (for messages and stats).
    pub path: PathBuf,
    pub width: usize,
    pub height: usize,
    /// Radiance per pixel (times `scale`), rows from the top (`+y`).
    texels: Vec<Vec3>,
    /// The turn about `+y`, radians: a direction `d` of the world reads the map at
    /// `R_y(−rotate) d`.
    rotate: f64,
    /// Running sums of the rows' probabilities (the last is 1).
    row_cdf: Vec<f64>,
    /// Per row, running sums of its pixels' conditional probabilities.
    col_cdf: Vec<f64>,
    /// Per pixel, its probability (row × column).
    prob: Vec<f64>,
}

/// Luminance weights of linear RGB (Rec. 709).
fn luminance(c: Vec3) -> f64 {
    0.2126 * c.x as f64 + 0.7152 * c.y as f64 + 0.0722 * c.z as f64
}

/// An index by running sums `cdf` (ending at 1) for `u` in [0, 1), and the remainder of
/// `u` within its interval, rescaled to [0, 1).
fn pick(cdf: &[f64], u: f64) -> (usize, f64) {
    let k = cdf.partition_point(|&c| c <= u).min(cdf.len() - 1);
    let lo = if k > 0 { cdf[k - 1] } else { 0.0 };
    let w = cdf[k] - lo;
    (
        k,
        if w > 0.0 {
            ((u - lo) / w).clamp(0.0, 1.0 - 1e-12)
        } else {
            0.5
        },
    )
}

impl EnvMap {
    /// Loads `rel` (OpenEXR or Radiance HDR, linear) from `source`, its file within a
    /// quarter and its pixels within half of `max_memory`; `scale` multiplies it,
    /// `rotate_deg` turns it about `+y`.
    pub fn load(source: &Source, rel: &Path, scale: f32, rotate_deg: f32, max_memory: u64) -> Result<EnvMap> {
        let shown = source.display(rel);
        let bytes = source.read_limited(rel, max_memory / 4)?;
        let bad = |message: String| Error::Texture {
            path: shown.clone(),
            message,
        };
        // Decoded RGBA f32, the radiance and the tables: about 56 bytes a pixel.
        let dims = image::ImageReader::new(std::io::Cursor::new(&bytes))
            .with_guessed_format()
            .ok()
            .and_then(|r| r.into_dimensions().ok());
        if let Some((w, h)) = dims {
            let need = w as u64 * h as u64 * 56;
            if need > max_memory / 2 {
                return Err(bad(format!(
                    "{w}×{h} pixels would need {:.1} GiB, above half the memory limit ({:.1} GiB; --max-memory)",
                    need as f64 / (1u64 << 30) as f64,
                    max_memory as f64 / (1u64 << 30) as f64
                )));
            }
        }
        let img = image::load_from_memory(&bytes).map_err(|e| {
            bad(format!(
                "not a readable environment map ({e}); an OpenEXR (.exr) or Radiance (.hdr) file is expected"
            ))
        })?;
        let rgb = img.to_rgb32f();
        let (w, h) = (rgb.width() as usize, rgb.height() as usize);
        if w < 2 || h < 1 {
            return Err(bad(format!("{w}×{h}: an environment map needs at least 2×1 pixels")));
        }
        let mut texels = Vec::with_capacity(w * h);
        for (i, p) in rgb.pixels().enumerate() {
            let c = Vec3::new(p[0], p[1], p[2]);
            if !c.is_finite() || c.min_element() < 0.0 {
                return Err(bad(format!(
                    "pixel ({}, {}) is {c}: radiance must be finite and non-negative",
                    i % w,
                    i / w
                )));
            }
            let l = c * scale;
            if l.max_element().is_nan() || l.max_element() > crate::limits::MAX_RADIANCE {
                return Err(bad(format!(
                    "pixel ({}, {}) is {c}, times sky.scale {scale} above {:e}, where the light's sums would overflow",
                    i % w,
                    i / w,
                    crate::limits::MAX_RADIANCE
                )));
            }
            texels.push(l);
        }
        Ok(EnvMap::from_texels(shown, w, h, texels, rotate_deg))
    }

    /// A map from radiance texels (rows from the top), with its sampling tables.
    pub fn from_texels(path: PathBuf, width: usize, height: usize, texels: Vec<Vec3>, rotate_deg: f32) -> EnvMap {
        let mut row_w = vec![0.0f64; height];
        let mut col_cdf = vec![0.0f64; width * height];
        for r in 0..height {
            let sin = (std::f64::consts::PI * (r as f64 + 0.5) / height as f64).sin();
            let mut run = 0.0;
            for c in 0..width {
                run += luminance(texels[r * width + c]);
                col_cdf[r * width + c] = run;
            }
            for c in 0..width {
                col_cdf[r * width + c] = if run > 0.0 {
                    col_cdf[r * width + c] / run
                } else {
                    (c + 1) as f64 / width as f64
                };
            }
            row_w[r] = run * sin;
        }
        let total: f64 = row_w.iter().sum();
        let mut run = 0.0;
        let row_cdf: Vec<f64> = row_w
            .iter()
            .map(|w| {
                run += if total > 0.0 { w / total } else { 0.0 };
                run
            })
            .collect();
        let mut prob = vec![0.0f64; width * height];
        for r in 0..height {
            let pr = row_cdf[r] - if r > 0 { row_cdf[r - 1] } else { 0.0 };
            for c in 0..width {
                let pc = col_cdf[r * width + c] - if c > 0 { col_cdf[r * width + c - 1] } else { 0.0 };
                prob[r * width + c] = pr * pc;
            }
        }
        EnvMap {
            path,
            width,
            height,
            texels,
            rotate: (rotate_deg as f64).to_radians(),
            row_cdf,
            col_cdf,
            prob,
        }
    }

    /// The kernels' tables: radiance per pixel (w unused), the rows' running sums, the
    /// pixels' running sums within their row, and each pixel's probability.
    pub fn gpu_tables(&self) -> (Vec<[f32; 4]>, Vec<f32>, Vec<f32>, Vec<f32>) {
        (
            self.texels.iter().map(|t| [t.x, t.y, t.z, 0.0]).collect(),
            self.row_cdf.iter().map(|&c| c as f32).collect(),
            self.col_cdf.iter().map(|&c| c as f32).collect(),
            self.prob.iter().map(|&c| c as f32).collect(),
        )
    }

    /// The turn about `+y`, radians.
    pub fn rotate(&self) -> f32 {
        self.rotate as f32
    }

    /// Whether any pixel has radiance.
    pub fn any(&self) -> bool {
        self.row_cdf.last().is_some_and(|&c| c > 0.0)
    }

    /// The pixel a world direction reads, and the map-space direction's `(u, v)`.
    fn pixel(&self, d: DVec3) -> usize {
        let (s, c) = self.rotate.sin_cos();
        // R_y(−rotate) d.
        let m = DVec3::new(c * d.x - s * d.z, d.y, s * d.x + c * d.z);
        let m = m.normalize_or_zero();
        let u = (m.x.atan2(-m.z) / std::f64::consts::TAU).rem_euclid(1.0);
        let v = m.y.clamp(-1.0, 1.0).acos() / std::f64::consts::PI;
        let col = ((u * self.width as f64) as usize).min(self.width - 1);
        let row = ((v * self.height as f64) as usize).min(self.height - 1);
        row * self.width + col
    }

    /// The radiance arriving from the world direction `d` (leaving the scene).
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        self.texels[self.pixel(d.as_dvec3())]
    }

    /// The world direction at map coordinates `(u, v)` ∈ [0, 1]² (map space: u =
    /// atan2(x, −z) / 2π, v = acos(y) / π; turned by `R_y(rotate)`), and its sin θ.
    fn direction(&self, u: f64, v: f64) -> (DVec3, f64) {
        let (theta, phi) = (std::f64::consts::PI * v, std::f64::consts::TAU * u);
        let sin_t = theta.sin();
        let m = DVec3::new(phi.sin() * sin_t, theta.cos(), -phi.cos() * sin_t);
        let (s, c) = self.rotate.sin_cos();
        (DVec3::new(c * m.x + s * m.z, m.y, -s * m.x + c * m.z), sin_t)
    }

    /// A world direction drawn by the map's luminance from two uniform numbers, its
    /// radiance and its density per solid angle; `None` where the density is zero.
    pub fn sample(&self, u: [f64; 2]) -> Option<(Vec3, Vec3, f64)> {
        if !self.any() {
            return None;
        }
        let (row, fv) = pick(&self.row_cdf, u[0]);
        let (col, fu) = pick(&self.col_cdf[row * self.width..(row + 1) * self.width], u[1]);
        let k = row * self.width + col;
        let p = self.prob[k];
        if p <= 0.0 {
            return None;
        }
        let (d, sin_t) = self.direction(
            (col as f64 + fu) / self.width as f64,
            (row as f64 + fv) / self.height as f64,
        );
        if sin_t <= 0.0 {
            return None;
        }
        // Density in the unit square p·W·H, per solid angle over the Jacobian 2π² sin θ.
        let pdf = p * (self.width * self.height) as f64 / (2.0 * std::f64::consts::PI * std::f64::consts::PI * sin_t);
        Some((d.as_vec3(), self.texels[k], pdf))
    }

    /// The density per solid angle with which [`EnvMap::sample`] draws the world
    /// direction `d`.
    pub fn pdf(&self, d: Vec3) -> f64 {
        let d = d.as_dvec3();
        let k = self.pixel(d);
        let sin_t = (1.0 - (d.y / d.length()).powi(2)).max(0.0).sqrt();
        if sin_t <= 0.0 {
            return 0.0;
        }
        self.prob[k] * (self.width * self.height) as f64 / (2.0 * std::f64::consts::PI * std::f64::consts::PI * sin_t)
    }

    /// The irradiance an unoccluded surface facing `n` receives from the map, by
    /// integrating each pixel's exact solid angle in 64 × 64 sub-cells (for tests).
    pub fn irradiance_unoccluded(&self, n: Vec3) -> Vec3 {
        let n = n.as_dvec3();
        let mut e = DVec3::ZERO;
        let sub = 64;
        for r in 0..self.height {
            for c in 0..self.width {
                let l = self.texels[r * self.width + c].as_dvec3();
                if l == DVec3::ZERO {
                    continue;
                }
                let mut w = 0.0;
                for i in 0..sub {
                    for j in 0..sub {
                        let (d, sin_t) = self.direction(
                            (c as f64 + (j as f64 + 0.5) / sub as f64) / self.width as f64,
                            (r as f64 + (i as f64 + 0.5) / sub as f64) / self.height as f64,
                        );
                        let dw = 2.0 * std::f64::consts::PI * std::f64::consts::PI * sin_t
                            / (self.width * self.height * sub * sub) as f64;
                        w += n.dot(d).max(0.0) * dw;
                    }
                }
                e += l * w;
            }
        }
        e.as_vec3()
    }
}

impl Sky {
    /// The radiance arriving from the world direction `d` (leaving the scene).
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        match self {
            Sky::Constant(l) => *l,
            Sky::Map(m) => m.radiance(d),
        }
    }

    /// The environment map's file, if the sky is one.
    pub fn file(&self) -> Option<&Path> {
        match self {
            Sky::Constant(_) => None,
            Sky::Map(m) => Some(&m.path),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A map of one bright pixel and dim others: samples land where the light is, with
    /// the density their frequency shows, and each direction reads back its own pixel.
    #[test]
    fn samples_follow_the_luminance_and_read_their_pixel() {
        let (w, h) = (8, 4);
        let mut t = vec![Vec3::splat(0.1); w * h];
        t[w + 5] = Vec3::splat(10.0);
        for rot in [0.0f32, 37.0] {
            let m = EnvMap::from_texels(PathBuf::from("t"), w, h, t.clone(), rot);
            let mut hits = 0;
            let n = 20000;
            for i in 0..n {
                let u = [(i as f64 + 0.5) / n as f64, ((i as f64) * 0.618_033_988_75).fract()];
                let (d, l, pdf) = m.sample(u).unwrap();
                assert!(pdf > 0.0 && (d.length() - 1.0).abs() < 1e-5);
                assert_eq!(m.radiance(d), l, "rotate {rot}: the sampled direction reads its pixel");
                hits += (l.x == 10.0) as usize;
            }
            let expected = m.prob[w + 5];
            let got = hits as f64 / n as f64;
            assert!((got - expected).abs() < 0.02, "rotate {rot}: {got} vs {expected}");
        }
    }

    /// The estimator `L cos / pdf` averages to the exact irradiance of an open plane.
    #[test]
    fn luminance_sampling_is_unbiased() {
        let (w, h) = (16, 8);
        let t: Vec<Vec3> = (0..w * h)
            .map(|i| {
                Vec3::new(
                    (i % 7) as f32 * 0.3,
                    (i % 5) as f32 * 0.2 + 0.05,
                    ((i * 13) % 11) as f32 * 0.1,
                )
            })
            .collect();
        let m = EnvMap::from_texels(PathBuf::from("t"), w, h, t, 20.0);
        for n in [Vec3::Y, Vec3::X, Vec3::new(0.3, -0.5, 0.8).normalize()] {
            let exact = m.irradiance_unoccluded(n);
            let mut sum = DVec3::ZERO;
            let count = 400_000;
            for i in 0..count {
                let u = [(i as f64 + 0.5) / count as f64, ((i as f64) * 0.754_877_666_2).fract()];
                if let Some((d, l, pdf)) = m.sample(u) {
                    sum += l.as_dvec3() * (n.dot(d).max(0.0) as f64 / pdf);
                }
            }
            let est = (sum / count as f64).as_vec3();
            assert!(
                (est - exact).abs().max_element() < 0.01 * exact.max_element(),
                "n {n}: {est} vs {exact}"
            );
        }
    }
}
