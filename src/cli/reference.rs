//! `meshrad reference`: the brute-force Monte Carlo reference at probe points (CSV, same
//! columns as `probe` plus standard errors) or from the camera (images).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Result;
use clap::Args;
use glam::Vec3;
use rayon::prelude::*;

use crate::output::{self, image, probe};
use crate::progress::Progress;
use crate::reference::{self, ReferenceOptions};
use crate::scene::Scene;

#[derive(Args, Debug)]
pub struct ReferenceArgs {
    /// Scene file (TOML).
    scene: PathBuf,
    /// Points file (`px py pz nx ny nz` per line): writes CSV.
    #[arg(long, conflicts_with = "camera")]
    points: Option<PathBuf>,
    /// Render the scene's camera instead: writes direct/indirect/total images.
    #[arg(long)]
    camera: bool,
    /// CSV file (points; default stdout) or directory (camera; default `out-reference`).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Paths per point (per pixel with --camera).
    #[arg(long)]
    samples: Option<u32>,
    /// Bounces of the series (default 0: unbounded with Russian roulette, the converged
    /// answer).
    #[arg(long)]
    max_bounces: Option<u32>,
    /// Seed (independent of the solver's).
    #[arg(long, default_value_t = 0x5eed)]
    seed: u64,
    #[arg(long, short)]
    quiet: bool,
}

/// Most paths per point or pixel.
pub const MAX_SAMPLES: u32 = 1 << 24;
/// Most paths of one run (about a day of path tracing on two cores).
pub const MAX_PATHS: u64 = 1 << 37;

/// Refuses a run of more than [`MAX_PATHS`] paths, with the estimate.
pub fn check_work(count: u64, samples: u32, what: &str) -> Result<()> {
    let paths = count * samples as u64;
    if paths > MAX_PATHS {
        anyhow::bail!(
            "--samples {samples}: {count} {what} × {samples} paths = {paths:.3e} paths, over the {MAX_PATHS:.3e} \
             one run may trace; lower --samples",
            paths = paths as f64,
            MAX_PATHS = MAX_PATHS as f64
        );
    }
    Ok(())
}

pub fn run(a: ReferenceArgs) -> Result<()> {
    let samples = a.samples.unwrap_or(if a.camera { 256 } else { 16384 });
    if !(2..=MAX_SAMPLES).contains(&samples) {
        anyhow::bail!("--samples {samples}: must be within 2..={MAX_SAMPLES} (a standard error needs two samples)");
    }
    let (scene, _) = Scene::load(&a.scene, &[])?;
    let opts = ReferenceOptions {
        samples,
        max_bounces: a.max_bounces.unwrap_or(0),
        seed: a.seed,
        ..Default::default()
    };
    let progress = Progress::new(a.quiet);
    let t = Instant::now();
    if let Some(points) = &a.points {
        let probes = probe::read(points)?;
        check_work(probes.len() as u64, samples, "points")?;
        if let Some(p) = &a.out {
            let mut inputs = scene.report.inputs.clone();
            inputs.push(points.clone());
            output::check_outputs(&[("--out", p.clone())], &inputs)?;
        }
        progress.stage(&format!("{} points × {} paths", probes.len(), opts.samples));
        let pts: Vec<(Vec3, Vec3)> = probes.iter().map(|q| (q.p, q.n)).collect();
        let est = reference::indirect_many(&scene, &pts, &opts);
        let direct: Vec<Vec3> = probes.par_iter().map(|q| scene.direct(q.p, q.n)).collect();
        let text = probe::reference_csv(&probes, &direct, &est);
        progress.finish();
        match &a.out {
            Some(p) => output::write_bytes(p, text.into_bytes())?,
            None => print!("{text}"),
        }
    } else if a.camera {
        let dir = a.out.clone().unwrap_or_else(|| PathBuf::from("out-reference"));
        let pixels = scene.camera.width as u64 * scene.camera.height as u64;
        check_work(pixels, samples, "pixels")?;
        output::ensure_dir(&dir)?;
        let planned: Vec<(&str, PathBuf)> = image::file_names(&dir).into_iter().map(|p| ("an image", p)).collect();
        output::check_outputs(&planned, &scene.report.inputs)?;
        progress.stage(&format!("camera, {} paths per pixel", opts.samples));
        let img = image::reference_image(&scene, &opts, &progress);
        image::write_all(&dir, &img, image::Exposure::default())?;
        progress.finish();
        if !a.quiet {
            println!(
                "reference images in {} ({:.1} s)",
                dir.display(),
                t.elapsed().as_secs_f64()
            );
        }
    } else {
        anyhow::bail!("give --points FILE or --camera");
    }
    Ok(())
}
