//! Benchmarks a user can rerun (`meshrad bench ...`): run time against error
//! ([`accuracy`]) and the paper's Table 2 ([`table2`]). Shared here: probe points (drawn
//! uniformly by area over every surface that can receive light, or where the camera
//! looks), the cached Monte Carlo reference at them, and a timed solve.

pub mod accuracy;
pub mod edit_vs_fresh;
pub mod images;
pub mod mitsuba;
pub mod plot;
pub mod table2;

use std::path::Path;
use std::time::Instant;

use glam::{DVec3, Vec3};
use serde::Serialize;

use crate::engine::Engine;
use crate::error::{Error, Result};
use crate::geom::ray::tri_normal;
use crate::geom::rng::Rng;
use crate::geom::transform::{xform_point, xform_vector};
use crate::hierarchy::Hierarchy;
use crate::output::probe::{self, Probe};
use crate::params::SolverParams;
use crate::progress::Progress;
use crate::reference::{self, Estimate, ReferenceOptions};
use crate::scene::Scene;
use crate::transport::readout::Readout;
use crate::transport::Solution;

/// `n` points drawn uniformly by area over every surface side that can receive light: the
/// solution is the whole scene, not one view. A triangle is drawn with probability
/// proportional to its world-space area and a point uniformly on it; of its two sides,
/// those that can receive light ([`Scene::receives_light`]) are kept, and one of them is chosen
/// at random (a point where neither can is drawn again). Independent of the solver: only
/// the geometry, the materials and the lights decide.
pub fn area_probes(scene: &Scene, n: usize, seed: u64) -> Vec<Probe> {
    let mut cdf = Vec::with_capacity(scene.tris.len());
    let mut owner = Vec::with_capacity(scene.tris.len());
    let mut total = 0.0f64;
    for (o, obj) in scene.objects.iter().enumerate() {
        let s2 = (obj.transform.scale as f64).powi(2);
        for t in &scene.tris[obj.tri_offset as usize..(obj.tri_offset + obj.tri_count) as usize] {
            let (a, b, c) = (
                Vec3::from(t.v0).as_dvec3(),
                Vec3::from(t.v1).as_dvec3(),
                Vec3::from(t.v2).as_dvec3(),
            );
            total += 0.5 * (b - a).cross(c - a).length() * s2;
            cdf.push(total);
            owner.push(o);
        }
    }
    let mut rng = Rng::new(seed, 0xa2ea);
    let mut out = Vec::with_capacity(n);
    let mut tries = 0;
    while out.len() < n && tries < 100 * n.max(1) && total > 0.0 {
        tries += 1;
        let u = rng.next_f64() * total;
        let i = cdf.partition_point(|&c| c <= u).min(cdf.len() - 1);
        let (t, obj) = (&scene.tris[i], &scene.objects[owner[i]]);
        let (u1, u2) = (rng.next_f32().sqrt(), rng.next_f32());
        let (v0, v1, v2) = (Vec3::from(t.v0), Vec3::from(t.v1), Vec3::from(t.v2));
        let p_obj = v0 * (1.0 - u1) + v1 * (u1 * (1.0 - u2)) + v2 * (u1 * u2);
        let p = xform_point(&obj.to_world, p_obj);
        let n = xform_vector(&obj.to_world, tri_normal(t)).normalize_or_zero();
        if n == Vec3::ZERO {
            continue;
        }
        let sides: Vec<Vec3> = [n, -n]
            .into_iter()
            .filter(|&s| scene.receives_light(p, s, &mut rng))
            .collect();
        if sides.is_empty() {
            continue;
        }
        let s = sides[(rng.next_u64() % sides.len() as u64) as usize];
        out.push(Probe { p, n: s });
    }
    out
}

/// `n` probe points where the scene's camera sees a surface: the primary hits of random
/// pixel positions. The error at them is the error a user sees in the image (a second
/// view beside [`area_probes`]).
pub fn camera_probes(scene: &Scene, n: usize, seed: u64) -> Vec<Probe> {
    let cam = &scene.camera;
    let mut rng = Rng::new(seed, 0x9406e);
    let mut out = Vec::with_capacity(n);
    let mut tries = 0;
    while out.len() < n && tries < 100 * n.max(1) {
        tries += 1;
        let ray = cam.ray(rng.next_f32() * cam.width as f32, rng.next_f32() * cam.height as f32);
        if let Some(hit) = scene.intersect(&ray, f32::INFINITY) {
            let s = scene.surface(&hit, ray.d);
            out.push(Probe { p: s.p, n: s.n });
        }
    }
    out
}

/// The reference at the probes, read from `cache` when it was computed with the same
/// probes and options, else computed and written there.
pub fn reference_at(
    scene: &Scene,
    probes: &[Probe],
    opts: &ReferenceOptions,
    cache: &Path,
    progress: &Progress,
) -> Result<(Vec<Estimate>, f64)> {
    let key = format!(
        "# meshrad reference samples={} max_bounces={} seed={}",
        opts.samples, opts.max_bounces, opts.seed
    );
    if let Ok(text) = std::fs::read_to_string(cache) {
        if let Some(est) = parse_cached(&text, &key, probes) {
            return Ok((est, 0.0));
        }
    }
    progress.stage(&format!("reference: {} points × {} paths", probes.len(), opts.samples));
    let t = Instant::now();
    let pts: Vec<(Vec3, Vec3)> = probes.iter().map(|q| (q.p, q.n)).collect();
    let est = reference::indirect_many(scene, &pts, opts);
    let secs = t.elapsed().as_secs_f64();
    let direct: Vec<Vec3> = probes.iter().map(|q| scene.direct(q.p, q.n)).collect();
    let text = format!("{key}\n{}", probe::reference_csv(probes, &direct, &est));
    std::fs::write(cache, text).map_err(|e| Error::io(cache, e))?;
    Ok((est, secs))
}

fn parse_cached(text: &str, key: &str, probes: &[Probe]) -> Option<Vec<Estimate>> {
    let mut lines = text.lines();
    if lines.next()? != key || lines.next()? != probe::REFERENCE_HEADER {
        return None;
    }
    let mut out = Vec::new();
    for (line, q) in lines.zip(probes) {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().ok()).collect::<Option<_>>()?;
        if v.len() != 18
            || (Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32) - q.p).length() > 1e-3 * (1.0 + q.p.length())
        {
            return None;
        }
        out.push(Estimate {
            mean: DVec3::new(v[9], v[10], v[11]),
            std_err: DVec3::new(v[15], v[16], v[17]),
        });
    }
    (out.len() == probes.len()).then_some(out)
}

/// A timed solve.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Measured {
    pub backend: String,
    /// Direct pass plus all bounces, wall clock (the paper's "total time").
    pub seconds: f64,
    /// Wall clock of each bounce.
    pub bounce_seconds: Vec<f64>,
    /// Sum of the GPU kernels' timestamps (GPU only).
    pub seconds_kernels: f64,
    /// The indirect light read at the camera's pixels as the parameters read it (the basis,
    /// or a final gather): the time per probe point times the pixel count.
    pub seconds_output: f64,
    /// Upload and pipeline creation (GPU only; preprocessing).
    pub seconds_setup: f64,
    pub integrals: u64,
    pub rays: u64,
    /// Bytes the links held at the end of the solve (`solve.links.bytes`; `None`: no links).
    pub links_bytes: Option<u64>,
    /// Indirect irradiance at the probes.
    #[serde(skip)]
    pub values: Vec<Vec3>,
}

/// The indirect irradiance at `probes` read from `sol` as `params` ask ([`Readout`]), and
/// that readout's cost for the camera's image: the time per point times the pixel count.
pub fn read_at(
    scene: &Scene,
    h: &Hierarchy,
    sol: &Solution,
    params: &SolverParams,
    probes: &[Probe],
) -> (Vec<Vec3>, f64) {
    use rayon::prelude::*;
    let read = Readout::new(scene, h, sol, params);
    let t = Instant::now();
    let values: Vec<Vec3> = probes.par_iter().map(|q| read.at(q.p, q.n).mean).collect();
    let per_point = t.elapsed().as_secs_f64() / probes.len().max(1) as f64;
    let pixels = (scene.camera.width * scene.camera.height) as f64;
    (values, per_point * pixels)
}

/// Solves `scene` for `params` with hierarchy `h` where `engine` runs and evaluates the
/// probes. With `warmup`, a first solve on the same backend is discarded (lavapipe
/// compiles pipelines at their first dispatch).
pub fn measure(
    scene: &Scene,
    params: &SolverParams,
    h: &Hierarchy,
    engine: &Engine,
    probes: &[Probe],
    warmup: bool,
    progress: &Progress,
) -> Result<(Measured, Solution)> {
    let (sol, gpu) = engine.transport(scene, params, h, warmup as u32, progress)?;
    // Upload and pipelines (preprocessing): the part of the GPU's wall time that is not
    // the solve it reports.
    let setup = gpu
        .as_ref()
        .map(|g| g.seconds_upload + g.seconds_pipelines)
        .unwrap_or(0.0);
    let backend = gpu.as_ref().map(|g| g.device.clone()).unwrap_or_else(|| "cpu".into());
    let st = &sol.stats;
    let (values, seconds_output) = read_at(scene, h, &sol, params, probes);
    let m = Measured {
        backend: if backend == "cpu" {
            backend
        } else {
            format!("gpu ({backend})")
        },
        seconds: st.seconds_direct + st.seconds_init + st.seconds_bounces,
        seconds_output,
        bounce_seconds: st.bounces.iter().map(|b| b.seconds).collect(),
        seconds_kernels: st.kernel_seconds.iter().map(|(_, t)| t).sum(),
        seconds_setup: setup,
        integrals: st.integrals,
        rays: st.rays_gathered,
        links_bytes: st.links.as_ref().map(|l| l.bytes),
        values,
    };
    Ok((m, sol))
}

/// The solved values at the nodes themselves against the converged reference there, per
/// level: a term of the error decomposition that leaves the outputs' interpolation out.
/// A node's value is its own integral where it was gathered and the pull-down of its
/// parents where it was not.
#[derive(Clone, Debug, Default, Serialize)]
pub struct NodeBias {
    pub level: u32,
    pub nodes: usize,
    /// Errors of the node values against the reference at the node centres.
    pub error: crate::metrics::ErrorStats,
}

/// [`NodeBias`] for up to `per_level` nodes of each level, drawn at random (`seed`).
pub fn node_bias(
    scene: &Scene,
    h: &Hierarchy,
    sol: &Solution,
    per_level: usize,
    opts: &ReferenceOptions,
    seed: u64,
) -> Vec<NodeBias> {
    use glam::Vec4Swizzles;
    let mut rng = Rng::new(seed, 0x0de5);
    (0..h.levels as usize)
        .map(|l| {
            let range = h.level_range(l);
            let mut pick: Vec<usize> = range.collect();
            // A partial Fisher–Yates shuffle: the first `per_level` are a uniform draw.
            let k = per_level.min(pick.len());
            for i in 0..k {
                let j = i + (rng.next_u64() % (pick.len() - i) as u64) as usize;
                pick.swap(i, j);
            }
            pick.truncate(k);
            let pts: Vec<(Vec3, Vec3)> = pick
                .iter()
                .map(|&j| crate::transport::cpu::node_world(scene, h, j))
                .collect();
            let refs = reference::indirect_many(scene, &pts, opts);
            let est: Vec<Vec3> = pick
                .iter()
                .map(|&j| {
                    let nd = &h.nodes[j];
                    if sol.variant.is_delta() {
                        crate::transport::reconstruct::delta_sum(
                            h,
                            nd.object as usize,
                            l,
                            Vec3::from(nd.pos),
                            Vec3::from(nd.normal),
                            &sol.values.indirect,
                        )
                    } else {
                        sol.values.indirect[j].xyz()
                    }
                })
                .collect();
            NodeBias {
                level: l as u32,
                nodes: k,
                error: crate::metrics::indirect_error(&est, &refs),
            }
        })
        .collect()
}
