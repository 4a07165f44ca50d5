//! Error metrics, defined once (README "Error metrics"): relative RMS and maximum relative
//! error of indirect irradiance over probe points or pixels against a reference with
//! standard errors, and the energy balance of a closed scene.

use glam::{DVec3, Vec3};
use serde::Serialize;

use crate::reference::Estimate;

/// Points whose reference is below this fraction of the mean reference are left out of
/// the relative errors (relative error is meaningless near zero).
pub const FLOOR_FRACTION: f64 = 0.01;
/// Points whose reference standard error exceeds this fraction of its value are left out
/// (the reference itself is not trustworthy there).
pub const MAX_REFERENCE_NOISE: f64 = 0.05;

/// Errors of an estimate against a reference.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct ErrorStats {
    /// `sqrt(Σ_i Σ_c (e − r)² / Σ_i Σ_c r²)` over the points kept.
    pub rel_rms: f64,
    /// `max_i |ē − r̄| / r̄` over the points kept (channel means).
    pub max_rel: f64,
    /// The reference's own noise on the same scale: `sqrt(Σ se² / Σ r²)`; errors near it
    /// are not resolved.
    pub reference_noise: f64,
    pub points: usize,
    pub below_floor: usize,
    pub too_noisy: usize,
    /// Bias, beside the RMS, so that lost energy is not mistaken for noise: the median
    /// over the kept points of `mean(e) / mean(r)` (1: the typical point gets its light).
    pub median_ratio: f64,
    /// The mean of the same ratios.
    pub mean_ratio: f64,
    /// `Σ mean(e) / Σ mean(r)` over the kept points: the energy balance.
    pub energy_ratio: f64,
    /// Kept points off by more than 3× (ratio above 3 or below 1/3).
    pub off_3x: usize,
    /// Light put where the reference has next to none: the mean estimate over the
    /// points below the floor, relative to the mean reference over all points.
    pub leak: f64,
}

fn mean3(v: DVec3) -> f64 {
    (v.x + v.y + v.z) / 3.0
}

/// Errors of `estimate[i]` (indirect irradiance) against `reference[i]`.
pub fn indirect_error(estimate: &[Vec3], reference: &[Estimate]) -> ErrorStats {
    let n = reference.len().max(1) as f64;
    let mean_ref = reference.iter().map(|r| mean3(r.mean)).sum::<f64>() / n;
    let floor = FLOOR_FRACTION * mean_ref;
    let mut s = ErrorStats::default();
    let (mut e2, mut r2, mut n2) = (0.0, 0.0, 0.0);
    let (mut ratios, mut sum_e, mut sum_r, mut leak) = (Vec::new(), 0.0, 0.0, 0.0);
    for (e, r) in estimate.iter().zip(reference) {
        let rm = mean3(r.mean);
        if rm < floor || rm <= 0.0 {
            s.below_floor += 1;
            leak += mean3(e.as_dvec3()).max(0.0);
            continue;
        }
        if mean3(r.std_err) > MAX_REFERENCE_NOISE * rm {
            s.too_noisy += 1;
            continue;
        }
        let d = e.as_dvec3() - r.mean;
        e2 += d.length_squared();
        r2 += r.mean.length_squared();
        n2 += r.std_err.length_squared();
        let em = mean3(e.as_dvec3());
        s.max_rel = s.max_rel.max((em - rm).abs() / rm);
        ratios.push(em / rm);
        sum_e += em;
        sum_r += rm;
        s.points += 1;
    }
    if r2 > 0.0 {
        s.rel_rms = (e2 / r2).sqrt();
        s.reference_noise = (n2 / r2).sqrt();
    }
    if !ratios.is_empty() {
        ratios.sort_by(f64::total_cmp);
        let k = ratios.len();
        s.median_ratio = if k % 2 == 1 {
            ratios[k / 2]
        } else {
            0.5 * (ratios[k / 2 - 1] + ratios[k / 2])
        };
        s.mean_ratio = ratios.iter().sum::<f64>() / k as f64;
        s.energy_ratio = sum_e / sum_r;
        s.off_3x = ratios.iter().filter(|&&q| !(1.0 / 3.0..=3.0).contains(&q)).count();
    }
    if s.below_floor > 0 && mean_ref > 0.0 {
        s.leak = leak / s.below_floor as f64 / mean_ref;
    }
    s
}

/// Relative RMS between two images (e.g. indirect radiance), over pixels whose reference
/// is above the floor.
pub fn image_rel_rms(estimate: &[Vec3], reference: &[Vec3]) -> f64 {
    let mean = reference.iter().map(|r| mean3(r.as_dvec3())).sum::<f64>() / reference.len().max(1) as f64;
    let (mut e2, mut r2) = (0.0, 0.0);
    for (e, r) in estimate.iter().zip(reference) {
        let r = r.as_dvec3();
        if mean3(r) >= FLOOR_FRACTION * mean {
            e2 += (e.as_dvec3() - r).length_squared();
            r2 += r.length_squared();
        }
    }
    if r2 > 0.0 {
        (e2 / r2).sqrt()
    } else {
        0.0
    }
}

/// An image's error against a converged reference image (issue #33), over all pixels and
/// away from edges, with the reference's own noise taken out: twin of
/// `experiments/images/image_error.py`.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct ImageError {
    /// Relative RMS over every pixel, edges included: `sqrt(mean|e − r|² − noise²) /
    /// mean(r)`, channels pooled.
    pub all: f64,
    /// The same over the smooth pixels: none of whose 4 neighbours differs from it by more
    /// than 10 % of the larger luminance (plus 1 % of the mean) in the reference.
    pub smooth: f64,
    /// Σ estimate / Σ reference over all pixels.
    pub energy: f64,
    pub smooth_pixels: usize,
    pub pixels: usize,
    /// The reference's own noise over all pixels, relative to its mean.
    pub reference_noise: f64,
}

/// [`ImageError`] of `img` against two independent references `a` and `b` of the same
/// `width × height` image (e.g. `meshrad reference --camera` with two seeds): their mean
/// is the reference, and a quarter of their squared difference per pixel its noise
/// (the variance of a mean of two), whose mean is subtracted from the squared error.
pub fn image_error(img: &[Vec3], a: &[Vec3], b: &[Vec3], width: usize, height: usize) -> ImageError {
    let n = width * height;
    assert!(img.len() == n && a.len() == n && b.len() == n, "image sizes differ");
    let r: Vec<DVec3> = a
        .iter()
        .zip(b)
        .map(|(a, b)| 0.5 * (a.as_dvec3() + b.as_dvec3()))
        .collect();
    let noise2: Vec<f64> = a
        .iter()
        .zip(b)
        .map(|(a, b)| 0.25 * (a.as_dvec3() - b.as_dvec3()).length_squared() / 3.0)
        .collect();
    let lum: Vec<f64> = r.iter().map(|v| 0.2126 * v.x + 0.7152 * v.y + 0.0722 * v.z).collect();
    let floor = 0.01 * lum.iter().sum::<f64>() / n.max(1) as f64;
    let mut edge = vec![false; n];
    for y in 0..height {
        for x in 0..width {
            let i = y * width + x;
            for j in [(x + 1 < width).then(|| i + 1), (y + 1 < height).then(|| i + width)]
                .into_iter()
                .flatten()
            {
                if (lum[i] - lum[j]).abs() > 0.1 * lum[i].max(lum[j]) + floor {
                    edge[i] = true;
                    edge[j] = true;
                }
            }
        }
    }
    let rel = |keep: &dyn Fn(usize) -> bool| {
        let (mut e2, mut n2, mut m, mut k) = (0.0, 0.0, 0.0, 0usize);
        for i in (0..n).filter(|&i| keep(i)) {
            e2 += (img[i].as_dvec3() - r[i]).length_squared() / 3.0;
            n2 += noise2[i];
            m += mean3(r[i]);
            k += 1;
        }
        if k == 0 || m <= 0.0 {
            return 0.0;
        }
        let k = k as f64;
        ((e2 / k - n2 / k).max(0.0)).sqrt() / (m / k)
    };
    let sum_e: f64 = img.iter().map(|v| mean3(v.as_dvec3())).sum();
    let sum_r: f64 = r.iter().map(|v| mean3(*v)).sum();
    let mean_r = sum_r / n.max(1) as f64;
    ImageError {
        all: rel(&|_| true),
        smooth: rel(&|i| !edge[i]),
        energy: if sum_r > 0.0 { sum_e / sum_r } else { 0.0 },
        smooth_pixels: edge.iter().filter(|e| !**e).count(),
        pixels: n,
        reference_noise: if mean_r > 0.0 {
            (noise2.iter().sum::<f64>() / n.max(1) as f64).sqrt() / mean_r
        } else {
            0.0
        },
    }
}

/// Energy balance of a closed scene: `(Σ_i (1 − ρ_i) E_i A_i) / Φ − 1`, the absorbed power
/// over the emitted one, from per-sample irradiance `E_i`, albedo `ρ_i` and area `A_i`
/// (RGB mean). With `K` bounces the series misses `ρ^{K+1}/(1 − ρ)` of the indirect part.
pub fn energy_balance(samples: &[(Vec3, Vec3, f64)], power: Vec3) -> f64 {
    let absorbed: f64 = samples
        .iter()
        .map(|(e, rho, a)| mean3((DVec3::ONE - rho.as_dvec3()) * e.as_dvec3()) * a)
        .sum();
    absorbed / mean3(power.as_dvec3()) - 1.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_error_takes_the_references_noise_out_and_finds_edges() {
        // A 8×4 image: left half 1, right half 3 (an edge between columns 3 and 4).
        let (w, h) = (8, 4);
        let r: Vec<Vec3> = (0..w * h)
            .map(|i| Vec3::splat(if i % w < 4 { 1.0 } else { 3.0 }))
            .collect();
        // Two references ±0.1 about it: noise 0.1 per pixel, taken out exactly.
        let a: Vec<Vec3> = r.iter().map(|v| *v + Vec3::splat(0.1)).collect();
        let b: Vec<Vec3> = r.iter().map(|v| *v - Vec3::splat(0.1)).collect();
        let e = image_error(&r, &a, &b, w, h);
        assert!(e.all < 1e-9 && e.smooth < 1e-9, "{e:?}");
        assert_eq!(e.smooth_pixels, w * h - 2 * h);
        assert!((e.reference_noise - 0.1 / 2.0).abs() < 1e-6, "{e:?}");
        // 10 % too bright everywhere: the noise (0.01 in the mean square) is taken out.
        let img: Vec<Vec3> = r.iter().map(|v| *v * 1.1).collect();
        let e = image_error(&img, &a, &b, w, h);
        let want = ((0.01 * (1.0 + 9.0) / 2.0 - 0.01f64).sqrt()) / 2.0;
        assert!((e.all - want).abs() < 1e-6, "{} {want}", e.all);
        assert!((e.energy - 1.1).abs() < 1e-6);
    }

    fn est(v: f64) -> Estimate {
        Estimate {
            mean: DVec3::splat(v),
            std_err: DVec3::ZERO,
        }
    }

    /// Half the light everywhere is a bias, not noise: the ratios say so.
    #[test]
    fn bias_figures_tell_lost_energy_from_noise() {
        let reference: Vec<Estimate> = (1..=10).map(|i| est(i as f64)).collect();
        let half: Vec<Vec3> = (1..=10).map(|i| Vec3::splat(0.5 * i as f32)).collect();
        let s = indirect_error(&half, &reference);
        assert_eq!(s.points, 10);
        assert!((s.median_ratio - 0.5).abs() < 1e-6 && (s.mean_ratio - 0.5).abs() < 1e-6);
        assert!((s.energy_ratio - 0.5).abs() < 1e-6);
        assert_eq!(s.off_3x, 0);
        // One point four times too bright, one a fifth: both off by more than 3×; the
        // median of the others stays 1.
        let mut odd: Vec<Vec3> = (1..=10).map(|i| Vec3::splat(i as f32)).collect();
        odd[0] *= 4.0;
        odd[9] *= 0.2;
        let s = indirect_error(&odd, &reference);
        assert_eq!(s.off_3x, 2);
        assert!((s.median_ratio - 1.0).abs() < 1e-6);
        // Light where the reference is dark is a leak, outside the RMS.
        let mut r2 = reference.clone();
        r2.push(est(0.0));
        let mut e2: Vec<Vec3> = (1..=10).map(|i| Vec3::splat(i as f32)).collect();
        e2.push(Vec3::splat(5.5));
        let s = indirect_error(&e2, &r2);
        assert_eq!((s.below_floor, s.points), (1, 10));
        assert!(s.rel_rms < 1e-6);
        let mean_ref = 55.0 / 11.0;
        assert!((s.leak - 5.5 / mean_ref).abs() < 1e-6, "{}", s.leak);
    }
}
