//! The scene file (TOML): the schema of issue #2, with unknown keys rejected.

use serde::Deserialize;

use crate::params::SolverParams;

/// A whole scene file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    #[serde(default)]
    pub object: Vec<ObjectEntry>,
    /// `[[light]]` tables, checked key by key in `light::from_table` (serde's tagged
    /// enums lose the key in their errors).
    #[serde(default)]
    pub light: Vec<toml::Table>,
    pub camera: Option<CameraEntry>,
    pub sky: Option<SkyEntry>,
    #[serde(default)]
    pub solver: SolverParams,
}

/// `[sky]`: light from every direction that leaves the scene: exactly one of `radiance`
/// and `envmap`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SkyEntry {
    /// Constant radiance (W/(m²·sr), RGB), as Mitsuba's `constant` emitter.
    pub radiance: Option<[f32; 3]>,
    /// An equirectangular environment map (OpenEXR or Radiance HDR, linear), relative to
    /// the scene file, as Mitsuba's `envmap` emitter.
    pub envmap: Option<String>,
    /// Multiplies the envmap's radiance (default 1).
    pub scale: Option<f32>,
    /// Turns the envmap about +y, degrees (default 0).
    pub rotate: Option<f32>,
}

/// `[[object]]`: a mesh with an optional rigid transform.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectEntry {
    /// OBJ path, relative to the scene file.
    pub mesh: String,
    /// The object's name, unique in the scene (default `object<i>`): frames and sessions
    /// move it by this name.
    pub name: Option<String>,
    /// Only the faces of these `o`/`g` groups of the OBJ, or these nodes' subtrees of a
    /// glTF (by name, or `nodes[i]`), one name or a list; `!name` leaves one out.
    pub group: Option<Groups>,
    pub translate: Option<[f32; 3]>,
    /// Degrees about x, then y, then z.
    pub rotate: Option<[f32; 3]>,
    pub scale: Option<f32>,
    /// Split every triangle into four, this many times.
    pub tessellate: Option<u32>,
    /// Whether its materials' emission (MTL `Ke`) lights the scene (default true); false:
    /// the emitting faces are plain diffuse surfaces.
    pub emission: Option<bool>,
    /// Whether the mesh's vertex normals (OBJ `vn`, glTF `NORMAL`), where it has them,
    /// shade it (default true): interpolated for the cosine at pixels, nodes and path
    /// vertices. False: every triangle is flat.
    pub smooth_normals: Option<bool>,
}

/// One group name or several.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum Groups {
    One(String),
    Many(Vec<String>),
}

impl Groups {
    /// The names, in the file's order.
    pub fn names(&self) -> Vec<String> {
        match self {
            Groups::One(s) => vec![s.clone()],
            Groups::Many(v) => v.clone(),
        }
    }
}

/// `[camera]`: a pinhole camera.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraEntry {
    pub position: [f32; 3],
    pub target: [f32; 3],
    #[serde(default = "default_up")]
    pub up: [f32; 3],
    /// Vertical field of view, degrees.
    #[serde(default = "default_fov")]
    pub fov: f32,
    #[serde(default = "default_size")]
    pub width: u32,
    #[serde(default = "default_size")]
    pub height: u32,
    /// Samples per pixel, stratified over the pixel filter's footprint (default
    /// [`crate::scene::camera::DEFAULT_SPP`]).
    pub spp: Option<u32>,
    /// The pixel filter: `"box"` (default, as reference renderers) or `"gaussian"`.
    pub filter: Option<crate::scene::camera::Filter>,
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}
fn default_fov() -> f32 {
    40.0
}
fn default_size() -> u32 {
    256
}
