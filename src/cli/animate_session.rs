//! `meshrad animate` (frames from a file) and `meshrad session` (JSON lines on stdin):
//! hierarchies built once, each frame or `solve` re-solves after its edits (`crate::editor`).

use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Result;
use clap::Args;
use glam::Vec3;
use serde::Serialize;
use serde_json::{json, Value};

use super::{load_scene, report_load, ImageArgs, ImageSummary, PhaseSeconds, RunStats, SolverArgs};
use crate::editor::{self, Changed, Edit, Editor, Frame, FrameSeconds};
use crate::output::{self, image, probe};
use crate::progress::Progress;

#[derive(Args, Debug)]
pub struct AnimateArgs {
    /// Scene file (TOML) whose objects and lights the frames name.
    scene: PathBuf,
    /// Frames file: `[[frame]]` tables of `objects.NAME = {translate, rotate, scale}` and
    /// `lights.NAME = {position, target, direction, intensity, irradiance, cutoff_angle,
    /// beam_width}` (absolute values; what a frame does not name keeps its value).
    #[arg(long)]
    frames: PathBuf,
    /// Output directory: one folder per frame, `DIR/0000`, `DIR/0001`, …
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Also evaluate these points (`px py pz nx ny nz` per line) per frame: `probe.csv`.
    #[arg(long, value_name = "P.txt")]
    points: Option<PathBuf>,
    #[command(flatten)]
    image: ImageArgs,
    #[command(flatten)]
    solver: SolverArgs,
}

#[derive(Args, Debug)]
pub struct SessionArgs {
    /// Scene file (TOML).
    scene: PathBuf,
    #[command(flatten)]
    solver: SolverArgs,
}

/// stats.json of one frame: the run's statistics and what the frame changed.
#[derive(Serialize)]
struct FrameStats<'a> {
    frame: usize,
    changed: &'a Changed,
    seconds_frame: FrameTimes,
    #[serde(flatten)]
    run: RunStats<'a>,
}

/// A frame's wall time, split.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FrameTimes {
    pub update: f64,
    pub direct: f64,
    pub bounces: f64,
    pub outputs: f64,
    pub total: f64,
}

impl FrameTimes {
    fn of(s: &FrameSeconds, outputs: f64) -> FrameTimes {
        FrameTimes {
            update: s.update,
            direct: s.direct,
            bounces: s.bounces,
            outputs,
            total: s.solve + outputs,
        }
    }
}

/// The frames' folders under `out`.
fn frame_dir(out: &Path, k: usize) -> PathBuf {
    out.join(format!("{k:04}"))
}

/// The images, stats.json and (with `points`) probe.csv of a solved frame, into `files`.
fn frame_outputs(
    ed: &mut Editor,
    f: &Frame,
    k: usize,
    dir: &Path,
    points: Option<&[probe::Probe]>,
    exposure: image::Exposure,
    progress: &Progress,
) -> Result<(output::Outputs, FrameTimes)> {
    let t = Instant::now();
    let sol = &f.solution;
    let (engine, scene, h, params) = ed.engine_and_scene();
    let img = image::render_on(engine, scene, h, sol, params, progress)?;
    super::check_finite(scene, "image", img.direct.iter().chain(&img.indirect).copied())?;
    let mut files = output::Outputs::default();
    let exposure = image::encode_all(dir, &img, exposure, &mut files)?;
    if let Some(points) = points {
        let values = probe::evaluate(scene, h, sol, points, params);
        super::check_finite(
            scene,
            "probe values",
            values.iter().flat_map(probe::ProbeValue::vectors),
        )?;
        files.add(dir.join("probe.csv"), probe::csv(points, &values).into_bytes());
    }
    let outputs = t.elapsed().as_secs_f64();
    let times = FrameTimes::of(&f.seconds, outputs);
    let stats = FrameStats {
        frame: k,
        changed: &f.changed,
        seconds_frame: times.clone(),
        run: RunStats::new(
            scene,
            params,
            (&h.stats, sol, f.gpu.as_ref()),
            ImageSummary::of(&img, scene, params, exposure),
            PhaseSeconds {
                load: 0.0,
                hierarchy: f.seconds.update,
                solve: f.seconds.solve - f.seconds.update,
                output: outputs,
                total: times.total,
            },
        ),
    };
    let p = dir.join("stats.json");
    files.add(&p, output::json_bytes(&p, &stats)?);
    Ok((files, times))
}

pub fn animate(a: AnimateArgs) -> Result<()> {
    let progress = Progress::new(a.solver.quiet);
    let (mut scene, params) = load_scene(Some(&a.scene), &a.solver)?;
    a.image.apply(&mut scene)?;
    let exposure = a.image.exposure.unwrap_or_default();
    report_load(&scene, a.solver.quiet);
    let params = editor::editing_params(&params, "animate")?;
    let text = crate::limits::read_text(&a.frames, crate::limits::MAX_TEXT_BYTES)?;
    let frames = editor::parse_frames(&text, &a.frames)?;
    // Every frame applied in order to a copy first: a bad name or value fails here,
    // before any solving.
    let mut check = scene.clone();
    for (k, f) in frames.iter().enumerate() {
        editor::apply(&mut check, f, &format!("{}: frame {k}", a.frames.display()))?;
    }
    drop(check);
    let limits = a.solver.limits()?;
    let points = a
        .points
        .as_deref()
        .map(|p| probe::read_within(p, &limits))
        .transpose()?;
    let mut inputs = scene.report.inputs.clone();
    inputs.push(a.frames.clone());
    inputs.extend(a.points.clone());
    // The frames' folders are made as each frame is written; a file in one that does not
    // exist yet can be no input and no other output, so only existing ones are checked
    // (a refused run leaves no empty folders behind).
    output::ensure_dir(&a.out)?;
    let mut planned: Vec<(&str, PathBuf)> = Vec::new();
    for k in 0..frames.len() {
        let dir = frame_dir(&a.out, k);
        if !dir.exists() {
            continue;
        }
        output::ensure_dir(&dir)?;
        planned.extend(image::file_names(&dir).into_iter().map(|p| ("an image", p)));
        planned.push(("stats.json", dir.join("stats.json")));
        if points.is_some() {
            planned.push(("probe.csv", dir.join("probe.csv")));
        }
    }
    output::check_outputs(&planned, &inputs)?;
    let engine = super::engine(&a.solver, a.solver.quiet)?;
    let mut ed = Editor::new(scene, params, engine, &progress)?;
    if !a.solver.quiet {
        eprintln!(
            "hierarchy: {} nodes in {:.2} s (built once)",
            ed.hierarchy.nodes.len(),
            ed.seconds_build
        );
    }
    let hidden = Progress::hidden();
    for (k, f) in frames.iter().enumerate() {
        let t = Instant::now();
        ed.apply(f, &format!("{}: frame {k}", a.frames.display()))?;
        let frame = ed.solve(&hidden)?;
        let dir = frame_dir(&a.out, k);
        output::ensure_dir(&dir)?;
        let (files, times) = frame_outputs(&mut ed, &frame, k, &dir, points.as_deref(), exposure, &hidden)?;
        files.commit()?;
        let total = t.elapsed().as_secs_f64();
        if !a.solver.quiet {
            println!(
                "frame {k}: {:.3} s (update {:.3} s, direct {:.3} s, bounces {:.3} s, outputs {:.3} s){} → {}",
                total,
                times.update,
                times.direct,
                times.bounces,
                times.outputs,
                if frame.changed.rebuild {
                    " [hierarchy rebuilt]"
                } else {
                    ""
                },
                dir.display()
            );
        }
    }
    progress.finish();
    Ok(())
}

/// A JSON value as TOML (for edits); `null` has no TOML form.
fn to_toml(v: &Value) -> std::result::Result<toml::Value, String> {
    Ok(match v {
        Value::Null => return Err("null is not a value".into()),
        Value::Bool(b) => toml::Value::Boolean(*b),
        Value::Number(n) => match n.as_i64() {
            Some(i) => toml::Value::Integer(i),
            None => toml::Value::Float(n.as_f64().ok_or("not a number")?),
        },
        Value::String(s) => toml::Value::String(s.clone()),
        Value::Array(a) => toml::Value::Array(a.iter().map(to_toml).collect::<std::result::Result<_, _>>()?),
        Value::Object(o) => {
            let mut t = toml::Table::new();
            for (k, v) in o {
                t.insert(k.clone(), to_toml(v)?);
            }
            toml::Value::Table(t)
        }
    })
}

/// A `probe` command's points: `[[px, py, pz, nx, ny, nz], …]`, finite, with non-zero
/// normals (normalised).
fn probe_points(arg: &Value, at: &str) -> Result<Vec<probe::Probe>> {
    let list = arg
        .as_array()
        .ok_or_else(|| anyhow::anyhow!("{at}: probe: expected [[px, py, pz, nx, ny, nz], …]"))?;
    let mut points = Vec::with_capacity(list.len());
    for (i, p) in list.iter().enumerate() {
        let a: Vec<f32> = p
            .as_array()
            .filter(|a| a.len() == 6)
            .map(|a| a.iter().filter_map(|x| x.as_f64().map(|x| x as f32)).collect())
            .unwrap_or_default();
        let bad = || {
            anyhow::anyhow!(
                "{at}: probe point {i}: expected six finite numbers [px, py, pz, nx, ny, nz] with a non-zero normal"
            )
        };
        if a.len() != 6 || a.iter().any(|x| !x.is_finite()) {
            return Err(bad());
        }
        let n = Vec3::new(a[3], a[4], a[5]).try_normalize().ok_or_else(bad)?;
        points.push(probe::Probe {
            p: Vec3::new(a[0], a[1], a[2]),
            n,
        });
    }
    Ok(points)
}

/// The session's state: the editor and the last solve.
struct Session {
    ed: Editor,
    last: Option<Frame>,
    inputs: Vec<PathBuf>,
    progress: Progress,
}

impl Session {
    /// Solves if edits wait (or nothing was solved yet); returns whether it did.
    fn ensure_solved(&mut self) -> Result<bool> {
        if self.last.is_some() && !self.ed.is_stale() {
            return Ok(false);
        }
        self.last = Some(self.ed.solve(&self.progress)?);
        Ok(true)
    }

    fn solve_answer(f: &Frame, nodes: usize) -> Value {
        let s = &f.solution.stats;
        json!({
            "ok": true,
            "changed": f.changed,
            "seconds": f.seconds,
            "bounces": s.bounces.len(),
            "integrals": s.integrals,
            "nodes": nodes,
            "backend": s.backend,
        })
    }

    fn handle(&mut self, line: &str, n: usize) -> Result<Value> {
        let v: Value = serde_json::from_str(line).map_err(|e| anyhow::anyhow!("line {n}: not JSON: {e}"))?;
        let obj = v.as_object().filter(|o| o.len() == 1).ok_or_else(|| {
            anyhow::anyhow!("line {n}: expected one command: {{\"set\"|\"solve\"|\"probe\"|\"render\"|\"stats\": …}}")
        })?;
        let (cmd, arg) = obj.iter().next().expect("one entry");
        let at = format!("line {n}");
        match cmd.as_str() {
            "set" => {
                let t = match to_toml(arg).map_err(|e| anyhow::anyhow!("{at}: set: {e}"))? {
                    toml::Value::Table(t) => t,
                    _ => anyhow::bail!("{at}: set: expected {{\"objects\": {{…}}, \"lights\": {{…}}}}"),
                };
                let e = Edit::from_table(&t, &at)?;
                let c = self.ed.apply(&e, &at)?;
                Ok(json!({"ok": true, "changed": c}))
            }
            "solve" => {
                if !arg.as_object().is_some_and(|o| o.is_empty()) {
                    anyhow::bail!("{at}: solve takes {{}}");
                }
                self.last = Some(self.ed.solve(&self.progress)?);
                let f = self.last.as_ref().expect("just solved");
                Ok(Self::solve_answer(f, self.ed.hierarchy.nodes.len()))
            }
            "probe" => {
                let points = probe_points(arg, &at)?;
                let solved = self.ensure_solved()?;
                let f = self.last.as_ref().expect("solved");
                let values = probe::evaluate(
                    &self.ed.scene,
                    &self.ed.hierarchy,
                    &f.solution,
                    &points,
                    &self.ed.params,
                );
                super::check_finite(
                    &self.ed.scene,
                    "probe values",
                    values.iter().flat_map(probe::ProbeValue::vectors),
                )?;
                let out: Vec<Value> = values
                    .iter()
                    .map(|v| {
                        let (d, r) = (v.direct, v.indirect);
                        let t = d + r.mean;
                        json!({"direct": d.to_array(), "indirect": r.mean.to_array(), "total": t.to_array(),
                               "indirect_se": r.std_err.to_array(), "direct_se": v.direct_se.to_array()})
                    })
                    .collect();
                Ok(json!({"ok": true, "solved": solved, "values": out}))
            }
            "render" => {
                let dir = arg
                    .get("out")
                    .and_then(Value::as_str)
                    .filter(|s| !s.is_empty())
                    .ok_or_else(|| anyhow::anyhow!("{at}: render: expected {{\"out\": \"DIR\"}}"))?;
                let dir = PathBuf::from(dir);
                output::ensure_dir(&dir)?;
                let mut planned: Vec<(&str, PathBuf)> =
                    image::file_names(&dir).into_iter().map(|p| ("an image", p)).collect();
                planned.push(("stats.json", dir.join("stats.json")));
                output::check_outputs(&planned, &self.inputs)?;
                let solved = self.ensure_solved()?;
                let f = self.last.as_ref().expect("solved");
                let (files, _) = frame_outputs(
                    &mut self.ed,
                    f,
                    0,
                    &dir,
                    None,
                    image::Exposure::default(),
                    &self.progress,
                )?;
                let paths: Vec<String> = files.paths().map(|p| p.display().to_string()).collect();
                files.commit()?;
                Ok(json!({"ok": true, "solved": solved, "files": paths}))
            }
            "stats" => {
                let f = self
                    .last
                    .as_ref()
                    .ok_or_else(|| anyhow::anyhow!("{at}: stats: nothing solved yet (send {{\"solve\": {{}}}})"))?;
                Ok(json!({
                    "ok": true,
                    "stale": self.ed.is_stale(),
                    "nodes": self.ed.hierarchy.nodes.len(),
                    "seconds_build": self.ed.seconds_build,
                    "hierarchy": self.ed.hierarchy.stats,
                    "changed": f.changed,
                    "seconds": f.seconds,
                    "solve": f.solution.stats,
                    "gpu": f.gpu,
                }))
            }
            other => anyhow::bail!("{at}: unknown command `{other}` (set, solve, probe, render, stats)"),
        }
    }
}

pub fn session(a: SessionArgs) -> Result<()> {
    let progress = Progress::hidden();
    let (scene, params) = load_scene(Some(&a.scene), &a.solver)?;
    report_load(&scene, true);
    let params = editor::editing_params(&params, "session")?;
    let engine = super::engine(&a.solver, true)?;
    let inputs = scene.report.inputs.clone();
    let ed = Editor::new(scene, params, engine, &progress)?;
    let mut s = Session {
        ed,
        last: None,
        inputs,
        progress,
    };
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    writeln!(
        out,
        "{}",
        json!({"ok": true, "ready": true, "nodes": s.ed.hierarchy.nodes.len(), "seconds_build": s.ed.seconds_build,
               "objects": s.ed.scene.objects.iter().map(|o| o.name.clone()).collect::<Vec<_>>(),
               "lights": s.ed.scene.light_names})
    )?;
    out.flush()?;
    let stdin = std::io::stdin();
    let mut input = stdin.lock();
    for i in 0.. {
        let line = match read_bounded_line(&mut input, MAX_SESSION_LINE)? {
            None => break,
            Some(Ok(l)) => l,
            Some(Err(message)) => {
                writeln!(
                    out,
                    "{}",
                    json!({"ok": false, "error": short(&format!("line {}: {message}", i + 1))})
                )?;
                out.flush()?;
                continue;
            }
        };
        if line.trim().is_empty() {
            continue;
        }
        let answer = match s.handle(&line, i + 1) {
            Ok(v) => v,
            Err(e) => {
                // Every error answer names its line (some come from deeper than `handle`).
                let m = format!("{e:#}");
                let m = if m.starts_with(&format!("line {}:", i + 1)) {
                    m
                } else {
                    format!("line {}: {m}", i + 1)
                };
                json!({"ok": false, "error": short(&m)})
            }
        };
        writeln!(out, "{answer}")?;
        out.flush()?;
    }
    Ok(())
}

/// The longest `session` line (bytes, without its newline): a probe of about 100,000
/// points. A longer one is read to its end without being kept and answered with an error.
pub const MAX_SESSION_LINE: usize = 8 << 20;

/// The longest error text a `session` answer carries (characters).
const MAX_ANSWER_ERROR: usize = 2000;

/// `message`, cut to [`MAX_ANSWER_ERROR`] characters (an error may quote its input).
fn short(message: &str) -> String {
    match message.char_indices().nth(MAX_ANSWER_ERROR) {
        None => message.to_string(),
        Some((at, _)) => format!("{}… ({} bytes in all)", &message[..at], message.len()),
    }
}

/// The next line of `r` without its newline, holding at most `max` bytes: `None` at the
/// end of the input; `Some(Err(..))` for a line that is longer (consumed to its end) or
/// not UTF-8.
fn read_bounded_line(r: &mut impl BufRead, max: usize) -> std::io::Result<Option<std::result::Result<String, String>>> {
    let mut line: Vec<u8> = Vec::new();
    let mut total = 0usize;
    let mut any = false;
    loop {
        let buf = match r.fill_buf() {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        if buf.is_empty() {
            break;
        }
        any = true;
        let (chunk, done) = match buf.iter().position(|&b| b == b'\n') {
            Some(k) => (&buf[..k], Some(k + 1)),
            None => (buf, None),
        };
        total += chunk.len();
        if total <= max {
            line.extend_from_slice(chunk);
        } else {
            line = Vec::new();
        }
        let used = done.unwrap_or(buf.len());
        r.consume(used);
        if done.is_some() {
            break;
        }
    }
    if !any {
        return Ok(None);
    }
    if total > max {
        return Ok(Some(Err(format!(
            "the line has {total} bytes, over the {max} a session line may have (send fewer probe points per line)"
        ))));
    }
    if line.last() == Some(&b'\r') {
        line.pop();
    }
    Ok(Some(
        String::from_utf8(line).map_err(|_| "the line is not UTF-8".to_string()),
    ))
}

#[cfg(test)]
mod tests {
    use super::{read_bounded_line, short};

    #[test]
    fn session_lines_are_bounded_and_answers_short() {
        let text = format!("ab\n{}\ncd\r\n\nef", "x".repeat(100));
        let mut r = std::io::BufReader::with_capacity(7, text.as_bytes());
        assert_eq!(read_bounded_line(&mut r, 10).unwrap(), Some(Ok("ab".into())));
        let long = read_bounded_line(&mut r, 10).unwrap().unwrap().unwrap_err();
        assert!(long.contains("100 bytes") && long.contains("over the 10"), "{long}");
        assert_eq!(read_bounded_line(&mut r, 10).unwrap(), Some(Ok("cd".into())));
        assert_eq!(read_bounded_line(&mut r, 10).unwrap(), Some(Ok("".into())));
        assert_eq!(read_bounded_line(&mut r, 10).unwrap(), Some(Ok("ef".into())));
        assert_eq!(read_bounded_line(&mut r, 10).unwrap(), None);
        let e = short(&"y".repeat(10_000));
        assert!(e.len() < 2100 && e.ends_with("(10000 bytes in all)"), "{}", e.len());
    }
}
