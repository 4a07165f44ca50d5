//! `meshrad bench accuracy`'s image front (issue #33): the camera image's error against a
//! converged reference image, over all pixels (edges included) and away from edges,
//! against its end-to-end time, for meshrad at increasing samples per pixel on each
//! backend and for path tracing at increasing paths per pixel on the same machine: the
//! project's reference renderer, and Mitsuba 3 where it is installed ([`super::mitsuba`]).
//! The reference is two independent path-traced images
//! (seeds 1 and 2, cached in the output folder); their difference takes the reference's
//! own noise out of each error ([`crate::metrics::image_error`]).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::Vec3;
use serde::Serialize;

use crate::engine::Engine;
use crate::error::{Error, Result};
use crate::metrics::{image_error, ImageError};
use crate::output::image::{self, Images};
use crate::output::Outputs;
use crate::params::SolverParams;
use crate::progress::Progress;
use crate::reference::ReferenceOptions;
use crate::scene::Scene;

/// What the image front measures.
#[derive(Clone, Debug)]
pub struct ImageOptions {
    /// Paths per pixel of each of the two reference images (0: no image front).
    pub reference_samples: u32,
    /// meshrad's samples per pixel.
    pub spp: Vec<u32>,
    /// Path tracing's paths per pixel (the baseline).
    pub pathtrace: Vec<u32>,
    /// Mitsuba 3's paths per pixel (where it is installed; empty: none).
    pub mitsuba: Vec<u32>,
}

/// One point of the image front.
#[derive(Clone, Debug, Serialize)]
pub struct ImageRow {
    pub scene: String,
    /// `meshrad`, `pathtrace` (this project's reference renderer) or `mitsuba`.
    pub method: String,
    pub backend: String,
    /// Samples (meshrad) or paths (path tracing) per pixel.
    pub spp: u32,
    /// End to end from a loaded scene: meshrad's hierarchy, solve and image; path
    /// tracing's image.
    pub seconds: f64,
    /// Of `seconds`: the image alone.
    pub seconds_image: f64,
    /// The total image's error.
    pub total: ImageError,
    /// The indirect image's error (not measured for Mitsuba: NaN).
    pub indirect: ImageError,
    pub pareto: bool,
}

/// The two reference images of `scene` at `samples` paths per pixel, from the cache in
/// `dir` or rendered (and cached as EXR: direct, indirect and total of each seed).
fn references(scene: &Scene, name: &str, samples: u32, dir: &Path, progress: &Progress) -> Result<[Images; 2]> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let one = |seed: u64| -> Result<Images> {
        let sub = dir.join(format!("{name}-image-reference-{w}x{h}-{samples}-seed{seed}"));
        if let (Ok(d), Ok(i)) = (
            read_exr(&sub.join("direct.exr"), w, h),
            read_exr(&sub.join("indirect.exr"), w, h),
        ) {
            return Ok(Images {
                width: w,
                height: h,
                direct: d,
                indirect: i,
                clamped: 0,
                doubted_samples: 0,
                basis_samples: 0,
                device: None,
            });
        }
        progress.stage(&format!(
            "{name}: reference image, {samples} paths a pixel, seed {seed}"
        ));
        let opts = ReferenceOptions {
            samples,
            seed,
            ..Default::default()
        };
        let img = image::reference_image(scene, &opts, progress);
        std::fs::create_dir_all(&sub).map_err(|e| Error::io(&sub, e))?;
        image::write_all(&sub, &img, image::Exposure::default())?;
        Ok(img)
    };
    Ok([one(1)?, one(2)?])
}

/// An EXR of `w × h` pixels as linear RGB.
fn read_exr(path: &PathBuf, w: u32, h: u32) -> std::result::Result<Vec<Vec3>, String> {
    let img = ::image::open(path).map_err(|e| e.to_string())?.to_rgb32f();
    if img.width() != w || img.height() != h {
        return Err("size".into());
    }
    Ok(img.pixels().map(|p| Vec3::new(p[0], p[1], p[2])).collect())
}

/// The image front of one scene: meshrad at `opts.spp` samples per pixel on each backend
/// (one solve per backend, timed from the loaded scene; an image per count), then path
/// tracing at `opts.pathtrace` paths per pixel, each against the same two references.
pub fn front(
    name: &str,
    scene: &Scene,
    params: &SolverParams,
    backends: &[Engine],
    opts: &ImageOptions,
    dir: &Path,
    progress: &Progress,
) -> Result<Vec<ImageRow>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let [a, b] = references(scene, name, opts.reference_samples, dir, progress)?;
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let (ta, tb) = (a.total(), b.total());
    let errors = |img: &Images| {
        (
            image_error(&img.total(), &ta, &tb, w, h),
            image_error(&img.indirect, &a.indirect, &b.indirect, w, h),
        )
    };
    let hidden = Progress::hidden();
    let mut rows = Vec::new();
    for engine in backends {
        let mut engine = engine.fresh();
        let backend = engine
            .context()
            .map_or("cpu".to_string(), |c| format!("gpu ({})", c.info.name));
        progress.stage(&format!("{name}: image front, meshrad on {backend}"));
        let t = Instant::now();
        let run = crate::solve(scene, params, &mut engine, &hidden)?;
        let solve = t.elapsed().as_secs_f64();
        for &spp in &opts.spp {
            let mut s = scene.clone();
            s.camera.spp = spp;
            let t = Instant::now();
            let img = image::render_on(&mut engine, &s, &run.hierarchy, &run.solution, params, &hidden)?;
            let seconds_image = t.elapsed().as_secs_f64();
            let (total, indirect) = errors(&img);
            rows.push(ImageRow {
                scene: name.into(),
                method: "meshrad".into(),
                backend: backend.clone(),
                spp,
                seconds: solve + seconds_image,
                seconds_image,
                total,
                indirect,
                pareto: false,
            });
        }
    }
    for &paths in &opts.pathtrace {
        progress.stage(&format!("{name}: image front, path tracing {paths} paths a pixel"));
        let o = ReferenceOptions {
            samples: paths,
            seed: 0xba5e + paths as u64,
            ..Default::default()
        };
        let t = Instant::now();
        let img = image::reference_image(scene, &o, &hidden);
        let seconds = t.elapsed().as_secs_f64();
        let (total, indirect) = errors(&img);
        rows.push(path_tracer_row(
            name,
            "pathtrace",
            "cpu",
            paths,
            seconds,
            total,
            indirect,
        ));
    }
    if !opts.mitsuba.is_empty() {
        match mitsuba_rows(name, scene, &opts.mitsuba, dir, &ta, &tb, progress)? {
            Ok(mut r) => rows.append(&mut r),
            Err(why) => eprintln!("{name}: the image front leaves Mitsuba 3 out: {why}"),
        }
    }
    let snapshot: Vec<(f64, f64)> = rows.iter().map(|r| (r.seconds, r.total.all)).collect();
    for r in rows.iter_mut() {
        r.pareto = !snapshot
            .iter()
            .any(|&(t, e)| t <= r.seconds && e <= r.total.all && (t < r.seconds || e < r.total.all));
    }
    Ok(rows)
}

/// A path tracer's row of the front: its image is its own end to end.
fn path_tracer_row(
    name: &str,
    method: &str,
    backend: &str,
    paths: u32,
    seconds: f64,
    total: ImageError,
    indirect: ImageError,
) -> ImageRow {
    ImageRow {
        scene: name.into(),
        method: method.into(),
        backend: backend.into(),
        spp: paths,
        seconds,
        seconds_image: seconds,
        total,
        indirect,
        pareto: false,
    }
}

/// Mitsuba 3's rows at `counts` paths a pixel (the scene exported into `dir`), against
/// the references `ta` and `tb`; `Ok(Err(why))` where Mitsuba is not installed or the
/// scene cannot be exported. Mitsuba gives the total image only: the indirect error is
/// NaN.
fn mitsuba_rows(
    name: &str,
    scene: &Scene,
    counts: &[u32],
    dir: &Path,
    ta: &[Vec3],
    tb: &[Vec3],
    progress: &Progress,
) -> Result<std::result::Result<Vec<ImageRow>, String>> {
    let version = match super::mitsuba::available() {
        Ok(v) => v,
        Err(why) => return Ok(Err(why)),
    };
    let mdir = dir.join(format!("{name}-mitsuba"));
    if let Err(e) = super::mitsuba::export(scene, &mdir) {
        return Ok(Err(e.to_string()));
    }
    let (w, h) = (scene.camera.width, scene.camera.height);
    let backend = format!("cpu (Mitsuba {version}, llvm_ad_rgb)");
    let mut rows = Vec::new();
    for &paths in counts {
        progress.stage(&format!("{name}: image front, Mitsuba 3 {paths} paths a pixel"));
        let (px, seconds) = super::mitsuba::render(&mdir, paths, 0xba5e + paths, w, h)?;
        let total = image_error(&px, ta, tb, w as usize, h as usize);
        let indirect = ImageError {
            all: f64::NAN,
            smooth: f64::NAN,
            energy: f64::NAN,
            ..total
        };
        rows.push(path_tracer_row(
            name, "mitsuba", &backend, paths, seconds, total, indirect,
        ));
    }
    Ok(Ok(rows))
}

/// A path tracer's (`method`: `pathtrace` or `mitsuba`) time to reach `error` (total
/// image, all pixels), interpolated in log-log between its two rows around it (`None`
/// outside their range).
pub fn pathtrace_time_at(rows: &[ImageRow], scene: &str, method: &str, error: f64) -> Option<f64> {
    let mut pt: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.scene == scene && r.method == method && r.total.all > 0.0)
        .map(|r| (r.total.all, r.seconds))
        .collect();
    pt.sort_by(|a, b| b.0.total_cmp(&a.0));
    pt.windows(2).find_map(|w| {
        let ((e0, t0), (e1, t1)) = (w[0], w[1]);
        (e1 <= error && error <= e0).then(|| {
            let f = (error.ln() - e0.ln()) / (e1.ln() - e0.ln());
            (t0.ln() + f * (t1.ln() - t0.ln())).exp()
        })
    })
}

/// The image front's CSV.
pub fn csv(rows: &[ImageRow]) -> String {
    let mut s = String::from(
        "scene,method,backend,spp,seconds,seconds_image,total_all,total_smooth,total_energy,indirect_all,\
         indirect_smooth,indirect_energy,smooth_pixels,pixels,reference_noise,pareto\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{:.4},{:.4},{:.6},{:.6},{:.5},{:.6},{:.6},{:.5},{},{},{:.6},{}",
            r.scene.replace(',', ";"),
            r.method,
            r.backend.replace(',', ";"),
            r.spp,
            r.seconds,
            r.seconds_image,
            r.total.all,
            r.total.smooth,
            r.total.energy,
            r.indirect.all,
            r.indirect.smooth,
            r.indirect.energy,
            r.total.smooth_pixels,
            r.total.pixels,
            r.total.reference_noise,
            r.pareto
        );
    }
    s
}

/// The image front's summary: per scene and row, the errors and times, and for each
/// meshrad row the time path tracing takes to reach its error over all pixels.
pub fn summary(rows: &[ImageRow]) -> String {
    let mut s = String::from(
        "| scene | method | backend | spp | total: all / smooth | indirect: all / smooth | end to end | image | path tracing at equal error (all pixels) | Mitsuba 3 at equal error |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let equal = |method: &str| {
            if r.method != "meshrad" || !rows.iter().any(|o| o.scene == r.scene && o.method == method) {
                return String::new();
            }
            match pathtrace_time_at(rows, &r.scene, method, r.total.all) {
                Some(t) => format!("{t:.2} s ({:.1}×)", t / r.seconds),
                None => "outside its rows".into(),
            }
        };
        let indirect = if r.indirect.all.is_nan() {
            "–".to_string()
        } else {
            format!("{:.2} / {:.2} %", r.indirect.all * 100.0, r.indirect.smooth * 100.0)
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {:.2} / {:.2} % | {indirect} | {:.2} s | {:.2} s | {} | {} |",
            r.scene,
            r.method,
            r.backend,
            r.spp,
            r.total.all * 100.0,
            r.total.smooth * 100.0,
            r.seconds,
            r.seconds_image,
            equal("pathtrace"),
            equal("mitsuba")
        );
    }
    if let Some(r) = rows.first() {
        let _ = writeln!(
            s,
            "\nReference noise (taken out): {:.2} % of the mean over all {} pixels; smooth pixels: {}.",
            r.total.reference_noise * 100.0,
            r.total.pixels,
            r.total.smooth_pixels
        );
    }
    s
}

/// Writes the front's CSV (`image-front.csv`), summary table (`image-front.md`) and plot
/// (`image-front.png`) into `dir`.
pub fn write(rows: &[ImageRow], dir: &Path) -> Result<()> {
    let mut out = Outputs::default();
    out.add(dir.join("image-front.csv"), csv(rows).into_bytes());
    out.add(dir.join("image-front.md"), summary(rows).into_bytes());
    let series: Vec<(String, Vec<(f64, f64)>)> = {
        let mut keys: Vec<(String, String)> = rows.iter().map(|r| (r.scene.clone(), r.backend.clone())).collect();
        keys.dedup();
        let mut v = Vec::new();
        for (scene, backend) in keys {
            for method in ["meshrad", "pathtrace", "mitsuba"] {
                let pts: Vec<(f64, f64)> = rows
                    .iter()
                    .filter(|r| r.scene == scene && r.backend == backend && r.method == method)
                    .map(|r| (r.seconds, r.total.all * 100.0))
                    .collect();
                if !pts.is_empty() {
                    v.push((format!("{scene} {method} ({backend})"), pts));
                }
            }
        }
        v
    };
    out.commit()?;
    super::plot::lines(
        "the total image's error over all pixels against end-to-end time",
        &series,
        &dir.join("image-front.png"),
    )
}
