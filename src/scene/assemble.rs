//! Scene-file assembly: a scene file read and checked (its `[solver]` with the overrides,
//! lights, camera, `[sky]`), its objects added through the [`Builder`], and the edits that
//! check a new value as a file's would be.

use std::path::{Path, PathBuf};

use glam::Vec3;

use super::builder::{world_bounds, Builder};
use super::gltf_file::GltfLight;
use super::memory::plan_memory;
use super::{config, light, sky, source, Camera, Scene, SceneObject, Source};
use crate::error::{Error, Result};
use crate::geom::Transform;
use crate::layout::GpuLight;
use crate::limits::Limits;
use crate::params::SolverParams;

impl Scene {
    /// Loads a scene file from disk; `overrides` replace `[solver]` keys. Resource limits
    /// are the defaults ([`Limits::default`]).
    pub fn load(path: &Path, overrides: &[(String, toml::Value)]) -> Result<(Scene, SolverParams)> {
        Scene::load_with(path, overrides, &Limits::default())
    }

    /// [`Scene::load`] within `limits`.
    pub fn load_with(
        path: &Path,
        overrides: &[(String, toml::Value)],
        limits: &Limits,
    ) -> Result<(Scene, SolverParams)> {
        let text = crate::limits::read_text(path, crate::limits::MAX_TEXT_BYTES)?;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let dir = if dir.as_os_str().is_empty() {
            PathBuf::from(".")
        } else {
            dir
        };
        Scene::from_toml_with(&text, path, Source::Dir(dir), overrides, limits)
    }

    /// The Cornell box shipped inside the binary.
    pub fn embedded_cornell(overrides: &[(String, toml::Value)]) -> Result<(Scene, SolverParams)> {
        Scene::embedded_cornell_with(overrides, &Limits::default())
    }

    /// A scene file embedded in the binary (`cornell_box.toml`, `cornell_parts.toml`,
    /// `cornell_area.toml`).
    pub fn embedded_file(name: &str, overrides: &[(String, toml::Value)]) -> Result<(Scene, SolverParams)> {
        Scene::embedded_file_with(name, overrides, &Limits::default())
    }

    /// [`Scene::embedded_file`] within `limits`.
    pub fn embedded_file_with(
        name: &str,
        overrides: &[(String, toml::Value)],
        limits: &Limits,
    ) -> Result<(Scene, SolverParams)> {
        let src = Source::Embedded(source::EMBEDDED_CORNELL);
        let text = src.read(Path::new(name))?;
        Scene::from_toml_with(
            &String::from_utf8_lossy(&text),
            &src.display(Path::new(name)),
            src,
            overrides,
            limits,
        )
    }

    /// [`Scene::embedded_cornell`] within `limits`.
    pub fn embedded_cornell_with(
        overrides: &[(String, toml::Value)],
        limits: &Limits,
    ) -> Result<(Scene, SolverParams)> {
        Scene::embedded_file_with("cornell_box.toml", overrides, limits)
    }

    /// Parses and loads a scene whose files come from `source`.
    pub fn from_toml(
        text: &str,
        path: &Path,
        source: Source,
        overrides: &[(String, toml::Value)],
    ) -> Result<(Scene, SolverParams)> {
        Scene::from_toml_with(text, path, source, overrides, &Limits::default())
    }

    /// [`Scene::from_toml`] within `limits`.
    pub fn from_toml_with(
        text: &str,
        path: &Path,
        source: Source,
        overrides: &[(String, toml::Value)],
        limits: &Limits,
    ) -> Result<(Scene, SolverParams)> {
        let file = parse_scene_file(text, path, overrides)?;
        let (mut light_names, mut light_tables) = name_lights(&file.light, path)?;
        let mut lights = read_lights(&light_tables, path)?;
        // What the parameters alone ask for, before any mesh is read; checked again with
        // the triangles in `finish`.
        let camera = file.camera.as_ref().map(|c| Camera::from_entry(c, path)).transpose()?;
        let placeholder =
            Camera::framing(Vec3::ZERO, Vec3::ONE, std::path::Path::new("")).expect("the unit box frames");
        plan_memory(
            limits,
            path,
            0,
            &file.solver,
            camera.as_ref().unwrap_or(&placeholder),
            file.object.len(),
        )?;
        let mut b = Builder {
            limits: *limits,
            ..Default::default()
        };
        b.report.inputs.push(path.into());
        for (i, entry) in file.object.iter().enumerate() {
            b.add_object(&source, path, i, entry)?;
        }
        let sky = file
            .sky
            .as_ref()
            .map(|s| read_sky(s, path, &source, limits))
            .transpose()?
            .flatten();
        if let Some(f) = sky.as_ref().and_then(sky::Sky::file) {
            b.report.inputs.push(f.to_path_buf());
        }
        if !b.gltf_lights.is_empty() {
            let gltf_lights = std::mem::take(&mut b.gltf_lights);
            add_gltf_lights(gltf_lights, path, &mut lights, &mut light_names, &mut light_tables)?;
        }
        let camera_entry = file.camera.clone().or(b.gltf_camera.take());
        let mut scene = b.finish(path, &source, lights, camera_entry.as_ref(), &file.solver)?;
        scene.sky = sky;
        if scene.lights.is_empty() && !scene.emitters.any() && scene.sky.is_none() {
            return Err(Error::SceneValue {
                path: path.into(),
                key: "light".into(),
                message: "the scene has no [[light]], no emitting surface (MTL Ke) and no [sky]: everything would be \
                          black"
                    .into(),
            });
        }
        scene.light_names = light_names;
        scene.light_tables = light_tables;
        Ok((scene, file.solver))
    }

    /// The index of the object named `name`.
    pub fn object_index(&self, name: &str) -> Option<usize> {
        self.objects.iter().position(|o| o.name == name)
    }

    /// The index of the light named `name`.
    pub fn light_index(&self, name: &str) -> Option<usize> {
        self.light_names.iter().position(|n| n == name)
    }

    /// Places object `i` with `t` (checked as a scene file's transform is: the error
    /// gives the field and why) and recomputes the scene's bounds, exactly as loading a
    /// file that holds `t` computes them.
    pub fn set_transform(&mut self, i: usize, t: Transform) -> std::result::Result<(), (&'static str, String)> {
        check_transform(&t)?;
        let before = self.objects[i].transform;
        let place = |o: &mut SceneObject, t: Transform| {
            o.transform = t;
            o.to_world = t.to_world();
            o.to_object = t.to_object();
        };
        place(&mut self.objects[i], t);
        let (lo, hi, scale) = match world_bounds(&self.objects, &self.tris) {
            Ok(b) => b,
            Err(m) => {
                // The field at fault: the scale (or rotation) if the object overflows
                // where it stands at the origin, else the translation.
                let mut at_origin = self.objects[i].clone();
                place(
                    &mut at_origin,
                    Transform {
                        translate: Vec3::ZERO,
                        ..t
                    },
                );
                let (a, b) = super::builder::object_box(&at_origin, &self.tris);
                let key = if (b - a).length().is_finite() {
                    "translate"
                } else {
                    "scale"
                };
                place(&mut self.objects[i], before);
                return Err((key, format!("{m} with this transform")));
            }
        };
        self.bounds = (lo, hi);
        self.scale = scale;
        let placed: Vec<_> = self.objects.iter().map(|o| o.to_world).collect();
        self.emitters.place(&self.tris, &placed);
        Ok(())
    }

    /// Replaces light `i` by the light `table` describes (the keys of a `[[light]]`, less
    /// `name`), parsed as a scene file's (errors name `light[i]`).
    pub fn set_light(&mut self, i: usize, table: toml::Table) -> Result<()> {
        let l = light::from_table(&table, i, &self.path)?;
        let mut lights = self.lights.clone();
        lights[i] = l;
        check_light_power(&lights).map_err(|message| Error::SceneValue {
            path: self.path.clone(),
            key: format!("light[{i}]"),
            message,
        })?;
        self.lights = lights;
        self.light_tables[i] = table;
        Ok(())
    }
}

/// The scene file parsed, its `[solver]` with the overrides applied and validated, and
/// checked to hold an object.
fn parse_scene_file(text: &str, path: &Path, overrides: &[(String, toml::Value)]) -> Result<config::SceneFile> {
    let text = crate::limits::strip_bom(text);
    let mut file: config::SceneFile = toml::from_str(text).map_err(|e| Error::SceneSyntax {
        path: path.into(),
        message: clip_lines(e.to_string().trim_end()),
    })?;
    // The file's [solver], then the overrides, validated once: a file whose values
    // are only valid together with an override (`levels = 3` and `--set
    // sender_level=2`) is fine.
    if overrides.is_empty() {
        file.solver.validate().map_err(|e| Error::SceneValue {
            path: path.into(),
            key: "solver".into(),
            message: e.to_string(),
        })?;
    } else {
        file.solver = apply_overrides(&file.solver, overrides)?;
    }
    if file.object.is_empty() {
        return Err(Error::SceneValue {
            path: path.into(),
            key: "object".into(),
            message: "the scene has no [[object]]: nothing to light".into(),
        });
    }
    Ok(file)
}

/// Each `[[light]]`'s name (its `name`, default `light<i>`; unique) and its table less
/// `name`.
fn name_lights(entries: &[toml::Table], path: &Path) -> Result<(Vec<String>, Vec<toml::Table>)> {
    let mut light_names = Vec::new();
    let mut light_tables = Vec::new();
    for (i, l) in entries.iter().enumerate() {
        let mut t = l.clone();
        let named = t.contains_key("name");
        let name = match t.remove("name") {
            None => format!("light{i}"),
            Some(toml::Value::String(s)) if !s.trim().is_empty() => s,
            Some(v) => {
                return Err(Error::SceneValue {
                    path: path.into(),
                    key: format!("light[{i}].name"),
                    message: format!("expected a non-empty string, found {v}"),
                })
            }
        };
        if light_names.contains(&name) {
            return Err(Error::SceneValue {
                path: path.into(),
                key: format!("light[{i}].name"),
                message: if named {
                    format!("`{name}` names an earlier light too: names must be unique")
                } else {
                    format!(
                        "this light has no `name`, and its default `{name}` names an earlier light: \
                         names must be unique, so give it one"
                    )
                },
            });
        }
        light_names.push(name);
        light_tables.push(t);
    }
    Ok((light_names, light_tables))
}

/// The lights the `[[light]]` tables describe; where there are any, some must give light.
fn read_lights(light_tables: &[toml::Table], path: &Path) -> Result<Vec<GpuLight>> {
    let lights = light_tables
        .iter()
        .enumerate()
        .map(|(i, l)| light::from_table(l, i, path))
        .collect::<Result<Vec<_>>>()?;
    if !lights.is_empty() {
        check_light_power(&lights).map_err(|message| Error::SceneValue {
            path: path.into(),
            key: "light".into(),
            message,
        })?;
    }
    Ok(lights)
}

/// Adds the glTF objects' lights after the file's, each under its own name (its object's
/// name before it where that is taken, then `#2`, `#3`… until unique), and checks again
/// that some light gives light.
fn add_gltf_lights(
    gltf_lights: Vec<(String, GltfLight)>,
    path: &Path,
    lights: &mut Vec<GpuLight>,
    light_names: &mut Vec<String>,
    light_tables: &mut Vec<toml::Table>,
) -> Result<()> {
    for (object, l) in gltf_lights {
        // The light's own name; its object's name before it where that is taken.
        let mut name = l.name.clone();
        if light_names.contains(&name) {
            name = format!("{object}/{}", l.name);
        }
        let base = name.clone();
        let mut k = 1;
        while light_names.contains(&name) {
            k += 1;
            name = format!("{base}#{k}");
        }
        lights.push(light::from_table(&l.table, lights.len(), path)?);
        light_names.push(name);
        light_tables.push(l.table);
    }
    check_light_power(lights).map_err(|message| Error::SceneValue {
        path: path.into(),
        key: "light".into(),
        message,
    })?;
    Ok(())
}

/// `message` with every line cut to 160 characters (a TOML error quotes the offending
/// line, which may be as long as the file).
fn clip_lines(message: &str) -> String {
    message
        .lines()
        .map(|l| {
            if l.chars().count() > 160 {
                format!("{}…", l.chars().take(160).collect::<String>())
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Replaces `[solver]` keys; each key is checked on its own so that an error names it.
pub fn apply_overrides(params: &SolverParams, overrides: &[(String, toml::Value)]) -> Result<SolverParams> {
    let mut table = toml::Table::try_from(params).map_err(|e| Error::param("solver", e.to_string()))?;
    for (k, v) in overrides {
        let mut one = toml::Table::new();
        one.insert(k.clone(), v.clone());
        toml::Value::Table(one)
            .try_into::<SolverParams>()
            .map_err(|e| Error::param(k, e.to_string().trim_end().to_string()))?;
        table.insert(k.clone(), v.clone());
    }
    let p: SolverParams = toml::Value::Table(table)
        .try_into()
        .map_err(|e| Error::param("solver", e.to_string()))?;
    p.validate()?;
    Ok(p)
}

/// Object `i`'s transform, each part checked.
pub(super) fn object_transform(scene_path: &Path, i: usize, e: &config::ObjectEntry) -> Result<Transform> {
    let t = Transform {
        scale: e.scale.unwrap_or(1.0),
        rotate_deg: Vec3::from(e.rotate.unwrap_or([0.0; 3])),
        translate: Vec3::from(e.translate.unwrap_or([0.0; 3])),
    };
    check_transform(&t).map_err(|(f, m)| Error::SceneValue {
        path: scene_path.into(),
        key: format!("object[{i}].{f}"),
        message: m,
    })?;
    Ok(t)
}

/// The `[sky]` table checked and read: `None` for a sky without light.
fn read_sky(s: &config::SkyEntry, path: &Path, source: &Source, limits: &Limits) -> Result<Option<sky::Sky>> {
    let err = |key: &str, message: String| Error::SceneValue {
        path: path.into(),
        key: format!("sky.{key}"),
        message,
    };
    match (&s.radiance, &s.envmap) {
        (Some(r), None) => {
            if s.scale.is_some() || s.rotate.is_some() {
                let k = if s.scale.is_some() { "scale" } else { "rotate" };
                return Err(err(k, "applies to an `envmap` only".into()));
            }
            let l = Vec3::from(*r);
            if !l.is_finite() || l.min_element() < 0.0 {
                return Err(err("radiance", format!("{r:?} must be finite and non-negative")));
            }
            if l.max_element() > crate::limits::MAX_RADIANCE {
                return Err(err(
                    "radiance",
                    format!(
                        "{r:?} is above {:e}, where the light's sums would overflow",
                        crate::limits::MAX_RADIANCE
                    ),
                ));
            }
            Ok((l.max_element() > 0.0).then_some(sky::Sky::Constant(l)))
        }
        (None, Some(file)) => {
            let scale = s.scale.unwrap_or(1.0);
            if !(scale.is_finite() && scale > 0.0) {
                return Err(err(
                    "scale",
                    format!("{scale} must be finite and positive (0 would turn the map off: remove [sky] instead)"),
                ));
            }
            let rotate = s.rotate.unwrap_or(0.0);
            if !rotate.is_finite() {
                return Err(err("rotate", format!("{rotate} must be finite")));
            }
            if file.trim().is_empty() {
                return Err(err("envmap", "is empty: give the map's file".into()));
            }
            let expanded = source::expand_scenes_var(file);
            let rel = expanded.as_deref().unwrap_or(Path::new(file));
            // The file, its decoded pixels (RGBA f32) and the sampling tables.
            let m = sky::EnvMap::load(source, rel, scale, rotate, limits.max_memory)?;
            Ok(m.any().then(|| sky::Sky::Map(Box::new(m))))
        }
        (Some(_), Some(_)) => Err(err("envmap", "give `radiance` or `envmap`, not both".into())),
        (None, None) => Err(err(
            "radiance",
            "is missing: give `radiance = [r, g, b]` or `envmap = \"FILE\"`".into(),
        )),
    }
}

/// Whether `t` is a transform a scene may hold: the field at fault and why if not.
pub fn check_transform(t: &Transform) -> std::result::Result<(), (&'static str, String)> {
    if !(t.scale.is_finite() && t.scale > 0.0) {
        return Err(("scale", format!("{} must be finite and positive", t.scale)));
    }
    if !t.rotate_deg.is_finite() {
        return Err(("rotate", format!("{:?} must be finite", t.rotate_deg.to_array())));
    }
    if !t.translate.is_finite() {
        return Err(("translate", format!("{:?} must be finite", t.translate.to_array())));
    }
    Ok(())
}

/// Some light must give light.
fn check_light_power(lights: &[GpuLight]) -> std::result::Result<(), String> {
    if lights.iter().all(|l| l.power.iter().all(|&c| c == 0.0)) {
        return Err("every light has zero intensity or irradiance: everything would be black".into());
    }
    Ok(())
}
