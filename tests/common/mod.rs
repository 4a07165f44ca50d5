//! Helpers shared by the integration tests.
#![allow(dead_code)]

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
    let r = meshrad::solve(scene, params, None, &Progress::hidden()).expect("solve");
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
