//! `meshrad bench edit`: the modify-review cycle timed (paper §6, Fig. 5). A fixed set of
//! frames per scene (the tall block of the Cornell box turned and moved and the spot
//! light moved; the Buddha moved and the spot moved; the sun swung over Sponza), each
//! solved twice in one run, alternating: as a frame of an [`Editor`] (hierarchy built
//! once, only the update per frame) and as a fresh solve of the same frame (load, build,
//! transport, outputs). Per frame: update / direct / bounces / outputs, and the fresh
//! solve's load / build / rest.

use std::path::Path;
use std::time::Instant;

use glam::Vec3;
use serde::Serialize;

use crate::editor::{self, Edit, Editor, ObjectEdit};
use crate::engine::Engine;
use crate::error::{Error, Result};
use crate::geom::Transform;
use crate::hierarchy::Hierarchy;
use crate::output::image;
use crate::params::SolverParams;
use crate::progress::Progress;
use crate::scene::Scene;

/// A scene of the benchmark.
#[derive(Clone, Copy, Debug)]
pub struct EditScene {
    pub name: &'static str,
    /// Embedded (`None`: the shipped Cornell box in parts), else a file of the scene folder.
    pub file: Option<&'static str>,
}

/// The benchmark's scenes.
pub const SCENES: [EditScene; 3] = [
    EditScene {
        name: "cornell",
        file: None,
    },
    EditScene {
        name: "buddha",
        file: Some("cornell_buddha_parts.toml"),
    },
    EditScene {
        name: "sponza",
        file: Some("sponza.toml"),
    },
];

/// The world-space centre of object `o`'s bounds (under its transform at load).
fn centre(scene: &Scene, o: usize) -> Vec3 {
    let (lo, hi) = crate::scene::object_box(&scene.objects[o], &scene.tris);
    (lo + hi) * 0.5
}

/// Object `o` (at identity at load) turned by `deg` about the vertical through its centre
/// and moved by `shift`.
fn turn(scene: &Scene, o: usize, deg: f32, shift: Vec3) -> ObjectEdit {
    let c = centre(scene, o);
    let r = Transform {
        rotate_deg: Vec3::new(0.0, deg, 0.0),
        ..Default::default()
    }
    .rotation();
    ObjectEdit {
        rotate: Some(Vec3::new(0.0, deg, 0.0)),
        translate: Some(c + shift - r * c),
        scale: None,
    }
}

fn light(keys: &[(&str, [f32; 3])]) -> toml::Table {
    keys.iter()
        .map(|(k, v)| {
            (
                k.to_string(),
                toml::Value::Array(v.iter().map(|&x| toml::Value::Float(x as f64)).collect()),
            )
        })
        .collect()
}

/// The frames of a scene: frame 0 is the scene as loaded; then `n − 1` edits. In the
/// Cornell box and Cornell + Buddha, odd frames move the object, even frames only the
/// light (a relighting frame: the last frame's links serve it); over Sponza every frame
/// swings the sun.
pub fn frames(name: &str, scene: &Scene, n: usize) -> Result<Vec<Edit>> {
    let find = |o: &str| {
        scene.object_index(o).ok_or_else(|| Error::Param {
            name: "scene".into(),
            message: format!("bench edit: {name} has no object `{o}`"),
        })
    };
    let mut out = vec![Edit::default()];
    for k in 1..n {
        let kf = k as f32;
        let mut e = Edit::default();
        match name {
            "cornell" | "buddha" => {
                let (obj, shift) = if name == "cornell" {
                    ("tallbox", Vec3::new(-8.0 * kf, 0.0, 6.0 * kf))
                } else {
                    ("buddha", Vec3::new(-12.0 * kf, 0.0, -10.0 * kf))
                };
                let o = find(obj)?;
                if k % 2 == 1 {
                    e.objects.push((obj.into(), turn(scene, o, 9.0 * kf, shift)));
                } else {
                    let a = 0.7 * kf;
                    let p = [278.0 + 90.0 * a.cos(), 548.0, 279.6 + 90.0 * a.sin()];
                    e.lights
                        .push(("spot".into(), light(&[("position", p), ("target", [p[0], 0.0, p[2]])])));
                }
            }
            _ => {
                // The sun swung about the vertical and lowered.
                let a = 0.35 * kf;
                let d = [
                    0.25 * a.cos() - 0.15 * a.sin(),
                    -1.0 + 0.02 * kf,
                    0.25 * a.sin() + 0.15 * a.cos(),
                ];
                e.lights.push(("sun".into(), light(&[("direction", d)])));
            }
        }
        out.push(e);
    }
    Ok(out)
}

/// Loads a scene of the benchmark (`smoke`: tiny parameters) with editing parameters.
pub fn load(s: &EditScene, dir: &Path, smoke: bool) -> Result<(Scene, SolverParams)> {
    let small: Vec<(String, toml::Value)> = if smoke {
        [
            ("levels", 4),
            ("coarsest", 40),
            ("rays", 64),
            ("sender_level", 3),
            ("final_gather", 0),
        ]
        .iter()
        .map(|(k, v)| (k.to_string(), toml::Value::Integer(*v)))
        .collect()
    } else {
        Vec::new()
    };
    let (mut scene, p) = match s.file {
        None => Scene::embedded_file("cornell_parts.toml", &small)?,
        Some(f) => Scene::load(&dir.join(f), &small)?,
    };
    if smoke {
        scene.camera.width = 32;
        scene.camera.height = 32;
    }
    Ok((scene, editor::editing_params(&p, "bench edit")?))
}

/// One frame, both ways.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FrameRow {
    pub scene: String,
    pub backend: String,
    pub frame: usize,
    /// What the frame changed: "objects", "lights" or "objects+lights".
    pub kind: String,
    pub update: f64,
    pub direct: f64,
    pub bounces: f64,
    pub outputs: f64,
    /// Update, transport (with the GPU's uploads) and outputs.
    pub total: f64,
    pub clips_computed: usize,
    pub parents_computed: usize,
    pub nodes: usize,
    pub rebuilt: bool,
    pub fresh_load: f64,
    pub fresh_build: f64,
    /// The fresh solve less its load and hierarchy build: transport (with the GPU's
    /// pipelines and uploads) and outputs.
    pub fresh_rest: f64,
    pub fresh_total: f64,
}

/// Images of a solution, encoded in memory (what a frame writes, without the disk).
fn outputs(scene: &Scene, h: &Hierarchy, sol: &crate::Solution, p: &SolverParams) -> Result<f64> {
    let t = Instant::now();
    let img = image::render(scene, h, sol, p, &Progress::hidden());
    let mut files = crate::output::Outputs::default();
    image::encode_all(Path::new("."), &img, image::Exposure::default(), &mut files)?;
    Ok(t.elapsed().as_secs_f64())
}

/// Runs the frames of `s` where `engine` runs (each solve on a fresh copy of it).
pub fn run_scene(
    s: &EditScene,
    dir: &Path,
    n: usize,
    smoke: bool,
    engine: &Engine,
    progress: &Progress,
) -> Result<Vec<FrameRow>> {
    let backend = engine
        .context()
        .map_or("cpu".to_string(), |c| format!("gpu ({})", c.info.name));
    progress.stage(&format!("{}: hierarchy ({backend})", s.name));
    let (scene, params) = load(s, dir, smoke)?;
    let edits = frames(s.name, &scene, n)?;
    let hidden = Progress::hidden();
    let mut ed = Editor::new(scene, params, engine.fresh(), &hidden)?;
    let mut rows = Vec::new();
    for (k, e) in edits.iter().enumerate() {
        progress.stage(&format!("{}: frame {k}/{n} ({backend})", s.name));
        let t = Instant::now();
        ed.apply(e, &format!("bench edit {} frame {k}", s.name))?;
        let f = ed.solve(&hidden)?;
        let out = outputs(&ed.scene, &ed.hierarchy, &f.solution, &ed.params)?;
        let total = t.elapsed().as_secs_f64();
        // The same frame solved from scratch: the file loaded, the frames' edits so far
        // applied (what a file holding their values gives: tests/edit.rs), built, solved.
        let t0 = Instant::now();
        let (mut fresh, p) = load(s, dir, smoke)?;
        let fresh_load = t0.elapsed().as_secs_f64();
        for (j, ej) in edits[..=k].iter().enumerate() {
            editor::apply(&mut fresh, ej, &format!("frame {j}"))?;
        }
        // As `meshrad solve` does it: on a device, the build ends with the upload and the
        // arrangement there (`Engine::build`); the rest is the transport.
        let mut there = engine.fresh();
        let t = Instant::now();
        let mut h = there.build(&fresh, &p, &hidden)?;
        let fresh_build = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let sol = there.solve(&fresh, &mut h, &p, false, &hidden)?.0;
        outputs(&fresh, &h, &sol, &p)?;
        let fresh_rest = t.elapsed().as_secs_f64();
        rows.push(FrameRow {
            scene: s.name.into(),
            backend: backend.clone(),
            frame: k,
            kind: match (f.changed.objects.is_empty(), f.changed.lights.is_empty()) {
                (false, true) => "objects",
                (true, false) => "lights",
                (false, false) => "objects+lights",
                (true, true) => "nothing",
            }
            .into(),
            update: f.seconds.update,
            direct: f.seconds.direct,
            bounces: f.seconds.bounces,
            outputs: out,
            total,
            clips_computed: f.changed.clips_computed,
            parents_computed: f.changed.parents_computed,
            nodes: ed.hierarchy.nodes.len(),
            rebuilt: f.changed.rebuild,
            fresh_load,
            fresh_build,
            fresh_rest,
            fresh_total: fresh_load + fresh_build + fresh_rest,
        });
    }
    Ok(rows)
}

/// The `q`-quantile (nearest rank) of `v`.
fn quantile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[((q * s.len() as f64).ceil() as usize).clamp(1, s.len()) - 1]
}

/// Per scene, backend and kind of frame, over the re-solve frames (1…): median and 95th
/// percentile of each part, the frame against the fresh solve less its load and build, and
/// the update's share of the frame.
pub fn markdown(rows: &[FrameRow]) -> String {
    let mut s = String::from(
        "| scene | backend | frames change | nodes | frames | update | direct | bounces | outputs | frame total | fresh: load | \
         fresh: build | fresh: rest | frame / fresh rest | update / frame |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let mut keys: Vec<(String, String, String)> = Vec::new();
    for r in rows.iter().filter(|r| r.frame > 0) {
        let k = (r.scene.clone(), r.backend.clone(), r.kind.clone());
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    for (sc, b, kind) in keys {
        let re: Vec<&FrameRow> = rows
            .iter()
            .filter(|r| r.scene == sc && r.backend == b && r.kind == kind && r.frame > 0)
            .collect();
        let col = |f: fn(&FrameRow) -> f64| {
            let v: Vec<f64> = re.iter().map(|r| f(r)).collect();
            format!("{:.3} / {:.3}", quantile(&v, 0.5), quantile(&v, 0.95))
        };
        let ratio: Vec<f64> = re.iter().map(|r| r.total / r.fresh_rest).collect();
        let share: Vec<f64> = re.iter().map(|r| r.update / r.total).collect();
        s += &format!(
            "| {sc} | {b} | {kind} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.3} / {:.3} | {:.1} % / {:.1} % |\n",
            re.first().map_or(0, |r| r.nodes),
            re.len(),
            col(|r| r.update),
            col(|r| r.direct),
            col(|r| r.bounces),
            col(|r| r.outputs),
            col(|r| r.total),
            col(|r| r.fresh_load),
            col(|r| r.fresh_build),
            col(|r| r.fresh_rest),
            quantile(&ratio, 0.5),
            quantile(&ratio, 0.95),
            100.0 * quantile(&share, 0.5),
            100.0 * quantile(&share, 0.95),
        );
    }
    s
}

/// The CSV of every frame.
pub fn csv(rows: &[FrameRow]) -> String {
    let mut s = String::from(
        "scene,backend,frame,kind,update,direct,bounces,outputs,total,clips_computed,parents_computed,nodes,rebuilt,\
         fresh_load,fresh_build,fresh_rest,fresh_total\n",
    );
    for r in rows {
        s += &format!(
            "{},\"{}\",{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            r.scene,
            r.backend.replace('"', "'"),
            r.frame,
            r.kind,
            r.update,
            r.direct,
            r.bounces,
            r.outputs,
            r.total,
            r.clips_computed,
            r.parents_computed,
            r.nodes,
            r.rebuilt,
            r.fresh_load,
            r.fresh_build,
            r.fresh_rest,
            r.fresh_total
        );
    }
    s
}
