//! Memory planning: what a solve of a scene will need, estimated and checked against the
//! run's limits before any work.

use std::path::Path;

use super::Camera;
use crate::error::Result;
use crate::limits::{Limits, Part};
use crate::params::SolverParams;

/// The memory a solve of this scene will plan for, checked against `limits` before any
/// work: triangles, the hierarchy's candidates and nodes (their counts follow from
/// `coarsest`, `levels`, `candidate_factor` and `max_candidates` alone), rays in flight
/// and the image. Returns the estimate in bytes; the error blames the largest part.
pub(crate) fn plan_memory(
    limits: &Limits,
    path: &Path,
    triangles: usize,
    p: &SolverParams,
    camera: &Camera,
    objects: usize,
) -> Result<f64> {
    use crate::limits::{BYTES_PER_CANDIDATE, BYTES_PER_NODE, BYTES_PER_PIXEL, BYTES_PER_TRIANGLE};
    let m = p.levels as i32;
    // Level l holds about coarsest × 4^l nodes (r_l = r_0 / 2^l).
    let nodes = p.coarsest as f64 * (4f64.powi(m) - 1.0) / 3.0;
    let finest = p.coarsest as f64 * 4f64.powi(m - 1);
    let candidates = (p.candidate_factor as f64 * finest).min(objects as f64 * p.max_candidates as f64);
    let threads = rayon::current_num_threads() as f64;
    let pixels = camera.width as f64 * camera.height as f64;
    let parts = [
        (
            "object",
            format!("{triangles} triangles"),
            triangles as f64 * BYTES_PER_TRIANGLE as f64,
        ),
        (
            "solver.coarsest",
            format!(
                "{:.3e} hierarchy nodes (coarsest = {}, levels = {m})",
                nodes, p.coarsest
            ),
            nodes * BYTES_PER_NODE as f64,
        ),
        (
            "solver.candidate_factor",
            format!("{candidates:.3e} candidates"),
            candidates * BYTES_PER_CANDIDATE as f64,
        ),
        (
            "solver.rays",
            format!("{} rays per integral on {threads} threads", p.rays),
            p.rays as f64 * 64.0 * threads,
        ),
        (
            "camera.width",
            format!("a {}×{} image", camera.width, camera.height),
            pixels * BYTES_PER_PIXEL as f64,
        ),
    ];
    let largest = parts
        .iter()
        .max_by(|a, b| a.2.total_cmp(&b.2))
        .map(|p| p.0)
        .unwrap_or("solver");
    let list: Vec<Part> = parts
        .iter()
        .map(|(_, what, bytes)| Part {
            what: what.clone(),
            bytes: *bytes,
        })
        .collect();
    limits.check(path, largest, &list)?;
    Ok(list.iter().map(|p| p.bytes).sum())
}
