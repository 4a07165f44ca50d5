//! Bad input gets a clear error that names the input, a non-zero exit, and no panic; every
//! run's peak memory is measured and held to its `--max-memory` plus a fixed slack
//! ([`common::meshrad_bounded`]).

mod common;

use std::path::Path;

const OBJ: &str = "mtllib m.mtl\nusemtl a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n";
const MTL: &str = "newmtl a\nKd 0.5 0.5 0.5\n";
const LIGHT: &str = "[[light]]\ntype = \"point\"\nposition = [0.2, 0.2, 0.2]\nintensity = [1.0, 1.0, 1.0]\n";
const FAST: &str = "[solver]\nlevels = 2\ncoarsest = 20\nrays = 16\nbounces = 1\nsender_level = 1\ngather_levels = 1\n";

struct Case<'a> {
    toml: String,
    obj: &'a str,
    mtl: &'a str,
    extra: &'a [&'a str],
}

fn scene(toml: &str) -> Case<'static> {
    Case {
        toml: toml.to_string(),
        obj: OBJ,
        mtl: MTL,
        extra: &[],
    }
}

fn default_toml() -> String {
    format!("[[object]]\nmesh = \"m.obj\"\n\n{LIGHT}\n{FAST}")
}

/// Runs `meshrad solve -q` on the case; returns (success, stderr).
fn run(c: &Case) -> (bool, String) {
    run_with(c, true)
}

/// Runs `meshrad solve` on the case, quiet or with its notes; returns (success, stderr).
fn run_with(c: &Case, quiet: bool) -> (bool, String) {
    let dir = common::tmpdir();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), &c.toml).unwrap();
    std::fs::write(d.join("m.obj"), c.obj).unwrap();
    std::fs::write(d.join("m.mtl"), c.mtl).unwrap();
    let mut args = vec!["solve", "s.toml", "--out", "o", "--backend", "cpu"];
    if quiet {
        args.push("-q");
    }
    args.extend_from_slice(c.extra);
    let o = common::meshrad_output(d, &args, b"");
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(!err.contains("panicked"), "panic: {err}");
    (o.status.success(), err)
}

fn fails_with(c: Case, needles: &[&str]) {
    let (ok, err) = run(&c);
    assert!(!ok, "should fail: {}", c.toml);
    for n in needles {
        assert!(err.contains(n), "error should mention `{n}`:\n{err}");
    }
}

#[test]
fn a_good_case_passes() {
    let (ok, err) = run(&scene(&default_toml()));
    assert!(ok, "{err}");
}

#[test]
fn missing_scene_file() {
    let o = common::meshrad_output(Path::new("."), &["solve", "/nonexistent/scene.toml", "-q"], b"");
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("/nonexistent/scene.toml") && !err.contains("panicked"),
        "{err}"
    );
}

#[test]
fn malformed_toml_names_the_line() {
    fails_with(scene("[[object]]\nmesh = \"m.obj\n"), &["s.toml", "line 2"]);
}

#[test]
fn unknown_keys_are_errors() {
    let t = default_toml().replace("intensity", "intensty");
    fails_with(scene(&t), &["s.toml", "intensty"]);
    let t = format!("{}\nsender_levle = 1\n", default_toml());
    fails_with(scene(&t), &["sender_levle"]);
    let t = default_toml().replace("[[object]]\nmesh", "[[object]]\nscael = 2.0\nmesh");
    fails_with(scene(&t), &["scael"]);
    let mut c = scene(&default_toml());
    c.extra = &["--set", "bogus_key=1"];
    fails_with(c, &["bogus_key"]);
}

#[test]
fn impossible_parameters() {
    fails_with(scene(&default_toml().replace("rays = 16", "rays = -5")), &["rays"]);
    fails_with(scene(&default_toml().replace("levels = 2", "levels = 0")), &["levels"]);
    fails_with(
        scene(&default_toml().replace("sender_level = 1", "sender_level = 3")),
        &["sender_level"],
    );
    let mut c = scene(&default_toml());
    c.extra = &["--set", "kappa=nan"];
    fails_with(c, &["kappa"]);
    let t = default_toml().replace("[[object]]\nmesh", "[[object]]\nscale = -1.0\nmesh");
    fails_with(scene(&t), &["object[0].scale"]);
}

#[test]
fn no_light_or_no_geometry() {
    fails_with(
        scene(&format!("[[object]]\nmesh = \"m.obj\"\n{FAST}")),
        &["s.toml", "light"],
    );
    fails_with(scene(&format!("{LIGHT}\n{FAST}")), &["s.toml", "object"]);
}

#[test]
fn bad_lights() {
    let t = default_toml().replace(
        LIGHT,
        "[[light]]\ntype = \"directional\"\ndirection = [0.0, 0.0, 0.0]\nirradiance = [1.0, 1.0, 1.0]\n",
    );
    fails_with(scene(&t), &["light[0].direction"]);
    let t = default_toml().replace(
        LIGHT,
        "[[light]]\ntype = \"spot\"\nposition = [0.2, 0.2, 0.2]\ntarget = [0.0, 0.0, 0.0]\n\
         direction = [0.0, -1.0, 0.0]\nintensity = [1.0, 1.0, 1.0]\ncutoff_angle = 30.0\nbeam_width = 20.0\n",
    );
    fails_with(scene(&t), &["light[0]", "exactly one"]);
    let t = default_toml().replace("intensity = [1.0, 1.0, 1.0]", "intensity = [1.0, nan, 1.0]");
    fails_with(scene(&t), &["light[0].intensity"]);
    let t = default_toml().replace("type = \"point\"", "type = \"area\"");
    fails_with(scene(&t), &["area"]);
}

#[test]
fn missing_mesh_material_and_texture_files() {
    fails_with(scene(&default_toml().replace("m.obj", "nope.obj")), &["nope.obj"]);
    let mut c = scene(&default_toml());
    c.obj = "mtllib missing.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    fails_with(c, &["m.obj", "missing.mtl"]);
    let mut c = scene(&default_toml());
    c.mtl = "newmtl a\nKd 0.5 0.5 0.5\nmap_Kd tex/none.png\n";
    fails_with(c, &["none.png"]);
}

#[test]
fn malformed_obj_names_the_line() {
    let mut c = scene(&default_toml());
    c.obj = "mtllib m.mtl\nv 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n";
    fails_with(c, &["m.obj:3", "not finite"]);
    let mut c = scene(&default_toml());
    c.obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 inf\nf 1 2 3\n";
    fails_with(c, &["m.obj:4"]);
    let mut c = scene(&default_toml());
    c.obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n";
    fails_with(c, &["m.obj:5", "vertex 7"]);
    let mut c = scene(&default_toml());
    c.obj = "mtllib m.mtl\nv 0 0 0\nv 1 zero 0\n";
    fails_with(c, &["m.obj:3", "zero"]);
}

#[test]
fn degenerate_triangles_are_dropped_and_counted() {
    let mut c = scene(&default_toml());
    let obj = format!("{OBJ}v 2 2 2\nf 1 1 2\nf 1 2 5\n");
    c.obj = &obj;
    // `f 1 2 5`: (0,0,0), (1,0,0), (2,2,2) is fine; `f 1 1 2` is degenerate.
    let (ok, err) = run(&c);
    assert!(ok, "{err}");
    assert!(err.contains("dropped 1 degenerate triangle"), "{err}");
    let mut c = scene(&default_toml());
    c.obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n";
    fails_with(c, &["m.obj", "no (non-degenerate) triangles"]);
}

#[test]
fn albedo_above_one_is_an_error_and_one_is_lowered_with_a_note() {
    let mut c = scene(&default_toml());
    c.mtl = "newmtl a\nKd 1.01 0.5 0.5\n";
    fails_with(c, &["m.obj", "material `a`", "albedo above 1"]);
    let mut c = scene(&default_toml());
    c.mtl = "newmtl a\nKd 0.5 -0.5 0.5\n";
    fails_with(c, &["material `a`"]);
    // Issue #34: an albedo of 1 loads, lowered to max_albedo, with one note naming it.
    let mut c = scene(&default_toml());
    c.mtl = "newmtl a\nKd 1.0 0.5 0.5\nnewmtl b\nKd 1 1 1\n";
    let (ok, err) = run_with(&c, false);
    assert!(ok, "{err}");
    assert!(err.contains("albedo lowered to 0.98"), "{err}");
    assert!(
        err.contains("2 material(s)") && err.contains("`a`") && err.contains("`b`"),
        "{err}"
    );
    assert_eq!(err.matches("albedo lowered").count(), 1, "{err}");
    let mut c = scene(&format!("{}max_albedo = 0.9\n", default_toml()));
    c.mtl = "newmtl a\nKd 0.95 0.5 0.5\n";
    let (ok, err) = run_with(&c, false);
    assert!(ok && err.contains("albedo lowered to 0.9 "), "{err}");
    let c = scene(&format!("{}max_albedo = 1.0\n", default_toml()));
    fails_with(c, &["max_albedo"]);
}

/// Issue #34: strict only for the MTL keys that change the answer; a typo elsewhere is a
/// note with file:line.
#[test]
fn unused_mtl_keys_that_do_not_parse_are_notes() {
    let mut c = scene(&default_toml());
    c.mtl = "newmtl a\nKa 0.0000 0.0000 0.0000c\nKs x\nKd 0.5 0.5 0.5\n";
    let (ok, err) = run_with(&c, false);
    assert!(ok, "{err}");
    assert!(
        err.contains("m.mtl:2") && err.contains("`Ka` is not used here"),
        "{err}"
    );
    assert!(err.contains("m.mtl:3"), "{err}");
    let mut c = scene(&default_toml());
    c.mtl = "newmtl a\nKd 0.5 0.5 0.5c\n";
    fails_with(c, &["m.mtl", "Kd"]);
}

/// Issue #34: a group that exists without faces is named as such, not as missing.
#[test]
fn an_empty_group_is_not_a_missing_one() {
    let toml = format!("[[object]]\nmesh = \"m.obj\"\ngroup = \"tallBox\"\n\n{LIGHT}\n{FAST}");
    let mut c = scene(&toml);
    let obj = format!("{OBJ}g tallBox\n");
    c.obj = &obj;
    fails_with(c, &["m.obj", "group `tallBox` (line 11) has no faces"]);
    let mut c = scene(&toml.replace("tallBox", "nothere"));
    c.obj = &obj;
    fails_with(c, &["m.obj", "has no group `nothere`"]);
}

#[test]
fn bad_points_file_names_the_line() {
    let dir = common::tmpdir();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), default_toml()).unwrap();
    std::fs::write(d.join("m.obj"), OBJ).unwrap();
    std::fs::write(d.join("m.mtl"), MTL).unwrap();
    for (text, needle) in [
        ("0 0 0 0 1 0\n0 0 0 0 1\n", "p.txt:2"),
        ("# c\n0 0 0 0 0 0\n", "p.txt:2"),
        ("0 0 x 0 1 0\n", "p.txt:1"),
        ("# nothing\n", "no points"),
    ] {
        std::fs::write(d.join("p.txt"), text).unwrap();
        let o = common::meshrad_output(d, &["probe", "s.toml", "--points", "p.txt", "-q"], b"");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && err.contains(needle) && !err.contains("panicked"),
            "{text:?}: {err}"
        );
    }
    let _ = Path::new("");
}

#[test]
fn unusable_camera() {
    let t = format!(
        "{}\n[camera]\nposition = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\n",
        default_toml()
    );
    fails_with(scene(&t), &["camera.up"]);
}

/// Runs `meshrad solve` on a scene holding the glTF `doc` (written as `m.gltf` + `m.bin`,
/// or `m.glb`), after `spoil` has changed the files; checks the error names each needle.
fn gltf_fails_with(doc: &common::gltf::Doc, layout: common::gltf::Layout, spoil: impl Fn(&Path), needles: &[&str]) {
    let dir = common::tmpdir();
    let d = dir.path();
    let g = doc.write(d, "m", layout);
    spoil(d);
    let name = g.file_name().unwrap().to_str().unwrap();
    std::fs::write(
        d.join("s.toml"),
        format!("[[object]]\nmesh = \"{name}\"\n\n{LIGHT}\n{FAST}"),
    )
    .unwrap();
    let o = common::meshrad_output(d, &["solve", "s.toml", "--out", "o", "-q", "--backend", "cpu"], b"");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "should fail: {needles:?}");
    assert!(!err.contains("panicked"), "panic: {err}");
    for n in needles {
        assert!(err.contains(n), "error should mention `{n}`:\n{err}");
    }
    assert!(!d.join("o").exists(), "no output after a failed load");
}

/// The tetrahedron of [`OBJ`] as glTF positions.
fn tetra() -> Vec<f32> {
    let v = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    [[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]]
        .iter()
        .flat_map(|f| f.iter().flat_map(|&i| v[i]))
        .collect()
}

#[test]
fn bad_gltf_names_the_file_and_the_json_path() {
    use common::gltf::{one_mesh, Layout};
    use serde_json::json;
    let good = one_mesh(&tetra(), [0.5; 3]);
    let ok = |_: &Path| {};
    // The good file passes (so that every failure below is the spoiling's).
    {
        let dir = common::tmpdir();
        good.write(dir.path(), "m", Layout::External);
        std::fs::write(
            dir.path().join("s.toml"),
            format!("[[object]]\nmesh = \"m.gltf\"\n\n{LIGHT}\n{FAST}"),
        )
        .unwrap();
        let o = common::meshrad_output(
            dir.path(),
            &["solve", "s.toml", "--out", "o", "-q", "--backend", "cpu"],
            b"",
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    // Not JSON; a truncated .glb.
    gltf_fails_with(
        &good,
        Layout::External,
        |d| std::fs::write(d.join("m.gltf"), "{ nope").unwrap(),
        &["m.gltf", "not a valid glTF"],
    );
    gltf_fails_with(
        &good,
        Layout::Binary,
        |d| {
            let b = std::fs::read(d.join("m.glb")).unwrap();
            std::fs::write(d.join("m.glb"), &b[..b.len() - 20]).unwrap();
        },
        &["m.glb", "not a valid glTF"],
    );
    // A missing buffer file; a buffer shorter than it says.
    gltf_fails_with(
        &good,
        Layout::External,
        |d| std::fs::remove_file(d.join("m.bin")).unwrap(),
        &["m.gltf", "buffers[0]", "m.bin"],
    );
    gltf_fails_with(
        &good,
        Layout::External,
        |d| std::fs::write(d.join("m.bin"), [0u8; 8]).unwrap(),
        &["buffers[0]", "byteLength"],
    );
    // An accessor running past its view; a view outside its buffer.
    let mut doc = one_mesh(&tetra(), [0.5; 3]);
    doc.json["accessors"][0]["count"] = json!(1000);
    gltf_fails_with(
        &doc,
        Layout::External,
        ok,
        &["m.gltf", "meshes[0].primitives[0].attributes.POSITION", "accessors[0]"],
    );
    let mut doc = one_mesh(&tetra(), [0.5; 3]);
    doc.json["bufferViews"][0]["byteOffset"] = json!(64);
    gltf_fails_with(&doc, Layout::Binary, ok, &["m.glb", "bufferViews[0]"]);
    // The wrong component type for POSITION; indices out of range.
    let mut doc = one_mesh(&tetra(), [0.5; 3]);
    doc.json["accessors"][0]["componentType"] = json!(5123);
    gltf_fails_with(&doc, Layout::External, ok, &["m.gltf", "POSITION"]);
    let mut doc = one_mesh(&tetra(), [0.5; 3]);
    let ix = doc.indices(&[0, 1, 99]);
    doc.json["meshes"][0]["primitives"][0]["indices"] = json!(ix);
    gltf_fails_with(
        &doc,
        Layout::External,
        ok,
        &["meshes[0].primitives[0].indices", "99", "out of range"],
    );
    // A textured material on a primitive without texture coordinates.
    let mut doc = one_mesh(&tetra(), [0.5; 3]);
    doc.json["images"] = json!([{"uri": "t.png"}]);
    doc.json["textures"] = json!([{"source": 0}]);
    doc.json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
    gltf_fails_with(&doc, Layout::External, ok, &["meshes[0].primitives[0]", "TEXCOORD_0"]);
    // An albedo above 1 (glTF's default white loads, lowered: tests/gltf.rs); a node that
    // is its own child.
    let mut doc = one_mesh(&tetra(), [0.5; 3]);
    doc.json["materials"][0] = json!({"name": "paper", "pbrMetallicRoughness": {"baseColorFactor": [1.2, 1, 1, 1]}});
    gltf_fails_with(
        &doc,
        Layout::External,
        ok,
        &["m.gltf", "materials[0].pbrMetallicRoughness.baseColorFactor", "[0, 1]"],
    );
    let mut doc = one_mesh(&tetra(), [0.5; 3]);
    doc.json["nodes"][0]["children"] = json!([0]);
    gltf_fails_with(&doc, Layout::External, ok, &["m.gltf", "nodes[0]"]);
    // A GLB header whose total length is below its own 12 bytes (the gltf crate
    // subtracted unchecked: an overflow panic in a test build; found by the fuzzer).
    let doc = one_mesh(&tetra(), [0.5; 3]);
    let short = |d: &Path| {
        let p = d.join("m.glb");
        let mut b = std::fs::read(&p).unwrap();
        b[8..12].copy_from_slice(&5u32.to_le_bytes());
        std::fs::write(&p, b).unwrap();
    };
    gltf_fails_with(
        &doc,
        Layout::Binary,
        short,
        &["m.glb", "GLB header", "length of 5 bytes"],
    );
    // Issue #35: a DAG, not a tree: each node lists the next twice, 40 deep (2^40 paths
    // if walked), refused at once naming the node.
    let mut doc = one_mesh(&tetra(), [0.5; 3]);
    let first = doc.json["nodes"].as_array().unwrap().len();
    for k in 0..40 {
        let next = first + k + 1;
        let children = if k < 39 { json!([next, next]) } else { json!([]) };
        doc.push("nodes", json!({"mesh": 0, "children": children}));
    }
    doc.json["scenes"][0]["nodes"] = json!([first]);
    let t = std::time::Instant::now();
    gltf_fails_with(
        &doc,
        Layout::External,
        ok,
        &[
            "m.gltf",
            &format!("nodes[{}]", first + 1),
            "(listed twice)",
            "at most one parent",
        ],
    );
    assert!(t.elapsed().as_secs() < 60, "the DAG took {:?}", t.elapsed());
    // A broken data: URI.
    let mut doc = one_mesh(&tetra(), [0.5; 3]);
    doc.json["images"] = json!([{"uri": "data:image/png;base64,@@@"}]);
    doc.json["textures"] = json!([{"source": 0}]);
    doc.json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
    doc.json["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(0);
    gltf_fails_with(&doc, Layout::External, ok, &["m.gltf", "images[0]", "base64"]);
    // Issue #35: URIs that leave the glTF's folder (absolute, or with `..`).
    let mut doc = one_mesh(&tetra(), [0.5; 3]);
    doc.json["images"] = json!([{"uri": "/etc/hostname"}]);
    doc.json["textures"] = json!([{"source": 0}]);
    doc.json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
    doc.json["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(0);
    gltf_fails_with(&doc, Layout::External, ok, &["m.gltf", "images[0]", "no absolute path"]);
    let doc = one_mesh(&tetra(), [0.5; 3]);
    let up = |d: &Path| {
        let g = d.join("m.gltf");
        let text = std::fs::read_to_string(&g)
            .unwrap()
            .replace("\"m.bin\"", "\"sub/../m.bin\"");
        assert!(text.contains("sub/../m.bin"));
        std::fs::write(&g, text).unwrap();
    };
    gltf_fails_with(&doc, Layout::External, up, &["m.gltf", "buffers[0]", "no `..`"]);
    // Issue #35: a vertex (or node scales) beyond what f32 areas hold is named, not dropped
    // as a degenerate triangle.
    let mut t = tetra();
    t[0] = 3e38;
    let doc = one_mesh(&t, [0.5; 3]);
    gltf_fails_with(
        &doc,
        Layout::External,
        ok,
        &["m.gltf", "POSITION", "element 0", "overflow"],
    );
    let mut doc = one_mesh(&tetra(), [0.5; 3]);
    doc.json["nodes"][0]["scale"] = json!([1e30, 1e30, 1e30]);
    gltf_fails_with(&doc, Layout::External, ok, &["m.gltf", "POSITION", "nodes' transforms"]);
    // Issue #35: an emissive strength whose product would overflow the light's sums.
    let mut doc = one_mesh(&tetra(), [0.5; 3]);
    doc.json["extensionsUsed"] = json!(["KHR_materials_emissive_strength"]);
    doc.json["materials"][0]["emissiveFactor"] = json!([1.0, 1.0, 1.0]);
    doc.json["materials"][0]["extensions"] = json!({"KHR_materials_emissive_strength": {"emissiveStrength": 3e38}});
    gltf_fails_with(&doc, Layout::External, ok, &["m.gltf", "materials[0]", "overflow"]);
}
