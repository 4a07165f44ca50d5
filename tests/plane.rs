//! Point light over a plane (`ALGORITHM.md` §7): `E_d = I h / (h² + d²)^{3/2}` at probes and
//! at every node, and no indirect light (nothing reflects back).

mod common;

use glam::{Vec3, Vec4Swizzles};
use meshrad::analytic::{plane, plane_expected};
use meshrad::output::probe;
use meshrad::transport::cpu::node_world;

#[test]
fn point_light_over_plane() {
    let dir = common::tmpdir();
    let (s, h, i) = (10.0, 2.0, 5.0);
    let path = plane(
        dir.path(),
        s,
        h,
        i,
        2,
        "levels = 3\ncoarsest = 50\nrays = 64\nbounces = 2\nsender_level = 2\ngather_levels = 2\n",
    )
    .unwrap();
    let (scene, params) = common::load(&path, &[]);
    let (hier, sol) = common::solve_cpu(&scene, &params);
    let mut worst = 0.0f64;
    for j in 0..hier.nodes.len() {
        let (x, n) = node_world(&scene, &hier, j);
        let e = sol.values.direct[j].x as f64;
        if n.y > 0.0 {
            let d = (x.x as f64).hypot(x.z as f64);
            worst = worst.max(common::rel(e, plane_expected(h, i, d)));
        } else {
            assert_eq!(e, 0.0, "the back of the plane is dark");
        }
        assert_eq!(
            sol.values.indirect[j].xyz(),
            Vec3::ZERO,
            "a lone plane has no indirect light"
        );
    }
    assert!(worst < 1e-5, "node direct irradiance off by {worst}");
    let probes: Vec<probe::Probe> = (0..40)
        .map(|k| probe::Probe {
            p: Vec3::new(k as f32 * 0.2 - 3.9, 0.0, (k % 7) as f32 - 3.0),
            n: Vec3::Y,
        })
        .collect();
    let vals = probe::evaluate(&scene, &hier, &sol, &probes, &params);
    for (q, v) in probes.iter().zip(&vals) {
        let (d, ind) = (&v.direct, &v.indirect);
        let want = plane_expected(h, i, (q.p.x as f64).hypot(q.p.z as f64));
        assert!(common::rel(d.x as f64, want) < 1e-5, "probe {q:?}: {d} vs {want}");
        assert_eq!(ind.mean, Vec3::ZERO);
    }
}

/// Work a scene does not need is skipped and reported: a spot light aimed away from all
/// geometry, and levels whose parents were never refined (a lone plane has no indirect
/// light, so the oracle refines nothing).
#[test]
fn unneeded_work_is_skipped_and_reported() {
    let dir = common::tmpdir();
    let path = plane(
        dir.path(),
        10.0,
        2.0,
        5.0,
        0,
        "levels = 4\ncoarsest = 50\nrays = 32\nbounces = 2\nsender_level = 3\ngather_levels = 3\n",
    )
    .unwrap();
    let text = std::fs::read_to_string(&path).unwrap().replace(
        "[camera]",
        "[[light]]\ntype = \"spot\"\nposition = [0.0, 2.0, 0.0]\ntarget = [0.0, 5.0, 0.0]\n\
         intensity = [1.0, 1.0, 1.0]\ncutoff_angle = 30.0\nbeam_width = 20.0\n\n[camera]",
    );
    std::fs::write(&path, text).unwrap();
    let (scene, params) = common::load(&path, &[]);
    for gpu in [false, true] {
        let ctx = gpu.then(|| {
            std::sync::Arc::new(
                meshrad::gpu::Context::new(&meshrad::gpu::ContextOptions {
                    validation: true,
                    device: None,
                })
                .expect("a Vulkan device"),
            )
        });
        let r = meshrad::solve(
            &scene,
            &params,
            &mut meshrad::Engine::on(ctx),
            &meshrad::progress::Progress::hidden(),
        )
        .unwrap();
        let st = &r.solution.stats;
        assert!(st.nodes_lit_per_light[0] > 0);
        assert_eq!(st.nodes_lit_per_light[1], 0);
        assert!(
            st.skipped.iter().any(|s| s.starts_with("light 1 reaches no node")),
            "{:?}",
            st.skipped
        );
        assert!(
            st.skipped
                .iter()
                .any(|s| s.contains("bounce 1: levels 2..3 had no active node")),
            "{:?}",
            st.skipped
        );
        assert_eq!(st.bounces[0].integrals_per_level.len(), 2, "level 2 was not gathered");
    }
}
