//! The modify-review cycle (paper §6, `ALGORITHM.md` §6): edits that move objects and
//! change lights by name, applied to a loaded scene, and re-solves over hierarchies built
//! once (`meshrad animate`, `meshrad session`, `meshrad bench edit`).
//!
//! With `reach = "object"` an object's nodes and kd-trees depend on that object alone;
//! what depends on the arrangement (support clips against every object, and the parent
//! relations whose weights respect them) is recomputed by [`Hierarchy::arrange`] after a
//! move, and the direct light is recomputed by every solve. So frame k's solution is the
//! solution of a scene file that holds frame k's values, bit for bit on the CPU backend.

use std::path::Path;
use std::time::Instant;

use glam::Vec3;
use serde::Serialize;

use crate::device::GpuReport;
use crate::engine::Engine;
use crate::error::{Error, Result};
use crate::hierarchy::{Arrangement, Hierarchy};
use crate::params::{Reach, SolverParams};
use crate::progress::Progress;
use crate::scene::Scene;
use crate::transport::Solution;

/// The light keys an edit may set (absolute values, as a `[[light]]` table holds them).
pub const LIGHT_KEYS: [&str; 7] = [
    "position",
    "target",
    "direction",
    "intensity",
    "irradiance",
    "cutoff_angle",
    "beam_width",
];

/// The object keys an edit may set.
pub const OBJECT_KEYS: [&str; 3] = ["translate", "rotate", "scale"];

/// New absolute values for one object's transform; what is `None` keeps its value.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjectEdit {
    pub translate: Option<Vec3>,
    pub rotate: Option<Vec3>,
    pub scale: Option<f32>,
}

/// One frame's or one `set`'s edits, by name, in the order given.
#[derive(Clone, Debug, Default)]
pub struct Edit {
    pub objects: Vec<(String, ObjectEdit)>,
    /// Light keys and their new values.
    pub lights: Vec<(String, toml::Table)>,
}

fn edit_err(at: &str, key: impl Into<String>, message: impl Into<String>) -> Error {
    Error::Edit {
        at: at.to_string(),
        key: key.into(),
        message: message.into(),
    }
}

fn number(v: &toml::Value) -> Option<f32> {
    match v {
        toml::Value::Float(f) => Some(*f as f32),
        toml::Value::Integer(i) => Some(*i as f32),
        _ => None,
    }
}

fn vec3(v: &toml::Value) -> Option<Vec3> {
    let a = v.as_array()?;
    if a.len() != 3 {
        return None;
    }
    Some(Vec3::new(number(&a[0])?, number(&a[1])?, number(&a[2])?))
}

impl Edit {
    /// Parses `{objects = {NAME = {translate, rotate, scale}}, lights = {NAME = {…}}}`;
    /// `at` names the frame or line in errors. Names are checked when the edit is applied.
    pub fn from_table(t: &toml::Table, at: &str) -> Result<Edit> {
        let mut e = Edit::default();
        for (k, v) in t {
            let table = |what: &str| {
                v.as_table()
                    .ok_or_else(|| edit_err(at, k, format!("expected a table of {what} by name")))
            };
            match k.as_str() {
                "objects" => {
                    for (name, o) in table("objects")? {
                        let key = format!("objects.{name}");
                        let o = o
                            .as_table()
                            .ok_or_else(|| edit_err(at, &key, "expected a table of translate, rotate, scale"))?;
                        let mut oe = ObjectEdit::default();
                        for (f, v) in o {
                            let fk = format!("{key}.{f}");
                            match f.as_str() {
                                "translate" => {
                                    oe.translate = Some(vec3(v).ok_or_else(|| edit_err(at, &fk, "expected [x, y, z]"))?)
                                }
                                "rotate" => {
                                    oe.rotate =
                                        Some(vec3(v).ok_or_else(|| edit_err(at, &fk, "expected degrees [x, y, z]"))?)
                                }
                                "scale" => {
                                    oe.scale = Some(number(v).ok_or_else(|| edit_err(at, &fk, "expected a number"))?)
                                }
                                _ => {
                                    return Err(edit_err(
                                        at,
                                        &fk,
                                        format!("unknown key (an object takes {})", OBJECT_KEYS.join(", ")),
                                    ))
                                }
                            }
                        }
                        e.objects.push((name.clone(), oe));
                    }
                }
                "lights" => {
                    for (name, l) in table("lights")? {
                        let key = format!("lights.{name}");
                        let l = l.as_table().ok_or_else(|| {
                            edit_err(at, &key, format!("expected a table of {}", LIGHT_KEYS.join(", ")))
                        })?;
                        if let Some(f) = l.keys().find(|f| !LIGHT_KEYS.contains(&f.as_str())) {
                            return Err(edit_err(
                                at,
                                format!("{key}.{f}"),
                                format!("unknown key (a light takes {})", LIGHT_KEYS.join(", ")),
                            ));
                        }
                        e.lights.push((name.clone(), l.clone()));
                    }
                }
                _ => return Err(edit_err(at, k, "unknown key (an edit takes objects and lights)")),
            }
        }
        Ok(e)
    }

    /// Whether the edit sets nothing.
    pub fn is_empty(&self) -> bool {
        self.objects.is_empty() && self.lights.is_empty()
    }
}

/// The frames of a frames file: `[[frame]]` tables, each an [`Edit`]; errors name the
/// file and the frame.
pub fn parse_frames(text: &str, path: &Path) -> Result<Vec<Edit>> {
    let t: toml::Table = toml::from_str(crate::limits::strip_bom(text)).map_err(|e| Error::SceneSyntax {
        path: path.into(),
        message: e.to_string().trim_end().to_string(),
    })?;
    if let Some(k) = t.keys().find(|k| *k != "frame") {
        return Err(edit_err(
            &path.display().to_string(),
            k,
            "unknown key (a frames file holds [[frame]] tables)",
        ));
    }
    let frames = match t.get("frame") {
        None => {
            return Err(edit_err(
                &path.display().to_string(),
                "frame",
                "no [[frame]]: nothing to solve",
            ))
        }
        Some(toml::Value::Array(a)) => a,
        Some(_) => {
            return Err(edit_err(
                &path.display().to_string(),
                "frame",
                "expected [[frame]] tables",
            ))
        }
    };
    frames
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let at = format!("{}: frame {k}", path.display());
            let f = f.as_table().ok_or_else(|| edit_err(&at, "frame", "expected a table"))?;
            Edit::from_table(f, &at)
        })
        .collect()
}

/// What edits changed since the last solve.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct Changed {
    /// Objects whose transform changed, by name.
    pub objects: Vec<String>,
    /// Lights that changed, by name.
    pub lights: Vec<String>,
    /// The hierarchy was built again: an object's scale changed (the levels' radii follow
    /// the scene's area), or a light moved into or out of an enclosure (which sides get
    /// nodes changed). A rigid move needs only [`Hierarchy::rearrange`].
    pub rebuild: bool,
    /// Support clips the update computed again (of all the nodes' after a rebuild), set by
    /// the solve.
    pub clips_computed: usize,
    /// Parent lists the update computed again.
    pub parents_computed: usize,
}

impl Changed {
    pub fn merge(&mut self, o: Changed) {
        for n in o.objects {
            if !self.objects.contains(&n) {
                self.objects.push(n);
            }
        }
        for n in o.lights {
            if !self.lights.contains(&n) {
                self.lights.push(n);
            }
        }
        self.rebuild |= o.rebuild;
    }
}

/// Applies `e` to `scene`, all or nothing: every name and value is checked first (as a
/// scene file holding the new values would be), and an error changes nothing. Setting a
/// spot light's `target` drops its `direction` and the other way round.
pub fn apply(scene: &mut Scene, e: &Edit, at: &str) -> Result<Changed> {
    let transforms = checked_transforms(scene, e, at)?;
    let tables = checked_light_tables(scene, e, at)?;
    set_all(scene, transforms, tables, at)
}

/// The new transform of every object `e` names, checked, in the order given (an object
/// named twice: the later values over the earlier).
fn checked_transforms(scene: &Scene, e: &Edit, at: &str) -> Result<Vec<(usize, crate::geom::Transform)>> {
    let mut transforms: Vec<(usize, crate::geom::Transform)> = Vec::new();
    for (name, oe) in &e.objects {
        let i = scene.object_index(name).ok_or_else(|| {
            let names: Vec<&str> = scene.objects.iter().map(|o| o.name.as_str()).collect();
            edit_err(
                at,
                format!("objects.{name}"),
                format!("no such object (the scene's: {})", names.join(", ")),
            )
        })?;
        let mut t = transforms
            .iter()
            .rev()
            .find(|(j, _)| *j == i)
            .map(|(_, t)| *t)
            .unwrap_or(scene.objects[i].transform);
        if let Some(v) = oe.translate {
            t.translate = v;
        }
        if let Some(v) = oe.rotate {
            t.rotate_deg = v;
        }
        if let Some(v) = oe.scale {
            t.scale = v;
        }
        crate::scene::check_transform(&t).map_err(|(f, m)| edit_err(at, format!("objects.{name}.{f}"), m))?;
        transforms.push((i, t));
    }
    Ok(transforms)
}

/// The new `[[light]]` table of every light `e` names, checked as a scene file's.
fn checked_light_tables(scene: &Scene, e: &Edit, at: &str) -> Result<Vec<(usize, toml::Table)>> {
    let mut tables: Vec<(usize, toml::Table)> = Vec::new();
    for (name, keys) in &e.lights {
        let i = scene.light_index(name).ok_or_else(|| {
            edit_err(
                at,
                format!("lights.{name}"),
                format!("no such light (the scene's: {})", scene.light_names.join(", ")),
            )
        })?;
        let mut t = tables
            .iter()
            .rev()
            .find(|(j, _)| *j == i)
            .map(|(_, t)| t.clone())
            .unwrap_or_else(|| scene.light_tables[i].clone());
        let spot = t.get("type").and_then(|v| v.as_str()) == Some("spot");
        for (k, v) in keys {
            if spot && k == "target" {
                t.remove("direction");
            }
            if spot && k == "direction" {
                t.remove("target");
            }
            t.insert(k.clone(), v.clone());
        }
        crate::scene::light::from_table(&t, i, &scene.path).map_err(|err| {
            let message = match err {
                Error::SceneValue { key, message, .. } => format!("{key}: {message}"),
                other => other.to_string(),
            };
            edit_err(at, format!("lights.{name}"), message)
        })?;
        tables.push((i, t));
    }
    Ok(tables)
}

/// Sets the checked transforms and light tables, all or nothing.
fn set_all(
    scene: &mut Scene,
    transforms: Vec<(usize, crate::geom::Transform)>,
    tables: Vec<(usize, toml::Table)>,
    at: &str,
) -> Result<Changed> {
    let mut changed = Changed::default();
    // Checked; now applied (the bounds and the lights' power are checked as they go in,
    // and undone on failure).
    let before = (
        scene.objects.clone(),
        scene.bounds,
        scene.scale,
        scene.lights.clone(),
        scene.light_tables.clone(),
    );
    let undo = |scene: &mut Scene| {
        scene.objects = before.0.clone();
        scene.bounds = before.1;
        scene.scale = before.2;
        scene.lights = before.3.clone();
        scene.light_tables = before.4.clone();
    };
    for (i, t) in transforms {
        let old = scene.objects[i].transform;
        if old == t {
            continue;
        }
        if let Err((f, m)) = scene.set_transform(i, t) {
            undo(scene);
            return Err(edit_err(at, format!("objects.{}.{f}", scene.objects[i].name), m));
        }
        changed.rebuild |= old.scale != t.scale;
        let name = scene.objects[i].name.clone();
        if !changed.objects.contains(&name) {
            changed.objects.push(name);
        }
    }
    for (i, t) in tables {
        if scene.light_tables[i] == t {
            continue;
        }
        if let Err(err) = scene.set_light(i, t) {
            undo(scene);
            let name = scene.light_names[i].clone();
            return Err(edit_err(at, format!("lights.{name}"), err.to_string()));
        }
        let name = scene.light_names[i].clone();
        if !changed.lights.contains(&name) {
            changed.lights.push(name);
        }
    }
    Ok(changed)
}

/// The parameters an editing command solves with: `reach` unset becomes `"object"`;
/// `"lights"` is refused (that hierarchy depends on the arrangement).
pub fn editing_params(p: &SolverParams, command: &str) -> Result<SolverParams> {
    match p.reach {
        Some(Reach::Lights) => Err(Error::param(
            "reach",
            format!(
                "`lights` makes every hierarchy depend on where the objects and lights are; {command} re-solves \
                 over hierarchies built once and needs reach = \"object\" (or reach unset)"
            ),
        )),
        _ => Ok(SolverParams {
            reach: Some(Reach::Object),
            ..p.clone()
        }),
    }
}

/// Times of one frame, seconds.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FrameSeconds {
    /// Bringing the hierarchy to the arrangement (support clips and parent relations), or
    /// the whole build after a scale change.
    pub update: f64,
    /// Direct light at the nodes.
    pub direct: f64,
    /// The bounce loop (with the un-shot initialisation).
    pub bounces: f64,
    /// Update and solve, with the transport's setup (the GPU's uploads).
    pub solve: f64,
}

/// One solved frame.
pub struct Frame {
    pub solution: Solution,
    pub gpu: Option<GpuReport>,
    /// What changed since the previous solve.
    pub changed: Changed,
    pub seconds: FrameSeconds,
}

/// A scene, its hierarchy built once, and the edits applied since the last solve.
pub struct Editor {
    pub scene: Scene,
    pub params: SolverParams,
    pub hierarchy: Hierarchy,
    /// Where the solves run, and what stays there between them (the device's state, the
    /// CPU's last links).
    engine: Engine,
    pending: Changed,
    /// Where the objects were when the hierarchy was last arranged.
    arranged: Arrangement,
    /// The hierarchy's build, seconds.
    pub seconds_build: f64,
}

impl Editor {
    /// Builds the hierarchy of `scene` (the parameters must have `reach = "object"`: see
    /// [`editing_params`]) for solves where `engine` runs.
    pub fn new(scene: Scene, params: SolverParams, mut engine: Engine, progress: &Progress) -> Result<Editor> {
        params.validate()?;
        if params.reach() != Reach::Object {
            return Err(Error::param("reach", "editing needs reach = \"object\""));
        }
        let t = Instant::now();
        let hierarchy = engine.build(&scene, &params, progress)?;
        Ok(Editor {
            arranged: Arrangement::of(&scene),
            scene,
            params,
            hierarchy,
            engine,
            pending: Changed::default(),
            seconds_build: t.elapsed().as_secs_f64(),
        })
    }

    /// Applies `e` (all or nothing; `at` names it in errors); the next [`Editor::solve`]
    /// brings the hierarchy to the new arrangement.
    pub fn apply(&mut self, e: &Edit, at: &str) -> Result<Changed> {
        let c = apply(&mut self.scene, e, at)?;
        self.pending.merge(c.clone());
        Ok(c)
    }

    /// The engine of the solves, beside the scene, hierarchy and parameters they used (an
    /// image of the last solve is drawn where it ran: `output::image::render_on`).
    pub fn engine_and_scene(&mut self) -> (&mut Engine, &Scene, &Hierarchy, &SolverParams) {
        (&mut self.engine, &self.scene, &self.hierarchy, &self.params)
    }

    /// Whether edits wait for a solve.
    pub fn is_stale(&self) -> bool {
        self.pending != Changed::default()
    }

    /// Solves the scene as it now is: the hierarchy arranged (or rebuilt after a scale
    /// change) if objects moved, then the direct light and the bounce loop.
    /// A solve that fails leaves the edits pending (`is_stale`), so that nothing reads
    /// the last solution as if it were this scene's, and the next solve tries again.
    pub fn solve(&mut self, progress: &Progress) -> Result<Frame> {
        let mut changed = std::mem::take(&mut self.pending);
        match self.solve_changed(&mut changed, progress) {
            Ok(f) => Ok(f),
            Err(e) => {
                let since = std::mem::take(&mut self.pending);
                changed.merge(since);
                changed.clips_computed = 0;
                changed.parents_computed = 0;
                self.pending = changed;
                Err(e)
            }
        }
    }

    fn solve_changed(&mut self, changed: &mut Changed, progress: &Progress) -> Result<Frame> {
        let all = Instant::now();
        let t = Instant::now();
        self.update(changed, progress)?;
        let update = t.elapsed().as_secs_f64();
        // Nothing moved: every gathering ray hits what it hit and reads the node it read in
        // the last solve, so that solve's links serve this one (relighting). On a device,
        // only the lights go up after such an edit; after a move the transforms and the
        // clip selection went up and the changed clips and relations came back
        // (`GpuResident::arrange`).
        let keep_links = changed.objects.is_empty() && !changed.rebuild;
        let (solution, gpu) =
            self.engine
                .solve(&self.scene, &mut self.hierarchy, &self.params, keep_links, progress)?;
        // Node values that overflowed f32 (a light made far too strong) fail the solve
        // here, so that the edit stays pending and nothing reads them (issue #35).
        crate::run::check_finite(
            &self.scene,
            "node values",
            solution
                .values
                .direct
                .iter()
                .chain(&solution.values.indirect)
                .map(|v| v.truncate()),
        )?;
        let seconds = FrameSeconds {
            update,
            direct: solution.stats.seconds_direct,
            bounces: solution.stats.seconds_init + solution.stats.seconds_bounces,
            solve: all.elapsed().as_secs_f64(),
        };
        Ok(Frame {
            solution,
            gpu,
            changed: std::mem::take(changed),
            seconds,
        })
    }

    /// Brings the hierarchy to the scene's arrangement: built again after a scale change
    /// or a light that crossed into or out of an enclosure, arranged anew where objects
    /// moved. Records in `changed` how many clips and parent lists were computed.
    fn update(&mut self, changed: &mut Changed, progress: &Progress) -> Result<()> {
        // A point or spot light moved into or out of an enclosure changes which sides
        // get nodes (`reach::ObjectReach`): then, too, the hierarchy is built again.
        if !changed.rebuild && (!changed.objects.is_empty() || !changed.lights.is_empty()) {
            if let Some(r) = &self.hierarchy.object_reach {
                changed.rebuild = r.sides_for(&self.scene) != self.hierarchy.sides;
            }
        }
        if changed.rebuild {
            self.engine.forget();
            self.hierarchy = self.engine.build(&self.scene, &self.params, progress)?;
            changed.clips_computed = self.hierarchy.nodes.len();
            changed.parents_computed = self.hierarchy.nodes.len();
        } else if !changed.objects.is_empty() {
            let moved: Vec<usize> = (0..self.scene.objects.len())
                .filter(|&o| self.scene.objects[o].transform != self.arranged.objects[o].transform)
                .collect();
            let arranged = self.engine.arrange(
                &self.scene,
                &mut self.hierarchy,
                &self.params,
                &self.arranged,
                &moved,
                progress,
            );
            let (clips, parents) = arranged.inspect_err(|_| {
                // Half arranged: the next solve builds everything again.
                self.pending.rebuild = true;
            })?;
            changed.clips_computed = clips;
            changed.parents_computed = parents;
        }
        self.arranged = Arrangement::of(&self.scene);
        Ok(())
    }
}
