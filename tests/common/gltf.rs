//! A small glTF 2.0 writer for the tests: accessors over one binary buffer, written as a
//! `.gltf` with the buffer beside it, inside it (a base64 `data:` URI), or as a `.glb`.

use std::path::{Path, PathBuf};

use base64::Engine;
use serde_json::{json, Value};

/// A glTF document being written.
pub struct Doc {
    pub json: Value,
    pub bin: Vec<u8>,
}

/// Where the binary buffer goes.
#[derive(Clone, Copy, Debug)]
pub enum Layout {
    /// `NAME.gltf` and `NAME.bin` beside it.
    External,
    /// `NAME.gltf` with the buffer as a `data:` URI.
    DataUri,
    /// `NAME.glb`.
    Binary,
}

impl Default for Doc {
    fn default() -> Self {
        Doc {
            json: json!({
                "asset": {"version": "2.0"},
                "scene": 0,
                "scenes": [{"nodes": []}],
                "nodes": [],
                "meshes": [],
                "materials": [],
                "accessors": [],
                "bufferViews": [],
            }),
            bin: Vec::new(),
        }
    }
}

impl Doc {
    /// Appends `v` to the JSON array `key`; returns its index.
    pub fn push(&mut self, key: &str, v: Value) -> usize {
        if self.json.get(key).is_none() {
            self.json[key] = json!([]);
        }
        let a = self.json[key]
            .as_array_mut()
            .unwrap_or_else(|| panic!("{key} is no array"));
        a.push(v);
        a.len() - 1
    }

    /// A buffer view over `bytes` (4-byte aligned).
    pub fn view(&mut self, bytes: &[u8]) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.push(
            "bufferViews",
            json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()}),
        )
    }

    /// A FLOAT accessor of `ty` ("VEC2", "VEC3") over `data`, with min and max.
    pub fn floats(&mut self, data: &[f32], ty: &str) -> usize {
        let n = if ty == "VEC2" { 2 } else { 3 };
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.view(&bytes);
        let mut lo = vec![f32::INFINITY; n];
        let mut hi = vec![f32::NEG_INFINITY; n];
        for c in data.chunks_exact(n) {
            for k in 0..n {
                lo[k] = lo[k].min(c[k]);
                hi[k] = hi[k].max(c[k]);
            }
        }
        self.push(
            "accessors",
            json!({"bufferView": view, "componentType": 5126, "count": data.len() / n, "type": ty,
                   "min": lo, "max": hi}),
        )
    }

    /// An UNSIGNED_INT index accessor.
    pub fn indices(&mut self, data: &[u32]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.push(
            "accessors",
            json!({"bufferView": view, "componentType": 5125, "count": data.len(), "type": "SCALAR"}),
        )
    }

    /// Writes the document as `dir/NAME.gltf` (and `NAME.bin`) or `dir/NAME.glb`.
    pub fn write(&self, dir: &Path, name: &str, layout: Layout) -> PathBuf {
        let mut j = self.json.clone();
        let mut bin = self.bin.clone();
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        let path = match layout {
            Layout::External => {
                std::fs::write(dir.join(format!("{name}.bin")), &bin).unwrap();
                j["buffers"] = json!([{"uri": format!("{name}.bin"), "byteLength": bin.len()}]);
                dir.join(format!("{name}.gltf"))
            }
            Layout::DataUri => {
                let b64 = base64::engine::general_purpose::STANDARD.encode(&bin);
                j["buffers"] = json!([{"uri": format!("data:application/octet-stream;base64,{b64}"),
                                       "byteLength": bin.len()}]);
                dir.join(format!("{name}.gltf"))
            }
            Layout::Binary => {
                j["buffers"] = json!([{"byteLength": bin.len()}]);
                dir.join(format!("{name}.glb"))
            }
        };
        match layout {
            Layout::Binary => {
                let mut text = serde_json::to_vec(&j).unwrap();
                while text.len() % 4 != 0 {
                    text.push(b' ');
                }
                let total = 12 + 8 + text.len() + 8 + bin.len();
                let mut out = Vec::with_capacity(total);
                out.extend_from_slice(b"glTF");
                out.extend_from_slice(&2u32.to_le_bytes());
                out.extend_from_slice(&(total as u32).to_le_bytes());
                out.extend_from_slice(&(text.len() as u32).to_le_bytes());
                out.extend_from_slice(b"JSON");
                out.extend_from_slice(&text);
                out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
                out.extend_from_slice(b"BIN\0");
                out.extend_from_slice(&bin);
                std::fs::write(&path, out).unwrap();
            }
            _ => std::fs::write(&path, serde_json::to_vec_pretty(&j).unwrap()).unwrap(),
        }
        path
    }
}

/// A glTF holding one triangle mesh of `tris` (object space) in one material of albedo
/// `kd`, under a root node; returns the document (more can be added to it).
pub fn one_mesh(positions: &[f32], kd: [f32; 3]) -> Doc {
    let mut d = Doc::default();
    let pos = d.floats(positions, "VEC3");
    let m = d.push(
        "materials",
        json!({"pbrMetallicRoughness": {"baseColorFactor": [kd[0], kd[1], kd[2], 1.0]}}),
    );
    let mesh = d.push(
        "meshes",
        json!({"primitives": [{"attributes": {"POSITION": pos}, "material": m}]}),
    );
    let node = d.push("nodes", json!({"mesh": mesh}));
    d.json["scenes"][0]["nodes"].as_array_mut().unwrap().push(json!(node));
    d
}

/// A 2×2 PNG: top row (glTF v = 0) red and green, bottom row blue and white.
pub fn checker_png() -> Vec<u8> {
    let mut img = image::RgbaImage::new(2, 2);
    img.put_pixel(0, 0, image::Rgba([255, 0, 0, 255]));
    img.put_pixel(1, 0, image::Rgba([0, 255, 0, 255]));
    img.put_pixel(0, 1, image::Rgba([0, 0, 255, 255]));
    img.put_pixel(1, 1, image::Rgba([255, 255, 255, 255]));
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

/// A corner as a `.glb` and its scene file: a 4 × 4 floor (y = 0) textured with
/// [`checker_png`] over uv ∈ [-1, 2]² (u clamped, v mirrored), a grey wall at x = 0, and a
/// directional light on both; `solver` is the `[solver]` table's body.
pub fn textured_corner(dir: &Path, solver: &str) -> PathBuf {
    let mut d = Doc::default();
    let floor = [
        0.0, 0.0, 0.0, 0.0, 0.0, 4.0, 4.0, 0.0, 4.0, 0.0, 0.0, 0.0, 4.0, 0.0, 4.0, 4.0, 0.0, 0.0,
    ];
    let uv: Vec<f32> = floor
        .chunks(3)
        .flat_map(|p| [-1.0 + 0.75 * p[0], -1.0 + 0.75 * p[2]])
        .collect();
    let wall = [
        0.0, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 4.0, 4.0, 0.0, 0.0, 0.0, 0.0, 4.0, 4.0, 0.0, 0.0, 4.0,
    ];
    let fp = d.floats(&floor, "VEC3");
    let ft = d.floats(&uv, "VEC2");
    let wp = d.floats(&wall, "VEC3");
    let view = d.view(&checker_png());
    let img = d.push("images", json!({"bufferView": view, "mimeType": "image/png"}));
    let sampler = d.push("samplers", json!({"wrapS": 33071, "wrapT": 33648}));
    let tex = d.push("textures", json!({"source": img, "sampler": sampler}));
    let fm = d.push(
        "materials",
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.9, 0.9, 1.0], "baseColorTexture": {"index": tex}}}),
    );
    let wm = d.push(
        "materials",
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0]}}),
    );
    let mesh = d.push(
        "meshes",
        json!({"primitives": [{"attributes": {"POSITION": fp, "TEXCOORD_0": ft}, "material": fm},
                              {"attributes": {"POSITION": wp}, "material": wm}]}),
    );
    let n = d.push("nodes", json!({"mesh": mesh}));
    d.json["scenes"][0]["nodes"] = json!([n]);
    d.write(dir, "corner", Layout::Binary);
    let p = dir.join("corner.toml");
    std::fs::write(
        &p,
        format!(
            "[[object]]\nmesh = \"corner.glb\"\n\n[[light]]\ntype = \"directional\"\ndirection = [-1.0, -1.0, -0.2]\n\
             irradiance = [1.0, 1.0, 1.0]\n\n[solver]\n{solver}"
        ),
    )
    .unwrap();
    p
}
