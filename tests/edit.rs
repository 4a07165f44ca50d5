//! The modify-review cycle (issue #10): a frame of `animate`/`session` is exactly the
//! solve of a scene file holding the frame's values (CPU bit for bit; GPU on lavapipe
//! identical), an object pushed into contact with another against the reference
//! renderer, the furnace with its light moved, and the commands' errors.

mod common;

use std::path::Path;
use std::sync::Arc;

use meshrad::bench::area_probes;
use meshrad::editor::{Edit, Editor};
use meshrad::gpu::{Context, ContextOptions};
use meshrad::metrics::indirect_error;
use meshrad::progress::Progress;
use meshrad::reference::{self, ReferenceOptions};
use meshrad::transport::readout::Readout;
use meshrad::{Hierarchy, Scene, Solution, SolverParams};

const SMALL: &str = "levels = 4\ncoarsest = 60\nrays = 64\nbounces = 3\nsender_level = 3\nfinal_gather = 0\n\
                     reach = \"object\"\n";

/// The Cornell box as three objects (room, shortbox, tallbox), the tall block with the
/// extra keys `tall` and the spot light with `spot` (position and target lines).
fn cornell(tall: &str, spot: &str, solver: &str) -> String {
    cornell_with("", tall, spot, solver)
}

/// [`cornell`] with the short block's extra keys `short`.
fn cornell_with(short: &str, tall: &str, spot: &str, solver: &str) -> String {
    let mesh = format!("{}/scenes/cornell_original_mm.obj", env!("CARGO_MANIFEST_DIR"));
    format!(
        "[[object]]\nname = \"room\"\nmesh = \"{mesh}\"\ngroup = [\"cbox_floor\", \"cbox_ceiling\", \"cbox_back\", \
         \"cbox_greenwall\", \"cbox_redwall\", \"cbox_luminaire\"]\nemission = false\n\n\
         [[object]]\nname = \"shortbox\"\nmesh = \"{mesh}\"\ngroup = \"cbox_smallbox\"\n{short}\n\n\
         [[object]]\nname = \"tallbox\"\nmesh = \"{mesh}\"\ngroup = \"cbox_largebox\"\n{tall}\n\n\
         [[light]]\nname = \"spot\"\ntype = \"spot\"\n{spot}\nintensity = [300000.0, 300000.0, 300000.0]\n\
         cutoff_angle = 60.0\nbeam_width = 45.0\n\n\
         [camera]\nposition = [278.0, 273.0, -800.0]\ntarget = [278.0, 273.0, -799.0]\nfov = 39.3077\n\
         width = 32\nheight = 32\n\n[solver]\n{solver}"
    )
}

const SPOT: &str = "position = [278.0, 548.0, 279.6]\ntarget = [278.0, 0.0, 279.6]";

fn load(dir: &Path, name: &str, text: &str) -> (Scene, SolverParams) {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    Scene::load(&p, &[]).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn edit(text: &str) -> Edit {
    Edit::from_table(&toml::from_str(text).unwrap(), "test").unwrap()
}

/// The frames: the scene as loaded, the tall block rotated and moved, the spot moved,
/// both at once. Each with the scene-file lines that hold its values.
fn frames() -> Vec<(Edit, String, String, String)> {
    let tall = "rotate = [0.0, 25.0, 0.0]\ntranslate = [-114.03, 0.0, 188.66]";
    let spot = "position = [200.0, 548.0, 250.0]\ntarget = [150.0, 0.0, 300.0]";
    vec![
        (Edit::default(), String::new(), String::new(), SPOT.into()),
        (
            edit("objects.tallbox = { rotate = [0.0, 25.0, 0.0], translate = [-114.03, 0.0, 188.66] }"),
            String::new(),
            tall.into(),
            SPOT.into(),
        ),
        (
            edit("lights.spot = { position = [200.0, 548.0, 250.0], target = [150.0, 0.0, 300.0] }"),
            String::new(),
            tall.into(),
            spot.into(),
        ),
        (
            edit(
                "objects.tallbox = { rotate = [0.0, -15.0, 0.0], translate = [60.0, 0.0, 40.0] }\n\
                 objects.shortbox = { translate = [20.0, 0.0, -10.0] }\n\
                 lights.spot = { position = [300.0, 540.0, 300.0] }",
            ),
            "translate = [20.0, 0.0, -10.0]".into(),
            "rotate = [0.0, -15.0, 0.0]\ntranslate = [60.0, 0.0, 40.0]".into(),
            "position = [300.0, 540.0, 300.0]\ntarget = [150.0, 0.0, 300.0]".into(),
        ),
    ]
}

fn bytes<T: bytemuck::Pod>(v: &[T]) -> &[u8] {
    bytemuck::cast_slice(v)
}

/// Hierarchy and solution of a frame and of the fresh solve are the same, bit for bit.
fn assert_same(k: usize, h: &Hierarchy, s: &Solution, fh: &Hierarchy, fs: &Solution) {
    assert_eq!(bytes(&h.nodes), bytes(&fh.nodes), "frame {k}: nodes");
    assert!(h.clips == fh.clips, "frame {k}: clips");
    assert_eq!(bytes(&h.parents), bytes(&fh.parents), "frame {k}: parents");
    assert_eq!(h.parent_offset, fh.parent_offset, "frame {k}: parent offsets");
    assert_eq!(bytes(&s.values.direct), bytes(&fs.values.direct), "frame {k}: direct");
    assert_eq!(
        bytes(&s.values.indirect),
        bytes(&fs.values.indirect),
        "frame {k}: indirect"
    );
}

fn frames_equal_fresh_solves(ctx: Option<Arc<Context>>) {
    let dir = common::tmpdir();
    let (scene, params) = load(dir.path(), "f0.toml", &cornell("", SPOT, SMALL));
    let mut ed = Editor::new(scene, params, meshrad::Engine::on(ctx.clone()), &Progress::hidden()).unwrap();
    for (k, (e, short, tall, spot)) in frames().iter().enumerate() {
        ed.apply(e, &format!("frame {k}")).unwrap();
        let f = ed.solve(&Progress::hidden()).unwrap();
        assert!(!f.changed.rebuild, "frame {k}: a rigid move rebuilt the hierarchy");
        let (fresh_scene, p) = load(
            dir.path(),
            &format!("fresh{k}.toml"),
            &cornell_with(short, tall, spot, SMALL),
        );
        let fresh = meshrad::solve(
            &fresh_scene,
            &p,
            &mut meshrad::Engine::on(ctx.clone()),
            &Progress::hidden(),
        )
        .unwrap();
        assert_same(k, &ed.hierarchy, &f.solution, &fresh.hierarchy, &fresh.solution);
        // Only what can change is computed again: near the moved block (frame 1), nothing
        // for a light (frame 2); on the GPU only the light (and Globals) cross the bus.
        let n = ed.hierarchy.nodes.len();
        match k {
            1 => assert!(
                f.changed.clips_computed > 0 && f.changed.clips_computed < n / 2,
                "frame 1: {} of {n} clips computed",
                f.changed.clips_computed
            ),
            2 => {
                assert_eq!((f.changed.clips_computed, f.changed.parents_computed), (0, 0));
                // A light move keeps the last frame's links: fewer rays traced than the
                // fresh solve of the same frame, for the same answer (asserted above).
                let (fl, ffl) = (&f.solution.stats, &fresh.solution.stats);
                assert!(
                    fl.rays_traced < ffl.rays_traced
                        && fl.links.as_ref().unwrap().integrals_linked > ffl.links.as_ref().unwrap().integrals_linked,
                    "frame 2 kept no links: rays traced {} against the fresh solve's {}",
                    fl.rays_traced,
                    ffl.rays_traced
                );
                if let Some(g) = &f.gpu {
                    assert!(g.bytes_uploaded < 1024, "frame 2 uploaded {} bytes", g.bytes_uploaded);
                }
            }
            _ => {}
        }
        let lit = f.solution.values.indirect.iter().filter(|v| v.x > 0.0).count();
        assert!(lit > ed.hierarchy.nodes.len() / 4, "frame {k}: {lit} nodes lit");
    }
    if let Some(c) = ctx {
        assert_eq!(c.validation_errors(), 0);
    }
}

#[test]
fn frames_equal_fresh_solves_cpu() {
    frames_equal_fresh_solves(None);
}

#[test]
fn frames_equal_fresh_solves_gpu() {
    let ctx = Context::new(&ContextOptions {
        validation: true,
        device: std::env::var("MESHRAD_TEST_DEVICE").ok(),
    })
    .unwrap_or_else(|e| panic!("no usable Vulkan device with validation: {e}"));
    frames_equal_fresh_solves(Some(Arc::new(ctx)));
}

/// The arrangement on the device (`meshrad::device::arrange`: clips and relations) against
/// the CPU's: on the Cornell box in parts, as built and after the tall block moved (frame
/// 1 of [`frames`]), the clips and parent lists are the same but for float rounding (a
/// ray grazing an edge, a distance on a quantisation step), and the same nodes' clips and
/// lists are computed again.
#[test]
fn device_clips_match_the_cpu() {
    let ctx = Arc::new(
        Context::new(&ContextOptions {
            validation: true,
            device: std::env::var("MESHRAD_TEST_DEVICE").ok(),
        })
        .unwrap_or_else(|e| panic!("no usable Vulkan device with validation: {e}")),
    );
    let dir = common::tmpdir();
    let (scene, params) = load(dir.path(), "c.toml", &cornell("", SPOT, SMALL));
    let mut cpu = Editor::new(
        scene.clone(),
        params.clone(),
        meshrad::Engine::cpu(),
        &Progress::hidden(),
    )
    .unwrap();
    let mut gpu = Editor::new(scene, params, meshrad::Engine::gpu(ctx.clone()), &Progress::hidden()).unwrap();
    let agree = |a: &Hierarchy, b: &Hierarchy, what: &str| {
        assert_eq!(bytes(&a.nodes), bytes(&b.nodes), "{what}: nodes");
        let n = a.nodes.len();
        let same = a.clips.iter().zip(&b.clips).filter(|(x, y)| x == y).count();
        let clipped = a
            .clips
            .iter()
            .filter(|c| **c != meshrad::hierarchy::weight::NO_CLIP)
            .count();
        assert!(clipped > n / 20, "{what}: {clipped} of {n} nodes clipped");
        assert!(
            same as f64 >= 0.995 * n as f64,
            "{what}: {same} of {n} clips agree ({clipped} clipped)"
        );
        // The relations built on the device: the same parents with the same weights but
        // for rounding, the same children in the same order, the same holes and orphans.
        let lists_same = (0..n)
            .filter(|&c| {
                let (x, y) = (a.parents_of(c), b.parents_of(c));
                x.len() == y.len()
                    && x.iter()
                        .zip(y)
                        .all(|(p, q)| p.node == q.node && (p.weight - q.weight).abs() <= 1e-5)
            })
            .count();
        assert!(a.parents.len() > n / 2, "{what}: {} parents", a.parents.len());
        assert!(
            lists_same as f64 >= 0.995 * n as f64,
            "{what}: {lists_same} of {n} parent lists agree"
        );
        let children_same = (0..n).filter(|&j| a.children_of(j) == b.children_of(j)).count();
        assert!(
            children_same as f64 >= 0.995 * n as f64,
            "{what}: {children_same} of {n} children lists agree"
        );
        assert_eq!(a.parents.len(), b.children.len(), "{what}: one child per parent entry");
        assert_eq!(
            a.stats.parent_holes_per_level, b.stats.parent_holes_per_level,
            "{what}: holes"
        );
        assert_eq!(a.stats.orphans_per_level, b.stats.orphans_per_level, "{what}: orphans");
        println!("{what}: {same} of {n} clips agree, {clipped} clipped; {lists_same} parent lists agree");
    };
    agree(&cpu.hierarchy, &gpu.hierarchy, "as built");
    let e = &frames()[1].0;
    cpu.apply(e, "frame 1").unwrap();
    gpu.apply(e, "frame 1").unwrap();
    let fc = cpu.solve(&Progress::hidden()).unwrap();
    let fg = gpu.solve(&Progress::hidden()).unwrap();
    agree(&cpu.hierarchy, &gpu.hierarchy, "after the move");
    for (what, a, b) in [
        ("clips", fc.changed.clips_computed, fg.changed.clips_computed),
        ("parent lists", fc.changed.parents_computed, fg.changed.parents_computed),
    ] {
        assert!(
            a > 0 && a < cpu.hierarchy.nodes.len() / 2 && a.abs_diff(b) <= a / 1000 + 1,
            "{what} computed after the move: CPU {a}, device {b}"
        );
    }
    assert_eq!(ctx.validation_errors(), 0);
}

/// An object's nodes do not depend on where it is: moving the tall block leaves every
/// node (object space) as it was; only clips and parent weights follow the arrangement.
#[test]
fn nodes_do_not_depend_on_the_arrangement() {
    let dir = common::tmpdir();
    let (a, p) = load(dir.path(), "a.toml", &cornell("", SPOT, SMALL));
    let (b, _) = load(
        dir.path(),
        "b.toml",
        &cornell(
            "rotate = [0.0, 90.0, 0.0]\ntranslate = [0.0, 0.0, 500.0]",
            "position = [100.0, 500.0, 100.0]\ntarget = [400.0, 0.0, 400.0]",
            SMALL,
        ),
    );
    let ha = Hierarchy::build(&a, &p, &Progress::hidden()).unwrap();
    let hb = Hierarchy::build(&b, &p, &Progress::hidden()).unwrap();
    assert_eq!(bytes(&ha.nodes), bytes(&hb.nodes));
    assert!(ha.clips != hb.clips, "the moved block cuts other supports");
}

/// The tall block pushed against the red wall (contact along a whole face): the solve
/// against the reference renderer at area-uniform points is as good as the unedited
/// box's (relative RMS within 1.5× plus 1 point, median estimate/reference within 3 %).
#[test]
fn box_pushed_against_the_wall_matches_the_reference() {
    let dir = common::tmpdir();
    let solver = "levels = 5\ncoarsest = 120\nrays = 128\nsender_level = 4\nreach = \"object\"\n";
    let (scene, params) = load(dir.path(), "a.toml", &cornell("", SPOT, solver));
    let mut ed = Editor::new(scene, params.clone(), meshrad::Engine::cpu(), &Progress::hidden()).unwrap();
    let opts = ReferenceOptions {
        samples: 2048,
        ..Default::default()
    };
    let mut errs = Vec::new();
    // The block's +x face at x = 472 moved to the wall's inner face at x = 549.6.
    for e in [
        Edit::default(),
        edit("objects.tallbox = { translate = [77.6, 0.0, 0.0] }"),
    ] {
        ed.apply(&e, "test").unwrap();
        let f = ed.solve(&Progress::hidden()).unwrap();
        let probes = area_probes(&ed.scene, 96, 11);
        let pts: Vec<_> = probes.iter().map(|q| (q.p, q.n)).collect();
        let refs = reference::indirect_many(&ed.scene, &pts, &opts);
        let read = Readout::with_rays(&ed.scene, &ed.hierarchy, &f.solution, &ed.params, 256);
        let est: Vec<_> = probes.iter().map(|q| read.at(q.p, q.n).mean).collect();
        let s = indirect_error(&est, &refs);
        println!("EDIT contact {:?}: {s:?}", e.objects);
        errs.push(s);
    }
    let (before, after) = (&errs[0], &errs[1]);
    assert!(
        after.rel_rms <= 1.5 * before.rel_rms + 0.01,
        "after the push {after:?}, before {before:?}"
    );
    assert!((after.median_ratio - 1.0).abs() < 0.03, "{after:?}");
    assert!((after.mean_ratio - 1.0).abs() < 0.03, "{after:?}");
}

/// The closed-sphere furnace with its light moved between frames: the answer is the
/// closed form wherever the light is, the moved light keeps the hierarchy (it stays in
/// the same enclosure), and the frame is the fresh solve.
#[test]
fn furnace_with_the_light_moved() {
    let dir = common::tmpdir();
    let (r, rho, i, k) = (1.0, 0.5, 2.0, 4u32);
    let solver = format!(
        "levels = 4\ncoarsest = 60\nrays = 256\nbounces = {k}\nsender_level = 3\ngather_levels = 3\n\
         variant = \"modified\"\nstop_threshold = 0.0\nreach = \"object\"\n"
    );
    let path = meshrad::analytic::furnace(dir.path(), r, 4, rho, [0.0; 3], i, &solver).unwrap();
    let (scene, params) = common::load(&path, &[]);
    let mut ed = Editor::new(scene, params, meshrad::Engine::cpu(), &Progress::hidden()).unwrap();
    let (_, eind, _) = meshrad::analytic::furnace_expected(r, rho, i, k);
    for (n, pos) in [[0.0, 0.0, 0.0], [0.35, -0.2, 0.1], [-0.5, 0.3, -0.2]]
        .into_iter()
        .enumerate()
    {
        ed.apply(
            &edit(&format!(
                "lights.light0 = {{ position = [{}, {}, {}] }}",
                pos[0], pos[1], pos[2]
            )),
            "test",
        )
        .unwrap();
        let f = ed.solve(&Progress::hidden()).unwrap();
        assert!(
            !f.changed.rebuild,
            "light moved within the sphere rebuilt the hierarchy"
        );
        let out = ed.params.output_level() as usize;
        let (mut sum, mut count, mut max) = (0.0, 0.0, 0.0f64);
        // The sphere's inside (normals towards the centre). Its outside has nodes too
        // (reach = "object": light from anywhere outside could reach it); they stay dark.
        for j in ed.hierarchy.level_range(out) {
            let nd = &ed.hierarchy.nodes[j];
            if glam::Vec3::from(nd.pos).dot(glam::Vec3::from(nd.normal)) > 0.0 {
                assert_eq!(f.solution.values.indirect[j].x, 0.0, "outside node {j} got light");
                continue;
            }
            let v = f.solution.values.indirect[j].x as f64;
            sum += v;
            count += 1.0;
            max = max.max(common::rel(v, eind));
        }
        let mean = common::rel(sum / count, eind);
        println!("EDIT furnace light at {pos:?}: mean {mean:.4}, max {max:.4}");
        assert!(mean < 0.01 && max < 0.03, "light at {pos:?}: mean {mean}, max {max}");
        if n == 2 {
            let text = std::fs::read_to_string(&path).unwrap().replace(
                "position = [0, 0, 0]",
                &format!("position = [{}, {}, {}]", pos[0], pos[1], pos[2]),
            );
            assert!(
                text.contains("-0.5"),
                "the furnace file holds the light's position: {text}"
            );
            let (s2, p2) = load(dir.path(), "moved.toml", &text);
            let fresh = meshrad::solve(&s2, &p2, &mut meshrad::Engine::cpu(), &Progress::hidden()).unwrap();
            assert_same(n, &ed.hierarchy, &f.solution, &fresh.hierarchy, &fresh.solution);
        }
    }
}

/// A bounded run: no panic, and the peak memory measured within `--max-memory` and a slack.
fn meshrad(args: &[&str], cwd: &Path) -> std::process::Output {
    common::meshrad_output(cwd, args, b"")
}

/// `animate` writes every frame's files; frame 1 of the file is the solve of the scene
/// file holding its values (same EXR bytes); bad frame files fail before any solving,
/// naming the frame and key.
#[test]
fn animate_writes_frames_and_names_bad_keys() {
    let dir = common::tmpdir();
    let d = dir.path();
    std::fs::write(d.join("scene.toml"), cornell("", SPOT, SMALL)).unwrap();
    std::fs::write(
        d.join("frames.toml"),
        "[[frame]]\n[[frame]]\nobjects.tallbox = { rotate = [0.0, 25.0, 0.0], translate = [-114.03, 0.0, 188.66] }\n",
    )
    .unwrap();
    let o = meshrad(
        &[
            "animate",
            "scene.toml",
            "--frames",
            "frames.toml",
            "--out",
            "anim",
            "--backend",
            "cpu",
        ],
        d,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let printed = String::from_utf8_lossy(&o.stdout);
    assert!(printed.contains("frame 1:") && printed.contains("update"), "{printed}");
    for k in ["0000", "0001"] {
        for f in ["direct.exr", "indirect.png", "total.exr", "stats.json"] {
            assert!(d.join("anim").join(k).join(f).is_file(), "{k}/{f}");
        }
    }
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("anim/0001/stats.json")).unwrap()).unwrap();
    assert_eq!(stats["changed"]["objects"][0], "tallbox");
    assert!(stats["seconds_frame"]["update"].as_f64().unwrap() > 0.0);
    std::fs::write(
        d.join("f1.toml"),
        cornell(
            "rotate = [0.0, 25.0, 0.0]\ntranslate = [-114.03, 0.0, 188.66]",
            SPOT,
            SMALL,
        ),
    )
    .unwrap();
    let o = meshrad(&["solve", "f1.toml", "--out", "fresh", "--backend", "cpu", "-q"], d);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["direct.exr", "indirect.exr", "total.exr"] {
        assert_eq!(
            std::fs::read(d.join("fresh").join(f)).unwrap(),
            std::fs::read(d.join("anim/0001").join(f)).unwrap(),
            "{f}"
        );
    }
    for (frames, want) in [
        (
            "[[frame]]\nobjects.nosuch = { translate = [0.0, 0.0, 0.0] }\n",
            vec!["frame 0", "objects.nosuch", "no such object", "tallbox"],
        ),
        (
            "[[frame]]\n[[frame]]\nobjects.tallbox = { spin = 3.0 }\n",
            vec!["frame 1", "objects.tallbox.spin", "unknown key"],
        ),
        (
            "[[frame]]\nlights.spot = { cutoff_angle = 200.0 }\n",
            vec!["frame 0", "lights.spot", "cutoff_angle"],
        ),
        (
            "[[frame]]\nobjects.tallbox = { scale = -1.0 }\n",
            vec!["frame 0", "objects.tallbox.scale", "positive"],
        ),
        // Issue #35: an overflowing scale is the scale's fault, not the translation's.
        (
            "[[frame]]\nobjects.tallbox = { scale = 1e30 }\n",
            vec!["frame 0", "objects.tallbox.scale", "not finite"],
        ),
        (
            "[[frame]]\nobjects.tallbox = { translate = [3e38, 0.0, 0.0] }\n",
            vec!["frame 0", "objects.tallbox.translate", "not finite"],
        ),
        (
            "[[frame]]\nlights.spot = { colour = [1.0, 1.0, 1.0] }\n",
            vec!["lights.spot.colour", "unknown key"],
        ),
        (
            "[[frame]]\nobjects.tallbox = { translate = [1.0, 2.0] }\n",
            vec!["objects.tallbox.translate", "[x, y, z]"],
        ),
        ("frame = 3\n", vec!["bad.toml", "[[frame]]"]),
    ] {
        std::fs::write(d.join("bad.toml"), frames).unwrap();
        let o = meshrad(
            &[
                "animate",
                "scene.toml",
                "--frames",
                "bad.toml",
                "--out",
                "bad",
                "--backend",
                "cpu",
            ],
            d,
        );
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{frames}");
        for w in &want {
            assert!(err.contains(w), "{frames}: `{w}` not in {err}");
        }
        assert!(
            !d.join("bad/0000/stats.json").exists(),
            "{frames}: solved before checking"
        );
    }
    // The light-reach hierarchy depends on the arrangement: refused.
    let o = meshrad(
        &[
            "animate",
            "scene.toml",
            "--frames",
            "frames.toml",
            "--set",
            "reach=\"lights\"",
            "--backend",
            "cpu",
        ],
        d,
    );
    assert!(String::from_utf8_lossy(&o.stderr).contains("reach"));
}

/// `session`: JSON lines in, one answer per line out; bad lines get an error answer and
/// the session goes on.
#[test]
fn session_answers_every_line_and_survives_bad_ones() {
    let dir = common::tmpdir();
    let d = dir.path();
    std::fs::write(d.join("scene.toml"), cornell("", SPOT, SMALL)).unwrap();
    let lines = [
        r#"{"solve": {}}"#,
        r#"{"probe": [[278.0, 0.0, 279.6, 0.0, 1.0, 0.0]]}"#,
        "this is not json",
        r#"{"set": {"objects": {"nosuch": {"translate": [0, 0, 0]}}}}"#,
        r#"{"set": {"objects": {"tallbox": {"translate": [0.0, 0.0, 40.0]}}, "lights": {"spot": {"intensity": [1e5, 1e5, 1e5]}}}}"#,
        r#"{"probe": [[278.0, 0.0, 279.6, 0.0, 1.0, 0.0], [1, 2]]}"#,
        r#"{"probe": [[278.0, 0.0, 279.6, 0.0, 1.0, 0.0]]}"#,
        r#"{"render": {"out": "view"}}"#,
        r#"{"stats": {}}"#,
        r#"{"fly": {}}"#,
        r#"{"solve": {}}"#,
        r#"{"render": {"out": "afile"}}"#,
    ];
    std::fs::write(d.join("afile"), "").unwrap();
    let input: String = lines.iter().map(|l| format!("{l}\n")).collect();
    let o = common::meshrad_output(d, &["session", "scene.toml", "--backend", "cpu"], input.as_bytes());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let answers: Vec<serde_json::Value> = String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{l}: {e}")))
        .collect();
    assert_eq!(answers.len(), lines.len() + 1, "{answers:?}");
    assert_eq!(answers[0]["ready"], true);
    let ok: Vec<bool> = answers[1..].iter().map(|a| a["ok"] == true).collect();
    assert_eq!(
        ok,
        [true, true, false, false, true, false, true, true, true, false, true, false],
        "{answers:#?}"
    );
    // Issue #35: a render error names its line, and says what is wrong in words.
    let e = answers[12]["error"].as_str().unwrap();
    assert!(
        e.starts_with("line 12: ") && e.contains("afile") && e.contains("not a directory"),
        "{e}"
    );
    assert!(answers[4]["error"].as_str().unwrap().contains("line 4"));
    assert!(answers[4]["error"].as_str().unwrap().contains("nosuch"));
    let before = answers[2]["values"][0]["total"][1].as_f64().unwrap();
    let after = answers[7]["values"][0]["total"][1].as_f64().unwrap();
    assert_eq!(answers[7]["solved"], true, "a probe after a set solves first");
    // A third of the intensity, a third of the light (the block moved a little too).
    assert!(after < 0.5 * before && after > 0.2 * before, "{before} → {after}");
    assert!(d.join("view/total.exr").is_file());
    assert_eq!(answers[9]["stale"], false);
}

/// Groups select faces; unknown groups and repeated names are errors naming the key.
#[test]
fn groups_and_names_are_checked() {
    let dir = common::tmpdir();
    let d = dir.path();
    let good = cornell("", SPOT, SMALL);
    let (scene, _) = load(d, "good.toml", &good);
    assert_eq!(
        scene.objects.iter().map(|o| o.tri_count).collect::<Vec<_>>(),
        [12, 12, 12],
        "room: 6 quads; each block: 6 quads"
    );
    for (text, want) in [
        (
            good.replace("\"cbox_largebox\"", "\"cbox_hugebox\""),
            vec!["cbox_hugebox", "cbox_largebox"],
        ),
        (
            good.replace("name = \"shortbox\"", "name = \"room\""),
            vec!["object[1].name", "unique"],
        ),
        (good.replace("name = \"spot\"", "name = 3"), vec!["light[0].name"]),
        // A default name taken by an earlier explicit one: the error says it is a default.
        (
            good.replace("name = \"room\"", "name = \"object1\"")
                .replace("name = \"shortbox\"\n", ""),
            vec!["object[1].name", "no `name`", "default `object1`"],
        ),
        (
            format!(
                "{}\n[[light]]\ntype = \"point\"\nposition = [1.0, 1.0, 1.0]\nintensity = [1.0, 1.0, 1.0]\n",
                good.replace("name = \"spot\"", "name = \"light1\"")
            ),
            vec!["light[1].name", "no `name`", "default `light1`"],
        ),
        (
            good.replace("group = \"cbox_smallbox\"", "group = []"),
            vec!["object[1].group"],
        ),
    ] {
        let p = d.join("bad.toml");
        std::fs::write(&p, &text).unwrap();
        let err = Scene::load(&p, &[]).map(|_| ()).expect_err("an error").to_string();
        for w in want {
            assert!(err.contains(w), "`{w}` not in {err}");
        }
    }
}

/// Issue #35: a solve that fails after an edit leaves the edit pending: the editor stays
/// stale (a session's probe then solves again instead of reading the old solution), and
/// the next solve that succeeds applies it (here the rebuild a scale asks for).
#[test]
fn a_failed_solve_keeps_the_edit_pending() {
    let dir = common::tmpdir();
    let (scene, params) = load(dir.path(), "f.toml", &cornell("", SPOT, SMALL));
    let mut ed = Editor::new(scene, params.clone(), meshrad::Engine::cpu(), &Progress::hidden()).unwrap();
    ed.solve(&Progress::hidden()).unwrap();
    assert!(!ed.is_stale());
    ed.apply(&edit("objects.tallbox = { scale = 2.0 }"), "test").unwrap();
    // The rebuild the scale asks for is refused (the candidate cap below what a level needs).
    ed.params.max_candidates = 10;
    let Err(e) = ed.solve(&Progress::hidden()) else {
        panic!("the solve should have been refused")
    };
    assert!(e.to_string().contains("max_candidates"), "{e}");
    assert!(ed.is_stale(), "a failed solve dropped the pending edit");
    assert!(
        ed.solve(&Progress::hidden()).is_err(),
        "the retry must fail the same way"
    );
    ed.params.max_candidates = params.max_candidates;
    let f = ed.solve(&Progress::hidden()).unwrap();
    assert!(f.changed.rebuild && f.changed.objects == ["tallbox"], "{:?}", f.changed);
    assert!(!ed.is_stale());
}
