//! The crate's layers (docs/ARCHITECTURE.md, "Layers"): which top-level module of `src/`
//! may name which. Reads every `.rs` file below `src/` and fails on a `crate::X` path, in
//! code (comments aside), that the table does not allow, naming the file and line. So the
//! Vulkan wrapper (`gpu`) never reaches the method, and the method never reaches the
//! layers that run it.

use std::collections::BTreeMap;
use std::path::Path;

/// Below everything: may be named by every module.
const FOUNDATION: &[&str] = &["constants", "error", "params", "layout", "limits", "progress", "geom"];

/// Each module and what it may name besides the foundation (and itself). A module not
/// listed here fails the test, so a new one is placed in the table when it is added.
fn allowed() -> BTreeMap<&'static str, Vec<&'static str>> {
    let method = ["scene", "hierarchy", "transport"];
    let mut t: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    // The foundation names only itself, and not every part of it all of it; the test
    // keeps it below the method.
    for f in FOUNDATION {
        t.insert(f, vec![]);
    }
    t.insert("gpu", vec![]);
    t.insert("scene", vec![]);
    t.insert("hierarchy", vec!["scene"]);
    t.insert("transport", vec!["scene", "hierarchy"]);
    t.insert("reference", vec!["scene"]);
    t.insert("metrics", vec!["reference"]);
    t.insert("analytic", vec![]);
    t.insert("device", [&method[..], &["gpu"]].concat());
    t.insert("engine", [&method[..], &["gpu", "device"]].concat());
    t.insert("run", [&method[..], &["gpu", "device", "engine"]].concat());
    t.insert("editor", [&method[..], &["device", "engine", "run"]].concat());
    t.insert("output", [&method[..], &["reference", "engine"]].concat());
    let everything_below_cli = [
        &method[..],
        &[
            "gpu",
            "device",
            "engine",
            "run",
            "solve",
            "editor",
            "output",
            "reference",
            "metrics",
            "analytic",
        ],
    ]
    .concat();
    t.insert("bench", everything_below_cli.clone());
    t.insert("cli", [&everything_below_cli[..], &["bench"]].concat());
    // The Python module (feature `python`) calls what the CLI calls, and the CLI's checks.
    t.insert("python", [&everything_below_cli[..], &["bench", "cli"]].concat());
    t.insert("lib", vec![]);
    t.insert("main", vec![]);
    t
}

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// Every `crate::NAME` in `line`'s code (before a `//`).
fn crate_paths(line: &str) -> Vec<String> {
    let code = line.split("//").next().unwrap_or("");
    code.match_indices("crate::")
        .filter(|(i, _)| !code[..*i].ends_with('$')) // `$crate::` in macros is the same crate
        .map(|(i, m)| {
            code[i + m.len()..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect()
        })
        .collect()
}

#[test]
fn modules_name_only_the_layers_below_them() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    assert!(
        files.len() > 50,
        "found only {} files below {}",
        files.len(),
        src.display()
    );
    let table = allowed();
    let mut bad = Vec::new();
    for f in &files {
        let rel = f.strip_prefix(&src).unwrap();
        let top = rel.components().next().unwrap().as_os_str().to_string_lossy();
        let top = top.trim_end_matches(".rs").to_string();
        let Some(ok) = table.get(top.as_str()) else {
            bad.push(format!(
                "src/{}: module `{top}` has no row in the layer table",
                rel.display()
            ));
            continue;
        };
        let text = std::fs::read_to_string(f).unwrap();
        for (n, line) in text.lines().enumerate() {
            let trimmed = line.trim_start();
            if trimmed.starts_with("//") || trimmed.starts_with("#[doc") {
                continue;
            }
            for name in crate_paths(line) {
                let fine = name.is_empty()
                    || name == top
                    || ok.contains(&name.as_str())
                    || FOUNDATION.contains(&name.as_str())
                    // Names re-exported at the crate root by lib.rs (`crate::Result`, …).
                    || name.starts_with(char::is_uppercase);
                if !fine {
                    bad.push(format!("src/{}:{}: `{top}` names crate::{name}", rel.display(), n + 1));
                }
            }
        }
    }
    assert!(bad.is_empty(), "layer violations:\n{}", bad.join("\n"));
}

#[test]
fn the_checker_sees_a_violation() {
    // The parser the test relies on: code paths found, comments and `$crate` ignored.
    assert_eq!(crate_paths("use crate::scene::Scene; // crate::bench"), vec!["scene"]);
    assert_eq!(
        crate_paths("pub struct X($crate::gpu::pipeline::Kernel);"),
        Vec::<String>::new()
    );
    assert_eq!(crate_paths("let r = crate::solve(&s);"), vec!["solve"]);
    let t = allowed();
    assert!(!t["gpu"].contains(&"scene") && !t["gpu"].contains(&"transport"));
    assert!(!t["scene"].contains(&"hierarchy") && !t["transport"].contains(&"device"));
}
