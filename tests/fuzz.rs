//! Mutation fuzzing of every input meshrad reads, and of what runs on an input that loads.
//! Each case is a mutated copy of one kind's seed files, written to a temporary directory:
//! - `text`: the scene (TOML), mesh (OBJ), material (MTL: emission and alpha maps too) and
//!   points parsers, with a
//!   `--set` override;
//! - `gltf`: a glTF's JSON and its binary buffer (nodes with TRS and matrices, an indexed
//!   list and a strip, normals and uvs, a texture, emission and its strength, alpha modes,
//!   `KHR_lights_punctual` lights, a camera, an emissive texture);
//! - `glb`: the same as a GLB container, mutated as bytes or through its JSON chunk (with
//!   the chunk lengths rebuilt or left stale);
//! - `envmap`: an OpenEXR and a Radiance `.hdr` sky map, as bytes;
//! - `frames`: an `animate` frames file, applied and solved frame by frame;
//! - `session`: a `session` stream, run by the `meshrad` binary (its lines with `render`
//!   are dropped: a mutated `out` could write anywhere).
//!
//! In-process cases load the scene and run a small solve; a panic fails the test (and the
//! case is saved), an abort kills it, a case that runs longer than `CASE_LIMIT` aborts it
//! with the case saved. A session case fails on a panic message, an exit by a signal or
//! one past `CASE_LIMIT`; its memory is bounded by `--max-memory`.
//!
//! `MESHRAD_FUZZ_SECONDS` (default 60) bounds the run, `MESHRAD_FUZZ_SEED` (default 1)
//! picks the sequence, `MESHRAD_FUZZ_KINDS` (default all, e.g. `gltf,glb`) the kinds,
//! `MESHRAD_FUZZ_BIN` the binary for session cases (default the one cargo built; a copy
//! keeps a long run apart from rebuilds); failing cases go to `target/fuzz-failures/`. For a long run,
//! in the test profile (optimised, with overflow checks; `--release` is faster but lets an
//! integer overflow wrap unseen, as a GLB header's length did):
//! `MESHRAD_FUZZ_SECONDS=3600 MESHRAD_FUZZ_SEED=$RANDOM cargo test --test fuzz -- --nocapture`.

mod common;

use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::gltf::{Doc, Layout};
use serde_json::json;

use meshrad::limits::Limits;
use meshrad::progress::Progress;
use meshrad::Scene;

const CASE_LIMIT: Duration = Duration::from_secs(60);

const TOML: &str = "[[object]]\nname = \"box\"\nmesh = \"m.obj\"\ntranslate = [0.0, 0.5, 0.0]\nrotate = [0.0, 30.0, 0.0]\nscale = 1.0\n\
tessellate = 1\n\n[[object]]\nname = \"big\"\nmesh = \"m.obj\"\nscale = 2.0\n\n[[light]]\nname = \"lamp\"\ntype = \"point\"\nposition = [0.2, 3.0, 0.2]\n\
intensity = [1.0, 1.0, 1.0]\n\n[[light]]\nname = \"spot\"\ntype = \"spot\"\nposition = [0.0, 2.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\n\
intensity = [5.0, 5.0, 5.0]\ncutoff_angle = 40.0\nbeam_width = 30.0\n\n[[light]]\nname = \"sun\"\ntype = \"directional\"\n\
direction = [0.25, -1.0, 0.15]\nirradiance = [2.0, 2.0, 2.0]\n\n[camera]\nposition = [0.0, 1.0, -5.0]\n\
target = [0.0, 0.5, 0.0]\nup = [0.0, 1.0, 0.0]\nfov = 40.0\nwidth = 8\nheight = 8\n\n[solver]\nlevels = 2\n\
coarsest = 12\nrays = 8\nbounces = 1\nsender_level = 1\nvariant = \"approx\"\nreach_paths = 2048\n";

const OBJ: &str = "# a box with a floor\nmtllib m.mtl\no box\nusemtl a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\n\
v 1 0 1\nv 1 1 1\nv 0 1 1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 -1\nf 1/1/1 2/2/1 3/3/1 4/4/1\nf 5/1 8/4 7/3 6/2\n\
f 1 5 6 2\nf 2 6 7 3\nf 3 7 8 4\nf 4 8 5 1\ng floor\nusemtl b\nv -3 -0.01 -3\nv 3 -0.01 -3\nv 3 -0.01 3\nv -3 -0.01 3\n\
f -4 -1 -2\nf -4 -2 -3\n";

const MTL: &str = "newmtl a\nKd 0.5 0.4 0.3\nKs 0 0 0\nNs 10\nmap_Kd -s 1 1 1 t.png\nd 0.9\nmap_d t.png\n\nnewmtl b\nKd 0.7\nKe 0 0 0\nmap_Ke t.png\nTr 0.1\n";

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
    "map_Ke",
    "map_d",
    "d",
    "Tr",
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
    // glTF, frames and session words.
    "null",
    "true",
    "false",
    "{}",
    "[]",
    ":",
    "accessors",
    "bufferView",
    "bufferViews",
    "byteOffset",
    "byteLength",
    "byteStride",
    "count",
    "componentType",
    "5121",
    "5123",
    "5125",
    "5126",
    "SCALAR",
    "VEC3",
    "MAT4",
    "nodes",
    "children",
    "matrix",
    "rotation",
    "translation",
    "primitives",
    "indices",
    "mode",
    "POSITION",
    "NORMAL",
    "TEXCOORD_0",
    "material",
    "baseColorFactor",
    "baseColorTexture",
    "emissiveFactor",
    "emissiveTexture",
    "emissiveStrength",
    "alphaMode",
    "alphaCutoff",
    "MASK",
    "BLEND",
    "KHR_lights_punctual",
    "light",
    "camera",
    "yfov",
    "uri",
    "data:application/octet-stream;base64,",
    "g.bin",
    "[[frame]]",
    "objects",
    "lights",
    "objects.box",
    "lights.sun",
    "set",
    "solve",
    "probe",
    "stats",
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

/// Which inputs a case mutates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Text,
    Gltf,
    Glb,
    Envmap,
    Frames,
    Session,
}

const KINDS: &[(Kind, &str)] = &[
    (Kind::Text, "text"),
    (Kind::Gltf, "gltf"),
    (Kind::Glb, "glb"),
    (Kind::Envmap, "envmap"),
    (Kind::Frames, "frames"),
    (Kind::Session, "session"),
];

/// Files by name: (name, bytes).
type Files = Vec<(String, Vec<u8>)>;

/// The files of one case and a `--set` override.
#[derive(Clone, Debug)]
struct Case {
    kind: Kind,
    files: Files,
    set: Option<(String, String)>,
}

impl Case {
    fn file(&mut self, name: &str) -> &mut Vec<u8> {
        &mut self
            .files
            .iter_mut()
            .find(|f| f.0 == name)
            .unwrap_or_else(|| panic!("seed file {name}"))
            .1
    }

    /// Applies a text mutation to file `name` (`other` is spliced from).
    fn mutate_text(&mut self, name: &str, other: &str, rng: &mut Rng) {
        let f = self.file(name);
        *f = mutate(&String::from_utf8_lossy(f), other, rng).into_bytes();
    }
}

/// A small solve's `[solver]` table for the glTF and envmap seeds.
const SOLVER: &str =
    "[solver]\nlevels = 2\ncoarsest = 12\nrays = 8\nbounces = 1\nsender_level = 1\nreach_paths = 2048\n";

const FRAMES: &str =
    "[[frame]]\n\n[[frame]]\nobjects.box = { rotate = [0.0, 45.0, 0.0], translate = [0.1, 0.6, 0.0], scale = 1.5 }\n\
lights.lamp = { position = [0.3, 2.5, 0.1], intensity = [3.0, 3.0, 3.0] }\n\n[[frame]]\n\
lights.spot = { target = [0.5, 0.0, 0.0], cutoff_angle = 50.0, beam_width = 20.0 }\n\
lights.sun = { direction = [0.1, -1.0, 0.3], irradiance = [1.0, 0.5, 0.5] }\n";

const SESSION: &str = "{\"solve\": {}}\n{\"probe\": [[0.5, 1.0, 0.5, 0, 1, 0], [0.0, 0.0, 0.0, 0, 1, 0]]}\n\
{\"set\": {\"objects\": {\"box\": {\"translate\": [0.1, 0.5, 0.0], \"rotate\": [0.0, 10.0, 0.0], \"scale\": 1.5}}, \
\"lights\": {\"lamp\": {\"intensity\": [2.0, 2.0, 2.0]}, \"sun\": {\"direction\": [0.1, -1.0, 0.2]}}}}\n{\"stats\": {}}\n\
{\"solve\": {}}\n{\"set\": {\"lights\": {\"spot\": {\"target\": [0.5, 0.0, 0.0], \"cutoff_angle\": 50.0}}}}\n\
{\"probe\": [[0.5, 1.0, 0.5, 0, 1, 0]]}\n{\"stats\": {}}\n";

fn text_files() -> Files {
    [("s.toml", TOML), ("m.obj", OBJ), ("m.mtl", MTL), ("p.txt", POINTS)]
        .iter()
        .map(|(n, t)| (n.to_string(), t.as_bytes().to_vec()))
        .collect()
}

/// The glTF seed: a floor (indexed, with normals and uvs, textured, alpha MASK) placed by
/// two nodes (TRS, and a matrix under a parent), a wall drawn as a strip (u16-free
/// UNSIGNED_SHORT indices, emissive with a strength, alpha BLEND), a point and a spot
/// light and a camera.
fn gltf_doc() -> Doc {
    let mut d = Doc::default();
    let floor = [-1.0f32, 0.0, -1.0, 1.0, 0.0, -1.0, 1.0, 0.0, 1.0, -1.0, 0.0, 1.0];
    let fp = d.floats(&floor, "VEC3");
    let fnrm = d.floats(&[0.0, 1.0, 0.0].repeat(4), "VEC3");
    let fuv = d.floats(&[0.0, 0.0, 2.0, 0.0, 2.0, 2.0, 0.0, 2.0], "VEC2");
    let fi = d.indices(&[0, 2, 1, 0, 3, 2]);
    let wall = [-1.0f32, 0.0, -1.0, -1.0, 1.0, -1.0, 1.0, 0.0, -1.0, 1.0, 1.0, -1.0];
    let wp = d.floats(&wall, "VEC3");
    let short: Vec<u8> = [0u16, 1, 2, 3].iter().flat_map(|i| i.to_le_bytes()).collect();
    let wv = d.view(&short);
    let wi = d.push(
        "accessors",
        json!({"bufferView": wv, "componentType": 5123, "count": 4, "type": "SCALAR"}),
    );
    let png = d.view(&common::gltf::checker_png());
    let img = d.push("images", json!({"bufferView": png, "mimeType": "image/png"}));
    let sampler = d.push("samplers", json!({"wrapS": 10497, "wrapT": 33071}));
    let tex = d.push("textures", json!({"source": img, "sampler": sampler}));
    let m0 = d.push(
        "materials",
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "baseColorTexture": {"index": tex}},
               "emissiveFactor": [0.2, 0.2, 0.2], "emissiveTexture": {"index": tex},
               "alphaMode": "MASK", "alphaCutoff": 0.5}),
    );
    let m1 = d.push(
        "materials",
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.4, 0.3, 1.0]}, "emissiveFactor": [1.0, 0.5, 0.2],
               "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2.0}}, "alphaMode": "BLEND"}),
    );
    let floor_mesh = d.push(
        "meshes",
        json!({"primitives": [{"attributes": {"POSITION": fp, "NORMAL": fnrm, "TEXCOORD_0": fuv}, "indices": fi,
                               "material": m0}]}),
    );
    let wall_mesh = d.push(
        "meshes",
        json!({"primitives": [{"attributes": {"POSITION": wp}, "indices": wi, "mode": 5, "material": m1}]}),
    );
    let n1 = d.push("nodes", json!({"mesh": floor_mesh}));
    let n2 = d.push(
        "nodes",
        json!({"mesh": wall_mesh, "matrix": [0.5, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.2, 0.0, 0.3, 1.0]}),
    );
    let n0 = d.push(
        "nodes",
        json!({"name": "room", "children": [n1, n2], "translation": [0.0, 0.1, 0.0],
               "rotation": [0.0, 0.382_683_43, 0.0, 0.923_879_5], "scale": [1.0, 1.0, 1.0]}),
    );
    let n3 = d.push(
        "nodes",
        json!({"name": "bulb", "translation": [0.0, 1.5, 0.0],
                                    "extensions": {"KHR_lights_punctual": {"light": 0}}}),
    );
    let n4 = d.push(
        "nodes",
        json!({"translation": [0.5, 2.0, 0.0], "rotation": [-0.707_106_77, 0.0, 0.0, 0.707_106_77],
                                    "extensions": {"KHR_lights_punctual": {"light": 1}}}),
    );
    let n5 = d.push("nodes", json!({"camera": 0, "translation": [0.0, 1.0, 4.0]}));
    d.json["scenes"][0]["nodes"] = json!([n0, n3, n4, n5]);
    d.json["cameras"] =
        json!([{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1, "aspectRatio": 1.0}}]);
    d.json["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": [1.0, 1.0, 1.0], "intensity": 20.0},
        {"type": "spot", "intensity": 50.0, "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.6}}]}});
    d.json["extensionsUsed"] = json!(["KHR_lights_punctual", "KHR_materials_emissive_strength"]);
    d
}

/// Every kind's seed files.
fn seeds() -> Vec<(Kind, Files)> {
    let tmp = common::tmpdir();
    let dir = tmp.path();
    let read = |n: &str| (n.to_string(), std::fs::read(dir.join(n)).unwrap());
    let text = |n: &str, t: &str| (n.to_string(), t.as_bytes().to_vec());
    let doc = gltf_doc();
    doc.write(dir, "g", Layout::External);
    doc.write(dir, "g", Layout::Binary);
    let light = "[[light]]\nname = \"sun\"\ntype = \"directional\"\ndirection = [-0.3, -1.0, -0.2]\nirradiance = [1.0, 1.0, 1.0]\n\n";
    exr::prelude::write_rgb_file(dir.join("e.exr"), 8, 4, |x, y| {
        (1.0 + x as f32 * 0.1, 0.5, 0.2 + y as f32 * 0.3)
    })
    .unwrap();
    image::DynamicImage::ImageRgb32F(image::Rgb32FImage::from_fn(8, 4, |x, y| {
        image::Rgb([0.2 + x as f32 * 0.1, 1.0, 0.1 * y as f32])
    }))
    .save(dir.join("e.hdr"))
    .unwrap();
    let mut scene_files = text_files();
    scene_files.retain(|f| f.0 != "p.txt");
    vec![
        (Kind::Text, text_files()),
        (
            Kind::Gltf,
            vec![
                text(
                    "s.toml",
                    &format!("[[object]]\nname = \"g\"\nmesh = \"g.gltf\"\n\n{light}{SOLVER}"),
                ),
                read("g.gltf"),
                read("g.bin"),
            ],
        ),
        (
            Kind::Glb,
            vec![
                text(
                    "s.toml",
                    &format!("[[object]]\nname = \"g\"\nmesh = \"g.glb\"\n\n{light}{SOLVER}"),
                ),
                read("g.glb"),
            ],
        ),
        (
            Kind::Envmap,
            vec![
                text(
                    "s.toml",
                    &format!("[[object]]\nmesh = \"m.obj\"\n\n[sky]\nenvmap = \"e.exr\"\nscale = 0.5\n\n{SOLVER}"),
                ),
                text("m.obj", OBJ),
                text("m.mtl", MTL),
                read("e.exr"),
                read("e.hdr"),
            ],
        ),
        (
            Kind::Frames,
            [scene_files.clone(), vec![text("f.toml", FRAMES)]].concat(),
        ),
        (Kind::Session, [scene_files, vec![text("st.jsonl", SESSION)]].concat()),
    ]
}

/// One mutation of binary `b`: bits, bytes, ranges, interesting integers and floats
/// (f32 and f16) at (mostly aligned) offsets, truncation, a repeated range.
fn mutate_bytes(b: &[u8], rng: &mut Rng) -> Vec<u8> {
    const U32: &[u32] = &[
        0,
        1,
        2,
        3,
        4,
        7,
        8,
        0x7f,
        0x80,
        0xff,
        0x100,
        0xffff,
        0x1_0000,
        0x7fff_ffff,
        0x8000_0000,
        0xffff_fffe,
        0xffff_ffff,
    ];
    const F32: &[f32] = &[
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::MAX,
        -f32::MAX,
        1e38,
        1e30,
        1e-45,
        -0.0,
        0.0,
        65504.0,
        -1.0,
    ];
    const F16: &[u16] = &[0x7c00, 0xfc00, 0x7e00, 0x7bff, 0x0001, 0x8000];
    let mut b = b.to_vec();
    let n = b.len();
    match rng.below(10) {
        0 => {
            if n > 0 {
                let i = rng.below(n);
                b[i] ^= 1 << rng.below(8);
            }
        }
        1 => {
            if n > 0 {
                let i = rng.below(n);
                b[i] = rng.below(256) as u8;
            }
        }
        2 => {
            let i = rng.below(n + 1);
            b.insert(i, rng.below(256) as u8);
        }
        3 => {
            let i = rng.below(n + 1);
            let k = rng.below(64).min(n - i);
            b.drain(i..i + k);
        }
        4 => {
            let i = rng.below(n + 1);
            let k = rng.below(256).min(n - i);
            let piece = b[i..i + k].to_vec();
            let j = rng.below(n + 1);
            b.splice(j..j, piece);
        }
        5 | 6 => {
            let v = if rng.below(4) == 0 {
                // Near the file's length (sizes and offsets that just fit or just don't).
                (n as u32).wrapping_add(rng.below(9) as u32).wrapping_sub(4)
            } else {
                U32[rng.below(U32.len())]
            };
            write_at(&mut b, rng, &v.to_le_bytes());
        }
        7 => {
            if rng.below(2) == 0 {
                let v = F32[rng.below(F32.len())];
                write_at(&mut b, rng, &v.to_le_bytes());
            } else {
                let v = F16[rng.below(F16.len())];
                write_at(&mut b, rng, &v.to_le_bytes());
            }
        }
        8 => b.truncate(rng.below(n + 1)),
        _ => {
            let i = rng.below(n + 1);
            let k = (1 + rng.below(64)).min(n - i);
            let piece = b[i..i + k].repeat(1 + rng.below(4096));
            b.splice(i..i, piece);
        }
    }
    b
}

/// Writes `v` over `b` at a random offset, aligned to 4 three times in four.
fn write_at(b: &mut [u8], rng: &mut Rng, v: &[u8]) {
    if b.len() < v.len() {
        return;
    }
    let mut i = rng.below(b.len() - v.len() + 1);
    if rng.below(4) != 0 {
        i &= !3;
    }
    b[i..i + v.len()].copy_from_slice(v);
}

/// A GLB mutated as bytes, or through its JSON chunk as text: the header's and the
/// chunk's lengths rebuilt three times in four, left as they were (stale) otherwise.
fn mutate_glb(b: &[u8], rng: &mut Rng) -> Vec<u8> {
    if rng.below(2) == 0 || b.len() < 20 || &b[16..20] != b"JSON" {
        return mutate_bytes(b, rng);
    }
    let len = u32::from_le_bytes(b[12..16].try_into().unwrap()) as usize;
    if 20 + len > b.len() {
        return mutate_bytes(b, rng);
    }
    let json = String::from_utf8_lossy(&b[20..20 + len]).into_owned();
    let mut text = mutate(&json, &json, rng).into_bytes();
    let rebuild = rng.below(4) != 0;
    while rebuild && text.len() % 4 != 0 {
        text.push(b' ');
    }
    let rest = &b[20 + len..];
    let (total, chunk) = if rebuild {
        ((20 + text.len() + rest.len()) as u32, text.len() as u32)
    } else {
        (u32::from_le_bytes(b[8..12].try_into().unwrap()), len as u32)
    };
    let mut out = Vec::with_capacity(20 + text.len() + rest.len());
    out.extend_from_slice(&b[..8]);
    out.extend_from_slice(&total.to_le_bytes());
    out.extend_from_slice(&chunk.to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(rest);
    out
}

/// A mutated case of `kind` from its seed files.
fn mutated(kind: Kind, seed: &[(String, Vec<u8>)], rng: &mut Rng) -> Case {
    let mut c = Case {
        kind,
        files: seed.to_vec(),
        set: None,
    };
    if kind == Kind::Envmap && rng.below(2) == 0 {
        let t = c.file("s.toml");
        *t = String::from_utf8_lossy(t).replace("e.exr", "e.hdr").into_bytes();
    }
    for _ in 0..1 + rng.below(4) {
        match kind {
            Kind::Text => match rng.below(5) {
                0 | 1 => c.mutate_text("s.toml", OBJ, rng),
                2 => c.mutate_text("m.obj", MTL, rng),
                3 => c.mutate_text("m.mtl", OBJ, rng),
                _ => c.mutate_text("p.txt", TOML, rng),
            },
            Kind::Gltf => match rng.below(10) {
                0..=6 => c.mutate_text("g.gltf", "\"nodes\": [{\"mesh\": 0, \"children\": [0]}]", rng),
                7 | 8 => *c.file("g.bin") = mutate_bytes(c.file("g.bin"), rng),
                _ => c.mutate_text("s.toml", TOML, rng),
            },
            Kind::Glb => *c.file("g.glb") = mutate_glb(c.file("g.glb"), rng),
            Kind::Envmap => match rng.below(10) {
                0..=4 => *c.file("e.exr") = mutate_bytes(c.file("e.exr"), rng),
                5..=8 => *c.file("e.hdr") = mutate_bytes(c.file("e.hdr"), rng),
                _ => c.mutate_text("s.toml", TOML, rng),
            },
            Kind::Frames => c.mutate_text("f.toml", TOML, rng),
            Kind::Session => c.mutate_text("st.jsonl", FRAMES, rng),
        }
    }
    if kind == Kind::Text && rng.below(4) == 0 {
        c.set = Some((rng.pick(WORDS).to_string(), rng.pick(NUMBERS).to_string()));
    }
    c
}

/// Writes the case's files into `dir` and removes any other file there but `keep`.
fn write_case(dir: &Path, c: &Case, keep: &[&str]) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if !keep.contains(&name.as_str()) && !c.files.iter().any(|f| f.0 == name) {
            let p = e.path();
            let _ = if p.is_dir() {
                std::fs::remove_dir_all(&p)
            } else {
                std::fs::remove_file(&p)
            };
        }
    }
    for (name, bytes) in &c.files {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
}

/// What a case came to.
enum Outcome {
    Loaded,
    Refused,
    /// A session process that panicked, died by a signal or hung.
    Failed(String),
}

/// The solve at sizes a fuzz case can afford, on whatever geometry and lights loaded.
fn small(p: &mut meshrad::SolverParams) {
    p.levels = p.levels.min(3);
    p.sender_level = p.sender_level.min(p.levels - 1);
    p.gather_levels = p.gather_levels.map(|g| g.min(p.levels));
    p.output_level = p.output_level.map(|o| o.min(p.levels - 1));
    p.coarsest = p.coarsest.min(40);
    p.rays = p.rays.min(16);
    p.bounces = p.bounces.min(2);
    p.reach_paths = p.reach_paths.min(4096);
    p.candidate_factor = p.candidate_factor.min(8.0);
}

const LIMITS: Limits = Limits { max_memory: 256 << 20 };

fn run_case(dir: &Path, c: &Case) -> Outcome {
    match c.kind {
        Kind::Frames => run_frames(dir),
        Kind::Session => run_session(dir),
        _ => run_load_and_solve(dir, c),
    }
}

/// Load (parse, BVH, textures, envmap), the points for a text case, and on success a
/// small solve.
fn run_load_and_solve(dir: &Path, c: &Case) -> Outcome {
    if c.kind == Kind::Text {
        let _ = meshrad::output::probe::read(&dir.join("p.txt"));
    }
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
    let Ok((scene, mut params)) = Scene::load_with(&dir.join("s.toml"), &overrides, &LIMITS) else {
        return Outcome::Refused;
    };
    small(&mut params);
    if meshrad::solve(&scene, &params, &mut meshrad::Engine::cpu(), &Progress::hidden()).is_ok() {
        Outcome::Loaded
    } else {
        Outcome::Refused
    }
}

/// As `animate` does: the frames parsed, every frame applied to a copy first, then each
/// (the first four) applied to the editor and solved.
fn run_frames(dir: &Path) -> Outcome {
    use meshrad::editor;
    let path = dir.join("f.toml");
    let Ok((scene, mut params)) = Scene::load_with(&dir.join("s.toml"), &[], &LIMITS) else {
        return Outcome::Refused;
    };
    small(&mut params);
    let Ok(text) = meshrad::limits::read_text(&path, meshrad::limits::MAX_TEXT_BYTES) else {
        return Outcome::Refused;
    };
    let (Ok(frames), Ok(params)) = (
        editor::parse_frames(&text, &path),
        editor::editing_params(&params, "animate"),
    ) else {
        return Outcome::Refused;
    };
    let mut check = scene.clone();
    for (k, f) in frames.iter().enumerate() {
        if editor::apply(&mut check, f, &format!("frame {k}")).is_err() {
            return Outcome::Refused;
        }
    }
    let hidden = Progress::hidden();
    let Ok(mut ed) = editor::Editor::new(scene, params, meshrad::Engine::cpu(), &hidden) else {
        return Outcome::Refused;
    };
    for (k, f) in frames.iter().take(4).enumerate() {
        if ed.apply(f, &format!("frame {k}")).is_err() || ed.solve(&hidden).is_err() {
            return Outcome::Refused;
        }
    }
    Outcome::Loaded
}

/// Whether a session line is a `render` command (dropped: its `out` could name any
/// folder). Parsed as the session parses it: one JSON value per line.
fn is_render(line: &[u8]) -> bool {
    serde_json::from_slice::<serde_json::Value>(line)
        .ok()
        .and_then(|v| v.as_object().map(|o| o.contains_key("render")))
        .unwrap_or(false)
}

/// The stream through `meshrad session` (CPU backend, `--max-memory 256M`).
fn run_session(dir: &Path) -> Outcome {
    use std::io::{Read, Write};
    use std::process::{Command, Stdio};
    let text = std::fs::read(dir.join("st.jsonl")).unwrap();
    let stream: Vec<u8> = text
        .split(|&b| b == b'\n')
        .filter(|l| !is_render(l))
        .collect::<Vec<_>>()
        .join(&b'\n');
    let bin = std::env::var_os("MESHRAD_FUZZ_BIN").unwrap_or_else(|| env!("CARGO_BIN_EXE_meshrad").into());
    let mut child = Command::new(bin)
        .args(["session", "s.toml", "--backend", "cpu", "--max-memory", "256M"])
        .current_dir(dir)
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("meshrad session starts");
    let mut stdin = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || {
        // It may exit before reading everything (a broken pipe is no failure).
        let _ = stdin.write_all(&stream);
    });
    let mut stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = Vec::new();
        let _ = stderr.read_to_end(&mut s);
        String::from_utf8_lossy(&s).into_owned()
    });
    let t = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t.elapsed() > CASE_LIMIT {
            let _ = child.kill();
            let _ = child.wait();
            return Outcome::Failed(format!("session ran past {CASE_LIMIT:?}"));
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    let _ = writer.join();
    let err = reader.join().unwrap();
    match status.code() {
        _ if err.contains("panicked") => Outcome::Failed(format!("session panicked: {err}")),
        None => Outcome::Failed(format!("session killed by a signal ({status}): {err}")),
        Some(0) => Outcome::Loaded,
        Some(1) => Outcome::Refused,
        Some(c) => Outcome::Failed(format!("session exit code {c}: {err}")),
    }
}

fn save(c: &Case, why: &str, n: u64) -> PathBuf {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("target/fuzz-failures/{why}-{n}"));
    std::fs::create_dir_all(&d).unwrap();
    write_case(&d, c, &[]);
    std::fs::write(d.join("kind.txt"), format!("{:?}\n", c.kind)).unwrap();
    if let Some((k, v)) = &c.set {
        std::fs::write(d.join("set.txt"), format!("{k}={v}\n")).unwrap();
    }
    d
}

#[test]
fn fuzz_every_input_kind() {
    let seconds: u64 = std::env::var("MESHRAD_FUZZ_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(60);
    let seed: u64 = std::env::var("MESHRAD_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    let wanted = std::env::var("MESHRAD_FUZZ_KINDS").unwrap_or_default();
    let kinds: Vec<(Kind, &str)> = KINDS
        .iter()
        .copied()
        .filter(|(_, n)| wanted.is_empty() || wanted.split(',').any(|w| w.trim() == *n))
        .collect();
    assert!(
        !kinds.is_empty(),
        "MESHRAD_FUZZ_KINDS={wanted} names no kind of {KINDS:?}"
    );
    let seeds = seeds();
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

    // Watchdog: a case that runs past CASE_LIMIT (and a little, for a session's own
    // timeout to speak first) is a hang.
    let started = Arc::new(AtomicU64::new(u64::MAX));
    let current: Arc<Mutex<Option<Case>>> = Arc::new(Mutex::new(None));
    let t0 = Instant::now();
    {
        let (started, current) = (started.clone(), current.clone());
        std::thread::spawn(move || loop {
            std::thread::sleep(Duration::from_secs(1));
            let s = started.load(Ordering::Relaxed);
            if s != u64::MAX && t0.elapsed().as_secs().saturating_sub(s) > CASE_LIMIT.as_secs() + 5 {
                if let Some(c) = current.lock().unwrap().clone() {
                    let d = save(&c, "hang", s);
                    eprintln!("fuzz: a case ran past {CASE_LIMIT:?}; saved in {}", d.display());
                }
                std::process::abort();
            }
        });
    }
    std::panic::set_hook(Box::new(|_| {}));
    // Per kind: cases, loaded (and solved, or a session that ended well).
    let mut counts = vec![(0u64, 0u64); kinds.len()];
    let (mut cases, mut failures) = (0u64, Vec::new());
    while t0.elapsed().as_secs() < seconds {
        let k = rng.below(kinds.len());
        let kind = kinds[k].0;
        let seed_files = &seeds.iter().find(|s| s.0 == kind).unwrap().1;
        let c = mutated(kind, seed_files, &mut rng);
        write_case(&dir, &c, &["t.png"]);
        *current.lock().unwrap() = Some(c.clone());
        started.store(t0.elapsed().as_secs(), Ordering::Relaxed);
        let failure = match std::panic::catch_unwind(AssertUnwindSafe(|| run_case(&dir, &c))) {
            Ok(Outcome::Loaded) => {
                counts[k].1 += 1;
                None
            }
            Ok(Outcome::Refused) => None,
            Ok(Outcome::Failed(why)) => Some(why),
            Err(e) => Some(
                e.downcast_ref::<String>()
                    .cloned()
                    .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default(),
            ),
        };
        if let Some(why) = failure {
            let d = save(&c, "failure", cases);
            failures.push(format!("{why} (case in {})", d.display()));
        }
        started.store(u64::MAX, Ordering::Relaxed);
        counts[k].0 += 1;
        cases += 1;
    }
    let _ = std::panic::take_hook();
    let table: Vec<String> = kinds
        .iter()
        .zip(&counts)
        .map(|((_, n), (c, l))| format!("{n} {c} ({l} loaded)"))
        .collect();
    eprintln!(
        "fuzz: {cases} cases in {:.0} s (seed {seed}): {}; {} failures",
        t0.elapsed().as_secs_f64(),
        table.join(", "),
        failures.len()
    );
    assert!(counts.iter().all(|c| c.0 > 0), "every kind ran: {table:?}");
    assert!(failures.is_empty(), "failures:\n{}", failures.join("\n"));
}

/// Every seed loads and solves unmutated (a seed that fails would only fuzz its first
/// error), and the session seed's every line is answered `ok`.
#[test]
fn every_seed_loads_and_solves() {
    let tmp = common::tmpdir();
    let dir = tmp.path();
    image::RgbImage::from_pixel(2, 2, image::Rgb([100, 120, 140]))
        .save(dir.join("t.png"))
        .unwrap();
    for (kind, files) in seeds() {
        let c = Case { kind, files, set: None };
        write_case(dir, &c, &["t.png"]);
        let tag = match run_case(dir, &c) {
            Outcome::Loaded => None,
            Outcome::Refused => Some("refused".to_string()),
            Outcome::Failed(why) => Some(why),
        };
        if kind != Kind::Session {
            // Why a load fails, to say so.
            let err = Scene::load_with(&dir.join("s.toml"), &[], &LIMITS).err();
            assert!(tag.is_none(), "the {kind:?} seed: {tag:?} {err:?}");
        } else {
            assert!(tag.is_none(), "the session seed: {tag:?}");
            let o = std::process::Command::new(env!("CARGO_BIN_EXE_meshrad"))
                .args(["session", "s.toml", "--backend", "cpu"])
                .current_dir(dir)
                .stdin(std::fs::File::open(dir.join("st.jsonl")).unwrap())
                .output()
                .unwrap();
            let out = String::from_utf8_lossy(&o.stdout);
            assert_eq!(out.lines().count(), 1 + SESSION.lines().count(), "{out}");
            assert!(out.lines().all(|l| l.contains("\"ok\":true")), "{out}");
        }
    }
}
