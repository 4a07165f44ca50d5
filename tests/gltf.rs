//! glTF 2.0 scenes (`ALGORITHM.md` §10): the Cornell box written as a glTF (its
//! luminaire's emission, the spot as a `KHR_lights_punctual` light, the camera, node
//! transforms) solves to the OBJ + TOML box's answer; textures with glTF's uv convention
//! and wrap modes, photometric light units, mirroring node matrices, strips and the note
//! that names what is not used.

mod common;

use std::path::{Path, PathBuf};

use common::gltf::{one_mesh, Doc, Layout};
use glam::Vec3;
use meshrad::scene::obj;
use meshrad::scene::source::Source;
use serde_json::json;

const SOLVER: &str = "levels = 4\ncoarsest = 60\nrays = 64\nbounces = 3\nsender_level = 3\n";

/// The shipped Cornell box's folder.
fn scenes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes")
}

/// The Cornell box (cornell_original_mm.obj with its luminaire emitting) as a glTF: the
/// mesh at half size under a root node that scales by 2 (exact in binary), one primitive
/// per run of a material in the OBJ's face order, the ceiling spot of cornell_box.toml as
/// a spot light (candela = W/sr × 683), and the cbox camera.
fn cornell_gltf() -> Doc {
    let mesh = obj::load(
        &Source::Dir(scenes()),
        Path::new("cornell_original_mm.obj"),
        1 << 30,
        None,
    )
    .unwrap();
    let mut d = Doc::default();
    d.json["extensionsUsed"] = json!(["KHR_lights_punctual", "KHR_materials_emissive_strength"]);
    for m in &mesh.materials {
        let e = m.emission;
        let s = e[0].max(e[1]).max(e[2]);
        let mut mat = json!({"name": m.name,
                             "pbrMetallicRoughness": {"baseColorFactor": [m.kd[0], m.kd[1], m.kd[2], 1.0]}});
        if s > 0.0 {
            mat["emissiveFactor"] = json!([e[0] / s, e[1] / s, e[2] / s]);
            mat["extensions"] = json!({"KHR_materials_emissive_strength": {"emissiveStrength": s}});
        }
        d.push("materials", mat);
    }
    let mut prims = Vec::new();
    let mut start = 0;
    while start < mesh.tris.len() {
        let material = mesh.tris[start].material;
        let end = (start..mesh.tris.len())
            .find(|&i| mesh.tris[i].material != material)
            .unwrap_or(mesh.tris.len());
        let pos: Vec<f32> = mesh.tris[start..end]
            .iter()
            .flat_map(|t| [t.v0, t.v1, t.v2])
            .flat_map(|v| v.map(|c| c * 0.5))
            .collect();
        let a = d.floats(&pos, "VEC3");
        prims.push(json!({"attributes": {"POSITION": a}, "material": material}));
        start = end;
    }
    let m = d.push("meshes", json!({"name": "cbox", "primitives": prims}));
    let geometry = d.push("nodes", json!({"name": "geometry", "mesh": m}));
    // The spot: local -z turned to world -y (a rotation of -90° about x, written as a
    // matrix with exact entries), at half the position under the scaling root.
    let spot = d.push(
        "nodes",
        json!({"name": "spot-node", "extensions": {"KHR_lights_punctual": {"light": 0}},
               "matrix": [1, 0, 0, 0,  0, 0, -1, 0,  0, 1, 0, 0,  139.0, 274.0, 139.8, 1]}),
    );
    let root = d.push(
        "nodes",
        json!({"name": "box", "scale": [2.0, 2.0, 2.0], "children": [geometry, spot]}),
    );
    // cbox's camera at (278, 273, -800) looking along +z: glTF cameras look down -z, so
    // half a turn about y.
    let cam = d.push(
        "cameras",
        json!({"type": "perspective",
               "perspective": {"yfov": 39.3077f32.to_radians(), "aspectRatio": 1.0, "znear": 1.0}}),
    );
    let camera = d.push(
        "nodes",
        json!({"camera": cam, "translation": [278.0, 273.0, -800.0], "rotation": [0.0, 1.0, 0.0, 0.0]}),
    );
    d.json["scenes"][0]["nodes"] = json!([root, camera]);
    d.json["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "spot", "name": "spot", "color": [1.0, 1.0, 1.0], "intensity": 300000.0 * 683.0,
         "spot": {"innerConeAngle": 45f32.to_radians(), "outerConeAngle": 60f32.to_radians()}}
    ]}});
    d
}

/// The OBJ + TOML version of the same box: the luminaire emitting, the spot and camera of
/// cornell_box.toml.
fn cornell_toml(dir: &Path) -> PathBuf {
    let obj = scenes().join("cornell_original_mm.obj");
    let text = format!(
        "[[object]]\nmesh = {:?}\n\n[[light]]\nname = \"spot\"\ntype = \"spot\"\nposition = [278.0, 548.0, 279.6]\n\
         target = [278.0, 0.0, 279.6]\nintensity = [300000.0, 300000.0, 300000.0]\ncutoff_angle = 60.0\n\
         beam_width = 45.0\n\n[camera]\nposition = [278.0, 273.0, -800.0]\ntarget = [278.0, 273.0, -799.0]\n\
         up = [0.0, 1.0, 0.0]\nfov = 39.3077\nwidth = 256\nheight = 256\n\n[solver]\n{SOLVER}",
        obj.to_str().unwrap()
    );
    let p = dir.join("obj.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// A scene file holding one glTF object and `extra` TOML.
fn gltf_toml(dir: &Path, mesh: &Path, extra: &str) -> PathBuf {
    let p = dir.join(format!(
        "{}.toml",
        mesh.file_name().unwrap().to_str().unwrap().replace('.', "_")
    ));
    std::fs::write(
        &p,
        format!(
            "[[object]]\nmesh = {:?}\n{extra}\n[solver]\n{SOLVER}",
            mesh.file_name().unwrap().to_str().unwrap()
        ),
    )
    .unwrap();
    p
}

/// Largest difference of two value lists, relative to the largest value.
fn max_rel_diff(a: impl Iterator<Item = f32> + Clone, b: impl Iterator<Item = f32>) -> f32 {
    let top = a.clone().fold(0.0f32, |m, x| m.max(x.abs()));
    a.zip(b).fold(0.0f32, |m, (x, y)| m.max((x - y).abs())) / top.max(1e-30)
}

#[test]
fn cornell_as_gltf_solves_as_obj_and_toml() {
    let dir = common::tmpdir();
    let doc = cornell_gltf();
    let (obj_scene, params) = common::load(&cornell_toml(dir.path()), &[]);
    let mut loaded = Vec::new();
    for (name, layout) in [
        ("ext", Layout::External),
        ("uri", Layout::DataUri),
        ("bin", Layout::Binary),
    ] {
        let g = doc.write(dir.path(), name, layout);
        let (s, p) = common::load(&gltf_toml(dir.path(), &g, ""), &[]);
        assert_eq!(s.tris.len(), obj_scene.tris.len(), "{name}");
        for (a, b) in s.tris.iter().zip(&obj_scene.tris) {
            assert_eq!(
                (a.v0, a.v1, a.v2),
                (b.v0, b.v1, b.v2),
                "{name}: the same triangles in the same order"
            );
        }
        assert_eq!(s.report.emitting_triangles, obj_scene.report.emitting_triangles);
        assert!(s.report.emitting_triangles > 0);
        assert_eq!(s.light_names, ["spot"]);
        let (l, m) = (s.lights[0], obj_scene.lights[0]);
        assert_eq!(
            (l.kind, l.position, l.direction, l.power),
            (m.kind, m.position, m.direction, m.power)
        );
        assert!((l.cutoff - m.cutoff).abs() < 1e-6 && (l.beam - m.beam).abs() < 1e-6);
        let (c, d) = (&s.camera, &obj_scene.camera);
        assert_eq!((c.width, c.height), (d.width, d.height));
        assert!(c.position.distance(d.position) < 1e-3 && c.forward.distance(d.forward) < 1e-6);
        assert!(c.up.distance(d.up) < 1e-6 && (c.tan_half - d.tan_half).abs() < 1e-6);
        assert!(s.report.notes.is_empty(), "{:?}", s.report.notes);
        loaded.push((s, p));
    }
    // One solve each: the glTF (from the .glb) against the OBJ + TOML.
    let (g_scene, g_params) = &loaded[2];
    let (h0, s0) = common::solve_cpu(&obj_scene, &params);
    let (h1, s1) = common::solve_cpu(g_scene, g_params);
    assert_eq!(h0.nodes.len(), h1.nodes.len(), "the same hierarchy");
    let d = max_rel_diff(
        s0.values.direct.iter().flat_map(|v| v.to_array()),
        s1.values.direct.iter().flat_map(|v| v.to_array()),
    );
    let i = max_rel_diff(
        s0.values.indirect.iter().flat_map(|v| v.to_array()),
        s1.values.indirect.iter().flat_map(|v| v.to_array()),
    );
    assert!(
        d < 1e-4 && i < 1e-4,
        "direct differs by {d}, indirect by {i} of the largest value"
    );
    let mean = |v: &[glam::Vec4]| v.iter().map(|x| x.x as f64).sum::<f64>() / v.len() as f64;
    assert!(mean(&s0.values.indirect) > 0.0 && mean(&s0.values.direct) > 0.0);
}

/// A unit quad in the xz plane (y = 0, facing +y) as two triangles, with uvs.
fn quad() -> (Vec<f32>, Vec<f32>) {
    let p = vec![
        0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 0.0,
    ];
    let uv = vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0];
    (p, uv)
}

#[test]
fn textures_lights_and_node_matrices() {
    let dir = common::tmpdir();
    let (p, uv) = quad();
    let mut d = Doc::default();
    let pos = d.floats(&p, "VEC3");
    let tex = d.floats(&uv, "VEC2");
    let png_view = d.view(&common::gltf::checker_png());
    let img = d.push("images", json!({"bufferView": png_view, "mimeType": "image/png"}));
    let sampler = d.push("samplers", json!({"wrapS": 33071, "wrapT": 33648}));
    let t = d.push("textures", json!({"source": img, "sampler": sampler}));
    let m = d.push(
        "materials",
        json!({"name": "checker", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0],
               "baseColorTexture": {"index": t}}}),
    );
    let mesh = d.push(
        "meshes",
        json!({"primitives": [{"attributes": {"POSITION": pos, "TEXCOORD_0": tex}, "material": m}]}),
    );
    // The quad, and a mirrored copy (scale -1 in x, moved up): its winding turns back, so
    // it still faces +y.
    let a = d.push("nodes", json!({"name": "quad", "mesh": mesh}));
    let b = d.push(
        "nodes",
        json!({"name": "mirror", "mesh": mesh, "translation": [0.0, 2.0, 0.0], "scale": [-1.0, 1.0, 1.0]}),
    );
    // A triangle strip of one quad, and a points primitive (not used, named in the note).
    let strip_pos = d.floats(&[3.0, 0.0, 0.0, 3.0, 0.0, 1.0, 4.0, 0.0, 0.0, 4.0, 0.0, 1.0], "VEC3");
    let strip = d.push(
        "meshes",
        json!({"primitives": [{"attributes": {"POSITION": strip_pos}, "mode": 5},
                              {"attributes": {"POSITION": strip_pos}, "mode": 0}]}),
    );
    let s = d.push("nodes", json!({"name": "strip", "mesh": strip}));
    // A directional light of 683 lux pointing down (-z turned to -y), a point light.
    let sun = d.push(
        "nodes",
        json!({"matrix": [1, 0, 0, 0,  0, 0, -1, 0,  0, 1, 0, 0,  0, 5, 0, 1],
               "extensions": {"KHR_lights_punctual": {"light": 0}}}),
    );
    let bulb = d.push(
        "nodes",
        json!({"name": "bulb", "translation": [0.5, 1.0, 0.5], "extensions": {"KHR_lights_punctual": {"light": 1}}}),
    );
    d.json["scenes"][0]["nodes"] = json!([a, b, s, sun, bulb]);
    d.json["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    d.json["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "directional", "name": "sun", "intensity": 683.0, "color": [1.0, 0.5, 0.25]},
        {"type": "point", "intensity": 6830.0, "range": 10.0}
    ]}});
    let g = d.write(dir.path(), "t", Layout::Binary);
    let (scene, _) = common::load(&gltf_toml(dir.path(), &g, ""), &[]);

    // Lights: lux / 683 = W/m², candela / 683 = W/sr; the unnamed light takes its node's name.
    assert_eq!(scene.light_names, ["sun", "bulb"]);
    assert_eq!(scene.lights[0].power, [1.0, 0.5, 0.25]);
    assert_eq!(Vec3::from(scene.lights[0].direction), Vec3::NEG_Y);
    assert_eq!(scene.lights[1].power, [10.0; 3]);
    assert_eq!(scene.lights[1].position, [0.5, 1.0, 0.5]);
    let note = scene.report.notes.join("\n");
    assert!(
        note.contains("point and line primitives ×1") && note.contains("light ranges"),
        "{note}"
    );

    // Triangles: 2 + 2 mirrored + 2 from the strip, all facing +y.
    assert_eq!(scene.tris.len(), 6);
    for t in &scene.tris {
        let n = meshrad::geom::ray::tri_normal(t);
        assert!(n.dot(Vec3::Y) > 0.99, "{n}");
    }

    // Albedo: 0.5 × the texel, glTF's v = 0 at the image's top row. Texel centres at
    // u, v = 1/4, 3/4 of the plain quad (x = u, z = v).
    let at = |x: f32, z: f32| {
        let ray = meshrad::geom::Ray {
            o: Vec3::new(x, 0.5, z),
            d: Vec3::NEG_Y,
        };
        let hit = scene.intersect(&ray, 1.0).expect("hits the quad");
        scene.surface(&hit, ray.d).albedo
    };
    let close = |a: Vec3, b: Vec3| a.distance(b) < 1e-5;
    assert!(
        close(at(0.25, 0.25), Vec3::new(0.5, 0.0, 0.0)),
        "red at the top left: {}",
        at(0.25, 0.25)
    );
    assert!(
        close(at(0.75, 0.25), Vec3::new(0.0, 0.5, 0.0)),
        "green: {}",
        at(0.75, 0.25)
    );
    assert!(
        close(at(0.25, 0.75), Vec3::new(0.0, 0.0, 0.5)),
        "blue: {}",
        at(0.25, 0.75)
    );
    assert!(close(at(0.75, 0.75), Vec3::splat(0.5)), "white: {}", at(0.75, 0.75));
    // Clamp in u: the edge texel up to the quad's edge, no blend with the far column.
    assert!(
        close(at(0.999, 0.25), Vec3::new(0.0, 0.5, 0.0)),
        "clamped: {}",
        at(0.999, 0.25)
    );
    // Mirror in v: at v → 1 the bottom row itself, not wrapped to the top.
    assert!(
        close(at(0.25, 0.999), Vec3::new(0.0, 0.0, 0.5)),
        "mirrored: {}",
        at(0.25, 0.999)
    );
}

#[test]
fn group_selects_nodes_and_a_missing_one_is_named() {
    let dir = common::tmpdir();
    let (p, _) = quad();
    let mut d = one_mesh(&p, [0.5; 3]);
    d.json["nodes"][0]["name"] = json!("floor");
    let lifted: Vec<f32> = p.chunks(3).flat_map(|v| [v[0], v[1] + 1.0, v[2]]).collect();
    let pos = d.floats(&lifted, "VEC3");
    let mesh = d.push(
        "meshes",
        json!({"primitives": [{"attributes": {"POSITION": pos}, "material": 0}]}),
    );
    let n = d.push("nodes", json!({"name": "shelf", "mesh": mesh}));
    d.json["scenes"][0]["nodes"].as_array_mut().unwrap().push(json!(n));
    let g = d.write(dir.path(), "g", Layout::External);
    let light = "[[light]]\ntype = \"directional\"\ndirection = [0, -1, 0]\nirradiance = [1, 1, 1]\n";
    let (s, _) = common::load(&gltf_toml(dir.path(), &g, &format!("group = \"shelf\"\n{light}")), &[]);
    assert_eq!(s.tris.len(), 2);
    assert!(s.tris.iter().all(|t| t.v0[1] == 1.0));
    let bad = gltf_toml(dir.path(), &g, &format!("group = \"attic\"\n{light}"));
    let err = meshrad::Scene::load(&bad, &[]).unwrap_err().to_string();
    assert!(
        err.contains("g.gltf") && err.contains("no node `attic`") && err.contains("shelf"),
        "{err}"
    );
    // Issue #34: `!` leaves a node out (a skybox, say) and keeps the rest; any node, named
    // or not, is also `nodes[i]`.
    let (s, _) = common::load(&gltf_toml(dir.path(), &g, &format!("group = \"!shelf\"\n{light}")), &[]);
    assert_eq!(s.tris.len(), 2);
    assert!(s.tris.iter().all(|t| t.v0[1] == 0.0));
    d.json["nodes"][n]["name"] = json!(null);
    let g = d.write(dir.path(), "unnamed", Layout::External);
    let (s, _) = common::load(
        &gltf_toml(dir.path(), &g, &format!("group = \"nodes[{n}]\"\n{light}")),
        &[],
    );
    assert!(s.tris.len() == 2 && s.tris.iter().all(|t| t.v0[1] == 1.0));
    let (s, _) = common::load(
        &gltf_toml(dir.path(), &g, &format!("group = [\"!nodes[{n}]\"]\n{light}")),
        &[],
    );
    assert!(s.tris.len() == 2 && s.tris.iter().all(|t| t.v0[1] == 0.0));
    let bad = gltf_toml(dir.path(), &g, &format!("group = \"!nodes[9]\"\n{light}"));
    let err = meshrad::Scene::load(&bad, &[]).unwrap_err().to_string();
    assert!(
        err.contains("no node `nodes[9]`") && err.contains("`nodes[i]`"),
        "{err}"
    );
}

/// Mutated glTF files load or fail with an error, never a panic: numbers in the JSON
/// replaced by values that break careless code (indices, counts, offsets, strides, types),
/// and bytes of a `.glb` overwritten at random. `MESHRAD_FUZZ_SEED` (default 1) picks the
/// sequence and `MESHRAD_GLTF_CASES` (default 1500) its length.
#[test]
fn mutated_gltf_never_panics() {
    let dir = common::tmpdir();
    let d = dir.path();
    let doc = {
        let mut p = common::gltf::textured_corner(d, "levels = 2\ncoarsest = 8\n");
        p.set_extension("glb");
        std::fs::read(&p).unwrap()
    };
    let light = "[[light]]\ntype = \"point\"\nposition = [1.0, 1.0, 1.0]\nintensity = [1.0, 1.0, 1.0]\n";
    std::fs::write(d.join("s.toml"), format!("[[object]]\nmesh = \"m.gltf\"\n{light}")).unwrap();
    std::fs::write(d.join("b.toml"), format!("[[object]]\nmesh = \"m.glb\"\n{light}")).unwrap();
    // The same document as JSON text with its buffer beside it.
    let json_len = u32::from_le_bytes(doc[12..16].try_into().unwrap()) as usize;
    let mut json: serde_json::Value = serde_json::from_slice(&doc[20..20 + json_len]).unwrap();
    let bin = doc[20 + json_len + 8..].to_vec();
    std::fs::write(d.join("m.bin"), &bin).unwrap();
    json["buffers"] = serde_json::json!([{"uri": "m.bin", "byteLength": bin.len()}]);
    let text = serde_json::to_string(&json).unwrap();
    let env = |k: &str, d: u64| std::env::var(k).ok().and_then(|v| v.parse().ok()).unwrap_or(d);
    let cases = env("MESHRAD_GLTF_CASES", 1500);
    let mut state = 0x9e37_79b9_7f4a_7c15u64 ^ env("MESHRAD_FUZZ_SEED", 1).wrapping_mul(0x2545_f491_4f6c_dd1d);
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let weird = [
        "0",
        "1",
        "-1",
        "2",
        "3",
        "4",
        "5",
        "7",
        "12",
        "255",
        "65535",
        "4294967295",
        "4294967296",
        "1e30",
        "-1e30",
        "0.5",
        "5120",
        "5121",
        "5123",
        "5125",
        "5126",
        "33071",
        "33648",
    ];
    let (mut loaded, mut failed) = (0, 0);
    for case in 0..cases {
        let (scene, bytes) = if case % 3 == 2 {
            let mut b = doc.clone();
            for _ in 0..1 + next() % 4 {
                let i = (next() % b.len() as u64) as usize;
                b[i] = next() as u8;
            }
            ("b.toml", b)
        } else {
            // Replace one to three numbers of the JSON.
            let mut t = text.clone();
            for _ in 0..1 + next() % 3 {
                let spans: Vec<(usize, usize)> = {
                    let b = t.as_bytes();
                    let mut v = Vec::new();
                    let mut i = 0;
                    while i < b.len() {
                        if b[i].is_ascii_digit() && (i == 0 || !b[i - 1].is_ascii_alphanumeric()) {
                            let s = i;
                            while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.' || b[i] == b'e' || b[i] == b'-')
                            {
                                i += 1;
                            }
                            v.push((s, i));
                        } else {
                            i += 1;
                        }
                    }
                    v
                };
                let (s, e) = spans[(next() % spans.len() as u64) as usize];
                let w = weird[(next() % weird.len() as u64) as usize];
                t.replace_range(s..e, w);
            }
            ("s.toml", t.into_bytes())
        };
        let target = if scene == "b.toml" { "m.glb" } else { "m.gltf" };
        std::fs::write(d.join(target), &bytes).unwrap();
        let path = d.join(scene);
        let r = std::panic::catch_unwind(|| meshrad::Scene::load(&path, &[]).map(|_| ()));
        match r {
            Ok(Ok(())) => loaded += 1,
            Ok(Err(e)) => {
                assert!(e.to_string().contains(target), "the error names the file: {e}");
                failed += 1
            }
            Err(_) => {
                let keep = std::env::temp_dir().join(format!("meshrad-gltf-panic-{case}.{}", &target[2..]));
                std::fs::write(&keep, &bytes).unwrap();
                panic!("case {case} panicked; kept as {}", keep.display());
            }
        }
    }
    eprintln!("mutated glTF: {loaded} loaded, {failed} refused with an error");
    assert!(loaded > 0 && failed > 0);
}

/// Issue #34: glTF's default white (no `pbrMetallicRoughness`: an albedo of 1) loads,
/// lowered to `max_albedo`, with one note naming the material; a textured material whose
/// mean albedo is above it has its factor scaled down to bring the mean there.
#[test]
fn an_albedo_of_one_loads_lowered_to_max_albedo() {
    let dir = common::tmpdir();
    let (p, _) = quad();
    let mut d = one_mesh(&p, [0.5; 3]);
    d.json["materials"][0] = json!({"name": "paper"});
    let g = d.write(dir.path(), "g", Layout::External);
    let light = "[[light]]\ntype = \"directional\"\ndirection = [0, -1, 0]\nirradiance = [1, 1, 1]\n";
    let (s, _) = common::load(&gltf_toml(dir.path(), &g, light), &[]);
    assert_eq!(s.materials[0].kd, [0.98; 3]);
    let notes = s.report.notes.join("\n");
    assert!(
        notes.contains("albedo lowered to 0.98") && notes.contains("paper"),
        "{notes}"
    );
    let (s, _) = common::load(&gltf_toml(dir.path(), &g, light), &[("max_albedo", "0.5")]);
    assert_eq!(s.materials[0].kd, [0.5; 3]);
}

/// Issue #34: `!` leaves an OBJ group out too, keeping every other one; a group named
/// both ways is left out.
#[test]
fn obj_groups_can_be_left_out() {
    let box_toml = scenes().join("cornell_box.toml");
    let (all, _) = common::load(&box_toml, &[]);
    let dir = common::tmpdir();
    let text = std::fs::read_to_string(&box_toml).unwrap();
    let mesh = scenes().join("cornell_original_mm.obj");
    let without = |groups: &str| {
        let p = dir.path().join("s.toml");
        let t = text.replace(
            "mesh = \"cornell_original_mm.obj\"",
            &format!("mesh = {:?}\ngroup = {groups}", mesh.to_str().unwrap()),
        );
        assert!(t.contains("group = "), "{t}");
        std::fs::write(&p, t).unwrap();
        common::load(&p, &[]).0.tris.len()
    };
    let n = all.tris.len();
    assert_eq!(without("\"!cbox_largebox\""), n - 12);
    assert_eq!(without("[\"!cbox_largebox\", \"!cbox_smallbox\"]"), n - 24);
    assert_eq!(without("[\"cbox_floor\", \"cbox_back\", \"!cbox_back\"]"), 2);
}

/// Issue #34: `emissiveTexture` × `emissiveFactor` is the emission, per texel (glTF's v
/// down the image, the sampler's clamp); a texture under the default factor of zero
/// emits nothing.
#[test]
fn emissive_textures_multiply_the_factor_per_texel() {
    let dir = common::tmpdir();
    let (p, uv) = quad();
    let mut d = Doc::default();
    let pos = d.floats(&p, "VEC3");
    let tc = d.floats(&uv, "VEC2");
    let view = d.view(&common::gltf::checker_png());
    let img = d.push("images", json!({"bufferView": view, "mimeType": "image/png"}));
    let sampler = d.push("samplers", json!({"wrapS": 33071, "wrapT": 33071}));
    let tex = d.push("textures", json!({"source": img, "sampler": sampler}));
    let m = d.push(
        "materials",
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0]},
               "emissiveFactor": [3.0, 3.0, 3.0], "emissiveTexture": {"index": tex}}),
    );
    let mesh = d.push(
        "meshes",
        json!({"primitives": [{"attributes": {"POSITION": pos, "TEXCOORD_0": tc}, "material": m}]}),
    );
    let n = d.push("nodes", json!({"mesh": mesh}));
    d.json["scenes"][0]["nodes"] = json!([n]);
    let g = d.write(dir.path(), "lamp", Layout::Binary);
    let (s, _) = common::load(&gltf_toml(dir.path(), &g, ""), &[]);
    assert_eq!(s.report.emitting_triangles, 2);
    let notes = s.report.notes.join("\n");
    assert!(!notes.contains("emissive"), "{notes}");
    // The quad lies in y = 0 with uv = (x, z); the checker's top row (glTF v = 0) is red
    // and green, its bottom row blue and white.
    let at = |x: f32, z: f32| -> Vec3 {
        for (t, tri) in s.tris.iter().enumerate() {
            let (a, b, c) = (Vec3::from(tri.v0), Vec3::from(tri.v1), Vec3::from(tri.v2));
            let cross = |u: Vec3, v: Vec3| u.x * v.z - u.z * v.x;
            let q = Vec3::new(x, 0.0, z);
            let area = cross(b - a, c - a);
            let (b1, b2) = (cross(q - a, c - a) / area, cross(b - a, q - a) / area);
            if b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 {
                return s.emitted_at(t as u32, b1, b2);
            }
        }
        panic!("({x}, {z}) is on no triangle");
    };
    for (x, z, want) in [
        (0.1, 0.1, Vec3::new(3.0, 0.0, 0.0)),
        (0.9, 0.1, Vec3::new(0.0, 3.0, 0.0)),
        (0.1, 0.9, Vec3::new(0.0, 0.0, 3.0)),
        (0.9, 0.9, Vec3::splat(3.0)),
    ] {
        let got = at(x, z);
        assert!(
            (got - want).abs().max_element() < 1e-5,
            "at ({x}, {z}): {got}, want {want}"
        );
    }
    // The default emissiveFactor is zero: the texture alone emits nothing.
    d.json["materials"][0] = json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0]},
                                    "emissiveTexture": {"index": tex}});
    let g = d.write(dir.path(), "dark", Layout::Binary);
    let light = "[[light]]\ntype = \"directional\"\ndirection = [0, -1, 0]\nirradiance = [1, 1, 1]\n";
    let (s, _) = common::load(&gltf_toml(dir.path(), &g, light), &[]);
    assert_eq!(s.report.emitting_triangles, 0);
}

/// Issue #34: `NORMAL` is read as the shading normal, placed by the inverse transpose of
/// the node matrix (a non-uniform scale tilts it the other way from the positions).
#[test]
fn vertex_normals_follow_the_inverse_transpose_of_the_node_matrix() {
    let dir = common::tmpdir();
    let (p, _) = quad();
    let mut d = Doc::default();
    let pos = d.floats(&p, "VEC3");
    let nrm = d.floats(&[0.6f32, 0.8, 0.0].repeat(6), "VEC3");
    let m = d.push(
        "materials",
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0]}}),
    );
    let mesh = d.push(
        "meshes",
        json!({"primitives": [{"attributes": {"POSITION": pos, "NORMAL": nrm}, "material": m}]}),
    );
    let n = d.push("nodes", json!({"mesh": mesh, "scale": [2.0, 1.0, 1.0]}));
    d.json["scenes"][0]["nodes"] = json!([n]);
    let g = d.write(dir.path(), "tilted", Layout::External);
    let light = "[[light]]\ntype = \"directional\"\ndirection = [0, -1, 0]\nirradiance = [1, 1, 1]\n";
    let (s, _) = common::load(&gltf_toml(dir.path(), &g, light), &[]);
    let d = -Vec3::Y;
    let hit = s
        .intersect(
            &meshrad::geom::Ray {
                o: Vec3::new(1.0, 2.0, 0.5),
                d,
            },
            f32::INFINITY,
        )
        .expect("the quad is below");
    let got = s.surface(&hit, d).n;
    let want = Vec3::new(0.3, 0.8, 0.0).normalize();
    assert!((got - want).length() < 1e-5, "{got} against {want}");
}

/// Issue #34: `alphaMode` MASK cuts out where the base colour's alpha (factor × texture)
/// is below `alphaCutoff`; BLEND is a cutout at 0.5, noted; OPAQUE ignores alpha.
#[test]
fn alpha_mask_and_blend_are_cutouts() {
    let dir = common::tmpdir();
    let (p, uv) = quad();
    let mut img = image::RgbaImage::new(2, 1);
    img.put_pixel(0, 0, image::Rgba([200, 200, 200, 51]));
    img.put_pixel(1, 0, image::Rgba([200, 200, 200, 255]));
    let mut png = std::io::Cursor::new(Vec::new());
    img.write_to(&mut png, image::ImageFormat::Png).unwrap();
    let light = "[[light]]\ntype = \"directional\"\ndirection = [0, -1, 0]\nirradiance = [1, 1, 1]\n";
    // Whether a ray stops at (x, 0, 0.5) of the quad (uv = (x, z)).
    let stops = |s: &meshrad::Scene, x: f32| {
        let d = -Vec3::Y;
        let ray = meshrad::geom::Ray {
            o: Vec3::new(x, 1.0, 0.5),
            d,
        };
        s.intersect(&ray, f32::INFINITY).is_some()
    };
    for (mode, factor, cutoff, left, right) in [
        ("MASK", 1.0, Some(0.3), false, true),
        ("MASK", 0.5, Some(0.3), false, true),
        ("MASK", 0.5, Some(0.6), false, false),
        ("BLEND", 1.0, None, false, true),
        ("OPAQUE", 0.1, None, true, true),
    ] {
        let mut d = Doc::default();
        let pos = d.floats(&p, "VEC3");
        let tc = d.floats(&uv, "VEC2");
        let view = d.view(png.get_ref());
        let im = d.push("images", json!({"bufferView": view, "mimeType": "image/png"}));
        let sampler = d.push("samplers", json!({"wrapS": 33071, "wrapT": 33071}));
        let tex = d.push("textures", json!({"source": im, "sampler": sampler}));
        let mut mat = json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, factor],
                                                      "baseColorTexture": {"index": tex}},
                             "alphaMode": mode});
        if let Some(c) = cutoff {
            mat["alphaCutoff"] = json!(c);
        }
        let m = d.push("materials", mat);
        let mesh = d.push(
            "meshes",
            json!({"primitives": [{"attributes": {"POSITION": pos, "TEXCOORD_0": tc}, "material": m}]}),
        );
        let n = d.push("nodes", json!({"mesh": mesh}));
        d.json["scenes"][0]["nodes"] = json!([n]);
        let g = d.write(dir.path(), &format!("{mode}{factor}{cutoff:?}"), Layout::Binary);
        let (s, _) = common::load(&gltf_toml(dir.path(), &g, light), &[]);
        let got = (stops(&s, 0.1), stops(&s, 0.9));
        assert_eq!(got, (left, right), "{mode} factor {factor} cutoff {cutoff:?}");
        let notes = s.report.notes.join("\n");
        assert_eq!(notes.contains("alphaMode BLEND"), mode == "BLEND", "{notes}");
    }
}

/// Issue #34: a public asset as shipped (Khronos' BoxTextured, CC-BY 4.0, in
/// `tests/data/`): its embedded PNG and buffer are read under glTF's default white
/// factor, its normals are read, and it solves and renders lit.
#[test]
fn box_textured_loads_as_shipped() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/BoxTextured/scene.toml");
    let (s, p) = common::load(&path, &[]);
    assert_eq!(s.triangle_count(), 12);
    assert!(s.textured());
    assert_eq!(s.normals.len(), 12);
    // glTF's default white factor: the texture's mean under it is below max_albedo, so
    // it stays 1 (a factor of 1 alone would be lowered: `an_albedo_of_one_loads…`).
    assert_eq!(s.materials[0].kd, [1.0; 3]);
    let hidden = meshrad::progress::Progress::hidden();
    let run = meshrad::solve(&s, &p, &mut meshrad::Engine::cpu(), &hidden).unwrap();
    let img = meshrad::output::image::render(&s, &run.hierarchy, &run.solution, &p, &hidden);
    let lit = img.total().iter().filter(|v| v.min_element() > 0.0).count();
    assert!(lit > img.direct.len() / 2, "{lit} of {} pixels lit", img.direct.len());
    // A lone convex box: nothing reflects light back onto it.
    assert!(run
        .solution
        .values
        .indirect
        .iter()
        .all(|v| v.x == 0.0 && v.y == 0.0 && v.z == 0.0));
}

/// Issue #35: a non-unit rotation quaternion is normalised with a note (it scaled and
/// sheared the mesh), and a zero one is refused naming the node.
#[test]
fn rotation_quaternions_are_normalised_or_refused() {
    let dir = common::tmpdir();
    let (p, _) = quad();
    let light = "[[light]]\ntype = \"directional\"\ndirection = [0, -1, 0]\nirradiance = [1, 1, 1]\n";
    let load = |name: &str, q: serde_json::Value| {
        let mut d = one_mesh(&p, [0.5; 3]);
        d.json["nodes"][0]["rotation"] = q;
        let g = d.write(dir.path(), name, Layout::External);
        meshrad::Scene::load(&gltf_toml(dir.path(), &g, light), &[])
    };
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let (unit, _) = load("unit", json!([0.0, h, 0.0, h])).unwrap();
    let (half, _) = load("half", json!([0.0, 0.5, 0.0, 0.5])).unwrap();
    assert_eq!(unit.tris.len(), half.tris.len());
    for (a, b) in unit.tris.iter().zip(&half.tris) {
        for (u, v) in [(a.v0, b.v0), (a.v1, b.v1), (a.v2, b.v2)] {
            assert!((Vec3::from(u) - Vec3::from(v)).length() < 1e-5, "{u:?} {v:?}");
        }
    }
    let notes = half.report.notes.join("\n");
    assert!(
        notes.contains("nodes[0].rotation") && notes.contains("normalised"),
        "{notes}"
    );
    assert!(!unit.report.notes.join("\n").contains("normalised"));
    let err = load("zero", json!([0.0, 0.0, 0.0, 0.0])).unwrap_err().to_string();
    assert!(err.contains("zero.gltf") && err.contains("nodes[0].rotation"), "{err}");
}

/// Issue #35: a glTF camera under a zero matrix is named (it was reported as the TOML's
/// `camera.target`), and a valid camera far from the origin works.
#[test]
fn gltf_cameras_far_away_work_and_degenerate_ones_are_named() {
    let dir = common::tmpdir();
    let (p, _) = quad();
    let light = "[[light]]\ntype = \"directional\"\ndirection = [0, -1, 0]\nirradiance = [1, 1, 1]\n";
    let with_camera = |name: &str, node: serde_json::Value| {
        let mut d = one_mesh(&p, [0.5; 3]);
        let cam = d.push(
            "cameras",
            json!({"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.1}}),
        );
        let mut node = node;
        node["camera"] = json!(cam);
        let n = d.push("nodes", node);
        d.json["scenes"][0]["nodes"].as_array_mut().unwrap().push(json!(n));
        let g = d.write(dir.path(), name, Layout::External);
        (meshrad::Scene::load(&gltf_toml(dir.path(), &g, light), &[]), n)
    };
    let (r, n) = with_camera("zero", json!({"scale": [0.0, 0.0, 0.0]}));
    let err = r.map(|_| ()).unwrap_err().to_string();
    assert!(
        err.contains("zero.gltf") && err.contains(&format!("nodes[{n}]")) && err.contains("cameras[0]"),
        "{err}"
    );
    assert!(!err.contains("camera.target"), "{err}");
    let (r, _) = with_camera("far", json!({"translation": [0.0, 0.0, 1e9]}));
    let (s, _) = r.unwrap();
    assert!(
        (s.camera.forward - Vec3::NEG_Z).length() < 1e-6,
        "{:?}",
        s.camera.forward
    );
    assert_eq!(s.camera.position, Vec3::new(0.0, 0.0, 1e9));
}

/// Issue #35: buffers that name one file read it once, and what the buffers read, together,
/// stays within the read limit (a quarter of `--max-memory`; here 16 MiB), naming the
/// buffer that would pass it.
#[test]
fn buffers_read_a_file_once_and_together_within_the_limit() {
    let dir = common::tmpdir();
    let (p, _) = quad();
    let d = one_mesh(&p, [0.5; 3]);
    let g = d.write(dir.path(), "m", Layout::External);
    let mut bin = std::fs::read(dir.path().join("m.bin")).unwrap();
    let n = bin.len();
    bin.resize(6 << 20, 0);
    std::fs::write(dir.path().join("m.bin"), &bin).unwrap();
    for k in 0..3 {
        std::fs::write(dir.path().join(format!("pad{k}.bin")), &bin).unwrap();
    }
    let mut json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&g).unwrap()).unwrap();
    let source = Source::Dir(dir.path().to_path_buf());
    let load = || meshrad::scene::gltf_file::load(&source, Path::new("m.gltf"), 16 << 20, None);
    // 40 buffers naming m.bin: one read of 6 MiB, within 16 MiB.
    json["buffers"] = json!((0..40)
        .map(|_| json!({"uri": "m.bin", "byteLength": n}))
        .collect::<Vec<_>>());
    std::fs::write(&g, json.to_string()).unwrap();
    load().unwrap();
    // Three files of 6 MiB: 18 MiB together, over 16 MiB.
    json["buffers"] = json!((0..3)
        .map(|k| json!({"uri": format!("pad{k}.bin"), "byteLength": n}))
        .collect::<Vec<_>>());
    std::fs::write(&g, json.to_string()).unwrap();
    let err = load().map(|_| ()).unwrap_err().to_string();
    assert!(err.contains("buffers[2]") && err.contains("pad2.bin"), "{err}");
}

/// Issue #35: the triangle count asked of the budget before any triangle is built: per
/// mesh instance, a list's count / 3 and a strip's or fan's count − 2, the index
/// accessor's count where there is one, and with `group` only the named subtrees; equal
/// to what is built when no triangle is degenerate.
#[test]
fn triangles_are_counted_from_the_accessors_before_they_are_built() {
    let dir = common::tmpdir();
    let (p, _) = quad();
    let mut d = one_mesh(&p, [0.5; 3]);
    // A strip of 6 vertices (4 triangles) drawn through an index accessor, and a fan.
    let strip: Vec<f32> = (0..6).flat_map(|i| [(i / 2) as f32, 0.0, (i % 2) as f32]).collect();
    let sp = d.floats(&strip, "VEC3");
    let si = d.indices(&[0, 1, 2, 3, 4, 5]);
    let fan: Vec<f32> = [
        [0.0, 2.0, 0.0],
        [1.0, 2.0, 0.0],
        [1.0, 2.0, 1.0],
        [0.0, 2.0, 1.0],
        [-1.0, 2.0, 0.5],
    ]
    .iter()
    .flatten()
    .copied()
    .collect();
    let fp = d.floats(&fan, "VEC3");
    let mesh = d.push(
        "meshes",
        json!({"primitives": [{"attributes": {"POSITION": sp}, "indices": si, "mode": 5},
                              {"attributes": {"POSITION": fp}, "mode": 6}]}),
    );
    // Mesh 1 twice: once under a named parent, once under an unnamed one.
    let a = d.push("nodes", json!({"mesh": mesh}));
    let b = d.push("nodes", json!({"mesh": mesh, "translation": [0.0, 5.0, 0.0]}));
    let named = d.push("nodes", json!({"name": "kept", "children": [a]}));
    let other = d.push("nodes", json!({"children": [b]}));
    d.json["scenes"][0]["nodes"]
        .as_array_mut()
        .unwrap()
        .extend([json!(named), json!(other)]);
    d.write(dir.path(), "m", Layout::External);
    let source = Source::Dir(dir.path().to_path_buf());
    let counted = std::cell::Cell::new(0u64);
    let budget = |n: u64| {
        counted.set(n);
        Ok(())
    };
    let g = meshrad::scene::gltf_file::load_within(&source, Path::new("m.gltf"), 1 << 30, None, &budget).unwrap();
    // The quad (2) and two instances of 4 + 3.
    assert_eq!(counted.get(), 2 + 2 * 7);
    assert_eq!(g.mesh.tris.len() as u64, counted.get());
    let kept = ["kept".to_string()];
    let g =
        meshrad::scene::gltf_file::load_within(&source, Path::new("m.gltf"), 1 << 30, Some(&kept), &budget).unwrap();
    assert_eq!(counted.get(), 7);
    assert_eq!(g.mesh.tris.len(), 7);
    // A refusal from the budget is the load's error, before anything is built.
    let refuse = |n: u64| {
        Err(meshrad::Error::Mesh {
            path: "m.gltf".into(),
            line: None,
            message: format!("{n} is too many"),
        })
    };
    let err = meshrad::scene::gltf_file::load_within(&source, Path::new("m.gltf"), 1 << 30, None, &refuse)
        .map(|_| ())
        .unwrap_err();
    assert!(err.to_string().contains("16 is too many"), "{err}");
}
