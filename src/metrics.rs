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
