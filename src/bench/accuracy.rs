//! `meshrad bench accuracy`: run time against error. For each scene, points drawn
//! uniformly by area over every surface that can receive light get a converged Monte Carlo
//! reference (the unbounded series, Russian roulette): the primary error, with its bias
//! figures, for all of them and per stratum ([`Strata`]: the points lit only indirectly
//! and the lit ones; the worse stratum is the headline, which the Pareto front and the
//! times to reach a target use). Camera-visible points against a reference cut at the solver's bounces (what
//! this benchmark measured before) are a second view. Then solver configurations are swept — variant × rays per integral, and one
//! parameter at a time around the scene's defaults (coarsest count, levels, gather
//! levels, sender level, oracle threshold) — on each backend, and brute-force path
//! tracing at increasing sample counts gives the baseline. Output: a CSV, a PNG plot of
//! error against time with the Pareto front, and the times to reach 5 % and 2 %.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use glam::Vec3;
use serde::Serialize;

use super::{area_probes, camera_probes, measure, read_at, reference_at, Measured};
use crate::engine::Engine;
use crate::error::{Error, Result};
use crate::hierarchy::Hierarchy;
use crate::metrics::{indirect_error, ErrorStats};
use crate::output::probe::Probe;
use crate::output::write_bytes;
use crate::params::{SolverParams, Variant};
use crate::progress::Progress;
use crate::reference::{self, Estimate, ReferenceOptions};
use crate::scene::Scene;
use crate::transport::coverage::{self, Coverage};
use crate::transport::Solution;

/// Options of a sweep.
#[derive(Clone, Debug)]
pub struct AccuracyOptions {
    pub probes: usize,
    pub reference_samples: u32,
    /// Path-tracing baseline sample counts per point.
    pub pathtrace_samples: Vec<u32>,
    /// A reduced sweep (CI).
    pub quick: bool,
    /// Only the scene's defaults (and the path-tracing baseline, if any).
    pub defaults_only: bool,
    /// The error decomposition ([`decomposition`]) instead of the sweep.
    pub decompose: bool,
    /// Only the configurations with these labels (empty: all).
    pub only: Vec<String>,
}

/// One measured point of the plot.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub scene: String,
    pub method: String,
    pub backend: String,
    pub variant: String,
    pub label: String,
    pub rays: u32,
    pub levels: u32,
    pub coarsest: u32,
    pub gather_levels: u32,
    pub sender_level: u32,
    pub eps_rel: f32,
    /// Solve time (direct + bounces; for path tracing, the camera image's pixel count
    /// times the measured cost per probe point).
    pub seconds: f64,
    /// Of `seconds`: reading the indirect light at the camera's pixels (the basis, or a
    /// final gather), scaled from the time per probe point.
    pub seconds_output: f64,
    pub seconds_kernels: f64,
    pub seconds_hierarchy: f64,
    pub integrals: u64,
    pub rays_traced: u64,
    /// At area-uniform points against the converged reference.
    pub error: ErrorStats,
    /// At camera-visible points against the reference cut at the solver's bounces (none
    /// for path tracing).
    pub error_camera: ErrorStats,
    /// At the area-uniform points, by stratum: lit only indirectly, and lit.
    pub strata: Strata,
    /// At the scene's defaults: the first bounce's light lost to hits without a value.
    pub coverage: Option<Coverage>,
    pub pareto: bool,
}

impl Row {
    /// The figure a row is judged by: the rel-RMS of its worse stratum.
    pub fn headline(&self) -> f64 {
        self.strata.headline().rel_rms
    }
}

/// The error at the area-uniform points by stratum. Points that get no direct light from
/// any source (lights, emitting surfaces, the sky) are where radiosity is needed, and lit
/// points hide their errors behind the exact direct term; so the two are measured apart
/// and the worse is the headline.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Strata {
    /// Points with no direct light: lit only indirectly.
    pub indirect_only: ErrorStats,
    /// Points with direct light.
    pub lit: ErrorStats,
}

impl Strata {
    /// The errors of `estimate` (one value per area point) in each stratum of `area`.
    pub fn of(estimate: &[Vec3], area: &Points) -> Strata {
        let pick = |lit: bool| -> (Vec<Vec3>, Vec<Estimate>) {
            estimate
                .iter()
                .zip(&area.reference)
                .zip(&area.lit)
                .filter(|(_, &l)| l == lit)
                .map(|((e, r), _)| (*e, *r))
                .unzip()
        };
        let (e, r) = pick(false);
        let (el, rl) = pick(true);
        Strata {
            indirect_only: indirect_error(&e, &r),
            lit: indirect_error(&el, &rl),
        }
    }

    /// The stratum with the larger rel-RMS among those with measured points (the lit one
    /// when neither has any).
    pub fn headline(&self) -> &ErrorStats {
        match (self.indirect_only.points, self.lit.points) {
            (0, _) => &self.lit,
            (_, 0) => &self.indirect_only,
            _ if self.indirect_only.rel_rms >= self.lit.rel_rms => &self.indirect_only,
            _ => &self.lit,
        }
    }
}

/// The configurations swept around `base`: (label, parameters).
///
/// Long by design: the list of configurations, one short block each.
pub fn configurations(base: &SolverParams, quick: bool) -> Vec<(String, SolverParams)> {
    // The scene's own settings first: the point a user gets without flags.
    let mut out = vec![("defaults".to_string(), base.clone())];
    let with = |label: String, f: &dyn Fn(&mut SolverParams)| {
        let mut p = base.clone();
        f(&mut p);
        (label, p)
    };
    let rays: &[u32] = if quick {
        &[32, 128]
    } else {
        &[32, 64, 128, 256, 512, 1024]
    };
    for v in Variant::ALL {
        for &r in rays {
            out.push(with(format!("{} rays={r}", v.name()), &|p| {
                p.variant = v;
                p.rays = r;
            }));
        }
    }
    if quick {
        return out;
    }
    for v in [Variant::Modified, Variant::Approx] {
        let n0 = base.coarsest;
        for c in [n0 / 2, n0 * 2] {
            out.push(with(format!("{} coarsest={c}", v.name()), &|p| {
                p.variant = v;
                p.coarsest = c.max(1);
            }));
        }
        for g in [2, 4, 5, 6, 7, 8] {
            if g <= base.levels && g != base.gather_levels() {
                out.push(with(format!("{} gather_levels={g}", v.name()), &|p| {
                    p.variant = v;
                    p.gather_levels = Some(g);
                }));
            }
        }
        for s in [base.sender_level.saturating_sub(1), base.sender_level + 1] {
            if s < base.levels && s != base.sender_level {
                out.push(with(format!("{} sender_level={s}", v.name()), &|p| {
                    p.variant = v;
                    p.sender_level = s;
                }));
            }
        }
        for e in [0.03f32, 0.3] {
            out.push(with(format!("{} eps_rel={e}", v.name()), &|p| {
                p.variant = v;
                p.eps_rel = e;
            }));
        }
        // Combinations towards high accuracy: more nodes everywhere, more levels gathered
        // (0: every level may be gathered where the oracle refines).
        for (c, g, r) in [
            (2, 4, 256),
            (2, 4, 512),
            (4, 4, 512),
            (1, 0, 256),
            (2, 0, 256),
            (2, 0, 512),
            (4, 0, 512),
        ] {
            let c = base.coarsest * c;
            let g = if g == 0 { base.levels } else { g.min(base.levels) };
            out.push(with(
                format!("{} coarsest={c} gather_levels={g} rays={r}", v.name()),
                &|p| {
                    p.variant = v;
                    p.coarsest = c;
                    p.gather_levels = Some(g);
                    p.rays = r;
                },
            ));
        }
        for l in [base.levels - 1, base.levels + 1] {
            if (base.sender_level.min(l - 1) + 1..=crate::params::MAX_LEVELS).contains(&l) && l != base.levels {
                out.push(with(format!("{} levels={l}", v.name()), &|p| {
                    p.variant = v;
                    p.levels = l;
                    p.sender_level = p.sender_level.min(l - 1);
                    p.gather_levels = Some(p.gather_levels().min(l));
                }));
            }
        }
    }
    out
}

/// The error decomposition around `base`: each term of the error switched off or to its
/// exact (or much finer) form, one at a time, so that the change of the error against
/// `defaults` is that term's share (`ALGORITHM.md` §8).
pub fn decomposition(base: &SolverParams) -> Vec<(String, SolverParams)> {
    let with = |label: &str, f: &dyn Fn(&mut SolverParams)| {
        let mut p = base.clone();
        f(&mut p);
        (label.to_string(), p)
    };
    vec![
        with("defaults", &|_| {}),
        // Output interpolation: the last hop traced at the point, the basis read one hop
        // away, with fewer and more rays (every configuration with a final gather is also
        // read from the basis at the point: "LABEL, basis read").
        with("final gather 256", &|p| p.final_gather = 256),
        with("final gather 4096", &|p| p.final_gather = 4096),
        // Sender reconstruction: the exact Shepard sum instead of the first leaf; the
        // finest level instead of the sender level; the first bounce reconstructing the
        // direct light from the nodes instead of reading it exactly (the paper's way).
        with("sender exact", &|p| p.variant = Variant::Modified),
        with("sender finest", &|p| p.sender_level = p.levels - 1),
        with("first bounce reconstructed", &|p| p.exact_first_bounce = false),
        // The construction's decisions.
        with("crevice off", &|p| p.crevice_distance = 0.0),
        with("clip off", &|p| p.support_clip = false),
        with("reach x8", &|p| {
            p.reach_paths = p.reach_paths.saturating_mul(8).min(1 << 28)
        }),
        // The oracle's thresholds, a third of the defaults; the sparse nodes (narrow faces)
        // left to the pull-down, as the paper's oracle leaves them (gathered where a parent
        // is lit by default).
        with("sparse nodes pulled", &|p| p.sparse_parents = 0),
        with("oracle /3", &|p| {
            p.eps_rel /= 3.0;
            p.eps_abs /= 3.0;
        }),
        // The bounce cut: the series summed much further.
        with("series 1e-5", &|p| p.stop_threshold = 1e-5),
        // Monte Carlo noise of the integrals: four times the rays (half the noise).
        with("rays x4", &|p| p.rays = p.rays.saturating_mul(4).min(1 << 16)),
        // Node density: twice the nodes per level.
        with("nodes x2", &|p| p.coarsest = p.coarsest.saturating_mul(2)),
    ]
}

/// Marks the Pareto front (no other row of the scene is both faster and more accurate, by
/// the headline error: the worse stratum).
pub fn mark_pareto(rows: &mut [Row]) {
    let snapshot: Vec<(String, f64, f64)> = rows
        .iter()
        .map(|r| (r.scene.clone(), r.seconds, r.headline()))
        .collect();
    for r in rows.iter_mut() {
        r.pareto = !snapshot.iter().any(|(s, t, e)| {
            *s == r.scene && *t <= r.seconds && *e <= r.headline() && (*t < r.seconds || *e < r.headline())
        });
    }
}

/// Runs the sweep for one scene on the given backends: meshrad at every
/// configuration around `base`, then path tracing at increasing samples, each against the
/// same reference at the same probe points.
pub fn sweep(
    name: &str,
    scene: &Scene,
    base: &SolverParams,
    backends: &[Engine],
    opts: &AccuracyOptions,
    dir: &Path,
    progress: &Progress,
) -> Result<Vec<Row>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let area = Points::new(
        scene,
        area_probes(scene, opts.probes, 0xacc),
        0,
        opts,
        dir,
        name,
        "area",
        progress,
    )?;
    let camera = Points::new(
        scene,
        camera_probes(scene, opts.probes, 0xacc),
        base.bounces,
        opts,
        dir,
        name,
        "camera",
        progress,
    )?;
    let mut rows = meshrad_rows(name, scene, base, backends, opts, &area, &camera, dir, progress)?;
    rows.extend(pathtrace_rows(name, scene, opts, &area, progress));
    mark_pareto(&mut rows);
    Ok(rows)
}

/// Probe points and the reference at them.
pub struct Points {
    pub probes: Vec<Probe>,
    pub reference: Vec<Estimate>,
    /// Whether each point gets direct light from any source ([`Scene::direct`] above 0).
    pub lit: Vec<bool>,
}

impl Points {
    /// The reference at `probes`: the converged series (`max_bounces = 0`) or cut after
    /// `max_bounces`; cached in `dir` under the scene's name and `kind`.
    #[allow(clippy::too_many_arguments)] // one reference's inputs, passed through once
    fn new(
        scene: &Scene,
        probes: Vec<Probe>,
        max_bounces: u32,
        opts: &AccuracyOptions,
        dir: &Path,
        name: &str,
        kind: &str,
        progress: &Progress,
    ) -> Result<Points> {
        let ref_opts = ReferenceOptions {
            samples: opts.reference_samples,
            max_bounces,
            ..Default::default()
        };
        let cut = if max_bounces == 0 {
            "converged".to_string()
        } else {
            format!("{max_bounces}-bounces")
        };
        let cache = dir.join(format!("{name}-{kind}-{cut}-reference.csv"));
        let (reference, _) = reference_at(scene, &probes, &ref_opts, &cache, progress)?;
        let lit = probes
            .iter()
            .map(|q| scene.direct(q.p, q.n).max_element() > 0.0)
            .collect();
        Ok(Points { probes, reference, lit })
    }
}

/// meshrad at every configuration on every backend; a hierarchy is built once per
/// (levels, coarsest) and shared by the configurations that only change the transport.
#[allow(clippy::too_many_arguments)] // one sweep's fixed inputs, passed through once
fn meshrad_rows(
    name: &str,
    scene: &Scene,
    base: &SolverParams,
    backends: &[Engine],
    opts: &AccuracyOptions,
    area: &Points,
    camera: &Points,
    dir: &Path,
    progress: &Progress,
) -> Result<Vec<Row>> {
    let both: Vec<Probe> = area.probes.iter().chain(&camera.probes).copied().collect();
    let mut rows = Vec::new();
    let mut hierarchies: Vec<(String, Hierarchy, f64)> = Vec::new();
    let configs = sweep_configurations(base, opts)?;
    // The last solve on each backend, by its transport parameters: a configuration that
    // only changes how outputs read the solution (final_gather) reuses it.
    let mut last: Vec<Option<(String, Measured, Solution)>> = vec![None; backends.len()];
    for (label, params) in configs {
        let key = format!("{}|{}|{}", params.levels, params.coarsest, params.reach_paths);
        let key = format!("{key}|{}|{}", params.crevice_distance.to_bits(), params.support_clip);
        if !hierarchies.iter().any(|(k, _, _)| *k == key) {
            progress.stage(&format!("{name}: hierarchy {key}"));
            let t = Instant::now();
            let h = Hierarchy::build(scene, &params, &Progress::hidden())?;
            // Kept: the first (the defaults') and the newest; the others' memory goes.
            if hierarchies.len() >= 2 {
                hierarchies.remove(1);
            }
            hierarchies.push((key.clone(), h, t.elapsed().as_secs_f64()));
        }
        let (_, h, th) = hierarchies.iter().find(|(k, _, _)| *k == key).expect("built above");
        let solve_key = {
            let mut q = params.clone();
            q.final_gather = 0;
            serde_json::to_string(&q).expect("parameters serialise")
        };
        for (b, ctx) in backends.iter().enumerate() {
            progress.stage(&format!(
                "{name}: {label} on {}",
                ctx.context().map_or("cpu".into(), |c| c.info.name.clone())
            ));
            let m = match &last[b] {
                Some((k, m, sol)) if *k == solve_key => {
                    let (values, seconds_output) = read_at(scene, h, sol, &params, &both);
                    Measured {
                        values,
                        seconds_output,
                        ..m.clone()
                    }
                }
                _ => {
                    let (m, sol) = measure(scene, &params, h, ctx, &both, ctx.is_gpu(), &Progress::hidden())?;
                    last[b] = Some((solve_key.clone(), m.clone(), sol));
                    m
                }
            };
            let (at_area, at_camera) = m.values.split_at(area.probes.len());
            if opts.decompose || label == "defaults" {
                let slug: String = label
                    .chars()
                    .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                    .collect();
                let file = dir.join(format!(
                    "{name}-{slug}-{}-points.ply",
                    if ctx.is_gpu() { "gpu" } else { "cpu" }
                ));
                write_bytes(&file, error_map(&area.probes, at_area, &area.reference).into_bytes())?;
            }
            let coverage = (label == "defaults").then(|| coverage::first_bounce(scene, h, &params));
            rows.push(Row {
                scene: name.into(),
                method: "meshrad".into(),
                backend: m.backend.clone(),
                variant: params.variant.name().into(),
                label: label.clone(),
                rays: params.rays,
                levels: params.levels,
                coarsest: params.coarsest,
                gather_levels: params.gather_levels(),
                sender_level: params.sender_level,
                eps_rel: params.eps_rel,
                seconds: m.seconds + m.seconds_output,
                seconds_output: m.seconds_output,
                seconds_kernels: m.seconds_kernels,
                seconds_hierarchy: *th,
                integrals: m.integrals,
                rays_traced: m.rays,
                error: indirect_error(at_area, &area.reference),
                error_camera: indirect_error(at_camera, &camera.reference),
                strata: Strata::of(at_area, area),
                coverage,
                pareto: false,
            });
        }
    }
    Ok(rows)
}

/// The sweep's configurations, labelled, as `opts` selects them; in the decomposition,
/// every solve that reads its outputs by a final gather is also read from the basis
/// directly (the same solve): both columns of each term.
fn sweep_configurations(base: &SolverParams, opts: &AccuracyOptions) -> Result<Vec<(String, SolverParams)>> {
    let mut configs = if opts.decompose {
        decomposition(base)
    } else {
        configurations(base, opts.quick)
    };
    if opts.defaults_only {
        configs.truncate(1);
    }
    if let Some(missing) = opts.only.iter().find(|o| !configs.iter().any(|(label, _)| label == *o)) {
        let labels: Vec<String> = configs.iter().map(|(l, _)| format!("`{l}`")).collect();
        return Err(crate::error::Error::param(
            "--only",
            format!("`{missing}` is none of this sweep's labels: {}", labels.join(", ")),
        ));
    }
    if !opts.only.is_empty() {
        configs.retain(|(label, _)| opts.only.iter().any(|o| o == label));
    }
    Ok(configs
        .into_iter()
        .flat_map(|(label, params)| {
            let mut out = vec![(label.clone(), params.clone())];
            if opts.decompose && params.final_gather > 0 {
                let mut q = params;
                q.final_gather = 0;
                out.push((format!("{label}, basis read"), q));
            }
            out
        })
        .collect())
}

/// The per-point error map: an ASCII PLY of the area-uniform points with their reference,
/// estimate and estimate/reference (channel means; the ratio is 0 where the reference is
/// 0), for a viewer that colours points by a property, to see where the deficit and the
/// leaks sit.
pub fn error_map(probes: &[Probe], estimate: &[Vec3], reference: &[Estimate]) -> String {
    let mut s = format!(
        "ply\nformat ascii 1.0\ncomment meshrad bench accuracy: indirect irradiance at area-uniform points\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\n\
         property float ny\nproperty float nz\nproperty float reference\nproperty float reference_se\n\
         property float estimate\nproperty float ratio\nend_header\n",
        probes.len()
    );
    for ((q, e), r) in probes.iter().zip(estimate).zip(reference) {
        let rm = (r.mean.x + r.mean.y + r.mean.z) / 3.0;
        let se = (r.std_err.x + r.std_err.y + r.std_err.z) / 3.0;
        let em = ((e.x + e.y + e.z) / 3.0) as f64;
        let ratio = if rm > 0.0 { em / rm } else { 0.0 };
        let _ = writeln!(
            s,
            "{} {} {} {} {} {} {rm:.6e} {se:.6e} {em:.6e} {ratio:.5}",
            q.p.x, q.p.y, q.p.z, q.n.x, q.n.y, q.n.z
        );
    }
    s
}

/// Path tracing (the unbounded series) at the area-uniform points with independent seeds
/// and increasing samples; its time is scaled from per point to the camera's pixel count.
fn pathtrace_rows(name: &str, scene: &Scene, opts: &AccuracyOptions, area: &Points, progress: &Progress) -> Vec<Row> {
    let pts: Vec<(Vec3, Vec3)> = area.probes.iter().map(|q| (q.p, q.n)).collect();
    let pixels = (scene.camera.width * scene.camera.height) as f64;
    let mut rows = Vec::new();
    for &spp in opts.pathtrace_samples.iter().filter(|&&s| s > 0) {
        progress.stage(&format!("{name}: path tracing {spp} samples"));
        let o = ReferenceOptions {
            samples: spp,
            max_bounces: 0,
            seed: 0xba5e + spp as u64,
            ..Default::default()
        };
        let t = Instant::now();
        let est = reference::indirect_many(scene, &pts, &o);
        let per_point = t.elapsed().as_secs_f64() / pts.len() as f64;
        let values: Vec<Vec3> = est.iter().map(|e| e.mean.as_vec3()).collect();
        rows.push(Row {
            scene: name.into(),
            method: "pathtrace".into(),
            backend: "cpu".into(),
            variant: "-".into(),
            label: format!("path tracing {spp} spp"),
            rays: spp,
            levels: 0,
            coarsest: 0,
            gather_levels: 0,
            sender_level: 0,
            eps_rel: 0.0,
            seconds: per_point * pixels,
            seconds_output: per_point * pixels,
            seconds_kernels: 0.0,
            seconds_hierarchy: 0.0,
            integrals: pts.len() as u64,
            rays_traced: 0,
            error: indirect_error(&values, &area.reference),
            error_camera: ErrorStats::default(),
            strata: Strata::of(&values, area),
            coverage: None,
            pareto: false,
        });
    }
    rows
}

/// The CSV of a sweep.
pub fn csv(rows: &[Row]) -> String {
    let mut s = String::from(
        "scene,method,backend,variant,label,rays,levels,coarsest,gather_levels,sender_level,eps_rel,seconds,\
         seconds_output,seconds_kernels,seconds_hierarchy,integrals,rays_traced,rel_rms,max_rel,reference_noise,points,\
         median_ratio,mean_ratio,energy_ratio,off_3x,below_floor,leak,camera_rel_rms,camera_median_ratio,\
         indirect_only_rel_rms,indirect_only_median_ratio,indirect_only_mean_ratio,indirect_only_energy_ratio,\
         indirect_only_points,lit_rel_rms,lit_median_ratio,lit_mean_ratio,lit_energy_ratio,lit_points,headline_rel_rms,\
         pareto\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{:.6},{:.6},{:.6},{:.6},{},{},{:.6},{:.6},{:.6},{},{:.4},{:.4},{:.4},{},{},{:.4},{:.6},{:.4},{},{}",
            r.scene.replace(',', ";"),
            r.method,
            r.backend.replace(',', ";"),
            r.variant,
            // "LABEL, basis read" would add a column.
            r.label.replace(',', ";"),
            r.rays,
            r.levels,
            r.coarsest,
            r.gather_levels,
            r.sender_level,
            r.eps_rel,
            r.seconds,
            r.seconds_output,
            r.seconds_kernels,
            r.seconds_hierarchy,
            r.integrals,
            r.rays_traced,
            r.error.rel_rms,
            r.error.max_rel,
            r.error.reference_noise,
            r.error.points,
            r.error.median_ratio,
            r.error.mean_ratio,
            r.error.energy_ratio,
            r.error.off_3x,
            r.error.below_floor,
            r.error.leak,
            r.error_camera.rel_rms,
            r.error_camera.median_ratio,
            strata_csv(&r.strata),
            r.pareto
        );
    }
    s
}

/// The CSV columns of the strata: each stratum's rel-RMS, median, mean and energy ratios
/// and points, then the headline rel-RMS.
fn strata_csv(s: &Strata) -> String {
    let one = |e: &ErrorStats| {
        format!(
            "{:.6},{:.4},{:.4},{:.4},{}",
            e.rel_rms, e.median_ratio, e.mean_ratio, e.energy_ratio, e.points
        )
    };
    format!("{},{},{:.6}", one(&s.indirect_only), one(&s.lit), s.headline().rel_rms)
}

/// The least time any row of a method (and variant) reached each target error (headline:
/// the worse stratum) with;
/// `None` when none did.
pub fn time_to_reach(rows: &[Row], targets: &[f64]) -> Vec<(String, Vec<Option<f64>>)> {
    let mut groups: Vec<String> = Vec::new();
    for r in rows {
        let g = group(r);
        if !groups.contains(&g) {
            groups.push(g);
        }
    }
    groups
        .into_iter()
        .map(|g| {
            let times = targets
                .iter()
                .map(|&t| {
                    rows.iter()
                        .filter(|r| group(r) == g && r.headline() <= t)
                        .map(|r| r.seconds)
                        .min_by(f64::total_cmp)
                })
                .collect();
            (g, times)
        })
        .collect()
}

/// The series a row belongs to in the plot and the summary.
pub fn group(r: &Row) -> String {
    if r.method == "pathtrace" {
        "path tracing".into()
    } else {
        format!("{} {}", r.variant, if r.backend == "cpu" { "cpu" } else { "gpu" })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_rows_have_the_header_s_columns() {
        let row = Row {
            scene: "a,b".into(),
            method: "meshrad".into(),
            backend: "cpu".into(),
            variant: "approx".into(),
            label: "defaults, basis read".into(),
            rays: 512,
            levels: 6,
            coarsest: 226,
            gather_levels: 6,
            sender_level: 5,
            eps_rel: 0.1,
            seconds: 1.0,
            seconds_output: 0.5,
            seconds_kernels: 0.0,
            seconds_hierarchy: 0.1,
            integrals: 1,
            rays_traced: 512,
            error: ErrorStats::default(),
            error_camera: ErrorStats::default(),
            strata: Strata::default(),
            coverage: None,
            pareto: false,
        };
        let text = csv(&[row]);
        let lines: Vec<&str> = text.lines().collect();
        let n = lines[0].split(',').count();
        assert_eq!(lines[1].split(',').count(), n, "{text}");
        assert!(lines[1].contains(",defaults; basis read,"), "{text}");
    }

    #[test]
    fn strata_split_the_points_and_the_worse_is_the_headline() {
        let p = |x: f32| Probe {
            p: Vec3::splat(x),
            n: Vec3::Z,
        };
        let r = |v: f64| Estimate {
            mean: glam::DVec3::splat(v),
            std_err: glam::DVec3::ZERO,
        };
        let area = Points {
            probes: (0..4).map(|i| p(i as f32)).collect(),
            reference: vec![r(1.0), r(1.0), r(2.0), r(2.0)],
            lit: vec![true, true, false, false],
        };
        // Lit points exact, the indirect-only ones at half their light.
        let estimate = [Vec3::ONE, Vec3::ONE, Vec3::ONE, Vec3::ONE];
        let s = Strata::of(&estimate, &area);
        assert_eq!((s.lit.points, s.indirect_only.points), (2, 2));
        assert!(s.lit.rel_rms < 1e-12);
        assert!((s.indirect_only.rel_rms - 0.5).abs() < 1e-9);
        assert!((s.indirect_only.median_ratio - 0.5).abs() < 1e-9);
        assert_eq!(s.headline().rel_rms, s.indirect_only.rel_rms);
        // With no indirect-only point, the lit stratum is the headline.
        let all_lit = Points {
            lit: vec![true; 4],
            ..area
        };
        let s = Strata::of(&estimate, &all_lit);
        assert_eq!(s.indirect_only.points, 0);
        assert_eq!(s.headline().points, 4);
    }
}
