//! Mutation fuzzing of the scene (TOML), mesh (OBJ), material (MTL) and points parsers,
//! and of what runs on a scene that loads: a small hierarchy and solve. Each case is a
//! mutated copy of a seed scene written to a temporary directory and loaded in this
//! process; a panic fails the test (and the case is saved), an abort kills it, a case that
//! runs longer than `CASE_LIMIT` aborts it with the case saved.
//!
//! `MESHRAD_FUZZ_SECONDS` (default 60) bounds the run, `MESHRAD_FUZZ_SEED` (default 1)
//! picks the sequence; failing cases go to `target/fuzz-failures/`. For a long run:
//! `MESHRAD_FUZZ_SECONDS=3600 MESHRAD_FUZZ_SEED=$RANDOM cargo test --release --test fuzz -- --nocapture`.

use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use meshrad::limits::Limits;
use meshrad::progress::Progress;
use meshrad::Scene;

const CASE_LIMIT: Duration = Duration::from_secs(60);

const TOML: &str = "[[object]]\nmesh = \"m.obj\"\ntranslate = [0.0, 0.5, 0.0]\nrotate = [0.0, 30.0, 0.0]\nscale = 1.0\n\
tessellate = 1\n\n[[object]]\nmesh = \"m.obj\"\nscale = 2.0\n\n[[light]]\ntype = \"point\"\nposition = [0.2, 3.0, 0.2]\n\
intensity = [1.0, 1.0, 1.0]\n\n[[light]]\ntype = \"spot\"\nposition = [0.0, 2.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\n\
intensity = [5.0, 5.0, 5.0]\ncutoff_angle = 40.0\nbeam_width = 30.0\n\n[[light]]\ntype = \"directional\"\n\
direction = [0.25, -1.0, 0.15]\nirradiance = [2.0, 2.0, 2.0]\n\n[camera]\nposition = [0.0, 1.0, -5.0]\n\
target = [0.0, 0.5, 0.0]\nup = [0.0, 1.0, 0.0]\nfov = 40.0\nwidth = 8\nheight = 8\n\n[solver]\nlevels = 2\n\
coarsest = 12\nrays = 8\nbounces = 1\nsender_level = 1\nvariant = \"approx\"\nreach_paths = 2048\n";

const OBJ: &str = "# a box with a floor\nmtllib m.mtl\no box\nusemtl a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\n\
v 1 0 1\nv 1 1 1\nv 0 1 1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 -1\nf 1/1/1 2/2/1 3/3/1 4/4/1\nf 5/1 8/4 7/3 6/2\n\
f 1 5 6 2\nf 2 6 7 3\nf 3 7 8 4\nf 4 8 5 1\ng floor\nusemtl b\nv -3 -0.01 -3\nv 3 -0.01 -3\nv 3 -0.01 3\nv -3 -0.01 3\n\
f -4 -1 -2\nf -4 -2 -3\n";

const MTL: &str = "newmtl a\nKd 0.5 0.4 0.3\nKs 0 0 0\nNs 10\nmap_Kd -s 1 1 1 t.png\n\nnewmtl b\nKd 0.7\nKe 0 0 0\n";

const POINTS: &str = "# probes\n0.5 1.0 0.5 0 1 0\n0 0 0 0 1 0\n1 2 3, 0, 0, 1\n";

/// Values that break careless code.
const NUMBERS: &[&str] = &[
    "0",
    "-0",
    "1",
    "-1",
    "2",
    "255",
    "256",
    "65535",
    "65536",
    "4294967295",
    "4294967296",
    "-4294967296",
    "9223372036854775807",
    "1e30",
    "-1e30",
    "1e38",
    "3.5e38",
    "1e-45",
    "1e-300",
    "nan",
    "inf",
    "-inf",
    "0.5",
    "1e15",
    "16384",
    "16385",
    "8",
    "9",
    "6",
    "7",
    "0x10",
    "1_000",
    "+1",
    ".5",
    "5.",
    "1e",
    "--1",
    "",
];
const WORDS: &[&str] = &[
    "\u{feff}",
    "#",
    "\\",
    "/",
    "//",
    "///",
    "\n",
    "\r\n",
    "\t",
    " ",
    "\"",
    "'",
    "[",
    "]",
    "{",
    "}",
    "=",
    ",",
    "f",
    "v",
    "vt",
    "vn",
    "l",
    "p",
    "o",
    "g",
    "s",
    "usemtl",
    "mtllib",
    "newmtl",
    "Kd",
    "Ka",
    "Ke",
    "map_Kd",
    "-s",
    "-o",
    "-clamp",
    "-mm",
    "-bm",
    "on",
    "off",
    "a",
    "b",
    "m.mtl",
    "t.png",
    "/dev/zero",
    "..",
    "m.obj",
    "[[light]]",
    "[[object]]",
    "[camera]",
    "[solver]",
    "type",
    "spot",
    "point",
    "directional",
    "area",
    "position",
    "target",
    "direction",
    "intensity",
    "irradiance",
    "cutoff_angle",
    "beam_width",
    "mesh",
    "name",
    "tessellate",
    "scale",
    "rotate",
    "translate",
    "levels",
    "coarsest",
    "rays",
    "bounces",
    "variant",
    "original",
    "modified",
    "sender_level",
    "gather_levels",
    "output_level",
    "kappa",
    "alpha",
    "eps_rel",
    "approx_cos",
    "plane_offset",
    "max_candidates",
    "reach_paths",
    "reach_bounces",
    "crevice_distance",
    "support_clip",
    "candidate_factor",
    "bvh",
    "cwbvh",
    "width",
    "height",
    "fov",
    "up",
    "\u{0}",
    "é",
    "🙂",
];

/// xorshift64*.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    fn pick<'a>(&mut self, v: &[&'a str]) -> &'a str {
        v[self.below(v.len())]
    }
}

/// One mutation of `text` (bytes or tokens or lines; `other` is spliced from).
fn mutate(text: &str, other: &str, rng: &mut Rng) -> String {
    let mut b = text.as_bytes().to_vec();
    let at = |rng: &mut Rng, b: &[u8]| rng.below(b.len() + 1);
    match rng.below(12) {
        0 => {
            if !b.is_empty() {
                let i = rng.below(b.len());
                b[i] ^= 1 << rng.below(8);
            }
        }
        1 => {
            let i = at(rng, &b);
            b.insert(i, rng.below(256) as u8);
        }
        2 => {
            let i = at(rng, &b);
            let n = rng.below(16).min(b.len() - i.min(b.len()));
            b.drain(i..i + n);
        }
        3 => {
            // Duplicate a range (a repeated line, a repeated table).
            let i = at(rng, &b);
            let n = rng.below(200).min(b.len() - i);
            let piece = b[i..i + n].to_vec();
            let j = at(rng, &b);
            b.splice(j..j, piece);
        }
        4 | 5 => return replace_token(text, rng, |r| r.pick(NUMBERS).to_string(), true),
        6 => return replace_token(text, rng, |r| r.pick(WORDS).to_string(), false),
        7 => {
            let i = at(rng, &b);
            let w = rng.pick(WORDS);
            b.splice(i..i, w.bytes());
        }
        8 => {
            // Delete, duplicate or swap lines.
            let mut lines: Vec<&str> = text.split('\n').collect();
            let i = rng.below(lines.len());
            match rng.below(3) {
                0 => {
                    lines.remove(i);
                }
                1 => lines.insert(i, lines[i]),
                _ => {
                    let j = rng.below(lines.len());
                    lines.swap(i, j);
                }
            }
            return lines.join("\n");
        }
        9 => {
            // Splice another seed in.
            let o = other.as_bytes();
            let i = at(rng, &b);
            let s = rng.below(o.len() + 1);
            let n = rng.below(300).min(o.len() - s);
            b.splice(i..i, o[s..s + n].iter().copied());
        }
        10 => {
            // A long line.
            let i = at(rng, &b);
            let w = rng.pick(WORDS).repeat(1 + rng.below(5000));
            b.splice(i..i, w.bytes());
        }
        _ => {
            // Scale a number by a huge or tiny factor.
            return replace_token(
                text,
                rng,
                |r| format!("{}e{}", 1 + r.below(9), r.below(80) as i32 - 40),
                true,
            );
        }
    }
    String::from_utf8_lossy(&b).into_owned()
}

/// Replaces one whitespace- or punctuation-separated token (a number, with `numeric`).
fn replace_token(text: &str, rng: &mut Rng, with: impl Fn(&mut Rng) -> String, numeric: bool) -> String {
    let is_sep = |c: char| c.is_whitespace() || "[],=\"/".contains(c);
    let mut spans = Vec::new();
    let mut start = None;
    for (i, c) in text.char_indices() {
        match (is_sep(c), start) {
            (false, None) => start = Some(i),
            (true, Some(s)) => {
                spans.push((s, i));
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        spans.push((s, text.len()));
    }
    let spans: Vec<_> = spans
        .into_iter()
        .filter(|&(s, e)| !numeric || text[s..e].parse::<f64>().is_ok())
        .collect();
    if spans.is_empty() {
        return text.to_string();
    }
    let (s, e) = spans[rng.below(spans.len())];
    format!("{}{}{}", &text[..s], with(rng), &text[e..])
}

/// The files of one case.
#[derive(Clone, Debug)]
struct Case {
    toml: String,
    obj: String,
    mtl: String,
    points: String,
    set: Option<(String, String)>,
}

fn seed_case() -> Case {
    Case {
        toml: TOML.into(),
        obj: OBJ.into(),
        mtl: MTL.into(),
        points: POINTS.into(),
        set: None,
    }
}

fn mutated(rng: &mut Rng) -> Case {
    let mut c = seed_case();
    let n = 1 + rng.below(4);
    for _ in 0..n {
        match rng.below(5) {
            0 | 1 => c.toml = mutate(&c.toml, OBJ, rng),
            2 => c.obj = mutate(&c.obj, MTL, rng),
            3 => c.mtl = mutate(&c.mtl, OBJ, rng),
            _ => c.points = mutate(&c.points, TOML, rng),
        }
    }
    if rng.below(4) == 0 {
        c.set = Some((rng.pick(WORDS).to_string(), rng.pick(NUMBERS).to_string()));
    }
    c
}

fn write_case(dir: &Path, c: &Case) {
    std::fs::write(dir.join("s.toml"), &c.toml).unwrap();
    std::fs::write(dir.join("m.obj"), &c.obj).unwrap();
    std::fs::write(dir.join("m.mtl"), &c.mtl).unwrap();
    std::fs::write(dir.join("p.txt"), &c.points).unwrap();
    if let Some((k, v)) = &c.set {
        std::fs::write(dir.join("set.txt"), format!("{k}={v}\n")).unwrap();
    }
}

/// What a case came to.
enum Outcome {
    Loaded,
    Refused,
}

/// Runs one case: load (parse, BVH, textures), points, and on success a small solve.
fn run_case(dir: &Path, c: &Case) -> Outcome {
    let limits = Limits { max_memory: 256 << 20 };
    let _ = meshrad::output::probe::read(&dir.join("p.txt"));
    let overrides: Vec<(String, toml::Value)> = c
        .set
        .iter()
        .map(|(k, v)| {
            let value = toml::from_str::<toml::Table>(&format!("v = {v}"))
                .ok()
                .and_then(|mut t| t.remove("v"))
                .unwrap_or_else(|| toml::Value::String(v.clone()));
            (k.clone(), value)
        })
        .collect();
    let Ok((scene, mut params)) = Scene::load_with(&dir.join("s.toml"), &overrides, &limits) else {
        return Outcome::Refused;
    };
    // The solve at sizes a fuzz case can afford, on whatever geometry and lights loaded.
    let p = &mut params;
    p.levels = p.levels.min(3);
    p.sender_level = p.sender_level.min(p.levels - 1);
    p.gather_levels = p.gather_levels.map(|g| g.min(p.levels));
    p.output_level = p.output_level.map(|o| o.min(p.levels - 1));
    p.coarsest = p.coarsest.min(40);
    p.rays = p.rays.min(16);
    p.bounces = p.bounces.min(2);
    p.reach_paths = p.reach_paths.min(4096);
    p.candidate_factor = p.candidate_factor.min(8.0);
    if meshrad::solve(&scene, &params, &mut meshrad::Engine::cpu(), &Progress::hidden()).is_ok() {
        Outcome::Loaded
    } else {
        Outcome::Refused
    }
}

fn save(c: &Case, why: &str, n: u64) -> PathBuf {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("target/fuzz-failures/{why}-{n}"));
    std::fs::create_dir_all(&d).unwrap();
    write_case(&d, c);
    d
}

#[test]
fn fuzz_scene_mesh_material_and_points_parsers() {
    let seconds: u64 = std::env::var("MESHRAD_FUZZ_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(60);
    let seed: u64 = std::env::var("MESHRAD_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    let mut rng = Rng(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1);
    // In memory where the machine has a tmpfs: rewriting the case files on a disk file
    // system waits for the disk at every truncation.
    let tmp = tempfile::tempdir_in("/dev/shm")
        .or_else(|_| tempfile::tempdir())
        .unwrap();
    let dir = tmp.path().to_path_buf();
    // A texture for `map_Kd t.png`.
    image::RgbImage::from_pixel(2, 2, image::Rgb([100, 120, 140]))
        .save(dir.join("t.png"))
        .unwrap();

    // Watchdog: a case that runs past CASE_LIMIT is a hang.
    let started = Arc::new(AtomicU64::new(u64::MAX));
    let current: Arc<Mutex<Option<Case>>> = Arc::new(Mutex::new(None));
    let t0 = Instant::now();
    {
        let (started, current) = (started.clone(), current.clone());
        std::thread::spawn(move || loop {
            std::thread::sleep(Duration::from_secs(1));
            let s = started.load(Ordering::Relaxed);
            if s != u64::MAX && t0.elapsed().as_secs().saturating_sub(s) > CASE_LIMIT.as_secs() {
                if let Some(c) = current.lock().unwrap().clone() {
                    let d = save(&c, "hang", s);
                    eprintln!("fuzz: a case ran past {CASE_LIMIT:?}; saved in {}", d.display());
                }
                std::process::abort();
            }
        });
    }
    std::panic::set_hook(Box::new(|_| {}));
    let (mut cases, mut loaded, mut panics) = (0u64, 0u64, Vec::new());
    while t0.elapsed().as_secs() < seconds {
        let c = mutated(&mut rng);
        write_case(&dir, &c);
        if c.set.is_none() {
            let _ = std::fs::remove_file(dir.join("set.txt"));
        }
        *current.lock().unwrap() = Some(c.clone());
        started.store(t0.elapsed().as_secs(), Ordering::Relaxed);
        match std::panic::catch_unwind(AssertUnwindSafe(|| run_case(&dir, &c))) {
            Ok(Outcome::Loaded) => loaded += 1,
            Ok(Outcome::Refused) => {}
            Err(e) => {
                let msg = e
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                let d = save(&c, "panic", cases);
                panics.push(format!("{msg} (case in {})", d.display()));
            }
        }
        started.store(u64::MAX, Ordering::Relaxed);
        cases += 1;
    }
    let _ = std::panic::take_hook();
    eprintln!(
        "fuzz: {cases} cases in {:.0} s (seed {seed}), {loaded} loaded and solved, {} panics",
        t0.elapsed().as_secs_f64(),
        panics.len()
    );
    assert!(cases > 0);
    assert!(panics.is_empty(), "panics:\n{}", panics.join("\n"));
}
