//! Alpha cutouts (issue #34, `ALGORITHM.md` §10): a screen over a floor, cut out by an MTL
//! `map_d` mask in its left half ([`cutout_screen`]), lets the light through there and
//! nowhere else, holds no node there, and does so on the GPU as on the CPU; without the
//! mask it is opaque; a constant `d` below the cutoff drops the material's triangles, one
//! above it keeps them opaque. glTF's `alphaMode`: `tests/gltf.rs`.

mod common;

use glam::Vec3;
use meshrad::analytic::cutout_screen;

const SOLVER: &str = "levels = 3\ncoarsest = 60\nsender_level = 2\nrays = 32\nbounces = 1\n";

/// Direct irradiance on the floor (normal +y) at `(x, 0, z)`.
fn floor_light(scene: &meshrad::Scene, x: f32, z: f32) -> f32 {
    scene.direct(Vec3::new(x, 0.0, z), Vec3::Y).x
}

/// The screen file with its MTL's `map_d mask.png` line replaced by `with` (in a copy).
fn variant(path: &std::path::Path, name: &str, with: &str) -> std::path::PathBuf {
    let dir = path.parent().unwrap();
    let mtl = std::fs::read_to_string(dir.join("screen.mtl")).unwrap();
    assert!(mtl.contains("map_d mask.png\n"));
    std::fs::write(dir.join(format!("{name}.mtl")), mtl.replace("map_d mask.png\n", with)).unwrap();
    let obj = std::fs::read_to_string(dir.join("screen.obj")).unwrap();
    std::fs::write(
        dir.join(format!("{name}.obj")),
        obj.replace("mtllib screen.mtl", &format!("mtllib {name}.mtl")),
    )
    .unwrap();
    let toml = std::fs::read_to_string(path).unwrap();
    let p = dir.join(format!("{name}.toml"));
    std::fs::write(&p, toml.replace("screen.obj", &format!("{name}.obj"))).unwrap();
    p
}

#[test]
fn cutouts_let_light_through_and_hold_no_nodes() {
    let dir = common::tmpdir();
    let path = cutout_screen(dir.path(), 3.0, SOLVER).unwrap();
    let (scene, params) = common::load(&path, &[]);
    assert!(scene.cutouts);
    assert_eq!(scene.report.cutout_materials, ["screen"]);
    let cases = [
        (-0.5, 0.0, 1.0),
        (-0.8, 0.6, 1.0),
        (0.5, 0.0, 0.0),
        (0.7, -0.5, 0.0),
        (2.0, 0.0, 1.0),
    ];
    for (x, z, want) in cases {
        let e = floor_light(&scene, x, z);
        assert!((e - want).abs() < 1e-6, "floor at ({x}, {z}): {e}, want {want}");
    }
    // Camera rays pass the cut-out half too: from above, the left half shows the floor.
    let down = -Vec3::Y;
    let hit_y = |x: f32| {
        let ray = meshrad::geom::Ray {
            o: Vec3::new(x, 3.0, 0.0),
            d: down,
        };
        scene.surface(&scene.intersect(&ray, f32::INFINITY).unwrap(), down).p.y
    };
    assert!(hit_y(-0.5).abs() < 1e-5 && (hit_y(0.5) - 1.0).abs() < 1e-5);
    // No node on the cut-out half of the screen; nodes on its opaque half.
    let (h, sol) = common::solve_cpu(&scene, &params);
    let on_screen: Vec<_> = h.nodes.iter().filter(|n| (n.pos[1] - 1.0).abs() < 1e-4).collect();
    let cut = on_screen.iter().filter(|n| n.pos[0] < -0.01).count();
    println!("{} nodes on the screen, {cut} on its cut-out half", on_screen.len());
    assert!(
        on_screen.len() > 20 && cut == 0,
        "{} nodes, {cut} cut out",
        on_screen.len()
    );
    // The floor's nodes under the cut-out half are lit, those under the opaque half not.
    for (j, n) in h
        .nodes
        .iter()
        .enumerate()
        .filter(|(_, n)| n.pos[1].abs() < 1e-4 && n.normal[1] > 0.0)
    {
        let (x, z) = (n.pos[0], n.pos[2]);
        let inside = x.abs() < 0.98 && z.abs() < 0.98;
        if inside && x < -0.02 {
            assert_eq!(sol.values.direct[j].x, 1.0, "floor node at ({x}, {z})");
        } else if inside && x > 0.02 {
            assert_eq!(sol.values.direct[j].x, 0.0, "floor node at ({x}, {z})");
        }
    }

    // Without the mask the screen is opaque.
    let (s, _) = common::load(&variant(&path, "opaque", ""), &[]);
    assert!(!s.cutouts);
    assert_eq!(floor_light(&s, -0.5, 0.0), 0.0);
    // A constant alpha below the cutoff: the screen is cut out everywhere, its triangles
    // dropped and named.
    let (s, _) = common::load(&variant(&path, "dissolved", "d 0.2\n"), &[]);
    assert_eq!(s.triangle_count(), 2);
    assert_eq!(floor_light(&s, 0.5, 0.0), 1.0);
    let notes = s.report.notes.join("\n");
    assert!(notes.contains("`screen` (alpha 0.2 below the cutoff 0.5)"), "{notes}");
    // At or above it: opaque (`Tr` is 1 − `d`).
    let (s, _) = common::load(&variant(&path, "solid", "Tr 0.3\n"), &[]);
    assert_eq!(s.triangle_count(), 4);
    assert_eq!(floor_light(&s, -0.5, 0.0), 0.0);
    // A bad value is an error naming the line.
    let bad = variant(&path, "bad", "d 1.5\n");
    let e = match meshrad::Scene::load(&bad, &[]) {
        Ok(_) => panic!("d 1.5 loaded"),
        Err(e) => e.to_string(),
    };
    assert!(
        e.contains("bad.mtl") && e.contains("`d` needs one number in [0, 1]"),
        "{e}"
    );
}

/// On the GPU (lavapipe in CI, validation on) the kernels' any-hit test reads the same
/// mask: the nodes and their direct light are the CPU's.
#[test]
fn cutouts_solve_on_the_gpu_as_on_the_cpu() {
    let dir = common::tmpdir();
    let path = cutout_screen(dir.path(), 3.0, SOLVER).unwrap();
    let (scene, params) = common::load(&path, &[]);
    let ctx = common::gpu_context();
    for bvh in [meshrad::params::BvhKind::Cwbvh, meshrad::params::BvhKind::Bvh2] {
        let mut p = params.clone();
        p.bvh = bvh;
        let g = meshrad::solve(
            &scene,
            &p,
            &mut meshrad::Engine::gpu(ctx.clone()),
            &meshrad::progress::Progress::hidden(),
        )
        .unwrap();
        let (h, c) = common::solve_cpu(&scene, &p);
        assert_eq!(g.hierarchy.nodes.len(), h.nodes.len());
        let mut worst = 0.0f32;
        for j in 0..h.nodes.len() {
            worst = worst.max((g.solution.values.direct[j] - c.values.direct[j]).abs().max_element());
            worst = worst.max(
                (g.solution.values.indirect[j] - c.values.indirect[j])
                    .abs()
                    .max_element(),
            );
        }
        println!("{bvh:?}: largest node difference GPU against CPU {worst:e}");
        assert!(worst < 1e-3, "{bvh:?}: {worst}");
    }
    assert_eq!(ctx.validation_errors(), 0);
}
