//! The Python module `meshrad` (cargo feature `python`; `pip install .` builds it with
//! maturin from `pyproject.toml`, and `python/meshrad/__init__.py` wraps it). It calls the
//! same library functions as the CLI, so a solve on the CPU backend gives the CLI's bytes:
//! `meshrad solve` for a scene never edited, `meshrad session` after [`PyScene::edit`].
//! Every solve, image, probe and reference runs with the GIL released; a scene is locked
//! (with the GIL released) while one call works on it.

use std::path::PathBuf;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;

use glam::Vec3;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyBytes, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

use crate::cli::{self, BackendChoice, ImageSummary, PhaseSeconds, RunStats};
use crate::device::GpuReport;
use crate::editor::{self, Changed, Edit, Editor};
use crate::engine::Engine;
use crate::hierarchy::Hierarchy;
use crate::limits::Limits;
use crate::output::{self, image, ply, probe};
use crate::params::SolverParams;
use crate::progress::{Hook, Progress};
use crate::reference::{self, ReferenceOptions};
use crate::scene::Scene;
use crate::transport::Solution;

/// Where a scene was loaded from (to load it again when a solve changes a key the loader
/// reads).
#[derive(Clone, Debug)]
enum Origin {
    File(PathBuf),
    Embedded(String),
}

/// An editor with the backend and parameters it was made for.
struct Slot {
    ed: Editor,
    key: EngineKey,
}

/// What an editor's solves depend on besides the scene.
#[derive(Clone, Debug, PartialEq)]
struct EngineKey {
    backend: BackendChoice,
    device: Option<String>,
    limits: u64,
    /// The parameters, as JSON (every key compared).
    params: String,
}

/// A scene as loaded and edited since.
struct State {
    origin: Origin,
    load_keys: Vec<(String, toml::Value)>,
    limits: Limits,
    /// The file's `[solver]` with the keys given to `load`.
    params: SolverParams,
    /// The parameters the scene was loaded with (a solve may change a key the loader reads).
    loaded: SolverParams,
    /// The scene; `None` while the editor holds it.
    scene: Option<Arc<Scene>>,
    /// Every edit since the load, in order (applied again when the scene is loaded again).
    edits: Vec<Edit>,
    editor: Option<Slot>,
    /// What the edits made while no editor was held changed (told by the solve that makes
    /// the editor).
    pending: Changed,
    /// Solves run as `meshrad session` does from the first (`editable=True`, or an edit).
    editable: bool,
    seconds_load: f64,
}

impl State {
    fn scene(&self) -> &Scene {
        match (&self.scene, &self.editor) {
            (Some(s), _) => s,
            (None, Some(slot)) => &slot.ed.scene,
            (None, None) => unreachable!("a scene is held by the state or its editor"),
        }
    }

    /// The scene, out of the editor if it holds it (the editor is dropped).
    fn take_scene(&mut self) -> Arc<Scene> {
        match (self.scene.take(), self.editor.take()) {
            (Some(s), _) => s,
            (None, Some(slot)) => Arc::new(slot.ed.scene),
            (None, None) => unreachable!("a scene is held by the state or its editor"),
        }
    }
}

fn load_origin(
    origin: &Origin,
    keys: &[(String, toml::Value)],
    limits: &Limits,
) -> crate::Result<(Scene, SolverParams)> {
    match origin {
        Origin::File(p) => Scene::load_with(p, keys, limits),
        Origin::Embedded(name) => Scene::embedded_file_with(name, keys, limits),
    }
}

/// A loaded scene: `meshrad.load(path)` or `meshrad.Scene.embedded()`.
#[pyclass(name = "Scene", module = "meshrad", frozen)]
pub struct PyScene {
    state: Mutex<State>,
}

/// A solve's results: the scene, hierarchy and values it was solved with, so that its
/// images and probes stay this solve's whatever the scene does next.
struct Solved {
    scene: Arc<Scene>,
    hierarchy: Hierarchy,
    solution: Solution,
    params: SolverParams,
    limits: Limits,
    gpu: Option<GpuReport>,
    seconds_load: f64,
    seconds_hierarchy: f64,
    seconds_solve: f64,
    /// What the edits changed (a solve of an edited scene).
    changed: Option<Changed>,
}

/// Rendered images and what they took.
struct Rendered {
    img: image::Images,
    dark: Vec<String>,
    seconds: f64,
}

/// The result of `meshrad.solve`.
#[pyclass(name = "Solution", module = "meshrad", frozen)]
pub struct PySolution {
    solved: Arc<Solved>,
    rendered: Mutex<Option<Arc<Rendered>>>,
}

/// Locks `m`; a lock poisoned by a panic is an error (what it guards may be half changed).
fn lock<T>(m: &Mutex<T>) -> anyhow::Result<MutexGuard<'_, T>> {
    m.lock()
        .map_err(|_| anyhow::anyhow!("an earlier call on this object panicked; load the scene again"))
}

/// The Python exception for `e`, of the class `meshrad._errors` names for its kind, with
/// the CLI's message and, where the error has them, `path`, `line` and `key`.
fn py_err(py: Python<'_>, e: anyhow::Error) -> PyErr {
    let message = format!("{e:#}");
    let (class, path, line, key): (&str, Option<String>, Option<usize>, Option<String>) = match e
        .downcast_ref::<crate::Error>()
    {
        Some(crate::Error::Io { path, .. }) => ("FileError", Some(path.display().to_string()), None, None),
        Some(crate::Error::SceneSyntax { path, .. }) | Some(crate::Error::Texture { path, .. }) => {
            ("Error", Some(path.display().to_string()), None, None)
        }
        Some(crate::Error::SceneValue { path, key, .. }) => {
            ("Error", Some(path.display().to_string()), None, Some(key.clone()))
        }
        Some(crate::Error::Mesh { path, line, .. }) => ("Error", Some(path.display().to_string()), *line, None),
        Some(crate::Error::Points { path, line, .. }) => ("Error", Some(path.display().to_string()), Some(*line), None),
        Some(crate::Error::Param { name, .. }) => ("Error", None, None, Some(name.clone())),
        Some(crate::Error::Resource { path, key, .. }) => (
            "ResourceError",
            Some(path.display().to_string()),
            None,
            Some(key.clone()),
        ),
        Some(crate::Error::Edit { key, .. }) => ("Error", None, None, Some(key.clone())),
        Some(crate::Error::Gpu(_)) => ("DeviceError", None, None, None),
        Some(crate::Error::Output { path, .. }) => ("FileError", Some(path.display().to_string()), None, None),
        None => ("Error", None, None, None),
    };
    let made = (|| -> PyResult<PyErr> {
        let cls = py.import("meshrad._errors")?.getattr(class)?;
        let err = cls.call1((message.clone(),))?;
        err.setattr("path", path)?;
        err.setattr("line", line)?;
        err.setattr("key", key)?;
        Ok(PyErr::from_value(err))
    })();
    made.unwrap_or_else(|_| PyRuntimeError::new_err(message))
}

/// Runs `f` with the GIL released and turns its error into the Python exception.
fn detached<T: Send>(py: Python<'_>, f: impl FnOnce() -> anyhow::Result<T> + Send) -> PyResult<T> {
    py.detach(f).map_err(|e| py_err(py, e))
}

/// A Python value as TOML (solver keys, edits); `at` names it in errors.
fn to_toml(v: &Bound<'_, PyAny>, at: &str) -> anyhow::Result<toml::Value> {
    if v.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(v.extract::<bool>()?));
    }
    if let Ok(s) = v.cast::<PyString>() {
        return Ok(toml::Value::String(s.to_str()?.to_string()));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, x) in d.iter() {
            let k: String = k.extract().map_err(|_| {
                anyhow::anyhow!(
                    "{at}: keys must be strings, found {}",
                    k.repr().map(|r| r.to_string()).unwrap_or_default()
                )
            })?;
            let value = to_toml(&x, &format!("{at}.{k}"))?;
            t.insert(k, value);
        }
        return Ok(toml::Value::Table(t));
    }
    if v.is_instance_of::<PyInt>() {
        return v
            .extract::<i64>()
            .map(toml::Value::Integer)
            .map_err(|_| anyhow::anyhow!("{at}: {v} does not fit 64 bits"));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(v.extract::<f64>()?));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let items = v
            .try_iter()?
            .enumerate()
            .map(|(i, x)| to_toml(&x?, &format!("{at}[{i}]")))
            .collect::<anyhow::Result<Vec<_>>>()?;
        return Ok(toml::Value::Array(items));
    }
    // numpy arrays and scalars: as the Python values they hold.
    if v.hasattr("tolist")? {
        let plain = v.call_method0("tolist")?;
        if !plain.is(v) && !plain.hasattr("tolist")? {
            return to_toml(&plain, at);
        }
    }
    if v.is_none() {
        anyhow::bail!("{at}: None is not a value");
    }
    anyhow::bail!(
        "{at}: a {} is not a value (give a number, a string, a bool, a list or a dict)",
        v.get_type().name().map(|n| n.to_string()).unwrap_or_default()
    )
}

/// Keyword arguments as `[solver]` overrides, in the order given.
fn keys_of(keys: Option<&Bound<'_, PyDict>>) -> anyhow::Result<Vec<(String, toml::Value)>> {
    let mut out = Vec::new();
    if let Some(d) = keys {
        for (k, v) in d.iter() {
            let k: String = k.extract()?;
            let value = to_toml(&v, &format!("parameter `{k}`"))?;
            out.push((k, value));
        }
    }
    Ok(out)
}

/// `max_memory=` as the CLI's `--max-memory` text (bytes as a number, or "8G").
fn max_memory_of(v: Option<&Bound<'_, PyAny>>) -> anyhow::Result<Option<String>> {
    match v {
        None => Ok(None),
        Some(v) if v.is_none() => Ok(None),
        Some(v) => {
            if let Ok(n) = v.extract::<u64>() {
                Ok(Some(n.to_string()))
            } else if let Ok(s) = v.extract::<String>() {
                Ok(Some(s))
            } else {
                anyhow::bail!("max_memory: expected a number of bytes or a size such as \"8G\"")
            }
        }
    }
}

/// The progress reporter for a Python `progress` callable (`None`: quiet), and where the
/// first exception it raised waits to be raised again once the work is done.
type HookError = Arc<Mutex<Option<PyErr>>>;

fn progress_of(callback: Option<Py<PyAny>>) -> (Progress, HookError) {
    let raised: HookError = Arc::new(Mutex::new(None));
    let Some(cb) = callback else {
        return (Progress::hidden(), raised);
    };
    let keep = raised.clone();
    let hook: Hook = Arc::new(move |stage: &str, done: u64, total: u64| {
        Python::attach(|py| {
            let mut first = keep.lock().unwrap_or_else(|e| e.into_inner());
            if first.is_some() {
                return;
            }
            if let Err(e) = cb.call1(py, (stage, done, total)) {
                *first = Some(e);
            }
        })
    });
    (Progress::with_hook(hook), raised)
}

/// Raises what the progress callback raised, if it did.
fn reraise(raised: &HookError) -> PyResult<()> {
    match raised.lock().unwrap_or_else(|e| e.into_inner()).take() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

impl PyScene {
    fn load(
        origin: Origin,
        editable: bool,
        max_memory: Option<String>,
        keys: Vec<(String, toml::Value)>,
    ) -> anyhow::Result<Self> {
        let limits = cli::limits_from(max_memory.as_deref(), "max_memory")?;
        let t = Instant::now();
        let (scene, params) = load_origin(&origin, &keys, &limits)?;
        if editable {
            editor::editing_params(&params, "an editable scene")?;
        }
        Ok(PyScene {
            state: Mutex::new(State {
                origin,
                load_keys: keys,
                limits,
                loaded: params.clone(),
                params,
                scene: Some(Arc::new(scene)),
                edits: Vec::new(),
                editor: None,
                pending: Changed::default(),
                editable,
                seconds_load: t.elapsed().as_secs_f64(),
            }),
        })
    }
}

#[pymethods]
impl PyScene {
    /// A scene shipped inside the module: `cornell_box.toml` (the default: the CLI's
    /// embedded Cornell box), `cornell_parts.toml` (its blocks as objects) or
    /// `cornell_area.toml` (lit by its ceiling quad).
    #[staticmethod]
    #[pyo3(signature = (name = "cornell_box.toml", editable = false, max_memory = None, **keys))]
    fn embedded(
        py: Python<'_>,
        name: &str,
        editable: bool,
        max_memory: Option<&Bound<'_, PyAny>>,
        keys: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let (mm, keys) = (|| Ok((max_memory_of(max_memory)?, keys_of(keys)?)))().map_err(|e| py_err(py, e))?;
        let name = name.to_string();
        detached(py, move || PyScene::load(Origin::Embedded(name), editable, mm, keys))
    }

    /// The scene file's path (or the embedded name).
    #[getter]
    fn path(&self, py: Python<'_>) -> PyResult<String> {
        self.with(py, |st| Ok(st.scene().path.display().to_string()))
    }

    /// The objects' names, as edits name them.
    #[getter]
    fn objects(&self, py: Python<'_>) -> PyResult<Vec<String>> {
        self.with(py, |st| Ok(st.scene().objects.iter().map(|o| o.name.clone()).collect()))
    }

    /// The lights' names, as edits name them.
    #[getter]
    fn lights(&self, py: Python<'_>) -> PyResult<Vec<String>> {
        self.with(py, |st| Ok(st.scene().light_names.clone()))
    }

    /// Triangles in the scene.
    #[getter]
    fn triangles(&self, py: Python<'_>) -> PyResult<usize> {
        self.with(py, |st| Ok(st.scene().triangle_count()))
    }

    /// Whether solves run as `meshrad session` does (reach = "object", the hierarchy built
    /// once and kept): loaded with `editable=True`, or `edit` was called.
    #[getter]
    fn editable(&self, py: Python<'_>) -> PyResult<bool> {
        self.with(py, |st| Ok(st.editable))
    }

    /// The scene's `[solver]` (with the keys given to `load`), as a dict.
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let text = self.with(py, |st| Ok(serde_json::to_string(&st.params)?))?;
        py.import("json")?.call_method1("loads", (text,))
    }

    /// Moves objects and changes lights, with the keys and checks of an `animate` frame:
    /// `objects={name: {"translate": [x, y, z], "rotate": [deg, deg, deg], "scale": s}}`,
    /// `lights={name: {"position", "target", "direction", "intensity", "irradiance",
    /// "cutoff_angle", "beam_width"}}`, absolute values. All or nothing. The next solve
    /// re-solves as `meshrad session` does, with the hierarchy kept. Returns what changed.
    #[pyo3(signature = (objects = None, lights = None))]
    fn edit<'py>(
        &self,
        py: Python<'py>,
        objects: Option<&Bound<'py, PyAny>>,
        lights: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let at = "Scene.edit";
        let table = (|| {
            let mut t = toml::Table::new();
            for (k, v) in [("objects", objects), ("lights", lights)] {
                if let Some(v) = v.filter(|v| !v.is_none()) {
                    t.insert(k.to_string(), to_toml(v, &format!("{at}: {k}"))?);
                }
            }
            anyhow::Ok(t)
        })()
        .map_err(|e| py_err(py, e))?;
        let changed = self.with(py, |st| {
            let e = Edit::from_table(&table, at)?;
            // reach = "lights" cannot be edited: say so now, not at the solve.
            editor::editing_params(&st.params, "an edited scene")?;
            let c = match &mut st.editor {
                Some(slot) => slot.ed.apply(&e, at)?,
                None => {
                    let s = st.scene.as_mut().expect("no editor: the state holds the scene");
                    let mut edited = (**s).clone();
                    let c = editor::apply(&mut edited, &e, at)?;
                    *s = Arc::new(edited);
                    st.pending.merge(c.clone());
                    c
                }
            };
            st.edits.push(e);
            st.editable = true;
            Ok(serde_json::to_string(&c)?)
        })?;
        py.import("json")?.call_method1("loads", (changed,))
    }

    /// `n` points drawn uniformly by area over every surface side that can receive light
    /// (as `meshrad bench accuracy` draws them), as an (n, 6) float32 array of position
    /// and unit normal.
    #[pyo3(signature = (n, seed = 7))]
    fn sample_points<'py>(&self, py: Python<'py>, n: usize, seed: u64) -> PyResult<Bound<'py, PyAny>> {
        let flat = self.with(py, |st| {
            if n == 0 || n > 100_000_000 {
                anyhow::bail!("sample_points: n = {n} is outside 1..=100000000");
            }
            let pts = crate::bench::area_probes(st.scene(), n, seed);
            Ok(pts
                .iter()
                .flat_map(|q| q.p.to_array().into_iter().chain(q.n.to_array()))
                .collect::<Vec<f32>>())
        })?;
        let rows = flat.len() / 6;
        Ok(PyArray1::from_vec(py, flat).reshape([rows, 6])?.into_any())
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        self.with(py, |st| {
            let s = st.scene();
            Ok(format!(
                "<meshrad.Scene {}: {} objects, {} triangles, {} lights{}>",
                s.path.display(),
                s.objects.len(),
                s.triangle_count(),
                s.lights.len(),
                if st.edits.is_empty() { "" } else { ", edited" }
            ))
        })
    }
}

impl PyScene {
    /// Runs `f` on the state with the GIL released.
    fn with<T: Send>(&self, py: Python<'_>, f: impl FnOnce(&mut State) -> anyhow::Result<T> + Send) -> PyResult<T> {
        detached(py, || f(&mut *lock(&self.state)?))
    }
}

/// Loads a scene file (TOML); `**keys` override its `[solver]` keys as `--set` does.
/// `editable=True`: every solve runs as `meshrad session` does, from the first.
#[pyfunction]
#[pyo3(signature = (path, editable = false, max_memory = None, **keys))]
fn load(
    py: Python<'_>,
    path: PathBuf,
    editable: bool,
    max_memory: Option<&Bound<'_, PyAny>>,
    keys: Option<&Bound<'_, PyDict>>,
) -> PyResult<PyScene> {
    let (mm, keys) = (|| Ok((max_memory_of(max_memory)?, keys_of(keys)?)))().map_err(|e| py_err(py, e))?;
    detached(py, move || PyScene::load(Origin::File(path), editable, mm, keys))
}

/// The backend by name.
fn backend_of(s: &str) -> anyhow::Result<BackendChoice> {
    match s {
        "auto" => Ok(BackendChoice::Auto),
        "cpu" => Ok(BackendChoice::Cpu),
        "gpu" => Ok(BackendChoice::Gpu),
        other => anyhow::bail!("backend `{other}`: expected \"auto\", \"cpu\" or \"gpu\""),
    }
}

/// Solves `scene` (the module's `solve`; `python/meshrad/__init__.py` wraps it).
#[pyfunction]
#[pyo3(signature = (scene, backend = "auto", device = None, max_memory = None, progress = None, keys = None))]
fn solve(
    py: Python<'_>,
    scene: &PyScene,
    backend: &str,
    device: Option<String>,
    max_memory: Option<&Bound<'_, PyAny>>,
    progress: Option<Py<PyAny>>,
    keys: Option<&Bound<'_, PyDict>>,
) -> PyResult<PySolution> {
    let (choice, mm, overrides) =
        (|| Ok((backend_of(backend)?, max_memory_of(max_memory)?, keys_of(keys)?)))().map_err(|e| py_err(py, e))?;
    let (progress, raised) = progress_of(progress);
    let solved = scene.with(py, |st| solve_state(st, choice, device, mm, &overrides, &progress));
    reraise(&raised)?;
    Ok(PySolution {
        solved: Arc::new(solved?),
        rendered: Mutex::new(None),
    })
}

/// A solve of the scene as it now is: `meshrad solve` if it was never edited, else the
/// editor's re-solve (made, or made again, when the backend or the parameters changed).
fn solve_state(
    st: &mut State,
    choice: BackendChoice,
    device: Option<String>,
    max_memory: Option<String>,
    overrides: &[(String, toml::Value)],
    progress: &Progress,
) -> anyhow::Result<Solved> {
    let params = if overrides.is_empty() {
        st.params.clone()
    } else {
        crate::scene::apply_overrides(&st.params, overrides)?
    };
    let limits = match &max_memory {
        Some(m) => cli::limits_from(Some(m), "max_memory")?,
        None => st.limits,
    };
    if !params.loads_as(&st.loaded) {
        // A key the loader reads changed: the scene is loaded again with it, and the
        // edits applied again.
        let t = Instant::now();
        let mut keys = st.load_keys.clone();
        keys.extend(overrides.iter().cloned());
        let (mut scene, loaded) = load_origin(&st.origin, &keys, &st.limits)?;
        for (k, e) in st.edits.iter().enumerate() {
            editor::apply(&mut scene, e, &format!("Scene.edit {k}"))?;
        }
        st.take_scene();
        st.scene = Some(Arc::new(scene));
        st.loaded = loaded;
        st.seconds_load = t.elapsed().as_secs_f64();
    }
    {
        let s = st.scene();
        crate::scene::memory::plan_memory(
            &limits,
            &s.path,
            s.triangle_count(),
            &params,
            &s.camera,
            s.objects.len(),
        )?;
    }
    let engine = || -> anyhow::Result<Engine> {
        Ok(Engine::on(cli::gpu_context(choice, device.as_deref(), true)?).within(limits))
    };
    let solved = if !st.editable {
        let scene = st.take_scene();
        st.scene = Some(scene.clone());
        let t = Instant::now();
        let run = crate::solve(&scene, &params, &mut engine()?, progress)?;
        Solved {
            scene,
            hierarchy: run.hierarchy,
            solution: run.solution,
            params,
            limits,
            gpu: run.gpu,
            seconds_load: st.seconds_load,
            seconds_hierarchy: run.seconds_hierarchy,
            seconds_solve: t.elapsed().as_secs_f64() - run.seconds_hierarchy,
            changed: None,
        }
    } else {
        let eparams = editor::editing_params(&params, "an edited scene")?;
        let key = EngineKey {
            backend: choice,
            device: device.clone(),
            limits: limits.max_memory,
            params: serde_json::to_string(&eparams)?,
        };
        // The editor is made (again) for a new backend or new parameters: its build is
        // told as a rebuild, with the edits made since the last solve.
        let mut made = None;
        if st.editor.as_ref().is_none_or(|slot| slot.key != key) {
            let scene = st.take_scene();
            st.scene = Some(scene.clone());
            let ed = Editor::new((*scene).clone(), eparams.clone(), engine()?, progress)?;
            st.scene = None;
            let mut c = std::mem::take(&mut st.pending);
            (c.rebuild, c.clips_computed, c.parents_computed) =
                (true, ed.hierarchy.nodes.len(), ed.hierarchy.nodes.len());
            made = Some((c, ed.seconds_build));
            st.editor = Some(Slot { ed, key });
        }
        let slot = st.editor.as_mut().expect("made above");
        let mut f = slot.ed.solve(progress)?;
        if let Some((c, build)) = made {
            f.changed = c;
            f.seconds.update += build;
            f.seconds.solve += build;
        }
        Solved {
            scene: Arc::new(slot.ed.scene.clone()),
            hierarchy: slot.ed.hierarchy.clone(),
            solution: f.solution,
            params: eparams,
            limits,
            gpu: f.gpu,
            seconds_load: st.seconds_load,
            seconds_hierarchy: f.seconds.update,
            seconds_solve: f.seconds.solve - f.seconds.update,
            changed: Some(f.changed),
        }
    };
    let v = &solved.solution.values;
    cli::check_finite(
        &solved.scene,
        "node values",
        v.direct.iter().chain(&v.indirect).map(|x| x.truncate()),
    )?;
    Ok(solved)
}

/// An (N, 6) array-like of px, py, pz, nx, ny, nz (a list of rows, a numpy array; one
/// row of six alone is one point) as rows of f32.
fn rows_of(points: &Bound<'_, PyAny>) -> anyhow::Result<Vec<[f32; 6]>> {
    let np = points.py().import("numpy")?;
    let a = np.call_method1("asarray", (points, np.getattr("float64")?))?;
    let a = if a.getattr("shape")?.extract::<Vec<usize>>()? == [6] {
        a.call_method1("reshape", (1, 6))?
    } else {
        a
    };
    let a = np.call_method1("ascontiguousarray", (a,))?;
    let a: PyReadonlyArray2<'_, f64> = a.extract().map_err(|_| {
        let shape = a.getattr("shape").map(|s| s.to_string()).unwrap_or_default();
        anyhow::anyhow!("points: expected an (N, 6) array of px, py, pz, nx, ny, nz; found shape {shape}")
    })?;
    if a.shape()[1] != 6 || a.shape()[0] == 0 {
        anyhow::bail!(
            "points: expected an (N, 6) array of px, py, pz, nx, ny, nz with N ≥ 1; found shape {:?}",
            a.shape()
        );
    }
    Ok(a.as_array()
        .outer_iter()
        .map(|r| std::array::from_fn(|k| r[k] as f32))
        .collect())
}

/// Rows as probes (the check and unit normal of a points file's line); errors name the row.
fn probes_of(rows: &[[f32; 6]]) -> anyhow::Result<Vec<probe::Probe>> {
    rows.iter()
        .enumerate()
        .map(|(i, r)| probe::point(*r).map_err(|m| anyhow::anyhow!("points[{i}]: {m}")))
        .collect()
}

/// A float32 array of `rows` × 3 (or `shape` × 3) from vectors.
fn vec3_array<'py>(py: Python<'py>, v: &[Vec3], shape: &[usize]) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<f32> = v.iter().flat_map(|x| x.to_array()).collect();
    let mut dims = shape.to_vec();
    dims.push(3);
    Ok(PyArray1::from_vec(py, flat).reshape(dims)?.into_any())
}

impl PySolution {
    /// The images, rendered once (with the GIL released).
    fn rendered(&self, py: Python<'_>, progress: Option<Py<PyAny>>) -> PyResult<Arc<Rendered>> {
        let (progress, raised) = progress_of(progress);
        let r = detached(py, || {
            let mut cache = lock(&self.rendered)?;
            if let Some(r) = cache.as_ref() {
                return Ok(r.clone());
            }
            let s = &*self.solved;
            let t = Instant::now();
            let img = image::render(&s.scene, &s.hierarchy, &s.solution, &s.params, &progress);
            cli::check_finite(&s.scene, "image", img.direct.iter().chain(&img.indirect).copied())?;
            let dark = output::dark::warnings(&s.scene, &s.hierarchy, &s.solution, Some(&img));
            let r = Arc::new(Rendered {
                img,
                dark,
                seconds: t.elapsed().as_secs_f64(),
            });
            *cache = Some(r.clone());
            Ok(r)
        });
        reraise(&raised)?;
        r
    }

    /// stats.json's text for the images `r` at `exposure` (`output::json_bytes`, as the
    /// CLI writes it: f32 values in their shortest form).
    fn stats_json(&self, r: &Rendered, exposure: image::AppliedExposure) -> anyhow::Result<Vec<u8>> {
        let s = &*self.solved;
        let seconds = PhaseSeconds {
            load: s.seconds_load,
            hierarchy: s.seconds_hierarchy,
            solve: s.seconds_solve,
            output: r.seconds,
            total: s.seconds_load + s.seconds_hierarchy + s.seconds_solve + r.seconds,
        };
        let stats = Stats {
            run: RunStats::new(
                &s.scene,
                &s.params,
                (&s.hierarchy.stats, &s.solution, s.gpu.as_ref()),
                ImageSummary {
                    warnings: r.dark.clone(),
                    ..ImageSummary::of(&r.img, &s.scene, &s.params, exposure)
                },
                seconds,
            ),
            changed: s.changed.as_ref(),
        };
        Ok(output::json_bytes(std::path::Path::new("stats.json"), &stats)?)
    }
}

/// A solution's stats.json: the CLI's, with what the edits changed after an edit.
#[derive(serde::Serialize)]
struct Stats<'a> {
    #[serde(flatten)]
    run: RunStats<'a>,
    #[serde(skip_serializing_if = "Option::is_none")]
    changed: Option<&'a Changed>,
}

#[pymethods]
impl PySolution {
    /// `{"direct", "indirect", "total"}`: float32 arrays of shape (H, W, 3), linear
    /// radiance, the values `meshrad solve` writes to its EXRs. Rendered on the first call.
    #[pyo3(signature = (progress = None))]
    fn images<'py>(&self, py: Python<'py>, progress: Option<Py<PyAny>>) -> PyResult<Bound<'py, PyDict>> {
        let r = self.rendered(py, progress)?;
        let (w, h) = (r.img.width as usize, r.img.height as usize);
        let d = PyDict::new(py);
        d.set_item("direct", vec3_array(py, &r.img.direct, &[h, w])?)?;
        d.set_item("indirect", vec3_array(py, &r.img.indirect, &[h, w])?)?;
        d.set_item("total", vec3_array(py, &r.img.total(), &[h, w])?)?;
        Ok(d)
    }

    /// Irradiance at `points`, an (N, 6) float array of position and normal (made unit):
    /// `{"direct", "indirect", "total", "indirect_se", "direct_se"}` as (N, 3) float32
    /// arrays, the values of `meshrad probe`'s CSV.
    fn probe<'py>(&self, py: Python<'py>, points: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyDict>> {
        let rows = rows_of(points).map_err(|e| py_err(py, e))?;
        let values = detached(py, || {
            let probes = probes_of(&rows)?;
            let s = &*self.solved;
            s.limits.check(
                std::path::Path::new("points"),
                "points",
                &[crate::limits::Part {
                    what: format!("{} probe points and their values", probes.len()),
                    bytes: (probes.len() as u64 * probe::BYTES_PER_PROBE) as f64,
                }],
            )?;
            let values = probe::evaluate(&s.scene, &s.hierarchy, &s.solution, &probes, &s.params);
            cli::check_finite(
                &s.scene,
                "probe values",
                values.iter().flat_map(probe::ProbeValue::vectors),
            )?;
            Ok(values)
        })?;
        let n = [values.len()];
        let col = |f: fn(&probe::ProbeValue) -> Vec3| values.iter().map(f).collect::<Vec<_>>();
        let d = PyDict::new(py);
        d.set_item("direct", vec3_array(py, &col(|v| v.direct), &n)?)?;
        d.set_item("indirect", vec3_array(py, &col(|v| v.indirect.mean), &n)?)?;
        d.set_item("total", vec3_array(py, &col(|v| v.direct + v.indirect.mean), &n)?)?;
        d.set_item("indirect_se", vec3_array(py, &col(|v| v.indirect.std_err), &n)?)?;
        d.set_item("direct_se", vec3_array(py, &col(|v| v.direct_se), &n)?)?;
        Ok(d)
    }

    /// The node cloud, the columns of `--export-nodes`' PLY: `position`, `normal` (M, 3),
    /// `level` (M,) int32, `radius` (M,), `E_d`, `E_ind` (M, 3), float32.
    fn nodes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let c = detached(py, || {
            let s = &*self.solved;
            Ok(ply::columns(&s.scene, &s.hierarchy, &s.solution))
        })?;
        let n = [c.level.len()];
        let d = PyDict::new(py);
        d.set_item("position", vec3_array(py, &c.position, &n)?)?;
        d.set_item("normal", vec3_array(py, &c.normal, &n)?)?;
        d.set_item("level", PyArray1::from_vec(py, c.level))?;
        d.set_item("radius", PyArray1::from_vec(py, c.radius))?;
        d.set_item("E_d", vec3_array(py, &c.e_d, &n)?)?;
        d.set_item("E_ind", vec3_array(py, &c.e_ind, &n)?)?;
        Ok(d)
    }

    /// What `meshrad solve` writes to stats.json (the images are rendered first if
    /// `images()` has not been called), with `changed` after an edit.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let r = self.rendered(py, None)?;
        let text = detached(py, || {
            self.stats_json(&r, image::Exposure::default().resolve(&r.img.total()))
        })?;
        py.import("json")?.call_method1("loads", (PyBytes::new(py, &text),))
    }

    /// Warnings that change what the results mean: lights skipped, bounces that did not
    /// converge, nothing lit (as `meshrad solve` prints them).
    #[getter]
    fn warnings(&self, py: Python<'_>) -> PyResult<Vec<String>> {
        detached(py, || {
            let s = &*self.solved;
            let mut w = cli::solve_warnings(&s.solution);
            w.extend(output::dark::warnings(&s.scene, &s.hierarchy, &s.solution, None));
            Ok(w)
        })
    }

    /// Writes what `meshrad solve --out DIR` writes (`{direct,indirect,total}.{exr,png}`
    /// and stats.json; with `export_nodes`, the PLY), all or none; `exposure` is the PNGs'
    /// stops or "auto". Returns the paths written.
    #[pyo3(signature = (out, exposure = None, export_nodes = None))]
    fn write(
        &self,
        py: Python<'_>,
        out: PathBuf,
        exposure: Option<&Bound<'_, PyAny>>,
        export_nodes: Option<PathBuf>,
    ) -> PyResult<Vec<String>> {
        let exposure = match exposure.filter(|e| !e.is_none()) {
            None => image::Exposure::default(),
            Some(e) => {
                let text = match e.extract::<f64>() {
                    Ok(x) => x.to_string(),
                    Err(_) => e.extract::<String>()?,
                };
                text.parse::<image::Exposure>()
                    .map_err(|m| py_err(py, anyhow::anyhow!("exposure: {m}")))?
            }
        };
        let r = self.rendered(py, None)?;
        detached(py, || {
            let s = &*self.solved;
            output::ensure_dir(&out)?;
            let mut planned: Vec<(&str, PathBuf)> =
                image::file_names(&out).into_iter().map(|p| ("an image", p)).collect();
            planned.push(("stats.json", out.join("stats.json")));
            if let Some(p) = &export_nodes {
                planned.push(("export_nodes", p.clone()));
            }
            output::check_outputs(&planned, &s.scene.report.inputs)?;
            let mut files = output::Outputs::default();
            let applied = image::encode_all(&out, &r.img, exposure, &mut files)?;
            if let Some(p) = &export_nodes {
                files.add(p, ply::encode(p, &s.scene, &s.hierarchy, &s.solution)?);
            }
            let p = out.join("stats.json");
            files.add(&p, self.stats_json(&r, applied)?);
            let paths = files.paths().map(|p| p.display().to_string()).collect();
            files.commit()?;
            Ok(paths)
        })
    }

    /// The backend that solved: "cpu" or the device's name.
    #[getter]
    fn backend(&self) -> String {
        self.solved.solution.stats.backend.clone()
    }

    fn __repr__(&self) -> String {
        let s = &*self.solved;
        format!(
            "<meshrad.Solution {}: {} nodes, {} integrals, {} ({})>",
            s.scene.path.display(),
            s.hierarchy.nodes.len(),
            s.solution.stats.integrals,
            s.solution.stats.backend,
            s.solution.variant.name()
        )
    }
}

/// The independent brute-force reference (`meshrad reference --points`): direct light
/// exact, indirect path-traced with `samples` paths a point (the whole series, or
/// `max_bounces` terms). Returns `{"direct", "indirect", "total", "indirect_se"}` as (N, 3)
/// float64 arrays.
#[pyfunction]
#[pyo3(name = "reference", signature = (scene, points, samples = 16384, max_bounces = 0, seed = 0x5eed, progress = None))]
fn reference_at<'py>(
    py: Python<'py>,
    scene: &PyScene,
    points: &Bound<'py, PyAny>,
    samples: u32,
    max_bounces: u32,
    seed: u64,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let rows = rows_of(points).map_err(|e| py_err(py, e))?;
    let (progress, raised) = progress_of(progress);
    let out = scene.with(py, |st| {
        if !(2..=cli::MAX_REFERENCE_SAMPLES).contains(&samples) {
            anyhow::bail!(
                "samples = {samples}: must be within 2..={} (a standard error needs two samples)",
                cli::MAX_REFERENCE_SAMPLES
            );
        }
        cli::check_reference_work(rows.len() as u64, samples, "points")?;
        let probes = probes_of(&rows)?;
        let opts = ReferenceOptions {
            samples,
            max_bounces,
            seed,
            ..Default::default()
        };
        let scene = st.scene();
        progress.stage(&format!("{} points × {} paths", probes.len(), samples));
        let pts: Vec<(Vec3, Vec3)> = probes.iter().map(|q| (q.p, q.n)).collect();
        let est = reference::indirect_many(scene, &pts, &opts);
        let direct: Vec<Vec3> = probes.iter().map(|q| scene.direct(q.p, q.n)).collect();
        Ok((direct, est))
    });
    reraise(&raised)?;
    let (direct, est) = out?;
    let n = direct.len();
    let f64s =
        |v: Vec<f64>| -> PyResult<Bound<'py, PyAny>> { Ok(PyArray1::from_vec(py, v).reshape([n, 3])?.into_any()) };
    let d = PyDict::new(py);
    d.set_item(
        "direct",
        f64s(direct.iter().flat_map(|x| x.as_dvec3().to_array()).collect())?,
    )?;
    d.set_item("indirect", f64s(est.iter().flat_map(|e| e.mean.to_array()).collect())?)?;
    d.set_item(
        "total",
        f64s(
            direct
                .iter()
                .zip(&est)
                .flat_map(|(x, e)| (x.as_dvec3() + e.mean).to_array())
                .collect(),
        )?,
    )?;
    d.set_item(
        "indirect_se",
        f64s(est.iter().flat_map(|e| e.std_err.to_array()).collect())?,
    )?;
    Ok(d)
}

/// The Vulkan devices (`meshrad devices`): a list of dicts.
#[pyfunction]
fn devices<'py>(py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
    let text = detached(py, || {
        let list = crate::gpu::list_devices()?;
        let v: Vec<serde_json::Value> = list
            .iter()
            .map(|d| {
                serde_json::json!({
                    "index": d.index, "name": d.name, "type": d.device_type, "driver": d.driver_name,
                    "driver_info": d.driver_info, "api_version": d.api_version,
                    "subgroup_size": d.subgroup_size, "device_local_bytes": d.device_local_bytes,
                    "unusable": d.unusable,
                })
            })
            .collect();
        Ok(serde_json::to_string(&v)?)
    })?;
    py.import("json")?.call_method1("loads", (text,))
}

#[pymodule]
#[pyo3(name = "_meshrad")]
fn meshrad_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyScene>()?;
    m.add_class::<PySolution>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(solve, m)?)?;
    m.add_function(wrap_pyfunction!(reference_at, m)?)?;
    m.add_function(wrap_pyfunction!(devices, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
