//! `meshrad bench accuracy`, `table2`, `coverage`, `nodes`, `edit` and `compare`.

use std::path::PathBuf;
use std::sync::Arc;

use std::fmt::Write as _;

use anyhow::{Context as _, Result};
use clap::{Args, Subcommand};

use crate::bench::{accuracy, images, plot, table2};
use crate::engine::Engine;
use crate::gpu::{Context, ContextOptions};
use crate::output;
use crate::params::SolverParams;
use crate::progress::Progress;
use crate::scene::Scene;

#[derive(Subcommand, Debug)]
pub enum BenchCommand {
    /// Sweep solver parameters and backends; error against time with the Pareto front and
    /// path tracing as the baseline (CSV + PNG).
    Accuracy(AccuracyArgs),
    /// The paper's Table 2 on Cornell, Cornell + Buddha (100k and 1.6M triangles), Sponza.
    Table2(Table2Args),
    /// Where the first bounce's light goes, without a reference: the level-0 integrals'
    /// rays cast once, escapes, hits without a value, and the bias of each reconstruction
    /// on the direct irradiance at the hits (sender as the transport reads it, sender
    /// exact, output level) against its exact value there.
    Coverage(CoverageArgs),
    /// The solved values at the nodes themselves (no output interpolation) against the
    /// converged reference at the node centres, per level.
    Nodes(NodesArgs),
    /// The modify-review cycle: fixed frames that move objects and lights, each solved as
    /// an edit (hierarchy built once) and as a fresh solve, alternating, in one run.
    Edit(EditArgs),
    /// Two images (EXR, linear) compared: relative RMS over the pixels whose reference is
    /// above 1 % of its mean, and the largest pixel difference relative to the reference's
    /// mean; exit 1 above `--tolerance` (the device check's GPU-against-CPU test).
    Compare(CompareArgs),
    /// The scene exported for Mitsuba 3 (its triangles, materials, lights, constant sky and
    /// camera, as this project loaded them) and, with `--spp`, its camera image rendered by
    /// Mitsuba's path tracer (`image.exr`): an independent reference, where `python3 -c
    /// 'import mitsuba'` works. `points.py` in the export renders irradiance at probe points.
    Mitsuba(MitsubaArgs),
}

#[derive(Args, Debug)]
pub struct MitsubaArgs {
    /// Scene file (default: the embedded Cornell box).
    scene: Option<PathBuf>,
    /// The export's folder (`scene.json`, meshes, texels, the scripts; `image.exr`).
    #[arg(long, default_value = "bench-mitsuba")]
    out: PathBuf,
    /// Paths per pixel of the camera image (0: the export alone).
    #[arg(long, default_value_t = 0)]
    spp: u32,
    /// The image's seed.
    #[arg(long, default_value_t = 1)]
    seed: u32,
}

#[derive(Args, Debug)]
pub struct CompareArgs {
    /// The image measured.
    estimate: PathBuf,
    /// The image it is measured against.
    reference: PathBuf,
    /// The largest relative RMS that passes (exit 1 above it).
    #[arg(long)]
    tolerance: Option<f64>,
}

#[derive(Args, Debug)]
pub struct EditArgs {
    /// Scenes (cornell, buddha, sponza; comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "cornell,buddha")]
    scenes: Vec<String>,
    /// Where cornell_buddha_parts.toml and sponza.toml are.
    #[arg(long, default_value = "scenes/shared")]
    scene_dir: PathBuf,
    #[arg(long, value_enum, default_value = "both")]
    backend: Backends,
    /// Vulkan device (index or name).
    #[arg(long)]
    device: Option<String>,
    /// Frames per scene (the first is the scene as loaded).
    #[arg(long, default_value_t = 8)]
    frames: usize,
    #[arg(long, default_value = "bench-edit")]
    out: PathBuf,
    /// Tiny parameters (CI).
    #[arg(long)]
    smoke: bool,
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Args, Debug)]
pub struct NodesArgs {
    /// Scene file (default: the embedded Cornell box).
    scene: Option<PathBuf>,
    /// Nodes per level.
    #[arg(long, default_value = "128")]
    per_level: usize,
    /// Reference paths per node.
    #[arg(long, default_value = "8192")]
    reference_samples: u32,
    /// Cut the reference after this many bounces (0: the whole series), to compare a
    /// solve cut at `--bounces K` (with `--set stop_threshold=0`) term by term.
    #[arg(long, default_value = "0")]
    reference_bounces: u32,
    #[command(flatten)]
    solver: super::SolverArgs,
}

#[derive(Args, Debug)]
pub struct CoverageArgs {
    /// Scene files (default: the embedded Cornell box).
    scenes: Vec<PathBuf>,
    #[command(flatten)]
    solver: super::SolverArgs,
}

/// Which backends a benchmark runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Backends {
    Cpu,
    Gpu,
    Both,
}

#[derive(Args, Debug)]
pub struct AccuracyArgs {
    /// Scene files (default: the embedded Cornell box).
    scenes: Vec<PathBuf>,
    #[arg(long, default_value = "bench-accuracy")]
    out: PathBuf,
    #[arg(long, value_enum, default_value = "both")]
    backend: Backends,
    /// Vulkan device (index or name).
    #[arg(long)]
    device: Option<String>,
    /// Probe points per scene.
    #[arg(long, default_value_t = 256)]
    probes: usize,
    /// Reference paths per probe point.
    #[arg(long, default_value_t = 65536)]
    reference_samples: u32,
    /// Path-tracing baseline, samples per point (comma-separated; 0: none).
    #[arg(long, value_delimiter = ',', default_value = "16,64,256,1024,4096")]
    pathtrace: Vec<u32>,
    /// A reduced sweep (a few points per variant).
    #[arg(long)]
    quick: bool,
    /// Only the scene's own settings (with the path-tracing baseline unless --pathtrace 0).
    #[arg(long)]
    defaults_only: bool,
    /// The error decomposition: each term switched off or to its exact form, one at a time
    /// (final gather, sender exact, sender finest, first bounce reconstructed, crevice off,
    /// clip off, reach x8, sparse nodes pulled, oracle /3, series 1e-5, rays x4, nodes x2),
    /// instead of the sweep.
    #[arg(long)]
    decompose: bool,
    /// Only the configurations with these labels (comma-separated, e.g.
    /// "defaults,final gather 256").
    #[arg(long, value_delimiter = ',')]
    only: Vec<String>,
    /// The image front: paths per pixel of each of two independent reference images of
    /// the scene's camera (cached in --out); 0: no image front. The total and indirect
    /// images' error over all pixels and away from edges against end-to-end time, for
    /// meshrad at --image-spp on each backend and path tracing at --image-pathtrace
    /// (`image-front.csv`, `.md`, `.png`).
    #[arg(long, default_value_t = 1024)]
    image_reference: u32,
    /// meshrad's samples per pixel on the image front (comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "1,4,16,64")]
    image_spp: Vec<u32>,
    /// Path tracing's paths per pixel on the image front (comma-separated; the project's
    /// reference renderer on this machine's cores).
    #[arg(long, value_delimiter = ',', default_value = "4,16,64,256,1024")]
    image_pathtrace: Vec<u32>,
    /// Mitsuba 3's paths per pixel on the image front (comma-separated; 0: none), where
    /// `python3 -c 'import mitsuba'` works (`$MESHRAD_PYTHON` names another interpreter)
    /// and its `llvm_ad_rgb` variant loads; otherwise its rows are left out with a note.
    #[arg(long, value_delimiter = ',', default_value = "4,16,64,256,1024")]
    image_mitsuba: Vec<u32>,
    /// Only the image front (no probe points).
    #[arg(long)]
    images_only: bool,
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Args, Debug)]
pub struct Table2Args {
    /// Scenes (cornell, buddha, buddha1m, sponza; comma-separated). Default: all four, or
    /// Cornell alone with --smoke.
    #[arg(long, value_delimiter = ',')]
    scenes: Vec<String>,
    /// Where cornell_buddha.toml and sponza.toml are.
    #[arg(long, default_value = "scenes/shared")]
    scene_dir: PathBuf,
    #[arg(long, default_value = "bench-table2")]
    out: PathBuf,
    /// Vulkan device (index or name); without a usable one only the CPU column runs.
    #[arg(long)]
    device: Option<String>,
    /// Leave out the CPU column.
    #[arg(long)]
    skip_cpu: bool,
    /// Tiny parameters, Cornell only unless --scenes says otherwise (CI).
    #[arg(long)]
    smoke: bool,
    #[arg(long, default_value_t = 256)]
    probes: usize,
    #[arg(long, default_value_t = 32768)]
    reference_samples: u32,
    #[arg(long, short)]
    quiet: bool,
}

impl Backends {
    /// The engines to run on: the CPU, the device, or both.
    fn engines(self, device: Option<&str>) -> Result<Vec<Engine>> {
        let mut v = Vec::new();
        if self != Backends::Gpu {
            v.push(Engine::cpu());
        }
        if self != Backends::Cpu {
            v.push(Engine::gpu(gpu(device)?));
        }
        Ok(v)
    }
}

fn gpu(device: Option<&str>) -> Result<Arc<Context>> {
    Ok(Arc::new(Context::new(&ContextOptions::from_env(
        device.map(String::from),
    ))?))
}

pub fn run(cmd: BenchCommand) -> Result<()> {
    match cmd {
        BenchCommand::Accuracy(a) => run_accuracy(a),
        BenchCommand::Table2(a) => run_table2(a),
        BenchCommand::Coverage(a) => run_coverage(a),
        BenchCommand::Nodes(a) => run_nodes(a),
        BenchCommand::Edit(a) => run_edit(a),
        BenchCommand::Compare(a) => run_compare(a),
        BenchCommand::Mitsuba(a) => run_mitsuba(a),
    }
}

fn run_mitsuba(a: MitsubaArgs) -> Result<()> {
    let (scene, _) = match &a.scene {
        Some(p) => Scene::load(p, &[])?,
        None => Scene::embedded_cornell(&[])?,
    };
    crate::bench::mitsuba::export(&scene, &a.out)?;
    println!(
        "wrote the Mitsuba 3 export of {} in {}",
        scene.path.display(),
        a.out.display()
    );
    if a.spp == 0 {
        return Ok(());
    }
    if a.spp > crate::scene::camera::MAX_SPP {
        anyhow::bail!("--spp: {} is outside 0..={}", a.spp, crate::scene::camera::MAX_SPP);
    }
    let version = crate::bench::mitsuba::available().map_err(|why| anyhow::anyhow!("Mitsuba 3 is needed: {why}"))?;
    let (w, h) = (scene.camera.width, scene.camera.height);
    let (px, seconds) = crate::bench::mitsuba::render(&a.out, a.spp, a.seed, w, h)?;
    let mut out = output::Outputs::default();
    output::image::encode_pair(&a.out, "image", w, h, &px, 0.0, &mut out)?;
    out.commit()?;
    println!(
        "Mitsuba {version}: {w}×{h} at {} paths a pixel in {seconds:.2} s: {}",
        a.spp,
        a.out.join("image.exr").display()
    );
    Ok(())
}

fn run_compare(a: CompareArgs) -> Result<()> {
    let read = |p: &std::path::Path| -> Result<(u32, u32, Vec<glam::Vec3>)> {
        let img = image::open(p)
            .with_context(|| format!("{}: not an image meshrad can read", p.display()))?
            .into_rgb32f();
        let px = img.pixels().map(|q| glam::Vec3::from(q.0)).collect();
        Ok((img.width(), img.height(), px))
    };
    let (ew, eh, e) = read(&a.estimate)?;
    let (rw, rh, r) = read(&a.reference)?;
    if (ew, eh) != (rw, rh) {
        anyhow::bail!(
            "{} is {ew}×{eh} and {} is {rw}×{rh}: images of one size are compared",
            a.estimate.display(),
            a.reference.display()
        );
    }
    let rel_rms = crate::metrics::image_rel_rms(&e, &r);
    let mean = r.iter().map(|v| v.as_dvec3().element_sum() / 3.0).sum::<f64>() / r.len().max(1) as f64;
    let max_diff = e
        .iter()
        .zip(&r)
        .map(|(a, b)| (a.as_dvec3() - b.as_dvec3()).abs().max_element())
        .fold(0.0f64, f64::max);
    let finite = e.iter().chain(&r).all(|v| v.is_finite());
    println!(
        "rel_rms={rel_rms:.6e} max_diff_over_mean={:.6e} pixels={} finite={finite}",
        if mean > 0.0 { max_diff / mean } else { 0.0 },
        r.len()
    );
    match a.tolerance {
        Some(t) if !(finite && rel_rms <= t) => anyhow::bail!(
            "{} differs from {} by a relative RMS of {rel_rms:.3e}, above the tolerance {t:e}{}",
            a.estimate.display(),
            a.reference.display(),
            if finite { "" } else { " (inf or NaN pixels)" }
        ),
        _ => Ok(()),
    }
}

fn run_accuracy(a: AccuracyArgs) -> Result<()> {
    let progress = Progress::new(a.quiet);
    output::ensure_dir(&a.out)?;
    let backends = a.backend.engines(a.device.as_deref())?;
    let opts = accuracy::AccuracyOptions {
        probes: a.probes,
        reference_samples: a.reference_samples,
        pathtrace_samples: a.pathtrace.clone(),
        quick: a.quick,
        defaults_only: a.defaults_only,
        decompose: a.decompose,
        only: a.only.clone(),
    };
    let scenes: Vec<(String, (Scene, SolverParams))> = if a.scenes.is_empty() {
        vec![("cornell".into(), Scene::embedded_cornell(&[])?)]
    } else {
        a.scenes
            .iter()
            .map(|p| {
                let name = p
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default();
                Ok((name, Scene::load(p, &[])?))
            })
            .collect::<Result<_>>()?
    };
    if a.images_only && a.image_reference == 0 {
        anyhow::bail!("--images-only needs an image front: --image-reference above 0");
    }
    let mitsuba: Vec<u32> = a.image_mitsuba.iter().copied().filter(|&n| n > 0).collect();
    for (key, list) in [
        ("--image-spp", &a.image_spp),
        ("--image-pathtrace", &a.image_pathtrace),
        ("--image-mitsuba", &mitsuba),
    ] {
        if let Some(bad) = list.iter().find(|&&n| n == 0 || n > crate::scene::camera::MAX_SPP) {
            anyhow::bail!("{key}: {bad} is outside 1..={}", crate::scene::camera::MAX_SPP);
        }
    }
    let mut all = Vec::new();
    let mut fronts = Vec::new();
    for (name, (scene, params)) in scenes {
        if !a.images_only {
            let rows = accuracy::sweep(&name, &scene, &params, &backends, &opts, &a.out, &progress)?;
            let png = a.out.join(format!("{name}.png"));
            plot::error_vs_time(&rows, &format!("{name}: error against time"), &png)?;
            all.extend(rows);
        }
        if a.image_reference > 0 {
            let io = images::ImageOptions {
                reference_samples: a.image_reference,
                spp: a.image_spp.clone(),
                pathtrace: a.image_pathtrace.clone(),
                mitsuba: mitsuba.clone(),
            };
            fronts.extend(images::front(
                &name, &scene, &params, &backends, &io, &a.out, &progress,
            )?);
        }
    }
    progress.finish();
    if !fronts.is_empty() {
        images::write(&fronts, &a.out)?;
        println!("{}", images::summary(&fronts));
        println!("wrote image-front.csv, .md and .png in {}", a.out.display());
    }
    if a.images_only {
        return Ok(());
    }
    let csv_path = a.out.join("accuracy.csv");
    std::fs::write(&csv_path, accuracy::csv(&all)).with_context(|| format!("writing {}", csv_path.display()))?;
    println!("{}", summary(&all));
    println!(
        "wrote {} and one PNG per scene in {}",
        csv_path.display(),
        a.out.display()
    );
    Ok(())
}

/// The defaults' error per stratum: the points lit only indirectly and the lit ones,
/// each with its bias figures; the headline is the worse.
fn strata_summary(rows: &[accuracy::Row]) -> String {
    let mut s = String::from(
        "| scene | backend | headline (worse stratum) | indirect-only: rel-RMS | median e/r | mean e/r | \
         energy e/r | points | lit: rel-RMS | median e/r | mean e/r | energy e/r | points |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows.iter().filter(|r| r.label == "defaults") {
        let (io, lit) = (&r.strata.indirect_only, &r.strata.lit);
        let _ = writeln!(
            s,
            "| {} | {} | {:.1} % | {:.1} % | {:.3} | {:.3} | {:.3} | {} | {:.1} % | {:.3} | {:.3} | {:.3} | {} |",
            r.scene,
            r.backend,
            100.0 * r.headline(),
            100.0 * io.rel_rms,
            io.median_ratio,
            io.mean_ratio,
            io.energy_ratio,
            io.points,
            100.0 * lit.rel_rms,
            lit.median_ratio,
            lit.mean_ratio,
            lit.energy_ratio,
            lit.points
        );
    }
    s.push('\n');
    s
}

/// The error at the scene's defaults with its bias figures, by stratum and over all
/// points, and the times to reach 5 % and 2 % relative RMS (the worse stratum's) per
/// scene and series.
fn summary(rows: &[accuracy::Row]) -> String {
    let mut s = strata_summary(rows);
    s.push_str(
        "| scene | backend | rel-RMS (area, converged; all points) | median e/r | mean e/r | energy e/r | off > 3× | \
         leak | rel-RMS (camera, cut) | 1st-bounce light lost at hits without value |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows.iter().filter(|r| r.label == "defaults") {
        let e = &r.error;
        s += &format!(
            "| {} | {} | {:.1} % | {:.3} | {:.3} | {:.3} | {} of {} | {:.3} | {:.1} % | {} |\n",
            r.scene,
            r.backend,
            100.0 * e.rel_rms,
            e.median_ratio,
            e.mean_ratio,
            e.energy_ratio,
            e.off_3x,
            e.points,
            e.leak,
            100.0 * r.error_camera.rel_rms,
            r.coverage.map_or("-".to_string(), |c| format!(
                "{:.2} % ({} of {} rays, {} escaped)",
                100.0 * c.light_lost,
                c.no_value,
                c.rays,
                c.escaped
            ))
        );
    }
    s += "\n| scene | series | time to 5 % | time to 2 % |\n|---|---|---|---|\n";
    let mut scenes: Vec<&str> = rows.iter().map(|r| r.scene.as_str()).collect();
    scenes.dedup();
    for sc in scenes {
        let mine: Vec<accuracy::Row> = rows.iter().filter(|r| r.scene == sc).cloned().collect();
        for (g, t) in accuracy::time_to_reach(&mine, &[0.05, 0.02]) {
            let f = |x: &Option<f64>| x.map_or("not reached".to_string(), |v| format!("{v:.3} s"));
            s += &format!("| {sc} | {g} | {} | {} |\n", f(&t[0]), f(&t[1]));
        }
    }
    s
}

fn run_coverage(a: CoverageArgs) -> Result<()> {
    let progress = Progress::new(a.solver.quiet);
    let scenes: Vec<(String, (Scene, SolverParams))> = if a.scenes.is_empty() {
        vec![("cornell".into(), super::load_scene(None, &a.solver)?)]
    } else {
        a.scenes
            .iter()
            .map(|p| Ok((p.display().to_string(), super::load_scene(Some(p), &a.solver)?)))
            .collect::<Result<_>>()?
    };
    let mut s = String::from(
        "| scene | rays | escaped | hits without value | their share of the light | E_d read by the sender / exact | \
         sender exact / exact | output level / exact | hierarchy s |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    for (name, (scene, params)) in scenes {
        params.validate()?;
        progress.stage(&format!("{name}: hierarchy"));
        let t = std::time::Instant::now();
        let h = crate::hierarchy::Hierarchy::build(&scene, &params, &progress)?;
        let th = t.elapsed().as_secs_f64();
        progress.stage(&format!("{name}: first-bounce rays"));
        let c = crate::transport::coverage::first_bounce(&scene, &h, &params);
        eprintln!(
            "{name}: nodes per level {:?}, orphans {:?}, parent holes {:?}, crevice drops {}",
            h.stats.nodes_per_level,
            h.stats.orphans_per_level,
            h.stats.parent_holes_per_level,
            h.stats.crevice_candidates_dropped
        );
        s += &format!(
            "| {name} | {} | {} | {} | {:.3} % | {:.4} | {:.4} | {:.4} | {th:.1} |\n",
            c.rays,
            c.escaped,
            c.no_value,
            100.0 * c.light_lost,
            c.sender_direct_ratio,
            c.sender_exact_direct_ratio,
            c.output_direct_ratio
        );
    }
    progress.finish();
    print!("{s}");
    Ok(())
}

fn run_nodes(a: NodesArgs) -> Result<()> {
    let progress = Progress::new(a.solver.quiet);
    let (scene, params) = super::load_scene(a.scene.as_deref(), &a.solver)?;
    let mut engine = super::engine(&a.solver, a.solver.quiet)?;
    let run = crate::solve(&scene, &params, &mut engine, &progress)?;
    progress.stage("reference at nodes");
    let opts = crate::reference::ReferenceOptions {
        samples: a.reference_samples,
        max_bounces: a.reference_bounces,
        ..Default::default()
    };
    let rows = crate::bench::node_bias(&scene, &run.hierarchy, &run.solution, a.per_level, &opts, 0x40de);
    // Bounce by bounce over every level-0 node: the solver's un-shot energy against the
    // reference's term of the same bounce, both relative to the direct energy there.
    progress.stage("reference terms at level 0");
    let (h, sol) = (&run.hierarchy, &run.solution);
    let k = sol.stats.bounces.len();
    let level0: Vec<usize> = h.level_range(0).collect();
    let term_opts = crate::reference::ReferenceOptions {
        samples: (a.reference_samples / 8).max(64),
        ..opts
    };
    use rayon::prelude::*;
    let per_node: Vec<Vec<glam::DVec3>> = level0
        .par_iter()
        .map(|&j| {
            let (x, n) = crate::transport::cpu::node_world(&scene, h, j);
            crate::reference::terms(&scene, x, n, &term_opts, k, j as u64)
        })
        .collect();
    let mean3 = |v: glam::DVec3| (v.x + v.y + v.z) / 3.0;
    let direct: f64 = level0
        .iter()
        .map(|&j| {
            let d = sol.values.direct[j];
            (d.x + d.y + d.z) as f64 / 3.0
        })
        .sum();
    progress.finish();
    println!("| bounce | solver un-shot / direct (level 0) | reference term / direct | solver / reference |\n|---|---|---|---|");
    for (b, st) in sol.stats.bounces.iter().enumerate() {
        let r: f64 = per_node.iter().map(|t| mean3(t[b])).sum::<f64>() / direct.max(1e-30);
        println!(
            "| {} | {:.5} | {:.5} | {:.3} |",
            b + 1,
            st.unshot_ratio,
            r,
            st.unshot_ratio / r.max(1e-30)
        );
    }
    println!(
        "| level | nodes | rel-RMS | median e/r | mean e/r | energy e/r | off > 3x | reference noise |\n|---|---|---|---|---|---|---|---|"
    );
    for r in rows {
        let e = &r.error;
        println!(
            "| {} | {} of {} | {:.1} % | {:.3} | {:.3} | {:.3} | {} | {:.1} % |",
            r.level,
            e.points,
            r.nodes,
            100.0 * e.rel_rms,
            e.median_ratio,
            e.mean_ratio,
            e.energy_ratio,
            e.off_3x,
            100.0 * e.reference_noise
        );
    }
    Ok(())
}

fn run_edit(a: EditArgs) -> Result<()> {
    use crate::bench::edit_vs_fresh;
    let progress = Progress::new(a.quiet);
    if a.frames < 2 {
        anyhow::bail!("--frames {}: at least 2 (the scene as loaded, then edits)", a.frames);
    }
    output::ensure_dir(&a.out)?;
    let backends = a.backend.engines(a.device.as_deref())?;
    let mut rows = Vec::new();
    for name in &a.scenes {
        let spec = edit_vs_fresh::SCENES
            .iter()
            .find(|s| s.name == name)
            .with_context(|| format!("--scenes: unknown scene `{name}` (cornell, buddha, sponza)"))?;
        for engine in &backends {
            rows.extend(edit_vs_fresh::run_scene(
                spec,
                &a.scene_dir,
                a.frames,
                a.smoke,
                engine,
                &progress,
            )?);
        }
    }
    progress.finish();
    let device = backends
        .iter()
        .find_map(Engine::context)
        .map_or("no GPU".to_string(), |c| {
            format!("{} ({} {})", c.info.name, c.info.driver_name, c.info.driver_info)
        });
    let text = format!(
        "Device: {device}; CPU: {} threads. Seconds, median / 95th percentile over the re-solve frames.\n\n{}",
        rayon::current_num_threads(),
        edit_vs_fresh::markdown(&rows)
    );
    std::fs::write(a.out.join("edit.md"), &text).context("writing edit.md")?;
    std::fs::write(a.out.join("edit.csv"), edit_vs_fresh::csv(&rows)).context("writing edit.csv")?;
    println!("{text}");
    Ok(())
}

fn run_table2(a: Table2Args) -> Result<()> {
    let progress = Progress::new(a.quiet);
    output::ensure_dir(&a.out)?;
    let ctx = match gpu(a.device.as_deref()) {
        Ok(c) => Some(Engine::gpu(c)),
        Err(e) => {
            eprintln!("note: no GPU columns: {e:#}");
            None
        }
    };
    let opts = table2::TableOptions {
        scene_dir: a.scene_dir.clone(),
        probes: if a.smoke { a.probes.min(48) } else { a.probes },
        reference_samples: if a.smoke {
            a.reference_samples.min(4096)
        } else {
            a.reference_samples
        },
        skip_cpu: a.skip_cpu,
        smoke: a.smoke,
    };
    let default: &[&str] = if a.smoke {
        &["cornell"]
    } else {
        &["cornell", "buddha", "buddha1m", "sponza"]
    };
    let scenes: Vec<String> = if a.scenes.is_empty() {
        default.iter().map(|s| s.to_string()).collect()
    } else {
        a.scenes.clone()
    };
    let mut tables = Vec::new();
    for name in &scenes {
        let spec = table2::SCENES
            .iter()
            .find(|s| s.name == name)
            .with_context(|| format!("unknown scene `{name}` (cornell, buddha, buddha1m, sponza)"))?;
        tables.push(table2::run_scene(spec, ctx.as_ref(), &opts, &a.out, &progress)?);
    }
    progress.finish();
    let md = table2::markdown(&tables);
    let device = ctx
        .as_ref()
        .and_then(Engine::context)
        .map_or("no GPU".to_string(), |c| {
            format!(
                "{} ({} {}, Vulkan {})",
                c.info.name, c.info.driver_name, c.info.driver_info, c.info.api_version
            )
        });
    let text = format!("Device: {device}; CPU: {} threads.\n{md}", rayon::current_num_threads());
    std::fs::write(a.out.join("table2.md"), &text).context("writing table2.md")?;
    output::write_json(&a.out.join("table2.json"), &tables)?;
    println!("{text}");
    Ok(())
}
