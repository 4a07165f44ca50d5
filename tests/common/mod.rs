//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub mod gltf;
pub mod room;

use std::path::{Path, PathBuf};

use meshrad::progress::Progress;
use meshrad::{Hierarchy, Scene, Solution, SolverParams};

/// A Vulkan context with validation on (`MESHRAD_TEST_DEVICE` picks the device; lavapipe
/// in CI, where a missing device fails the test).
pub fn gpu_context() -> std::sync::Arc<meshrad::gpu::Context> {
    let ctx = meshrad::gpu::Context::new(&meshrad::gpu::ContextOptions {
        validation: true,
        device: std::env::var("MESHRAD_TEST_DEVICE").ok(),
    })
    .unwrap_or_else(|e| panic!("no usable Vulkan device with validation: {e}"));
    eprintln!(
        "device: {} ({} {})",
        ctx.info.name, ctx.info.driver_name, ctx.info.driver_info
    );
    std::sync::Arc::new(ctx)
}

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
/// untextured, 16 otherwise; the GPU 16), a node `rays` links or, on level 1,
/// `level1_rays` (the default) times that; the linked integrals stand for at least
/// `rays` rays each.
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
    let level1 = meshrad::SolverParams::default().level1_rays as u64;
    assert!(l.rays_linked >= l.integrals_linked * rays, "{l:?}");
    assert!(
        (l.nodes * rays * per_link.0..=l.nodes * rays * level1 * per_link.1).contains(&l.bytes),
        "{per_link:?} bytes a link: {l:?}"
    );
}

/// A finished run of the `meshrad` binary: exit code, output, and peak resident memory.
pub struct Ran {
    pub code: i32,
    pub stdout: String,
    pub stderr: String,
    /// The process's peak resident set in bytes, `VmHWM` as it reported it at its end
    /// (`MESHRAD_REPORT_PEAK`; [`meshrad_bounded`] reads it).
    pub peak: u64,
}

/// What a run may hold beyond its `--max-memory`: the binary, its libraries, thread
/// stacks and what the limit does not plan (a tiny scene peaks at about 11 MB here).
pub const MEMORY_SLACK: u64 = 64 << 20;

/// The `--max-memory` a bounded run gets when its arguments name none (through
/// `MESHRAD_MAX_MEMORY`), so that its peak is held to a bound that means something.
pub const TEST_MAX_MEMORY: &str = "256M";

/// Runs `meshrad args…` in `cwd` with `stdin`, and checks what every run must do: it
/// exits (no signal) without a panic, and its peak resident memory, measured, stays
/// within its `--max-memory` (the argument, else [`TEST_MAX_MEMORY`]) plus
/// [`MEMORY_SLACK`].
pub fn meshrad_bounded(cwd: &Path, args: &[&str], stdin: &[u8]) -> Ran {
    let limit = args
        .iter()
        .position(|a| *a == "--max-memory")
        .and_then(|i| args.get(i + 1))
        .copied()
        .unwrap_or(TEST_MAX_MEMORY);
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_meshrad"));
    cmd.args(args)
        .current_dir(cwd)
        .env("MESHRAD_MAX_MEMORY", TEST_MAX_MEMORY)
        .env("MESHRAD_REPORT_PEAK", "1");
    let mut ran = run_measured(&mut cmd, stdin);
    // The peak the process read of itself at its end (`wait4`'s `ru_maxrss` would count
    // this test process's memory too: the child is spawned from it); the line is not the
    // test's to see.
    const PEAK: &str = "meshrad: peak resident memory ";
    let line = ran
        .stderr
        .lines()
        .rev()
        .find(|l| l.starts_with(PEAK))
        .map(str::to_string);
    if let Some(line) = line {
        let kib: u64 = line[PEAK.len()..]
            .trim_end_matches(" KiB")
            .parse()
            .expect("a peak in KiB");
        ran.peak = kib << 10;
        ran.stderr = ran.stderr.replacen(&format!("{line}\n"), "", 1);
    } else {
        // Clap's own exits (bad arguments) end before the report: nothing was loaded.
        assert_eq!(ran.code, 2, "no peak reported for {args:?}: {}", ran.stderr);
    }
    assert!(!ran.stderr.contains("panicked"), "panic for {args:?}: {}", ran.stderr);
    // A value that is no byte count is refused, under the default.
    let bound = meshrad::limits::parse_bytes(limit)
        .or_else(|_| meshrad::limits::parse_bytes(TEST_MAX_MEMORY))
        .expect("a byte count")
        + MEMORY_SLACK;
    assert!(
        ran.peak <= bound,
        "{args:?} peaked at {} MiB, above --max-memory {limit} + {} MiB",
        ran.peak >> 20,
        MEMORY_SLACK >> 20
    );
    ran
}

/// Runs `cmd` with `stdin` to its end: its exit code (a signal fails the test) and output
/// (`peak` is left 0: [`meshrad_bounded`] reads it from the process's own report).
pub fn run_measured(cmd: &mut std::process::Command, stdin: &[u8]) -> Ran {
    use std::io::{Read, Write};
    use std::process::Stdio;
    let mut child = cmd
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the command starts");
    let mut i = child.stdin.take().unwrap();
    let input = stdin.to_vec();
    // The child may exit before reading it all (a broken pipe is no failure).
    let writer = std::thread::spawn(move || drop(i.write_all(&input)));
    let read = |mut r: Box<dyn Read + Send>| {
        std::thread::spawn(move || {
            let mut v = Vec::new();
            let _ = r.read_to_end(&mut v);
            String::from_utf8_lossy(&v).into_owned()
        })
    };
    let out = read(Box::new(child.stdout.take().unwrap()));
    let err = read(Box::new(child.stderr.take().unwrap()));
    let status = child.wait().expect("wait");
    let _ = writer.join();
    let (stdout, stderr) = (out.join().unwrap(), err.join().unwrap());
    let code = status.code().unwrap_or_else(|| {
        panic!(
            "killed by a signal ({status}) for {:?}: {stderr}",
            cmd.get_args().collect::<Vec<_>>()
        )
    });
    Ran {
        code,
        stdout,
        stderr,
        peak: 0,
    }
}

/// [`meshrad_bounded`] as a [`std::process::Output`], for tests written against one.
pub fn meshrad_output(cwd: &Path, args: &[&str], stdin: &[u8]) -> std::process::Output {
    use std::os::unix::process::ExitStatusExt;
    let r = meshrad_bounded(cwd, args, stdin);
    std::process::Output {
        status: std::process::ExitStatus::from_raw(r.code << 8),
        stdout: r.stdout.into_bytes(),
        stderr: r.stderr.into_bytes(),
    }
}
