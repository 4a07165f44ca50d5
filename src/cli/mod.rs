//! The `meshrad` command line: `solve` (the default), `probe`, `animate`, `session`,
//! `devices`, `reference`, `bench`.

mod animate_session;
mod bench;
mod reference;

pub use reference::{check_work as check_reference_work, MAX_SAMPLES as MAX_REFERENCE_SAMPLES};

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context as _, Result};
use clap::{Args, Parser, Subcommand, ValueEnum};
use serde::Serialize;

use std::sync::Arc;

use crate::device::GpuReport;
use crate::engine::Engine;
use crate::gpu::{list_devices, Context, ContextOptions};
use crate::hierarchy::{Hierarchy, HierarchyStats};
use crate::limits::Limits;
use crate::output::{self, image, ply, probe};
use crate::params::{SolverParams, Variant};
use crate::progress::Progress;
use crate::scene::{LoadReport, Scene};
use crate::transport::{Solution, SolveStats};

#[derive(Parser, Debug)]
#[command(
    name = "meshrad",
    version,
    about = "Meshless hierarchical radiosity on the CPU and on Vulkan compute",
    long_about = "Meshless hierarchical radiosity (Zollhöfer & Stamminger 2011).\n\
                  With no command, solves the shipped Cornell box and writes images to ./out."
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Solve a scene and write images, stats.json and optionally the node cloud.
    Solve(SolveArgs),
    /// Solve a scene and print the irradiance at given surface points (CSV).
    Probe(ProbeArgs),
    /// Solve a sequence of frames that move objects and change lights: hierarchies are
    /// built once, each frame applies its edits and re-solves.
    Animate(animate_session::AnimateArgs),
    /// The modify-review cycle driven by JSON lines on stdin (`set`, `solve`, `probe`,
    /// `render`, `stats`), one JSON answer per line on stdout.
    Session(animate_session::SessionArgs),
    /// List the Vulkan devices, their drivers, and whether meshrad can use them.
    Devices,
    /// Brute-force Monte Carlo reference (no hierarchy) at points or from the camera.
    Reference(reference::ReferenceArgs),
    /// Benchmarks: run time against error, the paper's Table 2.
    #[command(subcommand)]
    Bench(bench::BenchCommand),
}

/// Where the transport runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum BackendChoice {
    /// A Vulkan device if one is usable, else the CPU.
    Auto,
    /// The CPU reference.
    Cpu,
    /// Vulkan compute.
    Gpu,
}

/// Flags shared by every command that solves.
#[derive(Args, Debug, Clone)]
pub struct SolverArgs {
    /// Where the transport runs.
    #[arg(long, value_enum, default_value = "auto")]
    pub backend: BackendChoice,
    /// Hierarchy variant (paper Table 2).
    #[arg(long, value_enum)]
    pub variant: Option<VariantArg>,
    /// Bounces of indirect light.
    #[arg(long)]
    pub bounces: Option<u32>,
    /// Rays per gathering integral.
    #[arg(long)]
    pub rays: Option<u32>,
    /// Seed of all random choices.
    #[arg(long)]
    pub seed: Option<u32>,
    /// Vulkan device, by index or name substring (see `meshrad devices`).
    #[arg(long)]
    pub device: Option<String>,
    /// Any other [solver] key, as KEY=VALUE (repeatable), e.g. --set eps_rel=0.05.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Memory a run may plan for (e.g. 8G, 512M); a run estimated above it is refused
    /// before it starts. Default: MESHRAD_MAX_MEMORY, else half of the machine's memory.
    #[arg(long, value_name = "BYTES")]
    pub max_memory: Option<String>,
    /// Print per-phase and per-kernel times to stderr.
    #[arg(long)]
    pub stats: bool,
    /// No progress output.
    #[arg(long, short)]
    pub quiet: bool,
}

#[derive(Args, Debug)]
struct SolveArgs {
    /// Scene file (TOML); default: the embedded Cornell box.
    scene: Option<PathBuf>,
    /// Output directory.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Also write the node cloud as PLY.
    #[arg(long, value_name = "FILE.ply")]
    export_nodes: Option<PathBuf>,
    #[command(flatten)]
    image: ImageArgs,
    #[command(flatten)]
    solver: SolverArgs,
}

/// How images are sampled and drawn.
#[derive(Args, Debug, Clone, Default)]
pub struct ImageArgs {
    /// Samples per pixel (default: `[camera] spp`, else 16), stratified over the pixel
    /// filter (`[camera] filter`: box or gaussian).
    #[arg(long)]
    pub spp: Option<u32>,
    /// PNG exposure in stops, or `auto` (the default: the total image's 99th percentile
    /// of lit pixels at white). The EXRs stay linear; stats.json records what was applied.
    #[arg(long, value_name = "EV|auto", allow_hyphen_values = true)]
    pub exposure: Option<image::Exposure>,
}

impl ImageArgs {
    /// Applies `--spp` to the scene's camera.
    pub fn apply(&self, scene: &mut Scene) -> Result<()> {
        if let Some(spp) = self.spp {
            scene.camera.spp = crate::scene::camera::check_spp(spp).map_err(|m| anyhow::anyhow!("--spp {m}"))?;
        }
        Ok(())
    }
}

#[derive(Args, Debug)]
struct ProbeArgs {
    /// Scene file (TOML).
    scene: PathBuf,
    /// Points file: `px py pz nx ny nz` per line, `#` comments.
    #[arg(long)]
    points: PathBuf,
    /// Write the CSV here instead of stdout.
    #[arg(long, value_name = "FILE.csv")]
    out: Option<PathBuf>,
    /// How the indirect light is read: `probe` (a final gather of `final_gather` rays, or
    /// the basis with `final_gather = 0`), or `image`: as the camera image reads a pixel
    /// there (the basis, and a gather of `doubt_gather` × spp rays where it is doubted).
    #[arg(long, value_enum, default_value = "probe")]
    read: ProbeRead,
    #[command(flatten)]
    solver: SolverArgs,
}

/// `probe --read`.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum ProbeRead {
    Probe,
    Image,
}

/// Entry point of the binary.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        None => solve_cmd(SolveArgs {
            scene: None,
            out: PathBuf::from("out"),
            export_nodes: None,
            image: ImageArgs::default(),
            solver: SolverArgs {
                backend: BackendChoice::Auto,
                variant: None,
                bounces: None,
                rays: None,
                seed: None,
                device: None,
                set: Vec::new(),
                max_memory: None,
                stats: false,
                quiet: false,
            },
        }),
        Some(Command::Solve(a)) => solve_cmd(a),
        Some(Command::Probe(a)) => probe_cmd(a),
        Some(Command::Animate(a)) => animate_session::animate(a),
        Some(Command::Session(a)) => animate_session::session(a),
        Some(Command::Devices) => devices_cmd(),
        Some(Command::Reference(a)) => reference::run(a),
        Some(Command::Bench(b)) => bench::run(b),
    };
    // For sizing `--max-memory`, and for the tests that hold each run to it: the process's
    // own peak, which its parent cannot read once it has exited (`wait4`'s `ru_maxrss`
    // counts the parent's memory too when the child was spawned from a large process).
    if std::env::var_os("MESHRAD_REPORT_PEAK").is_some() {
        if let Some(b) = crate::limits::peak_resident() {
            eprintln!("meshrad: peak resident memory {} KiB", b >> 10);
        }
    }
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

impl SolverArgs {
    /// The `[solver]` overrides these flags ask for.
    /// A key given twice (`--rays 16 --set rays=64`, or `--set` twice) is an error, not a
    /// silent choice.
    pub fn overrides(&self) -> Result<Vec<(String, toml::Value)>> {
        let mut o: Vec<(String, toml::Value)> = Vec::new();
        let mut given: Vec<(String, String)> = Vec::new();
        let mut add = |k: String, v: toml::Value, flag: String| -> Result<()> {
            if let Some((_, first)) = given.iter().find(|(g, _)| *g == k) {
                anyhow::bail!("`{k}` is given twice ({first} and {flag}): give it once");
            }
            given.push((k.clone(), flag));
            o.push((k, v));
            Ok(())
        };
        if let Some(v) = self.variant.map(Variant::from) {
            add(
                "variant".into(),
                toml::Value::String(v.name().into()),
                format!("--variant {}", v.name()),
            )?;
        }
        for (k, v) in [("bounces", self.bounces), ("rays", self.rays), ("seed", self.seed)] {
            if let Some(v) = v {
                add(k.into(), toml::Value::Integer(v as i64), format!("--{k} {v}"))?;
            }
        }
        for s in &self.set {
            let (k, v) = s
                .split_once('=')
                .with_context(|| format!("--set `{s}`: expected KEY=VALUE"))?;
            let value = toml::from_str::<toml::Table>(&format!("v = {v}"))
                .ok()
                .and_then(|mut t| t.remove("v"))
                .unwrap_or_else(|| toml::Value::String(v.to_string()));
            add(k.trim().to_string(), value, format!("--set {s}"))?;
        }
        Ok(o)
    }
}

/// `--variant`: the library's [`Variant`] as the command line spells it (the library's
/// parameters do not know the CLI's parser).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum VariantArg {
    /// Delta hierarchy (Lehtinen et al.), exact reconstruction over levels 0..=s.
    Original,
    /// Absolute hierarchy (paper §5), exact Shepard reconstruction on the sender level.
    Modified,
    /// Absolute hierarchy, first kd-tree leaf with normal rejection (paper §5.1).
    Approx,
}

impl From<VariantArg> for Variant {
    fn from(v: VariantArg) -> Variant {
        match v {
            VariantArg::Original => Variant::Original,
            VariantArg::Modified => Variant::Modified,
            VariantArg::Approx => Variant::Approx,
        }
    }
}

impl SolverArgs {
    /// The resource limits these flags set.
    pub fn limits(&self) -> Result<Limits> {
        limits_from(self.max_memory.as_deref(), "--max-memory")
    }
}

/// The resource limits: `max_memory` (`flag` names it in errors), else
/// `MESHRAD_MAX_MEMORY`, else half of the machine's memory.
pub fn limits_from(max_memory: Option<&str>, flag: &str) -> Result<Limits> {
    let mut l = Limits::default();
    if let Ok(m) = std::env::var("MESHRAD_MAX_MEMORY") {
        l.max_memory = crate::limits::parse_bytes(&m).map_err(|e| anyhow::anyhow!("MESHRAD_MAX_MEMORY: {e}"))?;
    }
    if let Some(m) = max_memory {
        l.max_memory = crate::limits::parse_bytes(m).map_err(|e| anyhow::anyhow!("{flag}: {e}"))?;
    }
    Ok(l)
}

/// Loads a scene (or the embedded Cornell box) with the flags' overrides and limits.
pub fn load_scene(path: Option<&Path>, args: &SolverArgs) -> Result<(Scene, SolverParams)> {
    let overrides = args.overrides()?;
    let limits = args.limits()?;
    Ok(match path {
        Some(p) => Scene::load_with(p, &overrides, &limits)?,
        None => Scene::embedded_cornell_with(&overrides, &limits)?,
    })
}

/// Timings of the phases of one run.
#[derive(Clone, Debug, Default, Serialize)]
pub struct PhaseSeconds {
    pub load: f64,
    pub hierarchy: f64,
    pub solve: f64,
    pub output: f64,
    pub total: f64,
}

/// Everything stats.json holds.
#[derive(Serialize)]
pub struct RunStats<'a> {
    pub scene: SceneSummary,
    pub backend: String,
    pub variant: &'static str,
    pub seed: u32,
    pub params: &'a SolverParams,
    pub hierarchy: &'a HierarchyStats,
    pub solve: &'a SolveStats,
    pub gpu: Option<&'a GpuReport>,
    pub image: ImageSummary,
    pub seconds: PhaseSeconds,
}

impl<'a> RunStats<'a> {
    /// The stats.json of a solve of `scene` with `params` and its images.
    pub fn new(
        scene: &Scene,
        params: &'a SolverParams,
        run: (&'a HierarchyStats, &'a Solution, Option<&'a GpuReport>),
        image: ImageSummary,
        seconds: PhaseSeconds,
    ) -> Self {
        let (hierarchy, sol, gpu) = run;
        RunStats {
            scene: SceneSummary::of(scene),
            backend: sol.stats.backend.clone(),
            variant: sol.variant.name(),
            seed: params.seed,
            params,
            hierarchy,
            solve: &sol.stats,
            gpu,
            image,
            seconds,
        }
    }
}

/// The rendered images.
#[derive(Serialize)]
pub struct ImageSummary {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel and the pixel filter.
    pub spp: u32,
    pub filter: crate::scene::camera::Filter,
    /// The PNGs' exposure (the EXRs are linear).
    pub exposure: image::AppliedExposure,
    pub output_level: u32,
    /// Pixels whose indirect irradiance came out negative (delta-hierarchy ringing) and
    /// were clamped to zero.
    pub negative_indirect_pixels_clamped: usize,
    /// Pixel samples gathered where the basis read was doubted (`doubt_gather`), and
    /// those that read the basis.
    pub doubted_samples: u64,
    pub basis_samples: u64,
    /// Where the image was drawn: `"cpu"`, or `"device"` (kernel `image` on the device
    /// that solved), with the device's times.
    pub drawn_on: &'static str,
    /// On the device: the `image` kernel's time (GPU timestamps) and the whole pass's
    /// (pipeline, uploads, bands and their readbacks).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub device_seconds: Option<image::DeviceSeconds>,
    /// What left the run dark, when it is (`output::dark`): no node lit, no pixel lit, the
    /// object that encloses the rest.
    pub warnings: Vec<String>,
}

impl ImageSummary {
    pub fn of(img: &image::Images, scene: &Scene, params: &SolverParams, exposure: image::AppliedExposure) -> Self {
        ImageSummary {
            width: img.width,
            height: img.height,
            spp: scene.camera.spp,
            filter: scene.camera.filter,
            exposure,
            output_level: params.output_level(),
            negative_indirect_pixels_clamped: img.clamped,
            doubted_samples: img.doubted_samples,
            basis_samples: img.basis_samples,
            drawn_on: if img.device.is_some() { "device" } else { "cpu" },
            device_seconds: img.device,
            warnings: Vec::new(),
        }
    }
}

/// The scene's size.
#[derive(Serialize)]
pub struct SceneSummary {
    pub path: String,
    pub objects: usize,
    pub triangles: usize,
    pub lights: usize,
    pub textured: bool,
    pub load: LoadReport,
}

impl SceneSummary {
    pub fn of(scene: &Scene) -> Self {
        SceneSummary {
            path: scene.path.display().to_string(),
            objects: scene.objects.len(),
            triangles: scene.triangle_count(),
            lights: scene.lights.len(),
            textured: scene.textured(),
            load: scene.report.clone(),
        }
    }
}

/// Where the flags say the work runs, within the limits they set: the CPU, or the device
/// [`gpu_context`] picks. Errors and notes as there (`quiet` silences the notes).
pub fn engine(args: &SolverArgs, quiet: bool) -> Result<Engine> {
    let ctx = gpu_context(args.backend, args.device.as_deref(), quiet)?;
    Ok(Engine::on(ctx).within(args.limits()?))
}

/// The Vulkan context `choice` asks for: `None` for the CPU. `auto` takes a hardware
/// device (GPU); on a machine whose only device is a software one (lavapipe) the CPU
/// backend is faster, so `auto` takes the CPU there, and says why on stderr.
pub fn gpu_context(choice: BackendChoice, device: Option<&str>, quiet: bool) -> Result<Option<Arc<Context>>> {
    let opts = ContextOptions::from_env(device.map(String::from));
    match choice {
        BackendChoice::Cpu => match device {
            Some(d) => {
                anyhow::bail!("--device {d}: a device is chosen for the GPU backend; drop --backend cpu or --device")
            }
            None => Ok(None),
        },
        BackendChoice::Gpu => Ok(Some(Arc::new(Context::new(&opts)?))),
        BackendChoice::Auto => match Context::new(&opts) {
            Ok(c) if device.is_some() || c.info.device_type != "CPU" => Ok(Some(Arc::new(c))),
            Ok(c) => {
                if !quiet {
                    eprintln!(
                        "note: auto backend: the only Vulkan device is {} (a CPU driver); using the CPU \
                         backend (--backend gpu forces it)",
                        c.info.name
                    );
                }
                Ok(None)
            }
            // A device that was asked for by name or index and is not there is an error,
            // not a reason to run somewhere else.
            Err(e) if device.is_some() => Err(e.into()),
            Err(e) => {
                if !quiet {
                    eprintln!("note: auto backend: no Vulkan device ({e}); using the CPU backend");
                }
                Ok(None)
            }
        },
    }
}

fn report_load(scene: &Scene, quiet: bool) {
    let r = &scene.report;
    if r.degenerate_dropped > 0 {
        eprintln!("note: dropped {} degenerate triangle(s)", r.degenerate_dropped);
    }
    if r.duplicate_dropped > 0 {
        eprintln!(
            "note: dropped {} triangle(s) that repeat an earlier one of the same mesh exactly",
            r.duplicate_dropped
        );
    }
    if quiet {
        return;
    }
    for n in &r.notes {
        eprintln!("note: {n}");
    }
    if !r.emissive_materials_ignored.is_empty() {
        eprintln!(
            "note: emission (Ke) of material(s) {} is off (`emission = false` on its object)",
            r.emissive_materials_ignored.join(", ")
        );
    }
    if r.faces_without_material > 0 {
        eprintln!(
            "note: {} face(s) have no material; albedo {:?} used",
            r.faces_without_material,
            crate::scene::obj::DEFAULT_KD
        );
    }
    if r.planned_bytes > (1u64 << 30) as f64 {
        eprintln!(
            "note: this run plans for about {} of memory",
            crate::limits::human(r.planned_bytes)
        );
    }
}

pub(crate) use crate::run::check_finite;

/// Warnings of the solve that change what the outputs mean.
fn report_solve(sol: &Solution, quiet: bool) {
    if quiet {
        return;
    }
    for s in solve_warnings(sol) {
        eprintln!("warning: {s}");
    }
}

/// The solve's warnings: lights skipped, bounces that did not converge.
pub(crate) fn solve_warnings(sol: &Solution) -> Vec<String> {
    let skipped = sol.stats.skipped.iter().filter(|s| s.starts_with("light "));
    skipped.chain(&sol.stats.unconverged).cloned().collect()
}

fn print_stats(h: &Hierarchy, sol: &Solution, sec: &PhaseSeconds) {
    let s = &sol.stats;
    eprintln!("nodes per level: {:?}", h.stats.nodes_per_level);
    eprintln!(
        "phases: load {:.3} s, hierarchy {:.3} s, direct {:.3} s, bounces {:.3} s, output {:.3} s",
        sec.load, sec.hierarchy, s.seconds_direct, s.seconds_bounces, sec.output
    );
    for b in &s.bounces {
        eprintln!(
            "bounce {}: {:.3} s, integrals per level {:?}, refined {:?}, un-shot {:.3e}",
            b.bounce, b.seconds, b.integrals_per_level, b.refined_per_level, b.unshot_ratio
        );
    }
    let rays_s = s.rays_gathered as f64 / s.seconds_bounces.max(1e-9);
    eprintln!(
        "integrals {}, rays {} ({:.2} Mrays/s over the bounces), of them traced {}",
        s.integrals,
        s.rays_gathered,
        rays_s / 1e6,
        s.rays_traced
    );
    if let Some(l) = &s.links {
        eprintln!(
            "links: {} nodes, {:.1} MiB of {:.0} MiB, {} integrals read from links, {} traced ({} with the links full)",
            l.nodes,
            l.bytes as f64 / (1 << 20) as f64,
            l.capacity_bytes as f64 / (1 << 20) as f64,
            l.integrals_linked,
            l.integrals_traced,
            l.integrals_traced_full
        );
    }
    for (k, t) in &s.kernel_seconds {
        eprintln!("kernel {k}: {:.4} s", t);
    }
}

fn solve_cmd(a: SolveArgs) -> Result<()> {
    let progress = Progress::new(a.solver.quiet);
    let t_all = Instant::now();
    let t = Instant::now();
    let (mut scene, params) = load_scene(a.scene.as_deref(), &a.solver)?;
    a.image.apply(&mut scene)?;
    report_load(&scene, a.solver.quiet);
    let load = t.elapsed().as_secs_f64();
    // Where the outputs go is settled before the solve: a bad --out fails in a moment,
    // not after minutes of work, and no output may replace an input or another output.
    output::ensure_dir(&a.out)?;
    let mut planned: Vec<(&str, PathBuf)> = image::file_names(&a.out).into_iter().map(|p| ("an image", p)).collect();
    planned.push(("stats.json", a.out.join("stats.json")));
    if let Some(p) = &a.export_nodes {
        planned.push(("--export-nodes", p.clone()));
    }
    output::check_outputs(&planned, &scene.report.inputs)?;
    // The engine (and what the solve left on the device) goes before the outputs.
    let mut eng = engine(&a.solver, a.solver.quiet)?;
    let run = crate::solve(&scene, &params, &mut eng, &progress)?;
    report_solve(&run.solution, a.solver.quiet);
    let (h, sol, th, ts) = (&run.hierarchy, &run.solution, run.seconds_hierarchy, run.seconds_solve);
    let t = Instant::now();
    progress.stage("images");
    check_finite(
        &scene,
        "node values",
        sol.values
            .direct
            .iter()
            .chain(&sol.values.indirect)
            .map(|v| v.truncate()),
    )?;
    let img = image::render_on(&mut eng, &scene, h, sol, &params, &progress)?;
    check_finite(&scene, "image", img.direct.iter().chain(&img.indirect).copied())?;
    let dark = output::dark::warnings(&scene, h, sol, Some(&img));
    let mut files = output::Outputs::default();
    let exposure = image::encode_all(&a.out, &img, a.image.exposure.unwrap_or_default(), &mut files)?;
    if let Some(p) = &a.export_nodes {
        files.add(p, ply::encode(p, &scene, h, sol)?);
    }
    let seconds = PhaseSeconds {
        load,
        hierarchy: th,
        solve: ts,
        output: t.elapsed().as_secs_f64(),
        total: t_all.elapsed().as_secs_f64(),
    };
    progress.finish();
    if a.solver.stats {
        print_stats(h, sol, &seconds);
    }
    let stats = RunStats::new(
        &scene,
        &params,
        (&h.stats, sol, run.gpu.as_ref()),
        ImageSummary {
            warnings: dark.clone(),
            ..ImageSummary::of(&img, &scene, &params, exposure)
        },
        seconds,
    );
    let stats_path = a.out.join("stats.json");
    files.add(&stats_path, output::json_bytes(&stats_path, &stats)?);
    files.commit()?;
    for w in &dark {
        eprintln!("warning: {w}");
    }
    if !a.solver.quiet {
        println!(
            "{}: {} nodes, {} integrals in {:.2} s ({}, {}); images in {}",
            scene.path.display(),
            h.nodes.len(),
            sol.stats.integrals,
            stats.seconds.total,
            sol.stats.backend,
            sol.variant.name(),
            a.out.display()
        );
    }
    Ok(())
}

fn probe_cmd(a: ProbeArgs) -> Result<()> {
    let progress = Progress::new(a.solver.quiet);
    let probes = probe::read_within(&a.points, &a.solver.limits()?)?;
    let (scene, params) = load_scene(Some(&a.scene), &a.solver)?;
    report_load(&scene, a.solver.quiet);
    if let Some(p) = &a.out {
        let mut inputs = scene.report.inputs.clone();
        inputs.push(a.points.clone());
        output::check_outputs(&[("--out", p.clone())], &inputs)?;
    }
    let run = crate::solve(&scene, &params, &mut engine(&a.solver, a.solver.quiet)?, &progress)?;
    report_solve(&run.solution, a.solver.quiet);
    for w in output::dark::warnings(&scene, &run.hierarchy, &run.solution, None) {
        eprintln!("warning: {w}");
    }
    let values = match a.read {
        ProbeRead::Probe => probe::evaluate(&scene, &run.hierarchy, &run.solution, &probes, &params),
        ProbeRead::Image => probe::evaluate_as_image(&scene, &run.hierarchy, &run.solution, &probes, &params),
    };
    check_finite(
        &scene,
        "probe values",
        values.iter().flat_map(probe::ProbeValue::vectors),
    )?;
    let text = probe::csv(&probes, &values);
    progress.finish();
    match &a.out {
        Some(p) => {
            let mut files = output::Outputs::default();
            files.add(p, text.into_bytes());
            files.commit()?;
        }
        None => print!("{text}"),
    }
    Ok(())
}

fn devices_cmd() -> Result<()> {
    let devices = list_devices()?;
    if devices.is_empty() {
        println!("no Vulkan devices");
    }
    for d in devices {
        println!(
            "{}: {} ({}), driver {} {} (version {:#x}), Vulkan {}, subgroup {}, {} MiB device-local{}",
            d.index,
            d.name,
            d.device_type,
            d.driver_name,
            d.driver_info,
            d.driver_version,
            d.api_version,
            d.subgroup_size,
            d.device_local_bytes >> 20,
            d.unusable.map(|u| format!(" — unusable: {u}")).unwrap_or_default()
        );
    }
    Ok(())
}
