//! Shading normals (issue #34, `ALGORITHM.md` §10): a low-poly sphere with vertex normals
//! under a directional light against the true sphere's answer, `E_d = max(0, n_y)` with
//! `n` the sphere's normal. Interpolated normals take the facets out of the nodes' direct
//! light and of the surfaces camera rays and path vertices read; `smooth_normals = false`
//! and a mesh without normals are flat alike. The GPU backend reads the same node normals
//! (`tests/gpu.rs` compares whole solves; the nodes come from the host's candidates).

mod common;

use glam::Vec3;
use meshrad::analytic::lit_sphere;

const SOLVER: &str = "levels = 3\ncoarsest = 80\nsender_level = 2\nrays = 32\nbounces = 1\n";

/// Relative RMS of the nodes' direct light against `max(0, n_y)` (`n` the true sphere's
/// normal at the node) over the nodes well inside the lit half (`n_y > 0.35`: nearer the
/// terminator a shading normal can face the light where the facet does not, and its
/// shadow ray then meets the sphere itself), and how many nodes that is.
fn node_error(path: &std::path::Path) -> (f64, usize) {
    let (scene, params) = common::load(path, &[]);
    let (h, sol) = common::solve_cpu(&scene, &params);
    let (mut e2, mut r2, mut n) = (0.0f64, 0.0f64, 0usize);
    for j in 0..h.nodes.len() {
        let p = Vec3::from(h.nodes[j].pos);
        let truth = p.normalize().y as f64;
        if truth <= 0.35 || Vec3::from(h.nodes[j].normal).dot(p) <= 0.0 {
            continue;
        }
        let got = sol.values.direct[j].x as f64;
        e2 += (got - truth).powi(2);
        r2 += truth * truth;
        n += 1;
    }
    ((e2 / r2).sqrt(), n)
}

/// The normal `Scene::surface` gives where rays from above meet the sphere, against the
/// true sphere's normal there: the largest angle between them, in degrees.
fn surface_error(path: &std::path::Path) -> f64 {
    let (scene, _) = common::load(path, &[]);
    let mut worst = 0.0f64;
    for i in 0..24 {
        for k in 0..8 {
            let (phi, r) = (i as f32 * 0.26, 0.1 + 0.1 * k as f32);
            let o = Vec3::new(r * phi.cos(), 3.0, r * phi.sin());
            let d = -Vec3::Y;
            let hit = scene
                .intersect(&meshrad::geom::Ray { o, d }, f32::INFINITY)
                .expect("the sphere is below");
            let s = scene.surface(&hit, d);
            let angle = (s.n.dot(s.p.normalize()).clamp(-1.0, 1.0) as f64).acos().to_degrees();
            worst = worst.max(angle);
        }
    }
    worst
}

#[test]
fn smooth_normals_remove_the_facets() {
    let dir = common::tmpdir();
    let smooth = lit_sphere(&dir.path().join("smooth"), 1.0, 1, true, SOLVER).unwrap();
    let flat = lit_sphere(&dir.path().join("flat"), 1.0, 1, false, SOLVER).unwrap();
    // The same mesh with its normals turned off by the object key.
    let off = dir.path().join("smooth/off.toml");
    let text = std::fs::read_to_string(&smooth).unwrap();
    std::fs::write(
        &off,
        text.replace("mesh = \"sphere.obj\"", "mesh = \"sphere.obj\"\nsmooth_normals = false"),
    )
    .unwrap();
    let (es, ns) = node_error(&smooth);
    let (ef, nf) = node_error(&flat);
    let (eo, no) = node_error(&off);
    println!(
        "nodes' direct light against the sphere: smooth {es:.4} ({ns} nodes), flat {ef:.4} ({nf}), off {eo:.4} ({no})"
    );
    assert!(ns > 50 && nf > 50, "{ns} {nf}");
    // 80 facets: a facet's normal is up to about 20° off the sphere's; the interpolated
    // normal is within a degree or two of it.
    assert!(es < 0.02, "smooth: {es}");
    assert!(ef > 4.0 * es, "flat {ef} against smooth {es}");
    assert_eq!(eo, ef, "smooth_normals = false is the flat mesh");
    let (ss, sf) = (surface_error(&smooth), surface_error(&flat));
    println!("surface normal against the sphere's: smooth {ss:.2}°, flat {sf:.2}°");
    assert!(ss < 3.0 && sf > 10.0, "smooth {ss}°, flat {sf}°");
}

/// On the GPU (lavapipe in CI, validation on) the smooth sphere's nodes carry the same
/// shading normals, so their direct light is the CPU's.
#[test]
fn smooth_normals_solve_on_the_gpu_as_on_the_cpu() {
    let dir = common::tmpdir();
    let smooth = lit_sphere(dir.path(), 1.0, 1, true, SOLVER).unwrap();
    let (scene, params) = common::load(&smooth, &[]);
    let ctx = common::gpu_context();
    let g = meshrad::solve(
        &scene,
        &params,
        &mut meshrad::Engine::gpu(ctx.clone()),
        &meshrad::progress::Progress::hidden(),
    )
    .unwrap();
    let (h, c) = common::solve_cpu(&scene, &params);
    assert_eq!(g.hierarchy.nodes.len(), h.nodes.len());
    let mut worst = 0.0f32;
    for (j, (a, b)) in g.hierarchy.nodes.iter().zip(&h.nodes).enumerate() {
        assert_eq!(a.normal, b.normal, "node {j}");
        worst = worst.max((g.solution.values.direct[j].x - c.values.direct[j].x).abs());
    }
    println!("largest node difference in direct light, GPU against CPU: {worst:e}");
    assert!(worst < 1e-4, "{worst}");
    assert_eq!(ctx.validation_errors(), 0);
}
