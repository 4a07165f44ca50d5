//! Emissive surfaces (MTL `Ke`, `ALGORITHM.md` §2.2) and the constant sky (§2.3) against
//! answers known in closed form: the emitting furnace (a closed box whose walls emit and
//! reflect), a square emitter over a floor (Lambert's polygon formula), a floor under the
//! sky (`E_d = π L`); the reference renderer on the same, and on a floor with a wall under
//! the sky; an environment map against its pixel-integrated irradiance; the scenes that
//! have no light at all and bad maps as errors. The GPU backend against the CPU on the
//! same sources: `tests/gpu.rs` `emitters_and_sky_solve_as_on_the_cpu`.

mod common;

use glam::{DVec3, Vec3};
use meshrad::analytic::{emitting_box, masked_emitter, polygon_irradiance, sky_plane, square_emitter, MASKED_STRIP};
use std::f64::consts::PI;

const RHO: f64 = 0.5;
const LE: f64 = 2.0;
/// Solver settings for scenes that are only loaded or refused.
const TINY: &str = "levels = 3\ncoarsest = 40\nsender_level = 2\n";

/// A small square emitter over a floor ([`square_emitter`]).
fn small_emitter(dir: &std::path::Path) -> std::path::PathBuf {
    square_emitter(dir, 4.0, 0.5, 1.0, LE, TINY).unwrap()
}

/// A CPU solve and the camera's images.
fn solve_and_render(
    scene: &meshrad::Scene,
    params: &meshrad::SolverParams,
) -> (meshrad::Run, meshrad::output::image::Images) {
    let hidden = meshrad::progress::Progress::hidden();
    let run = meshrad::solve(scene, params, &mut meshrad::Engine::cpu(), &hidden).unwrap();
    let img = meshrad::output::image::render(scene, &run.hierarchy, &run.solution, params, &hidden);
    (run, img)
}

/// The images of an emitter scene ([`square_emitter`] or [`masked_emitter`]) with its
/// camera moved under the lamp, looking up at it.
fn looking_up(path: &std::path::Path) -> meshrad::output::image::Images {
    let text = std::fs::read_to_string(path)
        .unwrap()
        .replace("position = [0.0, 0.5, 4]", "position = [0.0, 0.1, 0.0]")
        .replace(
            "target = [0.0, 0.0, 0.0]",
            "target = [0.0, 1.0, 0.0]\nup = [0.0, 0.0, 1.0]",
        );
    assert!(text.contains("position = [0.0, 0.1, 0.0]"), "{text}");
    std::fs::write(path, text).unwrap();
    let (scene, params) = common::load(path, &[]);
    let (_, img) = solve_and_render(&scene, &params);
    img
}

/// A floor under a sky of radiance 1 ([`sky_plane`]).
fn small_sky(dir: &std::path::Path) -> std::path::PathBuf {
    sky_plane(dir, 4.0, false, 1.0, TINY).unwrap()
}

/// Points on the inside of the cube `[-a, a]³`, facing in: a grid on each face, out to
/// a tenth of the side from its edges (at an edge the estimate's variance grows as
/// 1/distance).
fn box_points(a: f32) -> Vec<(Vec3, Vec3)> {
    let mut out = Vec::new();
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            for i in 0..4 {
                for j in 0..4 {
                    let (u, v) = (-0.9 + 0.6 * i as f32, -0.9 + 0.6 * j as f32);
                    let mut p = [0.0f32; 3];
                    p[axis] = sign * a;
                    p[(axis + 1) % 3] = u * a;
                    p[(axis + 2) % 3] = v * a;
                    let mut n = [0.0f32; 3];
                    n[axis] = -sign;
                    out.push((Vec3::from(p), Vec3::from(n)));
                }
            }
        }
    }
    out
}

/// `E_d = π L_e` everywhere inside (each estimate within 4 standard errors, which are
/// reported and small), and the solve's indirect light the series `π L_e Σ ρ^k`: after
/// 4 bounces and converged, at the output nodes and by the reference renderer.
#[test]
fn emitting_box_has_the_closed_form_answer() {
    let dir = common::tmpdir();
    let solver = "levels = 4\ncoarsest = 60\nrays = 256\nbounces = 4\nsender_level = 3\nstop_threshold = 0.0\n\
                  emitter_samples = 1024\n";
    let path = emitting_box(dir.path(), 1.0, RHO, LE, 1, solver).unwrap();
    let (scene, params) = common::load(&path, &[]);
    assert_eq!(scene.lights.len(), 0);
    assert_eq!(scene.report.emitting_triangles, 12 * 4);
    let ed = PI * LE;
    for (x, n) in box_points(1.0) {
        let (e, se) = scene.direct_with_error(x, n);
        let (e, se) = (e.x as f64, se.x as f64);
        assert!(se > 0.0 && se < 0.03 * ed, "at {x}: standard error {se} of {ed}");
        assert!(
            (e - ed).abs() < 4.0 * se + 1e-4 * ed,
            "E_d at {x}: {e} ± {se}, want {ed}"
        );
    }
    // The solve after 4 bounces: every output node, and the mean.
    let (h, sol) = common::solve_cpu(&scene, &params);
    let want = ed * (1..=4).map(|k| RHO.powi(k)).sum::<f64>();
    let out = params.output_level() as usize;
    let (mut sum, mut count, mut worst) = (0.0, 0.0, 0.0f64);
    for j in h.level_range(out) {
        let nd = &h.nodes[j];
        assert!(common::rel(sol.values.direct[j].x as f64, ed) < 0.05, "node {j} E_d");
        let v = sol
            .indirect_on(
                &h,
                nd.object as usize,
                Vec3::from(nd.pos),
                Vec3::from(nd.normal),
                out as u32,
            )
            .x as f64;
        worst = worst.max(common::rel(v, want));
        sum += v;
        count += 1.0;
    }
    println!(
        "emitting box, 4 bounces: mean {} want {want}, worst {worst}",
        sum / count
    );
    assert!(
        common::rel(sum / count, want) < 0.01,
        "mean {} want {want}",
        sum / count
    );
    assert!(worst < 0.05, "worst node off by {worst}");
    // Converged, and the reference renderer's whole series at a few points.
    let converged = ed * RHO / (1.0 - RHO);
    let (scene, params) = common::load(&path, &[("bounces", "100"), ("stop_threshold", "1e-5")]);
    let (h, sol) = common::solve_cpu(&scene, &params);
    let mean = h
        .level_range(out)
        .map(|j| {
            let nd = &h.nodes[j];
            sol.indirect_on(
                &h,
                nd.object as usize,
                Vec3::from(nd.pos),
                Vec3::from(nd.normal),
                out as u32,
            )
            .x as f64
        })
        .sum::<f64>()
        / h.level_range(out).len() as f64;
    assert!(
        common::rel(mean, converged) < 0.01,
        "converged mean {mean} want {converged}"
    );
    let opts = meshrad::reference::ReferenceOptions {
        samples: 4096,
        ..Default::default()
    };
    for (i, (x, n)) in box_points(1.0).into_iter().step_by(17).enumerate() {
        let r = meshrad::reference::indirect(&scene, x, n, &opts, i as u64);
        assert!(
            (r.mean.x - converged).abs() < 4.0 * r.std_err.x + 0.01 * converged,
            "reference at {x}: {} ± {}, want {converged}",
            r.mean.x,
            r.std_err.x
        );
    }
}

/// A square emitter `[-a, a]²` at height `h` facing a floor: the estimate against
/// Lambert's polygon formula on the axis and off it, nothing behind the emitter (it emits
/// from its front only), and the emitter seen by the camera with its own radiance.
#[test]
fn square_emitter_matches_lambert() {
    let dir = common::tmpdir();
    let (a, h) = (0.5f64, 1.0f64);
    let solver = "levels = 3\ncoarsest = 40\nsender_level = 2\nrays = 64\nbounces = 1\nemitter_samples = 4096\n";
    let path = square_emitter(dir.path(), 4.0, a, h, LE, solver).unwrap();
    let (scene, params) = common::load(&path, &[]);
    let poly = [
        DVec3::new(a, h, a),
        DVec3::new(-a, h, a),
        DVec3::new(-a, h, -a),
        DVec3::new(a, h, -a),
    ];
    for d in [0.0f64, 0.3, 0.8, 1.7, 3.0] {
        let x = DVec3::new(d, 0.0, 0.4 * d);
        let want = polygon_irradiance(x, DVec3::Y, &poly, LE);
        let (e, se) = scene.direct_with_error(x.as_vec3(), Vec3::Y);
        let (e, se) = (e.x as f64, se.x as f64);
        println!("square emitter at {x}: {e} ± {se}, Lambert {want}");
        assert!(
            (e - want).abs() < 4.0 * se + 2e-3 * want,
            "at {x}: {e} ± {se}, want {want}"
        );
        assert!(se < 0.02 * want, "at {x}: standard error {se} of {want}");
    }
    // On the axis the square's four corner rectangles give `4 L c atan(c)`,
    // `c = a / √(a² + h²)`: a check of the helper itself.
    let c = a / (a * a + h * h).sqrt();
    let on_axis = 4.0 * LE * c * c.atan();
    let helper = polygon_irradiance(DVec3::ZERO, DVec3::Y, &poly, LE);
    assert!(common::rel(helper, on_axis) < 1e-9, "{helper} vs {on_axis}");
    // Behind the emitter (above it, facing down): its back emits nothing.
    let (e, _) = scene.direct_with_error(Vec3::new(0.0, 2.0, 0.0), -Vec3::Y);
    assert_eq!(e, Vec3::ZERO);
    // The camera looks down at the floor past the emitter's edge: the emitter's front is
    // not visible from above, the floor under it is lit.
    let (run, img) = solve_and_render(&scene, &params);
    assert!(run.solution.values.direct.iter().any(|v| v.x > 0.0));
    assert!(img.direct.iter().all(|v| v.x.is_finite() && v.x >= 0.0));
}

/// An emission texture (`map_Ke`) read per texel: a square lamp masked to a strip
/// ([`masked_emitter`]) lights the floor as a uniform emitter of that strip's shape
/// (Lambert's formula over it), the dark half's triangles are no emitters (they cost
/// nothing), and the camera sees the mask: `L_e` under the strip, black beside it.
#[test]
fn emission_textures_light_by_texel() {
    let dir = common::tmpdir();
    let (a, h) = (1.0f64, 1.0f64);
    let solver = "levels = 3\ncoarsest = 40\nsender_level = 2\nrays = 64\nbounces = 1\nemitter_samples = 4096\n";
    let path = masked_emitter(dir.path(), 4.0, a, h, LE, solver).unwrap();
    let (scene, _) = common::load(&path, &[]);
    assert_eq!(
        scene.report.emitting_triangles, 2,
        "the black square's two triangles cost nothing"
    );
    let [x0, x1] = MASKED_STRIP.map(|f| f * a);
    let strip = [
        DVec3::new(x1, h, a),
        DVec3::new(x0, h, a),
        DVec3::new(x0, h, -a),
        DVec3::new(x1, h, -a),
    ];
    for (dx, dz) in [(0.5f64, 0.0f64), (-0.5, 0.2), (1.5, -0.4), (-2.0, 1.0), (0.05, 0.6)] {
        let x = DVec3::new(dx, 0.0, dz);
        let want = polygon_irradiance(x, DVec3::Y, &strip, LE);
        let (e, se) = scene.direct_with_error(x.as_vec3(), Vec3::Y);
        let (e, se) = (e.x as f64, se.x as f64);
        println!("masked emitter at {x}: {e} ± {se}, Lambert over the strip {want}");
        // The one-texel blends at the strip's borders are symmetric: what they move
        // changes the answer by well under 1 %.
        assert!(
            (e - want).abs() < 4.0 * se + 0.01 * want,
            "at {x}: {e} ± {se}, want {want}"
        );
    }
    // Seen from below, the lamp shows the mask: L_e under the strip, nothing beside it.
    let img = looking_up(&path);
    let row = (img.height / 2 * img.width) as usize;
    let px: Vec<f32> = (0..img.width as usize).map(|x| img.direct[row + x].x).collect();
    let (lit, dark) = (
        px.iter().filter(|&&v| (v as f64 - LE).abs() < 1e-3).count(),
        px.iter().filter(|&&v| v == 0.0).count(),
    );
    println!("row across the lamp: {px:?}");
    assert!(lit >= 8 && dark >= 8, "{lit} pixels at L_e, {dark} black: {px:?}");
}

/// The emitter seen from below shows its radiance `L_e` in the direct image (a black
/// lamp reflects nothing, so that is all it shows).
#[test]
fn emitters_show_their_radiance() {
    let dir = common::tmpdir();
    let solver = "levels = 3\ncoarsest = 40\nsender_level = 2\nrays = 64\nbounces = 1\n";
    let path = square_emitter(dir.path(), 4.0, 2.0, 1.0, LE, solver).unwrap();
    let img = looking_up(&path);
    let centre = img.direct[(img.height / 2 * img.width + img.width / 2) as usize];
    assert!((centre.x as f64 - LE).abs() < 1e-6, "{centre}");
}

/// A scene with no light and no emitting surface is an error that says so; one whose
/// only emission an object turns off too.
#[test]
fn no_light_at_all_is_an_error() {
    let dir = common::tmpdir();
    let path = small_emitter(dir.path());
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::write(
        &path,
        text.replace("mesh = \"scene.obj\"", "mesh = \"scene.obj\"\nemission = false"),
    )
    .unwrap();
    let e = meshrad::Scene::load(&path, &[]).unwrap_err().to_string();
    assert!(
        e.contains("no [[light]], no emitting surface (MTL Ke) and no [sky]"),
        "{e}"
    );
    assert!(e.contains("scene.toml"), "{e}");
    // A sky of negative radiance, and one with keys it does not have yet.
    let path = small_sky(dir.path());
    let text = std::fs::read_to_string(&path).unwrap();
    for (bad, want) in [
        ("radiance = [1.0, -1.0, 1.0]", "sky.radiance"),
        ("radiance = [1.0, 1.0, 1.0]\nenvmap = \"sky.exr\"", "envmap"),
    ] {
        std::fs::write(&path, text.replace("radiance = [1, 1, 1]", bad)).unwrap();
        let e = meshrad::Scene::load(&path, &[]).unwrap_err().to_string();
        assert!(e.contains(want) && e.contains("sky.toml"), "{bad}: {e}");
    }
}

/// The solver's bounce light on the floor at distances `dists` from the wall of
/// `sky_plane(…, wall = true, …)` (probe, final gather) against the reference renderer's:
/// within 3 % and 3 combined standard errors. Returns the probe values.
fn floor_beside_wall_vs_reference(
    scene: &meshrad::Scene,
    h: &meshrad::Hierarchy,
    sol: &meshrad::Solution,
    params: &meshrad::SolverParams,
    dists: &[f32],
    what: &str,
) -> Vec<meshrad::output::probe::ProbeValue> {
    let probes: Vec<meshrad::output::probe::Probe> = dists
        .iter()
        .map(|&d| meshrad::output::probe::Probe {
            p: Vec3::new(1.0 - d, 0.0, 0.3),
            n: Vec3::Y,
        })
        .collect();
    let got = meshrad::output::probe::evaluate(scene, h, sol, &probes, params);
    let opts = meshrad::reference::ReferenceOptions {
        samples: 16384,
        ..Default::default()
    };
    for (i, (q, v)) in probes.iter().zip(&got).enumerate() {
        let r = meshrad::reference::indirect(scene, q.p, q.n, &opts, i as u64);
        let (e, want) = (v.indirect.mean.x as f64, r.mean.x);
        let se = r.std_err.x.hypot(v.indirect.std_err.x as f64);
        println!(
            "floor at {}{what}: solver {e} ± {}, reference {want} ± {}",
            q.p, v.indirect.std_err.x, r.std_err.x
        );
        assert!(
            want > 0.0 && (e - want).abs() < 0.03 * want + 3.0 * se,
            "at {}{what}: {e} vs {want} ± {se}",
            q.p
        );
    }
    got
}

/// A floor under a constant sky: `E_d = π L` on either side (every sample escapes: no
/// error); with a wall beside it, the wall's bounce light on the floor
/// against the reference renderer's.
#[test]
fn floor_under_the_sky() {
    let dir = common::tmpdir();
    let solver = "levels = 4\ncoarsest = 60\nsender_level = 3\nrays = 256\n";
    let path = sky_plane(dir.path(), 4.0, false, LE, solver).unwrap();
    let (scene, _) = common::load(&path, &[]);
    for x in [Vec3::ZERO, Vec3::new(2.5, 0.0, -3.0)] {
        let (e, se) = scene.direct_with_error(x, Vec3::Y);
        assert!(common::rel(e.x as f64, PI * LE) < 1e-6, "{e}");
        assert_eq!(se, Vec3::ZERO);
        // The sky is a whole sphere (Mitsuba's `constant`): the underside sees it too.
        assert!(common::rel(scene.direct(x, -Vec3::Y).x as f64, PI * LE) < 1e-6);
    }
    // The wall: the floor next to it gets bounce light; solver (probe, final gather) and
    // reference agree within 3 % and 3 of their combined standard errors.
    let path = sky_plane(dir.path(), 4.0, true, LE, solver).unwrap();
    let (scene, params) = common::load(&path, &[]);
    let (h, sol) = common::solve_cpu(&scene, &params);
    let de = sol
        .stats
        .direct_error
        .as_ref()
        .expect("the sky's sampling error is reported");
    assert!(
        de.lit_nodes > 0 && de.mean_rel_std_err > 0.0 && de.shadow_rays > 0,
        "{de:?}"
    );
    let got = floor_beside_wall_vs_reference(&scene, &h, &sol, &params, &[0.2, 0.5, 1.0, 2.0], "");
    for v in got {
        // The direct light: the wall hides part of the sky.
        assert!(v.direct.x < (PI * LE) as f32 && v.direct.x > 0.5 * (PI * LE) as f32);
    }
}

/// Writes a `w × h` OpenEXR whose pixel `(x, y)` (rows from the top) is `f(x, y)`.
fn write_exr(path: &std::path::Path, w: usize, h: usize, f: impl Fn(usize, usize) -> [f32; 3] + Sync) {
    exr::prelude::write_rgb_file(path, w, h, |x, y| {
        let c = f(x, y);
        (c[0], c[1], c[2])
    })
    .unwrap();
}

/// A map with structure: a bright patch above the horizon, colours varying by pixel.
fn patchy(x: usize, y: usize) -> [f32; 3] {
    let base = [
        0.2 + 0.05 * (x % 5) as f32,
        0.3 + 0.04 * (y % 3) as f32,
        0.1 + 0.03 * ((x + y) % 4) as f32,
    ];
    if (5..8).contains(&x) && (1..3).contains(&y) {
        base.map(|c| c * 40.0)
    } else {
        base
    }
}

/// `sky_plane`'s scene with `[sky] envmap = "sky.exr"` (and `extra` keys) in place of its
/// constant radiance.
fn envmap_plane(dir: &std::path::Path, wall: bool, solver: &str, extra: &str) -> std::path::PathBuf {
    let path = sky_plane(dir, 4.0, wall, 1.0, solver).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::write(
        &path,
        text.replace("radiance = [1, 1, 1]", &format!("envmap = \"sky.exr\"\n{extra}")),
    )
    .unwrap();
    path
}

/// An environment map's direct light on an open floor, both sides, against the map's
/// irradiance integrated pixel by pixel (`EnvMap::irradiance_unoccluded`), with `scale`
/// and `rotate`; a constant map gives `π L`; the reference renderer and the solver agree
/// on the bounce light beside a wall; escaping camera rays see the map.
#[test]
fn floor_under_an_envmap() {
    let dir = common::tmpdir();
    let (w, h) = (16, 8);
    write_exr(&dir.path().join("sky.exr"), w, h, patchy);
    let solver = "levels = 4\ncoarsest = 60\nsender_level = 3\nrays = 256\nemitter_samples = 4096\n";
    let path = envmap_plane(dir.path(), false, solver, "scale = 2.0\nrotate = 30.0");
    let (scene, _) = common::load(&path, &[]);
    assert!(scene.report.inputs.iter().any(|p| p.ends_with("sky.exr")));
    let texels: Vec<Vec3> = (0..w * h).map(|i| Vec3::from(patchy(i % w, i / w)) * 2.0).collect();
    let exact = meshrad::scene::sky::EnvMap::from_texels("m".into(), w, h, texels, 30.0);
    for (x, n) in [(Vec3::ZERO, Vec3::Y), (Vec3::new(1.5, 0.0, -2.0), -Vec3::Y)] {
        let want = exact.irradiance_unoccluded(n);
        let (e, se) = scene.direct_with_error(x, n);
        println!("floor at {x} facing {n}: {e} ± {se}, exact {want}");
        for c in 0..3 {
            assert!(se[c] > 0.0 && se[c] < 0.03 * e[c], "{e} ± {se}");
            assert!(
                (e[c] - want[c]).abs() < 4.0 * se[c],
                "channel {c}: {e} ± {se} vs {want}"
            );
        }
    }
    // The rotation matters: the same point without it gets another answer.
    let unturned = envmap_plane(dir.path(), false, solver, "scale = 2.0");
    let (s0, _) = common::load(&unturned, &[]);
    let side = Vec3::new(0.0, 0.5, 0.0);
    let (a, b) = (scene.direct(side, Vec3::X), s0.direct(side, Vec3::X));
    assert!((a - b).abs().max_element() > 0.05 * a.max_element(), "{a} vs {b}");

    // A constant map: π L on the open floor.
    write_exr(&dir.path().join("sky.exr"), w, h, |_, _| [1.5, 1.5, 1.5]);
    let (scene, _) = common::load(&path, &[]);
    let (e, se) = scene.direct_with_error(Vec3::ZERO, Vec3::Y);
    let want = PI as f32 * 1.5 * 2.0;
    assert!((e.x - want).abs() < 4.0 * se.x + 1e-4 * want, "{e} ± {se} vs {want}");

    // The wall's bounce light under the patchy map: solver against reference.
    write_exr(&dir.path().join("sky.exr"), w, h, patchy);
    let path = envmap_plane(dir.path(), true, solver, "scale = 2.0\nrotate = 30.0");
    let (mut scene, params) = common::load(&path, &[]);
    let (hier, sol) = common::solve_cpu(&scene, &params);
    floor_beside_wall_vs_reference(&scene, &hier, &sol, &params, &[0.3, 1.0], " under the map");
    // Camera rays that leave the scene see the map itself (one sample per pixel: the
    // ray through its centre).
    scene.camera.spp = 1;
    let img = meshrad::output::image::render(&scene, &hier, &sol, &params, &meshrad::progress::Progress::hidden());
    let cam = &scene.camera;
    let mut seen = 0;
    for y in 0..cam.height {
        for x in 0..cam.width {
            let ray = cam.ray(x as f32 + 0.5, y as f32 + 0.5);
            if scene.intersect(&ray, f32::INFINITY).is_none() {
                assert_eq!(img.direct[(y * cam.width + x) as usize], scene.sky_radiance(ray.d));
                seen += 1;
            }
        }
    }
    assert!(seen > 0);
}

/// Bad environment maps: a missing file, a pixel that is not a radiance, a file that is
/// no image, and keys that do not go together.
#[test]
fn bad_envmaps_are_named() {
    let dir = common::tmpdir();
    let path = envmap_plane(dir.path(), false, TINY, "");
    let load = |p: &std::path::Path| meshrad::Scene::load(p, &[]).map(|_| ()).unwrap_err().to_string();
    let e = load(&path);
    assert!(e.contains("sky.exr"), "missing: {e}");
    write_exr(&dir.path().join("sky.exr"), 4, 2, |x, y| {
        if (x, y) == (3, 1) {
            [f32::NAN, 0.0, 0.0]
        } else {
            [1.0; 3]
        }
    });
    let e = load(&path);
    assert!(e.contains("sky.exr") && e.contains("pixel (3, 1)"), "NaN: {e}");
    std::fs::write(dir.path().join("sky.exr"), b"not an image").unwrap();
    let e = load(&path);
    assert!(e.contains("sky.exr") && e.contains("environment map"), "garbage: {e}");
    write_exr(&dir.path().join("sky.exr"), 4, 2, |_, _| [1.0; 3]);
    let text = std::fs::read_to_string(&path).unwrap();
    for (extra, want) in [("scale = -1.0", "sky.scale"), ("rotate = nan", "sky.rotate")] {
        std::fs::write(
            &path,
            text.replace("envmap = \"sky.exr\"", &format!("envmap = \"sky.exr\"\n{extra}")),
        )
        .unwrap();
        let e = load(&path);
        assert!(e.contains(want), "{extra}: {e}");
    }
    let constant = small_sky(dir.path());
    let text = std::fs::read_to_string(&constant).unwrap();
    std::fs::write(
        &constant,
        text.replace("radiance = [1, 1, 1]", "radiance = [1, 1, 1]\nscale = 2.0"),
    )
    .unwrap();
    let e = load(&constant);
    assert!(e.contains("sky.scale") && e.contains("envmap"), "{e}");
    // Issue #35: a scale of 0, and texels whose product with the scale would overflow the
    // light's sums, name sky.scale (they said "the scene has no [sky]", or gave inf).
    let path = envmap_plane(dir.path(), false, TINY, "");
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::write(
        &path,
        text.replace("envmap = \"sky.exr\"", "envmap = \"sky.exr\"\nscale = 0.0"),
    )
    .unwrap();
    let e = load(&path);
    assert!(e.contains("sky.scale") && e.contains("positive"), "scale 0: {e}");
    for (texel, scale) in [(1.7e38f32, 1.0f32), (1e20, 1e15)] {
        write_exr(&dir.path().join("sky.exr"), 4, 2, |_, _| [texel; 3]);
        std::fs::write(
            &path,
            text.replace(
                "envmap = \"sky.exr\"",
                &format!("envmap = \"sky.exr\"\nscale = {scale:e}"),
            ),
        )
        .unwrap();
        let e = load(&path);
        assert!(
            e.contains("sky.exr") && e.contains("sky.scale") && e.contains("overflow"),
            "{texel}: {e}"
        );
    }
    let constant = small_sky(dir.path());
    let text = std::fs::read_to_string(&constant).unwrap();
    assert!(text.contains("radiance = [1, 1, 1]"));
    std::fs::write(
        &constant,
        text.replace("radiance = [1, 1, 1]", "radiance = [3e38, 1, 1]"),
    )
    .unwrap();
    let e = load(&constant);
    assert!(e.contains("sky.radiance") && e.contains("overflow"), "{e}");
}

/// Antialiasing: the camera looks straight up at the square emitter, whose edge crosses
/// the image at pixel 26.25 (and 5.75). One sample per pixel takes the centre (all or
/// nothing); 16 stratified box samples give each edge pixel its covered quarter to within
/// one stratum; the Gaussian filter (σ = 0.5) gives Φ(−0.5) of the pixel beyond the edge.
#[test]
fn pixel_samples_cover_an_emitter_edge_as_its_area() {
    use meshrad::scene::camera::Filter;
    let dir = common::tmpdir();
    let (mut scene, _) = common::load(&small_emitter(dir.path()), &[]);
    // Distance d below the emitter (half side 0.5) puts its edge at x = 0.5 / d on the
    // image plane (tan_half = 1, 32 pixels): pixel 16 (x + 1) = 26.25.
    let d = 0.5 / 0.640625;
    let cam = &mut scene.camera;
    cam.position = Vec3::new(0.0, 1.0 - d, 0.0);
    cam.forward = Vec3::Y;
    cam.right = Vec3::X;
    cam.up = Vec3::Z;
    cam.tan_half = 1.0;
    cam.width = 32;
    cam.height = 32;
    let none = vec![false; scene.sources()];
    let row = |scene: &meshrad::Scene| {
        let img = meshrad::output::image::render_with(
            scene,
            &scene.camera,
            &none,
            &meshrad::progress::Progress::hidden(),
            |_, _| Vec3::ZERO,
        );
        (0..32)
            .map(|x| img.direct[16 * 32 + x].x as f64 / LE)
            .collect::<Vec<_>>()
    };
    scene.camera.spp = 1;
    let one = row(&scene);
    assert_eq!((one[5], one[6], one[25], one[26]), (0.0, 1.0, 1.0, 0.0), "{one:?}");
    scene.camera.spp = 16;
    let boxed = row(&scene);
    for x in [5, 26] {
        assert!((boxed[x] - 0.25).abs() <= 1.0 / 16.0 + 1e-6, "pixel {x}: {}", boxed[x]);
    }
    assert_eq!((boxed[4], boxed[16], boxed[27]), (0.0, 1.0, 0.0));
    let sum: f64 = boxed.iter().sum();
    assert!((sum - 20.5).abs() <= 2.0 / 16.0 + 1e-6, "row sum {sum}");
    scene.camera.spp = 1024;
    scene.camera.filter = Filter::Gaussian;
    let gauss = row(&scene);
    // Φ(−0.5) = 0.3085 of the pixel centred 0.25 past the edge, Φ(0.5) of the one before.
    assert!((gauss[26] - 0.3085).abs() < 0.01, "{}", gauss[26]);
    assert!((gauss[25] - 0.9332).abs() < 0.01, "{}", gauss[25]);
}
