//! glTF 2.0 loading (`.gltf` with its buffers and images, or `.glb`), through the `gltf`
//! crate's validated document. Accessors are read here, not by the crate's readers: every
//! range, component type and index is checked first, so a bad file is an error that names
//! the file and the JSON path (`meshes[0].primitives[1].indices`), never a panic.
//!
//! What a file gives (`ALGORITHM.md` §10):
//! - triangles of the default scene's node tree, each node's matrix applied (a mirroring
//!   matrix turns the winding back, as the specification asks); strips and fans become
//!   triangles;
//! - albedo `baseColorFactor` × `baseColorTexture` (sRGB, the sampler's wrap modes, glTF's
//!   v-down uv turned to our v-up), emission `emissiveFactor` ×
//!   `KHR_materials_emissive_strength` × `emissiveTexture` (sRGB, per texel) as radiance
//!   (W/(m²·sr), like MTL `Ke` × `map_Ke`);
//! - `KHR_lights_punctual` lights, photometric units turned radiometric at
//!   [`LUMENS_PER_WATT`]: candela / 683 = W/sr, lux / 683 = W/m² (Blender's glTF exporter's
//!   "standard" convention);
//! - the first perspective camera met in the node tree.
//!
//! What it does not use (skins, morph targets, point and line primitives, orthographic
//! cameras, light ranges, unknown extensions) is named in one note.

use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::mesh::Mode;
use ::gltf::texture::WrappingMode;
use glam::{Mat4, Vec3};

use super::obj::{keep, LoadedMesh, MtlData};
use super::source::Source;
use crate::error::{Error, Result};
use crate::layout::{Tri, WRAP_CLAMP, WRAP_MIRROR, WRAP_REPEAT};

/// Lumens per watt: the photometric-to-radiometric factor of glTF lights (the luminous
/// efficacy of 555 nm light).
pub const LUMENS_PER_WATT: f32 = 683.0;

/// The largest coordinate a placed glTF vertex may have (a triangle's area, the square of
/// its edges, stays finite in f32).
const MAX_COORDINATE: f32 = 1e18;

/// Node trees deeper than this are refused (a cycle, or a file built to exhaust the stack).
const MAX_DEPTH: usize = 256;

/// A glTF light as a `[[light]]` table would give it (in the file's space).
#[derive(Clone, Debug)]
pub struct GltfLight {
    pub name: String,
    pub table: toml::Table,
}

/// A glTF perspective camera (in the file's space).
#[derive(Clone, Copy, Debug)]
pub struct GltfCamera {
    pub position: Vec3,
    pub forward: Vec3,
    pub up: Vec3,
    /// Vertical field of view, degrees.
    pub fov: f32,
    pub aspect: Option<f32>,
}

/// A glTF file's triangles (in the file's space), lights and first camera.
#[derive(Clone, Debug, Default)]
pub struct LoadedGltf {
    pub mesh: LoadedMesh,
    pub lights: Vec<GltfLight>,
    pub camera: Option<GltfCamera>,
}

/// Whether `rel` names a glTF file (by its extension).
pub fn is_gltf(rel: &Path) -> bool {
    rel.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"))
}

/// The glTF file being read: where its buffers and images come from, and how messages
/// name it.
struct Input<'a> {
    source: &'a Source,
    rel: &'a Path,
    /// The file's folder, against which buffer and image URIs are read.
    dir: PathBuf,
    /// The most bytes the file and each buffer and image may have.
    limit: u64,
    /// The file as messages name it.
    shown: PathBuf,
}

/// Loads `rel` from `source`; it and each buffer and image may have at most `limit` bytes.
/// With `groups`, only the subtrees of the nodes of those names are kept (each must exist).
pub fn load(source: &Source, rel: &Path, limit: u64, groups: Option<&[String]>) -> Result<LoadedGltf> {
    load_within(source, rel, limit, groups, &|_| Ok(()))
}

/// [`load`], with `budget` asked about the triangles the file will make before any is
/// built: their count from the accessors' counts and the node tree
/// ([`count_triangles`]), so that a file too large for the run is refused while only its
/// JSON and buffers are held (issue #35: a 60 MB strip of 5.2M vertices peaked at 924 MB
/// at `--max-memory 256M` when the count was checked after building them).
pub fn load_within(
    source: &Source,
    rel: &Path,
    limit: u64,
    groups: Option<&[String]>,
    budget: &dyn Fn(u64) -> Result<()>,
) -> Result<LoadedGltf> {
    let input = Input {
        source,
        rel,
        dir: rel.parent().map(Path::to_path_buf).unwrap_or_default(),
        limit,
        shown: source.display(rel),
    };
    let err = |message: String| input.err(message);
    let bytes = source.read_limited(rel, limit)?;
    check_glb_header(&bytes).map_err(|m| err(format!("not a valid glTF 2.0 file: {m}")))?;
    let file = ::gltf::Gltf::from_slice_without_validation(&bytes)
        .map_err(|e| err(format!("not a valid glTF 2.0 file: {e}")))?;
    validate(file.document.as_json()).map_err(|m| err(format!("not a valid glTF 2.0 file: {m}")))?;
    let doc = &file.document;
    let mut out = LoadedGltf::default();
    out.mesh.inputs.push(input.shown.clone());
    let buffers = input.buffers(&file, &mut out.mesh.inputs)?;

    // Materials (ours: the file's, then a default grey for primitives without one).
    let mut unsupported: BTreeMap<&'static str, usize> = BTreeMap::new();
    // The TEXCOORD set each material's base colour texture reads.
    let tex_sets = input.materials(doc, &buffers, &mut out.mesh, &mut unsupported)?;
    let default_material = out.mesh.materials.len() as u32;

    let roots = scene_roots(doc);
    check_tree(doc, &roots).map_err(err)?;
    budget(count_triangles(doc, &roots, groups))?;
    let mut walk = Walk {
        buffers: &buffers,
        cameras: &doc.as_json().cameras,
        out: &mut out,
        seen: HashSet::new(),
        tex_sets: &tex_sets,
        default_material,
        unsupported: &mut unsupported,
        any_uv: false,
        any_normal: false,
        selection: Selection::of(groups),
        found: HashSet::new(),
    };
    let from_roots = walk.selection.keeps_the_roots();
    for n in &roots {
        walk.node(n, Mat4::IDENTITY, 0, from_roots).map_err(err)?;
    }
    let (any_uv, any_normal) = (walk.any_uv, walk.any_normal);
    input.check_groups(doc, groups, &walk.found)?;
    if !any_uv {
        out.mesh.uvs.clear();
    }
    if !any_normal {
        out.mesh.normals.clear();
    }
    if out.mesh.unassigned > 0 {
        out.mesh.materials.push(MtlData {
            used_by: input.shown.clone(),
            ..MtlData::grey("(default)".into(), input.shown.clone())
        });
    }
    input.note_unsupported(doc, &mut unsupported, &mut out.mesh);
    Ok(out)
}

/// A GLB's header (`glTF`, version, length) must give a length of at least its own 12
/// bytes: the gltf crate subtracts 12 from it unchecked (a panic where overflow is
/// checked, a wrapped length elsewhere). Found by the fuzzer (`tests/fuzz.rs`, glb kind).
fn check_glb_header(bytes: &[u8]) -> std::result::Result<(), String> {
    if bytes.get(..4) != Some(b"glTF".as_slice()) {
        return Ok(());
    }
    match bytes.get(8..12) {
        None => Err(format!("its GLB header is cut short ({} bytes of 12)", bytes.len())),
        Some(b) => {
            let length = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            if length < 12 {
                Err(format!(
                    "its GLB header gives a total length of {length} bytes, less than the header's own 12"
                ))
            } else {
                Ok(())
            }
        }
    }
}

/// glTF requires the node graph to be a forest: a node has at most one parent and a
/// scene's roots have none. A node listed twice (by one parent, two parents, or a root
/// list) would be walked once per path, 2^depth times for a chain that lists each next
/// node twice, so such a file is refused at once, naming the node.
fn check_tree(doc: &::gltf::Document, roots: &[::gltf::Node<'_>]) -> std::result::Result<(), String> {
    let mut parent: Vec<Option<usize>> = vec![None; doc.nodes().len()];
    for n in doc.nodes() {
        for c in n.children() {
            if let Some(p) = parent[c.index()].replace(n.index()) {
                return Err(format!(
                    "nodes[{}] is a child of nodes[{p}] and of nodes[{}]{}: glTF requires each node to have at most one \
                     parent",
                    c.index(),
                    n.index(),
                    if p == n.index() { " (listed twice)" } else { "" }
                ));
            }
        }
    }
    let mut seen = HashSet::new();
    for r in roots {
        if let Some(p) = parent[r.index()] {
            return Err(format!(
                "nodes[{}] is a root of the scene and a child of nodes[{p}]: glTF requires a scene's nodes to be roots",
                r.index()
            ));
        }
        if !seen.insert(r.index()) {
            return Err(format!("nodes[{}] is listed twice among the scene's nodes", r.index()));
        }
    }
    Ok(())
}

/// The triangles the walk will build (degenerate ones included) under `roots`, counted
/// without reading a buffer: each primitive's from its index (or POSITION) accessor's
/// `count` and its mode, once for every node that instances its mesh; with `groups`,
/// only inside the named nodes' subtrees, as [`Walk::node`] keeps them. The tree is a
/// forest here ([`check_tree`]), so every node is visited once.
/// How `[[object]] group` picks a glTF's nodes: an entry names a node to keep with its
/// subtree, by its `name` or, named or not, as `nodes[i]`; an entry starting with `!`
/// names one to leave out with its subtree (a skybox, say). With no entry to keep, every
/// node is kept but those left out.
struct Selection<'a> {
    keep: Vec<&'a str>,
    drop: Vec<&'a str>,
}

impl<'a> Selection<'a> {
    fn of(groups: Option<&'a [String]>) -> Selection<'a> {
        let mut s = Selection {
            keep: Vec::new(),
            drop: Vec::new(),
        };
        for g in groups.unwrap_or(&[]) {
            match g.strip_prefix('!') {
                Some(d) => s.drop.push(d),
                None => s.keep.push(g),
            }
        }
        s
    }

    /// Whether the roots are kept before any entry matches.
    fn keeps_the_roots(&self) -> bool {
        self.keep.is_empty()
    }

    /// The entry of `list` that names node `n`, if one does.
    fn matching(list: &[&'a str], n: &::gltf::Node) -> Option<&'a str> {
        let index = format!("nodes[{}]", n.index());
        list.iter().copied().find(|s| Some(*s) == n.name() || *s == index)
    }
}

fn count_triangles(doc: &::gltf::Document, roots: &[::gltf::Node<'_>], groups: Option<&[String]>) -> u64 {
    let per_mesh: Vec<u64> = doc
        .meshes()
        .map(|m| {
            m.primitives()
                .map(|p| {
                    let n = p
                        .indices()
                        .or_else(|| p.get(&::gltf::Semantic::Positions))
                        .map_or(0, |a| a.count() as u64);
                    match p.mode() {
                        Mode::Triangles => n / 3,
                        Mode::TriangleStrip | Mode::TriangleFan => n.saturating_sub(2),
                        _ => 0,
                    }
                })
                .fold(0u64, u64::saturating_add)
        })
        .collect();
    let mut total = 0u64;
    let sel = Selection::of(groups);
    let mut stack: Vec<(::gltf::Node<'_>, bool, usize)> =
        roots.iter().map(|n| (n.clone(), sel.keeps_the_roots(), 0)).collect();
    while let Some((n, on, depth)) = stack.pop() {
        if depth > MAX_DEPTH || Selection::matching(&sel.drop, &n).is_some() {
            // Too deep: the walk refuses it, naming the node. Left out: not counted.
            continue;
        }
        let on = on || Selection::matching(&sel.keep, &n).is_some();
        if on {
            if let Some(m) = n.mesh() {
                total = total.saturating_add(per_mesh[m.index()]);
            }
        }
        stack.extend(n.children().map(|c| (c, on, depth + 1)));
    }
    total
}

/// The nodes at the top of the default scene's tree (or the first scene's; or every root
/// node if there is no scene).
fn scene_roots(doc: &::gltf::Document) -> Vec<::gltf::Node<'_>> {
    match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(s) => s.nodes().collect(),
        None => {
            let children: HashSet<usize> = doc.nodes().flat_map(|n| n.children().map(|c| c.index())).collect();
            doc.nodes().filter(|n| !children.contains(&n.index())).collect()
        }
    }
}

impl Input<'_> {
    /// An error in the file, `message` saying where and why.
    fn err(&self, message: String) -> Error {
        Error::Mesh {
            path: self.shown.clone(),
            line: None,
            message,
        }
    }

    /// The file's buffers, each checked against its declared length; the files read are
    /// added to `inputs`.
    fn buffers(&self, file: &::gltf::Gltf, inputs: &mut Vec<PathBuf>) -> Result<Vec<Arc<[u8]>>> {
        let err = |message: String| self.err(message);
        let mut buffers: Vec<Arc<[u8]>> = Vec::new();
        // A file that several buffers name is read once; what is read, together, stays
        // within the read limit.
        let mut read: std::collections::HashMap<String, Arc<[u8]>> = std::collections::HashMap::new();
        let mut total = 0u64;
        for b in file.document.buffers() {
            let at = format!("buffers[{}]", b.index());
            let data: Arc<[u8]> = match b.source() {
                ::gltf::buffer::Source::Bin => match &file.blob {
                    Some(blob) => Arc::from(blob.as_slice()),
                    None => {
                        return Err(err(format!(
                            "{at}: refers to the GLB binary chunk, which the file lacks"
                        )))
                    }
                },
                ::gltf::buffer::Source::Uri(uri) => match read.get(uri) {
                    Some(d) => d.clone(),
                    None => {
                        let d = read_uri(self.source, &self.dir, uri, self.limit.saturating_sub(total), inputs)
                            .map_err(|m| err(format!("{at}: {m}")))?;
                        total += d.len() as u64;
                        read.insert(uri.to_string(), d.clone());
                        d
                    }
                },
            };
            if data.len() < b.length() {
                return Err(err(format!(
                    "{at}: has {} bytes, the file declares byteLength {}",
                    data.len(),
                    b.length()
                )));
            }
            buffers.push(data);
        }
        Ok(buffers)
    }

    /// The file's materials, appended to `mesh.materials`, and the TEXCOORD set each one's
    /// base colour texture reads.
    fn materials(
        &self,
        doc: &::gltf::Document,
        buffers: &[Arc<[u8]>],
        mesh: &mut LoadedMesh,
        unsupported: &mut BTreeMap<&'static str, usize>,
    ) -> Result<Vec<Option<u32>>> {
        let mut tex_sets: Vec<Option<u32>> = Vec::new();
        for m in doc.materials() {
            let md = self.material(doc, &m, buffers, &mut mesh.inputs, unsupported)?;
            // The base colour's set, else the emissive texture's (one set per triangle).
            let base = m.pbr_metallic_roughness().base_color_texture().map(|t| t.tex_coord());
            let emissive = md
                .emission_texture
                .as_ref()
                .and(m.emissive_texture())
                .map(|t| t.tex_coord());
            tex_sets.push(base.or(emissive));
            mesh.materials.push(md);
        }
        Ok(tex_sets)
    }

    /// Material `m`: its albedo and emission checked, its base colour texture found.
    fn material(
        &self,
        doc: &::gltf::Document,
        m: &::gltf::Material,
        buffers: &[Arc<[u8]>],
        inputs: &mut Vec<PathBuf>,
        unsupported: &mut BTreeMap<&'static str, usize>,
    ) -> Result<MtlData> {
        let err = |message: String| self.err(message);
        let i = m.index().unwrap_or(0);
        let at = format!("materials[{i}]");
        let name = match m.name() {
            Some(n) if !n.is_empty() => format!("{n} ({at})"),
            _ => at.clone(),
        };
        let pbr = m.pbr_metallic_roughness();
        let f = pbr.base_color_factor();
        let mut md = MtlData::grey(name, self.shown.clone());
        md.used_by = self.shown.clone();
        md.kd = [f[0], f[1], f[2]];
        if md.kd.iter().any(|&c| !(0.0..=1.0).contains(&c)) {
            return Err(err(format!(
                "{at}.pbrMetallicRoughness.baseColorFactor {f:?}: the albedo must be in [0, 1] (an albedo of 1, \
                 glTF's default white, is lowered to the solver key max_albedo)"
            )));
        }
        let strength = m.emissive_strength().unwrap_or(1.0);
        let e = m.emissive_factor().map(|c| c * strength);
        if e.iter().any(|c| !c.is_finite() || *c < 0.0) {
            return Err(err(format!(
                "{at}: emission {e:?} (emissiveFactor × emissive_strength) must be finite and non-negative"
            )));
        }
        if e.iter().any(|&c| c > crate::limits::MAX_RADIANCE) {
            return Err(err(format!(
                "{at}: emission {e:?} (emissiveFactor × emissive_strength) is above {:e}, where the light's sums \
                 would overflow",
                crate::limits::MAX_RADIANCE
            )));
        }
        md.emission = e;
        if let Some(info) = m.emissive_texture().filter(|_| e.iter().any(|&c| c > 0.0)) {
            let tex = info.texture();
            let (path, data) = self.image(doc, &tex.source(), buffers, inputs, &at)?;
            md.emission_texture = Some(path);
            md.emission_texture_data = data;
            md.emission_wrap = wrap_modes(&tex);
            let base = pbr.base_color_texture().map(|t| t.tex_coord());
            if base.is_some_and(|b| b != info.tex_coord()) {
                *unsupported
                    .entry("an emissive texture on another TEXCOORD set than the base colour's (it reads the base colour's)")
                    .or_default() += 1;
            }
        }
        if let Some(info) = pbr.base_color_texture() {
            let tex = info.texture();
            let (path, data) = self.image(doc, &tex.source(), buffers, inputs, &at)?;
            md.texture = Some(path);
            md.texture_data = data;
            md.wrap = wrap_modes(&tex);
        }
        // Alpha: a cutout of the base colour's alpha (factor × texture), at alphaCutoff
        // for MASK, at 0.5 for BLEND (no blending here: noted).
        match m.alpha_mode() {
            ::gltf::material::AlphaMode::Opaque => {}
            mode => {
                md.cutout = true;
                md.opacity = f[3];
                md.alpha_from_albedo = true;
                if mode == ::gltf::material::AlphaMode::Mask {
                    let c = m.alpha_cutoff().unwrap_or(0.5);
                    if !c.is_finite() || c < 0.0 {
                        return Err(err(format!("{at}.alphaCutoff {c} must be finite and non-negative")));
                    }
                    md.cutoff = c;
                } else {
                    *unsupported
                        .entry("alphaMode BLEND (treated as a cutout at alpha 0.5)")
                        .or_default() += 1;
                }
            }
        }
        Ok(md)
    }

    /// Image `img` of material `at`'s base colour texture: the path that names it, and its
    /// bytes where they are not a file of their own (a bufferView or a `data:` URI).
    fn image(
        &self,
        doc: &::gltf::Document,
        img: &::gltf::Image,
        buffers: &[Arc<[u8]>],
        inputs: &mut Vec<PathBuf>,
        at: &str,
    ) -> Result<(PathBuf, Option<Arc<[u8]>>)> {
        let err = |message: String| self.err(message);
        let key = format!("{}#images[{}]", self.rel.display(), img.index());
        // From the JSON: the crate's `Image::source` unwraps a missing `mimeType`.
        let ij = &doc.as_json().images[img.index()];
        Ok(match (&ij.buffer_view, &ij.uri) {
            (Some(v), _) => {
                let view = doc
                    .views()
                    .nth(v.value())
                    .ok_or_else(|| err(format!("images[{}]: no bufferView {}", img.index(), v.value())))?;
                let bytes = view_slice(buffers, &view).map_err(|m| err(format!("{at}: its image: {m}")))?;
                (PathBuf::from(key), Some(Arc::from(bytes)))
            }
            (None, Some(uri)) if uri.starts_with("data:") => {
                let bytes = read_uri(self.source, &self.dir, uri, self.limit, inputs)
                    .map_err(|m| err(format!("images[{}]: {m}", img.index())))?;
                (PathBuf::from(key), Some(bytes))
            }
            (None, Some(uri)) => (
                self.dir
                    .join(inside_uri(uri).map_err(|m| err(format!("images[{}]: {m}", img.index())))?),
                None,
            ),
            (None, None) => {
                return Err(err(format!(
                    "images[{}]: has neither a bufferView nor a uri",
                    img.index()
                )))
            }
        })
    }

    /// With `groups`, that the walk `found` a node of each name.
    fn check_groups(&self, doc: &::gltf::Document, groups: Option<&[String]>, found: &HashSet<String>) -> Result<()> {
        if let Some(names) = groups {
            if let Some(missing) = names.iter().find(|g| !found.contains(g.trim_start_matches('!'))) {
                let have: Vec<&str> = doc.nodes().filter_map(|n| n.name()).take(40).collect();
                return Err(self.err(format!(
                    "has no node `{}` in its scene (its named nodes: {}; any node is also `nodes[i]`)",
                    missing.trim_start_matches('!'),
                    if have.is_empty() {
                        "none".to_string()
                    } else {
                        have.join(", ")
                    }
                )));
            }
        }
        Ok(())
    }

    /// The one note that names what the file holds and loading does not use (unknown
    /// extensions counted in `unsupported` here), if anything.
    fn note_unsupported(
        &self,
        doc: &::gltf::Document,
        unsupported: &mut BTreeMap<&'static str, usize>,
        mesh: &mut LoadedMesh,
    ) {
        for e in doc.extensions_used() {
            if !matches!(e, "KHR_lights_punctual" | "KHR_materials_emissive_strength") {
                *unsupported.entry("extensions").or_default() += 1;
            }
        }
        if !unsupported.is_empty() {
            let parts: Vec<String> = unsupported.iter().map(|(k, n)| format!("{k} ×{n}")).collect();
            let mut note = format!("{}: glTF parts not used: {}", self.shown.display(), parts.join("; "));
            let unknown: Vec<&str> = doc
                .extensions_used()
                .filter(|e| !matches!(*e, "KHR_lights_punctual" | "KHR_materials_emissive_strength"))
                .collect();
            if !unknown.is_empty() {
                note.push_str(&format!(" (extensions: {})", unknown.join(", ")));
            }
            mesh.notes.push(note);
        }
    }
}

/// The `gltf` crate's validation of a document, after the one check its own validation
/// needs first: its POSITION rule indexes `accessors` without a bounds check (a panic on
/// an out-of-range POSITION accessor in gltf-json 1.4.1).
fn validate(root: &::gltf::json::Root) -> std::result::Result<(), String> {
    use ::gltf::json::validation::{Checked, Validate};
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            if let Some(a) = prim
                .attributes
                .get(&Checked::Valid(::gltf::json::mesh::Semantic::Positions))
            {
                if a.value() >= root.accessors.len() {
                    return Err(format!(
                        "meshes[{m}].primitives[{p}].attributes.POSITION: accessor {} does not exist ({} accessors)",
                        a.value(),
                        root.accessors.len()
                    ));
                }
            }
        }
    }
    let mut errors = Vec::new();
    root.validate(root, ::gltf::json::Path::new, &mut |path, error| {
        errors.push(format!("{}: {error}", path()))
    });
    match errors.len() {
        0 => Ok(()),
        n => Err(format!(
            "{}{}",
            errors[..n.min(8)].join("; "),
            if n > 8 {
                format!("; and {} more", n - 8)
            } else {
                String::new()
            }
        )),
    }
}

/// The state of one walk over the node tree.
struct Walk<'a> {
    buffers: &'a [Arc<[u8]>],
    cameras: &'a [::gltf::json::Camera],
    out: &'a mut LoadedGltf,
    /// Triangles already kept (their three corners), for dropping exact duplicates.
    seen: HashSet<[[u32; 3]; 3]>,
    /// The TEXCOORD set each material's base colour texture reads.
    tex_sets: &'a [Option<u32>],
    default_material: u32,
    unsupported: &'a mut BTreeMap<&'static str, usize>,
    any_uv: bool,
    any_normal: bool,
    /// `group`: only these nodes' subtrees.
    selection: Selection<'a>,
    /// The `group` entries a node matched (`!` stripped).
    found: HashSet<String>,
}

impl Walk<'_> {
    /// Adds node `n` (under the parent matrix `parent`) and its children; `on`: inside a
    /// selected subtree (always, without `group`).
    fn node(&mut self, n: &::gltf::Node, parent: Mat4, depth: usize, on: bool) -> std::result::Result<(), String> {
        let at = format!("nodes[{}]", n.index());
        if depth > MAX_DEPTH {
            return Err(format!("{at}: the node tree is deeper than {MAX_DEPTH} (a cycle?)"));
        }
        let local = match n.transform() {
            ::gltf::scene::Transform::Matrix { matrix } => Mat4::from_cols_array_2d(&matrix),
            ::gltf::scene::Transform::Decomposed {
                translation,
                rotation,
                scale,
            } => {
                // glTF requires a unit quaternion; another one would scale and shear the
                // mesh as the plain formula turns it into a matrix.
                let q = glam::Quat::from_array(rotation);
                let len = q.length();
                if !(len.is_finite() && len > 1e-6) {
                    return Err(format!(
                        "{at}.rotation {rotation:?}: a rotation quaternion must have unit length (this one has none)"
                    ));
                }
                if (len - 1.0).abs() > 1e-3 {
                    self.out.mesh.notes.push(format!(
                        "{at}.rotation {rotation:?} has length {len}: normalised (glTF requires unit quaternions)"
                    ));
                }
                Mat4::from_scale_rotation_translation(Vec3::from(scale), q / len, Vec3::from(translation))
            }
        };
        if !local.is_finite() {
            return Err(format!("{at}: its transform is not finite"));
        }
        let m = parent * local;
        if let Some(d) = Selection::matching(&self.selection.drop, n) {
            self.found.insert(d.to_string());
            return Ok(());
        }
        let on = on
            || match Selection::matching(&self.selection.keep, n) {
                Some(k) => {
                    self.found.insert(k.to_string());
                    true
                }
                None => false,
            };
        if on {
            if n.skin().is_some() {
                *self.unsupported.entry("skins (meshes in their bind pose)").or_default() += 1;
            }
            if let Some(mesh) = n.mesh() {
                let from = self.out.mesh.tris.len();
                for p in mesh.primitives() {
                    let pat = format!("meshes[{}].primitives[{}]", mesh.index(), p.index());
                    self.primitive(&p, &m, &pat)?;
                }
                // An unnamed node is a part by the name `group` knows it by.
                let name = n.name().map_or_else(|| format!("nodes[{}]", n.index()), str::to_string);
                super::obj::add_part(&mut self.out.mesh, &name, from);
            }
            if let Some(l) = n.light() {
                self.light(&l, &m, n).map_err(|e| format!("{at}: {e}"))?;
            }
            if let Some(c) = n.camera() {
                // From the JSON: the crate's `Camera::projection` unwraps the object its
                // `type` names, which validation does not require.
                let cj = c.index();
                match (
                    self.cameras[cj].perspective.as_ref(),
                    self.cameras[cj].orthographic.is_some(),
                ) {
                    (Some(p), _) if self.out.camera.is_none() => {
                        let yfov = p.yfov;
                        if !(yfov.is_finite() && yfov > 0.0 && yfov < std::f32::consts::PI) {
                            return Err(format!(
                                "cameras[{}].perspective.yfov: {yfov} is not in (0, π)",
                                c.index()
                            ));
                        }
                        let (position, forward, up) = (
                            m.transform_point3(Vec3::ZERO),
                            m.transform_vector3(Vec3::NEG_Z),
                            m.transform_vector3(Vec3::Y),
                        );
                        let degenerate = !(position.is_finite() && forward.is_finite() && up.is_finite())
                            || forward.length() < 1e-12
                            || up.length() < 1e-12
                            || forward.normalize().cross(up.normalize()).length() < 1e-6;
                        if degenerate {
                            return Err(format!(
                                "{at}: the camera cameras[{cj}] placed by this node's transform has no viewing direction \
                                 (a zero or degenerate matrix): fix the node's transform, or give the scene a [camera]"
                            ));
                        }
                        self.out.camera = Some(GltfCamera {
                            position,
                            forward,
                            up,
                            fov: yfov.to_degrees(),
                            aspect: p.aspect_ratio.filter(|a| a.is_finite() && *a > 0.0),
                        });
                    }
                    (None, true) => {
                        *self.unsupported.entry("orthographic cameras").or_default() += 1;
                    }
                    _ => {}
                }
            }
        }
        for c in n.children() {
            self.node(&c, m, depth + 1, on)?;
        }
        Ok(())
    }

    /// A `KHR_lights_punctual` light placed by the node matrix `m`.
    fn light(
        &mut self,
        l: &::gltf::khr_lights_punctual::Light,
        m: &Mat4,
        n: &::gltf::Node,
    ) -> std::result::Result<(), String> {
        let at = format!("KHR_lights_punctual.lights[{}]", l.index());
        let c = Vec3::from(l.color()) * l.intensity() / LUMENS_PER_WATT;
        if !c.is_finite() || c.min_element() < 0.0 {
            return Err(format!(
                "{at}: color {:?} × intensity {} must be finite and non-negative",
                l.color(),
                l.intensity()
            ));
        }
        if l.range().is_some() {
            *self
                .unsupported
                .entry("light ranges (lights fall off as 1/r² without end)")
                .or_default() += 1;
        }
        let position = m.transform_point3(Vec3::ZERO);
        let direction = m.transform_vector3(Vec3::NEG_Z);
        if !position.is_finite() || !direction.is_finite() || direction.length() == 0.0 {
            return Err(format!("{at}: its node's matrix gives no position or direction"));
        }
        let direction = direction.normalize();
        let arr = |v: Vec3| toml::Value::Array(v.to_array().iter().map(|&x| toml::Value::Float(x as f64)).collect());
        let mut t = toml::Table::new();
        use ::gltf::khr_lights_punctual::Kind;
        match l.kind() {
            Kind::Directional => {
                t.insert("type".into(), "directional".into());
                t.insert("direction".into(), arr(direction));
                t.insert("irradiance".into(), arr(c));
            }
            Kind::Point => {
                t.insert("type".into(), "point".into());
                t.insert("position".into(), arr(position));
                t.insert("intensity".into(), arr(c));
            }
            Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => {
                let half_pi = std::f32::consts::FRAC_PI_2;
                if !(outer_cone_angle > 0.0 && outer_cone_angle <= half_pi) {
                    return Err(format!(
                        "{at}: spot.outerConeAngle {outer_cone_angle} is not in (0, π/2]"
                    ));
                }
                if !(inner_cone_angle >= 0.0 && inner_cone_angle < outer_cone_angle) {
                    return Err(format!(
                        "{at}: spot.innerConeAngle {inner_cone_angle} is not in [0, outerConeAngle)"
                    ));
                }
                t.insert("type".into(), "spot".into());
                t.insert("position".into(), arr(position));
                t.insert("direction".into(), arr(direction));
                t.insert("intensity".into(), arr(c));
                t.insert(
                    "cutoff_angle".into(),
                    toml::Value::Float(outer_cone_angle.to_degrees() as f64),
                );
                t.insert(
                    "beam_width".into(),
                    toml::Value::Float(inner_cone_angle.to_degrees() as f64),
                );
            }
        }
        let name = l
            .name()
            .or(n.name())
            .filter(|s| !s.trim().is_empty())
            .map(str::to_string)
            .unwrap_or_else(|| format!("lights[{}]", l.index()));
        self.out.lights.push(GltfLight { name, table: t });
        Ok(())
    }

    /// One primitive's triangles, placed by the node matrix `m`.
    fn primitive(&mut self, p: &::gltf::Primitive, m: &Mat4, at: &str) -> std::result::Result<(), String> {
        let mode = p.mode();
        if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
            *self.unsupported.entry("point and line primitives").or_default() += 1;
            return Ok(());
        }
        if p.morph_targets().next().is_some() {
            *self
                .unsupported
                .entry("morph targets (the base shape is used)")
                .or_default() += 1;
        }
        let pos_acc = p
            .get(&::gltf::Semantic::Positions)
            .ok_or_else(|| format!("{at}: has no POSITION attribute"))?;
        let pos = floats(self.buffers, &pos_acc, 3, false).map_err(|e| format!("{at}.attributes.POSITION: {e}"))?;
        let nv = pos.len() / 3;
        let index = self.primitive_indices(p, nv, at)?;
        let material_index = p.material().index();
        let (material, set) = match material_index {
            Some(k) => (k as u32, self.tex_sets.get(k).copied().flatten()),
            None => (self.default_material, None),
        };
        let uv = self.primitive_uvs(p, set, material, nv, at)?;
        // Vertex normals, placed by the inverse transpose of the node matrix.
        let normals = match p.get(&::gltf::Semantic::Normals) {
            Some(acc) => {
                let n = floats(self.buffers, &acc, 3, false).map_err(|e| format!("{at}.attributes.NORMAL: {e}"))?;
                if n.len() != pos.len() {
                    return Err(format!(
                        "{at}.attributes.NORMAL: has {} elements, POSITION {nv}",
                        n.len() / 3
                    ));
                }
                let nm = glam::Mat3::from_mat4(*m).inverse().transpose();
                Some(
                    n.chunks_exact(3)
                        .map(|v| nm * Vec3::new(v[0], v[1], v[2]))
                        .collect::<Vec<_>>(),
                )
            }
            None => None,
        };
        self.any_normal |= normals.is_some();
        let corners = triangle_corners(mode, &index);
        // A mirroring matrix turns the winding; the specification keeps the front face.
        let flip = m.determinant() < 0.0;
        if material_index.is_none() {
            self.out.mesh.unassigned += corners.len();
        }
        self.any_uv |= uv.is_some();
        let place = |i: u32| {
            let i = i as usize * 3;
            m.transform_point3(Vec3::new(pos[i], pos[i + 1], pos[i + 2])).to_array()
        };
        // A vertex placed beyond 1e18 (a huge coordinate, or node scales that multiply to
        // one) would overflow the triangles' areas and normals in f32 and be dropped as
        // degenerate: name it instead.
        for i in 0..(pos.len() / 3) as u32 {
            let v = Vec3::from(place(i));
            if v.is_nan() || v.abs().max_element() > MAX_COORDINATE {
                let k = i as usize * 3;
                return Err(format!(
                    "{at}.attributes.POSITION (accessor {}): element {i} ({}, {}, {}) is placed at {v} by its nodes' \
                     transforms, beyond ±{MAX_COORDINATE:e}, where areas and normals overflow in single precision",
                    pos_acc.index(),
                    pos[k],
                    pos[k + 1],
                    pos[k + 2]
                ));
            }
        }
        for c in corners {
            let c = if flip { [c[0], c[2], c[1]] } else { c };
            let tri = Tri {
                v0: place(c[0]),
                v1: place(c[1]),
                v2: place(c[2]),
                material,
                ..Default::default()
            };
            if !keep(&tri, &mut self.seen, &mut self.out.mesh) {
                continue;
            }
            self.out.mesh.tris.push(tri);
            let mut t = [0.0f32; 6];
            if let Some(uv) = &uv {
                for (k, &i) in c.iter().enumerate() {
                    // glTF's v runs down the image, ours up.
                    t[k * 2] = uv[i as usize * 2];
                    t[k * 2 + 1] = 1.0 - uv[i as usize * 2 + 1];
                }
            }
            self.out.mesh.uvs.push(t);
            self.out.mesh.normals.push(match &normals {
                Some(n) => super::obj::corner_normals(&tri, c.map(|i| n[i as usize])),
                None => [0.0; 9],
            });
        }
        Ok(())
    }

    /// Primitive `p`'s vertex indices (`at` its JSON path), each checked against its `nv`
    /// vertices; without an index accessor, every vertex in order.
    fn primitive_indices(&self, p: &::gltf::Primitive, nv: usize, at: &str) -> std::result::Result<Vec<u32>, String> {
        Ok(match p.indices() {
            Some(acc) => {
                let ix = indices(self.buffers, &acc).map_err(|e| format!("{at}.indices: {e}"))?;
                if let Some(bad) = ix.iter().find(|&&i| i as usize >= nv) {
                    return Err(format!(
                        "{at}.indices: index {bad} is out of range (POSITION has {nv} vertices)"
                    ));
                }
                ix
            }
            None => (0..nv as u32).collect(),
        })
    }

    /// Primitive `p`'s uvs (TEXCOORD_`set`, which its material `material`'s base colour
    /// texture reads), one pair for each of its `nv` vertices; `None` without a texture.
    fn primitive_uvs(
        &self,
        p: &::gltf::Primitive,
        set: Option<u32>,
        material: u32,
        nv: usize,
        at: &str,
    ) -> std::result::Result<Option<Vec<f32>>, String> {
        Ok(match set {
            Some(s) => {
                let acc = p.get(&::gltf::Semantic::TexCoords(s)).ok_or_else(|| {
                    format!(
                        "{at}: its material materials[{material}] has a baseColorTexture on TEXCOORD_{s}, which the \
                         primitive lacks"
                    )
                })?;
                let v =
                    floats(self.buffers, &acc, 2, true).map_err(|e| format!("{at}.attributes.TEXCOORD_{s}: {e}"))?;
                if v.len() / 2 != nv {
                    return Err(format!(
                        "{at}.attributes.TEXCOORD_{s}: {} elements, POSITION has {nv}",
                        v.len() / 2
                    ));
                }
                Some(v)
            }
            None => None,
        })
    }
}

/// The triangles (three indices each) of a primitive drawn in `mode` (triangles, a strip
/// or a fan) over `index`.
fn triangle_corners(mode: Mode, index: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::Triangles => index.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        Mode::TriangleStrip => (0..index.len().saturating_sub(2))
            .map(|i| {
                if i % 2 == 0 {
                    [index[i], index[i + 1], index[i + 2]]
                } else {
                    [index[i + 1], index[i], index[i + 2]]
                }
            })
            .collect(),
        _ => (1..index.len().saturating_sub(1))
            .map(|i| [index[0], index[i], index[i + 1]])
            .collect(),
    }
}

/// The bytes of a buffer view, checked against its buffer.
fn view_slice<'b>(buffers: &'b [Arc<[u8]>], v: &::gltf::buffer::View) -> std::result::Result<&'b [u8], String> {
    let b = buffers
        .get(v.buffer().index())
        .ok_or_else(|| format!("bufferViews[{}]: no buffer {}", v.index(), v.buffer().index()))?;
    let end = v
        .offset()
        .checked_add(v.length())
        .filter(|&e| e <= b.len())
        .ok_or_else(|| {
            format!(
                "bufferViews[{}]: bytes {}..{} are outside buffers[{}] ({} bytes)",
                v.index(),
                v.offset(),
                v.offset().saturating_add(v.length()),
                v.buffer().index(),
                b.len()
            )
        })?;
    Ok(&b[v.offset()..end])
}

/// An accessor's elements' bytes: (the view's bytes from the first element, stride,
/// element size), every element checked to lie inside the view.
fn elements<'b>(
    buffers: &'b [Arc<[u8]>],
    a: &::gltf::Accessor,
) -> std::result::Result<(&'b [u8], usize, usize), String> {
    let at = format!("accessors[{}]", a.index());
    if a.sparse().is_some() {
        return Err(format!("{at}: sparse accessors are not supported"));
    }
    let view = a
        .view()
        .ok_or_else(|| format!("{at}: has no bufferView (all-zero accessors are not supported)"))?;
    let data = view_slice(buffers, &view)?;
    let size = a.data_type().size() * a.dimensions().multiplicity();
    let stride = view.stride().unwrap_or(size);
    if stride < size {
        return Err(format!(
            "{at}: byteStride {stride} is less than its element ({size} bytes)"
        ));
    }
    let count = a.count();
    if count == 0 {
        return Ok((&[], stride, size));
    }
    let end = (count - 1)
        .checked_mul(stride)
        .and_then(|x| x.checked_add(size))
        .and_then(|x| x.checked_add(a.offset()))
        .filter(|&e| e <= data.len())
        .ok_or_else(|| {
            format!(
                "{at}: {count} elements from byte {} with stride {stride} run past bufferViews[{}] ({} bytes)",
                a.offset(),
                view.index(),
                data.len()
            )
        })?;
    Ok((&data[a.offset()..end], stride, size))
}

/// A float accessor of `dims` components (`VEC2`/`VEC3` of FLOAT; with `normalized`, also
/// normalised UNSIGNED_BYTE/SHORT, as glTF allows for texture coordinates), flattened.
fn floats(
    buffers: &[Arc<[u8]>],
    a: &::gltf::Accessor,
    dims: usize,
    normalized: bool,
) -> std::result::Result<Vec<f32>, String> {
    let at = format!("accessors[{}]", a.index());
    let want = if dims == 2 { Dimensions::Vec2 } else { Dimensions::Vec3 };
    if a.dimensions() != want {
        return Err(format!("{at}: type {:?}, expected {want:?}", a.dimensions()));
    }
    let ok = match a.data_type() {
        DataType::F32 => true,
        DataType::U8 | DataType::U16 => normalized && a.normalized(),
        _ => false,
    };
    if !ok {
        return Err(format!(
            "{at}: componentType {:?}{} is not allowed here (expected FLOAT{})",
            a.data_type(),
            if a.normalized() { " normalized" } else { "" },
            if normalized {
                ", or normalized UNSIGNED_BYTE / UNSIGNED_SHORT"
            } else {
                ""
            }
        ));
    }
    let (bytes, stride, size) = elements(buffers, a)?;
    let mut out = Vec::with_capacity(a.count() * dims);
    let c = a.data_type().size();
    for e in 0..a.count() {
        let el = &bytes[e * stride..e * stride + size];
        for k in 0..dims {
            let b = &el[k * c..(k + 1) * c];
            let v = match a.data_type() {
                DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                DataType::U8 => b[0] as f32 / 255.0,
                _ => u16::from_le_bytes([b[0], b[1]]) as f32 / 65535.0,
            };
            if !v.is_finite() {
                return Err(format!("{at}: element {e} is not finite"));
            }
            out.push(v);
        }
    }
    Ok(out)
}

/// An index accessor (`SCALAR` of UNSIGNED_BYTE / SHORT / INT).
fn indices(buffers: &[Arc<[u8]>], a: &::gltf::Accessor) -> std::result::Result<Vec<u32>, String> {
    let at = format!("accessors[{}]", a.index());
    if a.dimensions() != Dimensions::Scalar || !matches!(a.data_type(), DataType::U8 | DataType::U16 | DataType::U32) {
        return Err(format!(
            "{at}: {:?} of {:?}, expected SCALAR of UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT",
            a.dimensions(),
            a.data_type()
        ));
    }
    let (bytes, stride, _) = elements(buffers, a)?;
    Ok((0..a.count())
        .map(|e| {
            let b = &bytes[e * stride..];
            match a.data_type() {
                DataType::U8 => b[0] as u32,
                DataType::U16 => u16::from_le_bytes([b[0], b[1]]) as u32,
                _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            }
        })
        .collect())
}

/// A buffer's or image's URI: a base64 `data:` URI, or a file relative to the glTF's
/// folder (percent-decoded), read within `limit` and recorded in `inputs`.
fn read_uri(
    source: &Source,
    dir: &Path,
    uri: &str,
    limit: u64,
    inputs: &mut Vec<PathBuf>,
) -> std::result::Result<Arc<[u8]>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (meta, payload) = rest
            .split_once(',')
            .ok_or_else(|| "its data: URI has no `,`".to_string())?;
        if !meta.ends_with(";base64") {
            return Err("its data: URI is not base64".into());
        }
        use base64::Engine;
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(payload)
            .map_err(|e| format!("its data: URI is not valid base64: {e}"))?;
        if bytes.len() as u64 > limit {
            return Err(format!(
                "its data: URI holds {} bytes, above the limit of {limit}",
                bytes.len()
            ));
        }
        return Ok(Arc::from(bytes));
    }
    if uri.contains("://") {
        return Err(format!(
            "`{uri}`: only files beside the glTF and data: URIs can be read"
        ));
    }
    let rel = dir.join(inside_uri(uri)?);
    let bytes = source.read_limited(&rel, limit).map_err(|e| e.to_string())?;
    inputs.push(source.display(&rel));
    Ok(Arc::from(bytes))
}

/// A file URI as a path inside the glTF's folder (its subfolders allowed): an absolute
/// one, or one with a `..` step, would read files elsewhere (the README promises files
/// beside the glTF), and is refused.
fn inside_uri(uri: &str) -> std::result::Result<PathBuf, String> {
    let decoded = percent_decode(uri);
    let path = Path::new(&decoded);
    let outside = path.is_absolute()
        || decoded.starts_with('/')
        || decoded.starts_with('\\')
        || decoded.get(1..2) == Some(":")
        || path
            .components()
            .any(|c| !matches!(c, std::path::Component::Normal(_) | std::path::Component::CurDir))
        || decoded.split(['/', '\\']).any(|part| part == "..");
    if outside {
        return Err(format!(
            "`{uri}`: a file URI must name a file in the glTF's folder or below it (no absolute path, no `..`)"
        ));
    }
    Ok(path.to_path_buf())
}

/// `%20` and the like in a relative URI.
fn percent_decode(uri: &str) -> String {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            let hex = |c: u8| (c as char).to_digit(16);
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// A glTF texture's sampler wrap modes as `TextureInfo::wrap` (u in bits 0–1, v in 2–3).
fn wrap_modes(tex: &::gltf::Texture) -> u32 {
    let mode = |w: WrappingMode| match w {
        WrappingMode::ClampToEdge => WRAP_CLAMP,
        WrappingMode::MirroredRepeat => WRAP_MIRROR,
        WrappingMode::Repeat => WRAP_REPEAT,
    };
    mode(tex.sampler().wrap_s()) | mode(tex.sampler().wrap_t()) << 2
}
