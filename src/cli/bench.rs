//! `meshrad bench accuracy` and `meshrad bench table2`.

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::{Context as _, Result};
use clap::{Args, Subcommand};

use crate::bench::{accuracy, plot, table2};
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
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Args, Debug)]
pub struct Table2Args {
    /// Scenes (cornell, buddha, buddha1m, sponza; comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "cornell,buddha,buddha1m,sponza")]
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

fn gpu(device: Option<&str>) -> Result<Arc<Context>> {
    Ok(Arc::new(Context::new(&ContextOptions::from_env(
        device.map(String::from),
    ))?))
}

pub fn run(cmd: BenchCommand) -> Result<()> {
    match cmd {
        BenchCommand::Accuracy(a) => run_accuracy(a),
        BenchCommand::Table2(a) => run_table2(a),
    }
}

fn run_accuracy(a: AccuracyArgs) -> Result<()> {
    let progress = Progress::new(a.quiet);
    output::ensure_dir(&a.out)?;
    let mut backends = Vec::new();
    if a.backend != Backends::Gpu {
        backends.push(None);
    }
    if a.backend != Backends::Cpu {
        backends.push(Some(gpu(a.device.as_deref())?));
    }
    let opts = accuracy::AccuracyOptions {
        probes: a.probes,
        reference_samples: a.reference_samples,
        pathtrace_samples: a.pathtrace.clone(),
        quick: a.quick,
        defaults_only: a.defaults_only,
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
    let mut all = Vec::new();
    for (name, (scene, params)) in scenes {
        let rows = accuracy::sweep(&name, &scene, &params, &backends, &opts, &a.out, &progress)?;
        let png = a.out.join(format!("{name}.png"));
        plot::error_vs_time(&rows, &format!("{name}: error against time"), &png)?;
        all.extend(rows);
    }
    progress.finish();
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

/// The error at the scene's defaults with its bias figures, and the times to reach 5 %
/// and 2 % relative RMS per scene and series.
fn summary(rows: &[accuracy::Row]) -> String {
    let mut s = String::from(
        "| scene | backend | rel-RMS (area, converged) | median e/r | mean e/r | energy e/r | off > 3× | \
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

fn run_table2(a: Table2Args) -> Result<()> {
    let progress = Progress::new(a.quiet);
    output::ensure_dir(&a.out)?;
    let ctx = match gpu(a.device.as_deref()) {
        Ok(c) => Some(c),
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
    let mut tables = Vec::new();
    for name in &a.scenes {
        let spec = table2::SCENES
            .iter()
            .find(|s| s.name == name)
            .with_context(|| format!("unknown scene `{name}` (cornell, buddha, buddha1m, sponza)"))?;
        tables.push(table2::run_scene(spec, ctx.clone(), &opts, &a.out, &progress)?);
    }
    progress.finish();
    let md = table2::markdown(&tables);
    let device = ctx.as_ref().map_or("no GPU".to_string(), |c| {
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
