//! The command line as a user runs it: the default run on the embedded Cornell box,
//! `solve` on a scene file, `probe`, and the PLY export.

mod common;

use std::path::Path;
use std::process::{Command, Output};

fn meshrad(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_meshrad"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("run meshrad")
}

fn ok(o: &Output) {
    assert!(
        o.status.success(),
        "meshrad failed:\nstdout: {}\nstderr: {}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

fn check_images(dir: &Path, w: u32, h: u32) {
    for stem in ["direct", "indirect", "total"] {
        let png = image::open(dir.join(format!("{stem}.png"))).expect("png decodes");
        assert_eq!((png.width(), png.height()), (w, h));
        let exr = exr::prelude::read_first_rgba_layer_from_file(
            dir.join(format!("{stem}.exr")),
            |res, _| vec![0.0f32; res.width() * res.height()],
            move |px: &mut Vec<f32>, pos, (r, _g, _b, _a): (f32, f32, f32, f32)| px[pos.y() * w as usize + pos.x()] = r,
        )
        .expect("exr decodes");
        let px = exr.layer_data.channel_data.pixels;
        assert!(px.iter().all(|v| v.is_finite() && *v >= 0.0));
        assert!(px.iter().any(|v| *v > 0.0), "{stem} is black");
    }
}

#[test]
fn default_run_solves_the_embedded_cornell_box() {
    let dir = common::tmpdir();
    let o = meshrad(&["-q"], dir.path());
    // `-q` is not a top-level flag: the default run takes no arguments at all.
    assert!(!o.status.success());
    let o = meshrad(&[], dir.path());
    ok(&o);
    let out = dir.path().join("out");
    check_images(&out, 256, 256);
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["scene"]["triangles"], 36);
    assert_eq!(stats["variant"], "approx");
    assert_eq!(stats["backend"], "cpu");
    let levels = stats["hierarchy"]["nodes_per_level"].as_array().unwrap();
    assert_eq!(levels.len(), 6);
    // The bounce count follows convergence: the loop stops once the un-shot energy is
    // below stop_threshold, well before the cap.
    let bounces = stats["solve"]["bounces"].as_array().unwrap();
    assert!((6..100).contains(&bounces.len()), "{} bounces", bounces.len());
    let last = bounces.last().unwrap()["unshot_ratio"].as_f64().unwrap();
    assert!(last < 1e-4, "un-shot ratio {last} after the last bounce");
    assert!(stats["solve"]["stopped_early"].is_string());
    assert!(stats["solve"]["unconverged"].is_null());
    assert!(stats["solve"]["rays_traced"].as_u64().unwrap() > 1_000_000);
    // The image: the default samples per pixel, box filter, the automatic exposure that
    // puts the 99th percentile of lit pixels at white (the EXRs stay linear).
    assert_eq!(stats["image"]["spp"], meshrad::scene::camera::DEFAULT_SPP);
    assert_eq!(stats["image"]["filter"], "box");
    assert_eq!(stats["image"]["exposure"]["mode"], "auto");
    let ev = stats["image"]["exposure"]["ev"].as_f64().unwrap();
    assert!((0.5..3.0).contains(&ev), "auto exposure {ev}");
}

#[test]
fn spp_and_exposure_from_the_command_line() {
    let dir = common::tmpdir();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell_box.toml");
    let small = [
        "--backend",
        "cpu",
        "--bounces",
        "2",
        "--rays",
        "32",
        "--set",
        "levels=3",
        "--set",
        "sender_level=2",
        "-q",
    ];
    let run = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec!["solve", scene.to_str().unwrap(), "--out", out.to_str().unwrap()];
        args.extend_from_slice(&small);
        args.extend_from_slice(extra);
        let o = meshrad(&args, dir.path());
        (o, out)
    };
    let (o, a) = run("a", &["--spp", "1", "--exposure", "0"]);
    ok(&o);
    let (o, b) = run("b", &["--spp", "1", "--exposure", "-1"]);
    ok(&o);
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(b.join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["image"]["spp"], 1);
    assert_eq!(stats["image"]["exposure"]["mode"], "fixed");
    assert_eq!(stats["image"]["exposure"]["ev"], -1.0);
    // One stop down halves the PNG's linear values; the EXRs are the same bytes.
    assert_eq!(
        std::fs::read(a.join("total.exr")).unwrap(),
        std::fs::read(b.join("total.exr")).unwrap()
    );
    let mean = |d: &Path| {
        let png = image::open(d.join("total.png")).unwrap().to_rgb8();
        png.pixels().map(|p| (p[1] as f64 / 255.0).powf(2.2)).sum::<f64>() / (png.width() * png.height()) as f64
    };
    let ratio = mean(&b) / mean(&a);
    assert!((ratio - 0.5).abs() < 0.02, "−1 EV gave {ratio} of the 0 EV brightness");
    for (flag, value, says) in [
        ("--spp", "0", "1..=4096"),
        ("--spp", "5000", "1..=4096"),
        ("--exposure", "bright", "neither `auto` nor a number"),
        ("--exposure", "1e9", "outside"),
    ] {
        let (o, _) = run("c", &[flag, value]);
        assert!(!o.status.success(), "{flag} {value} was taken");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(says) && err.contains(value), "{flag} {value}: {err}");
    }
}

#[test]
fn solve_a_scene_file_with_flags_and_export_nodes() {
    let dir = common::tmpdir();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell_box.toml");
    let out = dir.path().join("o");
    let ply = dir.path().join("nodes.ply");
    let run = |out: &Path, ply: &Path| {
        meshrad(
            &[
                "solve",
                scene.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
                "--backend",
                "cpu",
                "--variant",
                "original",
                "--bounces",
                "2",
                "--rays",
                "64",
                "--seed",
                "7",
                "--set",
                "levels=4",
                "--set",
                "sender_level=3",
                "--export-nodes",
                ply.to_str().unwrap(),
                "--stats",
                "-q",
            ],
            dir.path(),
        )
    };
    let o = run(&out, &ply);
    ok(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("nodes per level") && err.contains("bounce 2"), "{err}");
    check_images(&out, 256, 256);
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["variant"], "original");
    assert_eq!(stats["seed"], 7);
    assert_eq!(stats["params"]["rays"], 64);
    // Two bounces do not converge: the run says so.
    let unconverged = stats["solve"]["unconverged"].as_str().unwrap();
    assert!(unconverged.contains("bounce cap 2"), "{unconverged}");
    let nodes: u64 = stats["hierarchy"]["nodes_per_level"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .sum();
    let bytes = std::fs::read(&ply).unwrap();
    let text = String::from_utf8_lossy(&bytes[..600]);
    assert!(text.starts_with("ply\nformat binary_little_endian 1.0"));
    assert!(text.contains(&format!("element vertex {nodes}\n")));
    let header_len = text.find("end_header\n").unwrap() + "end_header\n".len();
    assert_eq!(bytes.len() - header_len, nodes as usize * 56);

    // The same command again writes the same bytes: nodes, EXR and PNG.
    let out2 = dir.path().join("o2");
    let ply2 = dir.path().join("nodes2.ply");
    ok(&run(&out2, &ply2));
    assert!(
        bytes == std::fs::read(&ply2).unwrap(),
        "node export differs between runs"
    );
    for f in [
        "direct.exr",
        "indirect.exr",
        "total.exr",
        "direct.png",
        "indirect.png",
        "total.png",
    ] {
        let (a, b) = (
            std::fs::read(out.join(f)).unwrap(),
            std::fs::read(out2.join(f)).unwrap(),
        );
        assert!(a == b, "{f} differs between two runs of the same command");
    }
}

#[test]
fn probe_prints_the_csv() {
    let dir = common::tmpdir();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell_box.toml");
    let pts = dir.path().join("p.txt");
    std::fs::write(
        &pts,
        "# floor centre, facing up\n278 0 279.6 0 1 0\n\n100 0 100  0 1 0 # near the green wall\n100 548.8 100 0 -1 0\n",
    )
    .unwrap();
    let csv = dir.path().join("p.csv");
    let args = [
        "probe",
        scene.to_str().unwrap(),
        "--points",
        pts.to_str().unwrap(),
        "--out",
        csv.to_str().unwrap(),
        "--rays",
        "64",
        "--set",
        "levels=4",
        "--set",
        "sender_level=3",
        "-q",
    ];
    ok(&meshrad(&args, dir.path()));
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), meshrad::output::probe::HEADER);
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 3);
    for r in &rows {
        assert_eq!(r.len(), 21);
        for c in 0..3 {
            assert!((r[12 + c] - r[6 + c] - r[9 + c]).abs() < 1e-4 * r[12 + c].abs().max(1.0));
        }
        // The spot is exact: no direct standard error.
        assert_eq!(&r[18..21], &[0.0; 3]);
    }
    // The floor centre is directly under the spot: E_d = I / h².
    let want = 300000.0 / (548.0f64 * 548.0);
    assert!((rows[0][6] - want).abs() < 1e-4 * want, "{} vs {want}", rows[0][6]);
    // The ceiling sees no direct light but gets indirect light.
    assert_eq!(rows[2][6], 0.0);
    assert!(rows[2][9] > 0.0);
    // A final gather by default: its standard error is reported, and it is small.
    for r in &rows {
        for c in 0..3 {
            assert!(r[15 + c] > 0.0 && r[15 + c] < 0.1 * r[9 + c], "{r:?}");
        }
    }
    // Without --out the CSV goes to stdout.
    let o = meshrad(
        &args[..args.len() - 9]
            .iter()
            .chain(&["--rays", "16", "-q"])
            .copied()
            .collect::<Vec<_>>(),
        dir.path(),
    );
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stdout).starts_with("px,py,pz"));
    // Issue #33: `--read image` reads the points as the image does. Without doubt it is
    // the basis read, the same as `--set final_gather=0` without the probes' own tests
    // of the point (`basis_crevice`, `basis_visibility`, issue #32), bit for bit; with
    // doubt (the default) it gathers where the basis is doubted and reads it elsewhere.
    let solver = ["--rays", "64", "--set", "levels=4", "--set", "sender_level=3", "-q"];
    let read = |extra: &[&str]| -> Vec<Vec<f64>> {
        let mut a = vec!["probe", scene.to_str().unwrap(), "--points", pts.to_str().unwrap()];
        a.extend(solver);
        a.extend(extra);
        let o = meshrad(&a, dir.path());
        ok(&o);
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
            .collect()
    };
    let basis = read(&[
        "--set",
        "final_gather=0",
        "--set",
        "basis_crevice=false",
        "--set",
        "basis_visibility=false",
    ]);
    assert_eq!(read(&["--read", "image", "--set", "doubt_gather=0"]), basis);
    let image = read(&["--read", "image"]);
    for (a, b) in image.iter().zip(&rows) {
        for c in 9..12 {
            assert!(
                a[c] > 0.0 && (a[c] - b[c]).abs() < 0.25 * b[c],
                "{a:?} against the probe {b:?}"
            );
        }
    }
}

#[test]
fn gpu_backend_from_the_command_line() {
    let dir = common::tmpdir();
    let o = meshrad(&["devices"], dir.path());
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stdout).contains("0: "));
    let out = dir.path().join("g");
    let o = Command::new(env!("CARGO_BIN_EXE_meshrad"))
        .args([
            "solve",
            "--backend",
            "gpu",
            "--out",
            out.to_str().unwrap(),
            "--rays",
            "32",
            "--bounces",
            "2",
            "--set",
            "levels=4",
            "--set",
            "sender_level=3",
            "--stats",
            "-q",
        ])
        .env("MESHRAD_VALIDATION", "1")
        .current_dir(dir.path())
        .output()
        .unwrap();
    ok(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("kernel trace:") && err.contains("kernel reduce:"), "{err}");
    assert!(!err.contains("validation error"), "{err}");
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("stats.json")).unwrap()).unwrap();
    assert!(stats["backend"].as_str().unwrap().starts_with("gpu"));
    assert_eq!(stats["gpu"]["validation_errors"], 0);
    let kernels = stats["solve"]["kernel_seconds"].as_array().unwrap();
    assert!(kernels.len() >= 9, "{kernels:?}");
    check_images(&out, 256, 256);
    let o = meshrad(
        &["solve", "--backend", "gpu", "--device", "no-such-device", "-q"],
        dir.path(),
    );
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("no-such-device"));
}

/// Issue #33: the image's gather where the basis is doubted. A sample never doubted reads
/// the basis bit for bit (the support is counted in the read's own pass); one always
/// doubted is the per-sample final gather of as many rays (`final_gather_pixels`) bit for
/// bit; the counts say which.
#[test]
fn doubted_samples_gather_and_the_others_read_the_basis_bit_for_bit() {
    let scene_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell_box.toml");
    let small = [
        ("levels", "4"),
        ("coarsest", "100"),
        ("sender_level", "3"),
        ("bounces", "2"),
        ("rays", "64"),
    ];
    let (mut scene, params) = common::load(&scene_path, &small);
    scene.camera.width = 24;
    scene.camera.height = 24;
    scene.camera.spp = 2;
    let (h, sol) = common::solve_cpu(&scene, &params);
    let render = |f: &dyn Fn(&mut meshrad::SolverParams)| {
        let mut p = params.clone();
        f(&mut p);
        meshrad::output::image::render(&scene, &h, &sol, &p, &meshrad::progress::Progress::hidden())
    };
    let bits = |v: &[glam::Vec3]| {
        v.iter()
            .flat_map(|p| p.to_array())
            .map(f32::to_bits)
            .collect::<Vec<_>>()
    };
    let basis = render(&|p| p.doubt_gather = 0);
    let never = render(&|p| {
        p.doubt_gather = 16;
        p.doubt_nodes = 0;
        p.doubt_spread = 1e6;
    });
    assert_eq!(bits(&never.indirect), bits(&basis.indirect));
    // Samples whose primary ray hits (the others see the background).
    let hits = never.basis_samples;
    assert!(never.doubted_samples == 0 && hits > 24 * 24, "{hits}");
    let always = render(&|p| {
        p.doubt_gather = 16;
        p.doubt_nodes = 1 << 10;
    });
    let gathered = render(&|p| p.final_gather_pixels = 16);
    assert_eq!(bits(&always.indirect), bits(&gathered.indirect));
    assert_eq!((always.doubted_samples, always.basis_samples), (hits, 0));
    // The default lies between: some samples doubted, not all.
    let default = render(&|_| {});
    assert_eq!(default.basis_samples + default.doubted_samples, hits);
    assert!(default.basis_samples > 0, "{}", default.doubted_samples);
}

/// `bench compare` (the device check's GPU-against-CPU test): equal images differ by 0; an
/// image 1 % brighter by 1 % relative RMS, refused above a tolerance below that; images
/// of two sizes are an error naming both.
#[test]
fn bench_compare_measures_and_refuses_above_the_tolerance() {
    let dir = common::tmpdir();
    let d = dir.path();
    let write = |name: &str, w: usize, h: usize, gain: f32| {
        exr::prelude::write_rgb_file(d.join(name), w, h, |x, y| {
            let v = gain * (0.1 + 0.01 * x as f32 + 0.02 * y as f32);
            (v, 0.5 * v, 0.25 * v)
        })
        .unwrap();
    };
    write("a.exr", 16, 8, 1.0);
    write("b.exr", 16, 8, 1.01);
    write("c.exr", 8, 8, 1.0);
    let o = meshrad(&["bench", "compare", "a.exr", "a.exr", "--tolerance", "0"], d);
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stdout).starts_with("rel_rms=0.0"));
    let o = meshrad(&["bench", "compare", "b.exr", "a.exr", "--tolerance", "0.02"], d);
    ok(&o);
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    let rel: f64 = out
        .strip_prefix("rel_rms=")
        .and_then(|s| s.split_whitespace().next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("{out}"));
    assert!((rel - 0.01).abs() < 1e-4, "{out}");
    let o = meshrad(&["bench", "compare", "b.exr", "a.exr", "--tolerance", "0.005"], d);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("b.exr") && err.contains("tolerance"), "{err}");
    let o = meshrad(&["bench", "compare", "c.exr", "a.exr"], d);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("c.exr") && err.contains("a.exr") && err.contains("8×8"),
        "{err}"
    );
}
