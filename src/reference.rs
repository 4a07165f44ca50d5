//! The brute-force Monte Carlo reference (issue #4): irradiance by cosine-weighted path
//! tracing with next-event estimation for the lights, no hierarchy, accumulated in f64,
//! with a standard error per value. It shares only the scene (geometry, materials, lights,
//! ray casting) with the solver, and is itself checked on the analytic scenes.
//!
//! Estimator: `E_ind(x) = Σ_{k≥1} (Π_{i≤k} ρ(y_i)) E_d(y_k)` along a path from `x` whose
//! directions are cosine-distributed (so each step's weight is `ρ`, no `cos/pdf`), with
//! `E_d(y_k)` by shadow rays: exact for the lights, one sample of the emitting surfaces
//! (`Scene::direct_one`; the paths' mean averages them). Bounce `k` of the solver is term `k`; `max_bounces`
//! cuts the series as the solver does (0: unbounded, Russian roulette after `rr_after`).

use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;

use crate::geom::rng::Rng;
use crate::geom::sampling::{cosine_direction, onb};
use crate::geom::Ray;
use crate::scene::Scene;

/// How the reference samples.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct ReferenceOptions {
    /// Paths per point.
    pub samples: u32,
    /// Terms of the series (0: all, with Russian roulette).
    pub max_bounces: u32,
    /// Bounces before Russian roulette starts (unbounded series only).
    pub rr_after: u32,
    pub seed: u64,
}

impl Default for ReferenceOptions {
    fn default() -> Self {
        ReferenceOptions {
            samples: 4096,
            max_bounces: 0,
            rr_after: 3,
            seed: 0x5eed,
        }
    }
}

/// Mean and standard error of the indirect irradiance at a point, per channel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimate {
    pub mean: DVec3,
    pub std_err: DVec3,
}

/// One path's contribution from the world-space point `(x, n)`.
fn path(scene: &Scene, x: Vec3, n: Vec3, opts: &ReferenceOptions, rng: &mut Rng) -> DVec3 {
    let mut sum = DVec3::ZERO;
    let mut weight = DVec3::ONE;
    let (mut p, mut nrm) = (x, n);
    let mut k = 0;
    loop {
        k += 1;
        let (t, b) = onb(nrm);
        let d = cosine_direction(nrm, t, b, Vec2::new(rng.next_f32(), rng.next_f32()), 0.0);
        let ray = Ray {
            o: scene.offset(p, nrm),
            d,
        };
        let Some(hit) = scene.intersect(&ray, f32::INFINITY) else {
            break;
        };
        let s = scene.surface(&hit, d);
        weight *= s.albedo.as_dvec3();
        sum += weight * scene.direct_one(s.p, s.n).as_dvec3();
        if opts.max_bounces > 0 && k >= opts.max_bounces {
            break;
        }
        if opts.max_bounces == 0 && k >= opts.rr_after {
            let q = (s.albedo.max_element() as f64).clamp(0.05, 0.95);
            if rng.next_f64() >= q {
                break;
            }
            weight /= q;
        }
        if weight.max_element() == 0.0 {
            break;
        }
        p = s.p;
        nrm = s.n;
    }
    sum
}

/// The terms `1..=terms` of the series at `(x, n)` separately (term `k`: the light of the
/// `k`-th bounce, the solver's bounce `k`), each the mean over `opts.samples` paths cut
/// after `terms` bounces (no Russian roulette).
pub fn terms(scene: &Scene, x: Vec3, n: Vec3, opts: &ReferenceOptions, terms: usize, stream: u64) -> Vec<DVec3> {
    let mut rng = Rng::new(opts.seed, stream.wrapping_mul(1 << 20) ^ 0x7e57);
    let mut sum = vec![DVec3::ZERO; terms];
    for _ in 0..opts.samples {
        let mut weight = DVec3::ONE;
        let (mut p, mut nrm) = (x, n);
        for term in sum.iter_mut() {
            let (t, b) = onb(nrm);
            let d = cosine_direction(nrm, t, b, Vec2::new(rng.next_f32(), rng.next_f32()), 0.0);
            let Some(hit) = scene.intersect(
                &Ray {
                    o: scene.offset(p, nrm),
                    d,
                },
                f32::INFINITY,
            ) else {
                break;
            };
            let s = scene.surface(&hit, d);
            weight *= s.albedo.as_dvec3();
            if weight.max_element() == 0.0 {
                break;
            }
            *term += weight * scene.direct_one(s.p, s.n).as_dvec3();
            p = s.p;
            nrm = s.n;
        }
    }
    sum.iter().map(|v| *v / opts.samples.max(1) as f64).collect()
}

/// The indirect irradiance at `(x, n)` from `opts.samples` paths; `stream` decorrelates
/// points.
pub fn indirect(scene: &Scene, x: Vec3, n: Vec3, opts: &ReferenceOptions, stream: u64) -> Estimate {
    const CHUNK: u32 = 1024;
    let chunks = opts.samples.div_ceil(CHUNK);
    let (s, s2) = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let mut rng = Rng::new(opts.seed, stream.wrapping_mul(1 << 20) ^ c as u64);
            let mut s = DVec3::ZERO;
            let mut s2 = DVec3::ZERO;
            for _ in c * CHUNK..((c + 1) * CHUNK).min(opts.samples) {
                let v = path(scene, x, n, opts, &mut rng);
                s += v;
                s2 += v * v;
            }
            (s, s2)
        })
        .reduce(|| (DVec3::ZERO, DVec3::ZERO), |a, b| (a.0 + b.0, a.1 + b.1));
    let nf = opts.samples as f64;
    let mean = s / nf;
    let var = ((s2 / nf - mean * mean) * (nf / (nf - 1.0).max(1.0))).max(DVec3::ZERO);
    Estimate {
        mean,
        std_err: (var / nf).map(f64::sqrt),
    }
}

/// Estimates at many points, in parallel over points.
pub fn indirect_many(scene: &Scene, points: &[(Vec3, Vec3)], opts: &ReferenceOptions) -> Vec<Estimate> {
    points
        .par_iter()
        .enumerate()
        .map(|(i, &(x, n))| indirect(scene, x, n, opts, i as u64))
        .collect()
}
