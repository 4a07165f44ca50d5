//! The Monte Carlo reference checked against closed forms, independently of the solver:
//! the furnace (any light position: bounce k gives ρ^k Φ/(4πR²) everywhere), with the
//! series cut and unbounded (Russian roulette), and its standard errors calibrated.

mod common;

use glam::Vec3;
use meshrad::analytic::{furnace, furnace_expected};
use meshrad::reference::{indirect_many, ReferenceOptions};

/// Points on the polyhedral sphere itself (where the furnace identity holds), facing in.
fn sphere_points(scene: &meshrad::Scene, n: usize) -> Vec<(Vec3, Vec3)> {
    (0..n)
        .map(|k| {
            let z = 1.0 - 2.0 * (k as f32 + 0.5) / n as f32;
            let phi = k as f32 * 2.399_963;
            let d = Vec3::new((1.0 - z * z).sqrt() * phi.cos(), (1.0 - z * z).sqrt() * phi.sin(), z);
            let hit = scene
                .intersect(&meshrad::geom::Ray { o: Vec3::ZERO, d }, f32::INFINITY)
                .unwrap();
            let s = scene.surface(&hit, d);
            (s.p, s.n)
        })
        .collect()
}

/// |mean − expected| ≤ 4 σ at every point, and at least 80 % of points within 2 σ
/// (95 % expected; the polyhedral sphere adds ≤ 0.2 % which is allowed for).
fn check(points: &[(Vec3, Vec3)], est: &[meshrad::reference::Estimate], expected: f64) {
    let mut within2 = 0;
    for (e, p) in est.iter().zip(points) {
        let sigma = e.std_err.x.max(1e-12) + 0.002 * expected;
        let z = (e.mean.x - expected).abs() / sigma;
        assert!(z < 4.0, "point {p:?}: {} ± {} vs {expected}", e.mean.x, e.std_err.x);
        within2 += (z < 2.0) as usize;
        assert!(e.std_err.x < 0.05 * expected, "too noisy: {}", e.std_err.x);
    }
    assert!(
        within2 * 10 >= points.len() * 8,
        "{within2} of {} within 2σ",
        points.len()
    );
}

#[test]
fn reference_matches_the_furnace() {
    let dir = common::tmpdir();
    let (rho, i) = (0.5, 1.0);
    let path = furnace(dir.path(), 1.0, 4, rho, [0.3, -0.25, 0.2], i, "").unwrap();
    let (scene, _) = common::load(&path, &[]);
    let points = sphere_points(&scene, 40);
    for k in [1u32, 3] {
        let opts = ReferenceOptions {
            samples: 2000,
            max_bounces: k,
            ..Default::default()
        };
        let est = indirect_many(&scene, &points, &opts);
        check(&points, &est, furnace_expected(1.0, rho, i, k).1);
    }
    // Unbounded, with Russian roulette: ρ/(1 − ρ) Φ/(4πR²).
    let opts = ReferenceOptions {
        samples: 4000,
        max_bounces: 0,
        ..Default::default()
    };
    let est = indirect_many(&scene, &points, &opts);
    check(&points, &est, rho / (1.0 - rho) * i);
}

#[test]
fn reference_sees_no_indirect_light_over_a_lone_plane() {
    let dir = common::tmpdir();
    let path = meshrad::analytic::plane(dir.path(), 10.0, 2.0, 5.0, 0, "").unwrap();
    let (scene, _) = common::load(&path, &[]);
    let est = indirect_many(
        &scene,
        &[(Vec3::ZERO, Vec3::Y), (Vec3::new(3.0, 0.0, 1.0), Vec3::Y)],
        &ReferenceOptions::default(),
    );
    for e in est {
        assert_eq!(e.mean.x, 0.0);
        assert_eq!(e.std_err.x, 0.0);
    }
}
