//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub mod gltf;
pub mod room;

use std::path::{Path, PathBuf};

use meshrad::progress::Progress;
use meshrad::{Hierarchy, Scene, Solution, SolverParams};

/// A fresh temporary directory that lives as long as the returned guard.
pub fn tmpdir() -> tempfile::TempDir {
    tempfile::tempdir().expect("temporary directory")
}

/// Loads a scene file with `[solver]` overrides given as `key=value` TOML snippets.
pub fn load(path: &Path, overrides: &[(&str, &str)]) -> (Scene, SolverParams) {
    let o: Vec<(String, toml::Value)> = overrides
        .iter()
        .map(|(k, v)| {
            let t: toml::Table = toml::from_str(&format!("v = {v}")).expect("override value");
            (k.to_string(), t["v"].clone())
        })
        .collect();
    Scene::load(path, &o).unwrap_or_else(|e| panic!("loading {}: {e}", path.display()))
}

/// Hierarchy and CPU solution of a scene.
pub fn solve_cpu(scene: &Scene, params: &SolverParams) -> (Hierarchy, Solution) {
    let r = meshrad::solve(scene, params, &mut meshrad::Engine::cpu(), &Progress::hidden()).expect("solve");
    (r.hierarchy, r.solution)
}

/// Path of a file of the public test scenes (`$MESHRAD_SCENES`, default
/// `../shared/scenes` from the repository root, where cargo runs the tests).
pub fn shared_scene(rel: &str) -> PathBuf {
    meshrad::scene::source::scenes_dir().join(rel)
}

/// Relative error.
pub fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-30)
}

/// The link counts of a solve with `link_memory` MiB and `rays` rays per integral
/// (`full`: room for fewer nodes than were gathered): links served integrals (more than
/// were traced when there was room for all), the full case traced some for want of
/// room, and the bytes held are the nodes' records, `per_link` bytes a link (between
/// `per_link.0` and `per_link.1` on average: the CPU keeps 8 where a node's hits are all
/// untextured, 16 otherwise; the GPU 16).
pub fn check_link_counts(
    l: &meshrad::transport::links::LinkStats,
    mib: u32,
    full: bool,
    rays: u64,
    per_link: (u64, u64),
) {
    assert!(
        l.integrals_linked > if full { 0 } else { l.integrals_traced },
        "link_memory {mib}: links served {} integrals, traced {}",
        l.integrals_linked,
        l.integrals_traced
    );
    assert_eq!(l.integrals_traced_full > 0, full, "link_memory {mib}: {l:?}");
    assert!(l.bytes <= l.capacity_bytes, "{l:?}");
    assert!(
        (l.nodes * rays * per_link.0..=l.nodes * rays * per_link.1).contains(&l.bytes),
        "{per_link:?} bytes a link: {l:?}"
    );
}
