//! The benchmark and reference commands at CI size, on lavapipe for the GPU columns.

mod common;

use std::process::Command;

fn meshrad(args: &[&str], dir: &std::path::Path) -> std::process::Output {
    let o = Command::new(env!("CARGO_BIN_EXE_meshrad"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run meshrad");
    assert!(
        o.status.success(),
        "meshrad {args:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

#[test]
fn table2_smoke() {
    let dir = common::tmpdir();
    let o = meshrad(
        &["bench", "table2", "--smoke", "--scenes", "cornell", "--out", "t", "-q"],
        dir.path(),
    );
    let text = String::from_utf8_lossy(&o.stdout);
    for needle in [
        "CPU original",
        "GPU direct",
        "GPU modified",
        "GPU approx",
        "1. bounce",
        "3. bounce",
        "integrals",
        "speedup",
        "Mrays/s",
        "rel. RMS error vs reference",
        "end to end, cold (load to written images)",
        "its hierarchy (darts thrown on)",
        "links memory",
        "Preprocessing",
    ] {
        assert!(text.contains(needle), "missing `{needle}`:\n{text}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("t/table2.json")).unwrap()).unwrap();
    let cols = json[0]["columns"].as_array().unwrap();
    assert_eq!(cols.len(), 4);
    // The delta hierarchy gives the same answer on both backends (same seed).
    let (cpu, gpu) = (&cols[0]["error"]["rel_rms"], &cols[1]["error"]["rel_rms"]);
    assert!(
        (cpu.as_f64().unwrap() - gpu.as_f64().unwrap()).abs() < 1e-3,
        "{cpu} vs {gpu}"
    );
    for c in cols {
        let e = c["error"]["rel_rms"].as_f64().unwrap();
        assert!(e > 0.0 && e < 0.5, "{c}");
        // The cold run does the solve the column times, and more; but the two are
        // separate runs, and on a loaded machine the timed solve can take longer than the
        // cold run did (12.84 against 12.75 s once, beside other work): only their order
        // of magnitude is checked.
        let (e2e, solve) = (
            c["seconds_end_to_end"].as_f64().unwrap(),
            c["measured"]["seconds"].as_f64().unwrap(),
        );
        assert!(e2e > 0.5 * solve, "end to end {e2e} s, solve {solve} s");
        let h = c["seconds_hierarchy_end_to_end"].as_f64().unwrap();
        assert!(h > 0.0 && h < e2e, "hierarchy {h} s of {e2e} s");
        // Unset, `dart_throwing` keeps the darts on the host for the CPU column and on a
        // CPU device (lavapipe), and throws them on any other device.
        let on_device = c["name"].as_str().unwrap().starts_with("GPU") && !text.contains("llvmpipe");
        assert_eq!(c["dart_throwing"], if on_device { "device" } else { "host" }, "{c}");
    }
    // Links only where the variant keeps them (approx), and the images of the cold runs.
    let links: Vec<bool> = cols.iter().map(|c| !c["measured"]["links_bytes"].is_null()).collect();
    assert_eq!(links, [false, false, false, true]);
    assert!(dir.path().join("t/cornell-smoke-images/total.exr").is_file());
}

#[test]
fn accuracy_quick() {
    let dir = common::tmpdir();
    // The Cornell box at CI size.
    let repo = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let text = std::fs::read_to_string(repo.join("cornell_box.toml"))
        .unwrap()
        .replace(
            "cornell_original_mm.obj",
            repo.join("cornell_original_mm.obj").to_str().unwrap(),
        )
        .replace(
            "coarsest = 226",
            "coarsest = 100\nlevels = 4\nsender_level = 3\nbounces = 2",
        )
        .replace("width = 256", "width = 96")
        .replace("height = 256", "height = 96");
    assert!(text.contains("levels = 4") && text.contains("width = 96"));
    std::fs::write(dir.path().join("cornell.toml"), text).unwrap();
    let o = meshrad(
        &[
            "bench",
            "accuracy",
            "cornell.toml",
            "--quick",
            "--backend",
            "both",
            "--probes",
            "32",
            "--reference-samples",
            "2000",
            "--pathtrace",
            "16,64",
            "--image-reference",
            "64",
            "--image-spp",
            "1,16",
            "--image-pathtrace",
            "4,16",
            "--image-mitsuba",
            "0",
            "--out",
            "a",
            "-q",
        ],
        dir.path(),
    );
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("time to 5 %") && text.contains("path tracing"), "{text}");
    assert!(
        text.contains("rel-RMS (area, converged; all points)") && text.contains("median e/r"),
        "{text}"
    );
    let csv = std::fs::read_to_string(dir.path().join("a/accuracy.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    // (the defaults + 3 variants × 2 ray counts) × 2 backends + 2 path-tracing points.
    assert_eq!(lines.len(), 1 + 14 + 2, "{csv}");
    // The bias figures are computed: at the defaults the typical point gets a sane share
    // of its light (the 2-bounce solve against the converged reference loses some).
    let header: Vec<&str> = lines[0].split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    for l in lines.iter().filter(|l| l.contains(",defaults,")) {
        let f: Vec<&str> = l.split(',').collect();
        let median: f64 = f[col("median_ratio")].parse().unwrap();
        let energy: f64 = f[col("energy_ratio")].parse().unwrap();
        assert!((0.5..1.2).contains(&median) && (0.5..1.2).contains(&energy), "{l}");
    }
    // Per stratum: the points lit only indirectly and the lit ones, apart, and the worse
    // as the headline.
    assert!(
        text.contains("headline (worse stratum)") && text.contains("indirect-only"),
        "{text}"
    );
    for l in lines.iter().filter(|l| l.contains(",defaults,")) {
        let f: Vec<&str> = l.split(',').collect();
        let num = |c: &str| -> f64 { f[col(c)].parse().unwrap() };
        let (io, lit) = (num("indirect_only_points"), num("lit_points"));
        assert!(lit > 0.0 && io + lit <= 32.0, "{l}");
        assert_eq!(
            num("headline_rel_rms"),
            num("lit_rel_rms").max(if io > 0.0 { num("indirect_only_rel_rms") } else { 0.0 }),
            "{l}"
        );
    }
    assert!(lines.iter().any(|l| l.ends_with(",true")), "a Pareto front");
    let png = image::open(dir.path().join("a/cornell.png")).unwrap();
    assert!(png.width() > 500);
    // Issue #33: the image front, against two reference images (their noise taken out):
    // meshrad at 1 and 16 samples a pixel on each backend (the device draws its own), path
    // tracing at 4 and 16 paths; more samples take the edges' aliasing out.
    assert!(text.contains("path tracing at equal error"), "{text}");
    let front = std::fs::read_to_string(dir.path().join("a/image-front.csv")).unwrap();
    let rows: Vec<Vec<&str>> = front.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 2 * 2 + 2, "{front}");
    let head: Vec<&str> = front.lines().next().unwrap().split(',').collect();
    let at = |r: &[&str], c: &str| -> f64 { r[head.iter().position(|h| *h == c).unwrap()].parse().unwrap() };
    for r in &rows {
        let (all, smooth, energy) = (at(r, "total_all"), at(r, "total_smooth"), at(r, "total_energy"));
        assert!(
            all > 0.0 && all < 1.0 && smooth <= all + 0.02 && (0.7..1.3).contains(&energy),
            "{r:?}"
        );
    }
    assert!(rows.iter().any(|r| r[2].starts_with("gpu")), "{front}");
    for backend in ["cpu", "gpu"] {
        let m: Vec<&Vec<&str>> = rows
            .iter()
            .filter(|r| r[1] == "meshrad" && r[2].starts_with(backend))
            .collect();
        assert!(at(m[1], "total_all") < at(m[0], "total_all"), "{front}");
    }
    assert!(image::open(dir.path().join("a/image-front.png")).unwrap().width() > 500);
    assert!(dir
        .path()
        .join("a/cornell-image-reference-96x96-64-seed2/total.exr")
        .is_file());
    // The cached reference is reused on a second run.
    let cached = std::fs::read_to_string(dir.path().join("a/cornell-area-converged-reference.csv")).unwrap();
    assert!(cached.starts_with("# meshrad reference samples=2000 max_bounces=0"));
    let cached = std::fs::read_to_string(dir.path().join("a/cornell-camera-2-bounces-reference.csv")).unwrap();
    assert!(cached.starts_with("# meshrad reference samples=2000 max_bounces=2"));
    // Issue #35: an `--only` label that matches nothing is an error listing the labels
    // (it ran nothing and exited 0), here on the cached references.
    let o = common::meshrad_output(
        dir.path(),
        &[
            "bench",
            "accuracy",
            "cornell.toml",
            "--quick",
            "--backend",
            "cpu",
            "--probes",
            "32",
            "--reference-samples",
            "2000",
            "--out",
            "a",
            "-q",
            "--only",
            "approx rays=33",
            "--image-reference",
            "0",
        ],
        b"",
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("--only") && err.contains("`approx rays=33`") && err.contains("`approx rays=32`"),
        "{err}"
    );
}

/// Issue #33: Mitsuba 3 as a second path-tracing baseline. `bench mitsuba` exports the
/// scene as loaded (the embedded Cornell box: its 36 triangles inside the box, the spot
/// light, the camera) on any machine. Without Mitsuba the image front leaves its rows out
/// with a note, and `bench mitsuba --spp` is an error that names the interpreter it tried.
#[test]
fn mitsuba_export_and_its_absence() {
    let dir = common::tmpdir();
    meshrad(&["bench", "mitsuba", "--out", "m"], dir.path());
    let m = dir.path().join("m");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(m.join("scene.json")).unwrap()).unwrap();
    let mats = json["materials"].as_array().unwrap();
    let mut tris = 0;
    for mat in mats {
        let n = mat["triangles"].as_u64().unwrap() as usize;
        tris += n;
        let floats =
            9 * n * (1 + mat["normals"].as_bool().unwrap() as usize) + 6 * n * mat["uvs"].as_bool().unwrap() as usize;
        let bytes = std::fs::read(m.join(mat["file"].as_str().unwrap())).unwrap();
        assert_eq!(bytes.len(), 4 * floats, "{mat}");
        for v in bytes.chunks_exact(4).take(9 * n) {
            let x = f32::from_le_bytes(v.try_into().unwrap());
            assert!((-1.0..=560.0).contains(&x), "{x} outside the box");
        }
    }
    assert_eq!(tris, 36, "{json}");
    let spot = &json["lights"][0];
    assert_eq!(spot["type"], "spot");
    let near = |v: &serde_json::Value, want: f64| (v.as_f64().unwrap() - want).abs() < 1e-3 * want.abs().max(1.0);
    assert!(
        near(&spot["cutoff_angle"], 60.0) && near(&spot["beam_width"], 45.0),
        "{spot}"
    );
    assert!(
        near(&spot["intensity"][0], 300000.0) && near(&spot["direction"][1], -1.0),
        "{spot}"
    );
    let cam = &json["camera"];
    assert!(
        near(&cam["fov"], 39.3077) && cam["width"] == 256 && cam["filter"] == "box",
        "{cam}"
    );
    assert!(m.join("mitsuba_render.py").is_file() && m.join("points.py").is_file());

    let without = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_meshrad"))
            .args(args)
            .current_dir(dir.path())
            .env("MESHRAD_PYTHON", "/nonexistent/python3")
            .output()
            .unwrap()
    };
    let o = without(&["bench", "mitsuba", "--out", "m", "--spp", "4"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("Mitsuba 3 is needed") && err.contains("/nonexistent/python3"),
        "{err}"
    );
    let o = without(&[
        "bench",
        "accuracy",
        "--images-only",
        "--backend",
        "cpu",
        "--image-reference",
        "4",
        "--image-spp",
        "1",
        "--image-pathtrace",
        "1",
        "--image-mitsuba",
        "4",
        "--out",
        "f",
        "-q",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("leaves Mitsuba 3 out") && err.contains("/nonexistent/python3"),
        "{err}"
    );
    let front = std::fs::read_to_string(dir.path().join("f/image-front.csv")).unwrap();
    assert_eq!(front.lines().count(), 1 + 2, "{front}");
    assert!(!front.contains("mitsuba"), "{front}");
}

#[test]
fn reference_command() {
    let dir = common::tmpdir();
    let scene = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell_box.toml");
    std::fs::write(dir.path().join("p.txt"), "278 0 279.6 0 1 0\n0 300 300 1 0 0\n").unwrap();
    let o = meshrad(
        &[
            "reference",
            scene.to_str().unwrap(),
            "--points",
            "p.txt",
            "--samples",
            "4000",
            "-q",
        ],
        dir.path(),
    );
    let text = String::from_utf8_lossy(&o.stdout);
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), meshrad::output::probe::REFERENCE_HEADER);
    for l in lines {
        let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
        assert_eq!(v.len(), 18);
        assert!(v[9] > 0.0 && v[15] > 0.0 && v[15] < 0.05 * v[9], "{l}");
    }
    let furnace = meshrad::analytic::furnace(dir.path(), 1.0, 3, 0.5, [0.0; 3], 1.0, "").unwrap();
    meshrad(
        &[
            "reference",
            furnace.to_str().unwrap(),
            "--camera",
            "--samples",
            "4",
            "--max-bounces",
            "6",
            "--out",
            "img",
            "-q",
        ],
        dir.path(),
    );
    let exr = exr::prelude::read_first_rgba_layer_from_file(
        dir.path().join("img/indirect.exr"),
        |res, _| vec![0.0f32; res.width() * res.height()],
        |px: &mut Vec<f32>, pos, (r, _g, _b, _a): (f32, f32, f32, f32)| px[pos.y() * 32 + pos.x()] = r,
    )
    .unwrap();
    // Inside the furnace every pixel sees the wall: indirect radiance ρ/π E_ind(6 bounces).
    let want = 0.5 / std::f32::consts::PI * meshrad::analytic::furnace_expected(1.0, 0.5, 1.0, 6).1 as f32;
    let mean = exr.layer_data.channel_data.pixels.iter().sum::<f32>() / 1024.0;
    assert!((mean - want).abs() < 0.03 * want, "{mean} vs {want}");
}

/// Area-uniform probe points on a closed sphere lit from inside: every point on the
/// sphere, on its inner side (the outer one cannot receive light), and spread by area
/// (half of them in the upper hemisphere, within 4 standard deviations).
#[test]
fn area_probes_cover_the_surfaces_that_receive_light_uniformly() {
    let dir = common::tmpdir();
    let path = meshrad::analytic::furnace(dir.path(), 1.0, 3, 0.5, [0.2, 0.1, -0.3], 1.0, "").unwrap();
    let (scene, _) = common::load(&path, &[]);
    let n = 400;
    let probes = meshrad::bench::area_probes(&scene, n, 7);
    assert_eq!(probes.len(), n);
    let mut upper = 0;
    for q in &probes {
        let r = q.p.length();
        assert!((0.95..=1.0001).contains(&r), "point {} off the sphere", q.p);
        assert!(q.n.dot(q.p) < 0.0, "point {} on the outer side", q.p);
        upper += (q.p.y > 0.0) as usize;
    }
    let sigma = (n as f64 * 0.25).sqrt();
    assert!(
        (upper as f64 - n as f64 / 2.0).abs() < 4.0 * sigma,
        "{upper} of {n} in the upper half"
    );
}

/// `bench edit` at CI size on the CPU and lavapipe: every frame solved as an edit and
/// fresh, the table and the CSV written.
#[test]
fn edit_smoke() {
    let dir = common::tmpdir();
    let o = meshrad(
        &[
            "bench",
            "edit",
            "--smoke",
            "--scenes",
            "cornell",
            "--frames",
            "3",
            "--backend",
            "both",
            "--out",
            "e",
            "-q",
        ],
        dir.path(),
    );
    let text = String::from_utf8_lossy(&o.stdout);
    for needle in [
        "| cornell | cpu | objects |",
        "| cornell | cpu | lights |",
        "| cornell | gpu (",
        "update / frame",
        "frame / fresh rest",
    ] {
        assert!(text.contains(needle), "`{needle}` not in\n{text}");
    }
    let csv = std::fs::read_to_string(dir.path().join("e/edit.csv")).unwrap();
    // Header and 3 frames per backend; frame 1 (the block moved) recomputed some clips,
    // not all, frame 2 (the light moved) none.
    let rows: Vec<&str> = csv.lines().collect();
    assert_eq!(rows.len(), 1 + 2 * 3, "{csv}");
    for r in &rows[1..] {
        let f: Vec<&str> = r.rsplitn(9, ',').collect();
        // From the right: fresh_total, fresh_rest, fresh_build, fresh_load, rebuilt, nodes, parents, clips.
        let (nodes, clips): (usize, usize) = (f[5].parse().unwrap(), f[7].parse().unwrap());
        assert_eq!(f[4], "false", "{r}");
        assert!(clips < nodes, "{r}");
        if r.contains(",objects,") {
            assert!(clips > 0, "{r}");
        }
        if r.contains(",lights,") {
            assert_eq!(clips, 0, "{r}");
        }
    }
}
