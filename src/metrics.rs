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
    for (e, r) in estimate.iter().zip(reference) {
        let rm = mean3(r.mean);
        if rm < floor || rm <= 0.0 {
            s.below_floor += 1;
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
        s.max_rel = s.max_rel.max((mean3(e.as_dvec3()) - rm).abs() / rm);
        s.points += 1;
    }
    if r2 > 0.0 {
        s.rel_rms = (e2 / r2).sqrt();
        s.reference_noise = (n2 / r2).sqrt();
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
