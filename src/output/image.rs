//! Images from the camera: per pixel, the primary hit's exact direct irradiance (shadow
//! rays) and its indirect irradiance evaluated from the hierarchy (the Shepard sum per
//! pixel, equivalent to the paper's splatting), as radiance `ρ E / π`.

use std::path::Path;

use glam::Vec3;
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::hierarchy::Hierarchy;
use crate::progress::Progress;
use crate::scene::{Scene, Surface};
use crate::transport::Solution;

/// Linear radiance images.
#[derive(Clone, Debug)]
pub struct Images {
    pub width: u32,
    pub height: u32,
    pub direct: Vec<Vec3>,
    pub indirect: Vec<Vec3>,
    /// Pixels whose reconstructed indirect irradiance was negative (delta-hierarchy
    /// ringing) and was clamped to zero.
    pub clamped: usize,
}

impl Images {
    /// Direct plus indirect.
    pub fn total(&self) -> Vec<Vec3> {
        self.direct.iter().zip(&self.indirect).map(|(a, b)| *a + *b).collect()
    }
}

/// Renders the camera view: per pixel, the primary hit's direct irradiance from the
/// lights `lights` (exact, shadow rays) and the indirect irradiance `indirect(surface,
/// pixel index)`, as radiance `ρ E / π`. Negative indirect values are clamped and counted.
pub fn render_with(
    scene: &Scene,
    lights: &[bool],
    progress: &Progress,
    indirect: impl Fn(&Surface, usize) -> Vec3 + Sync,
) -> Images {
    let cam = &scene.camera;
    let (w, hgt) = (cam.width as usize, cam.height as usize);
    let bar = progress.bar(hgt as u64, "image");
    let rows: Vec<(Vec<Vec3>, Vec<Vec3>)> = (0..hgt)
        .into_par_iter()
        .map(|y| {
            let mut d = Vec::with_capacity(w);
            let mut i = Vec::with_capacity(w);
            for x in 0..w {
                let ray = cam.ray(x as f32 + 0.5, y as f32 + 0.5);
                let (dv, iv) = match scene.intersect(&ray, f32::INFINITY) {
                    Some(hit) => {
                        let s = scene.surface(&hit, ray.d);
                        let k = s.albedo / std::f32::consts::PI;
                        (k * scene.direct_from(s.p, s.n, lights), k * indirect(&s, y * w + x))
                    }
                    None => (Vec3::ZERO, Vec3::ZERO),
                };
                d.push(dv);
                i.push(iv);
            }
            bar.inc(1);
            (d, i)
        })
        .collect();
    bar.finish();
    let (direct, indirect): (Vec<_>, Vec<_>) = rows.into_iter().unzip();
    let mut indirect = indirect.concat();
    let mut clamped = 0;
    for v in &mut indirect {
        if v.min_element() < 0.0 {
            clamped += 1;
            *v = v.max(Vec3::ZERO);
        }
    }
    Images {
        width: cam.width,
        height: cam.height,
        direct: direct.concat(),
        indirect,
        clamped,
    }
}

/// Renders the camera view of a solution, reading the indirect light from `level`.
/// Lights that reach no node reach no lit surface: no shadow rays for them.
pub fn render(scene: &Scene, h: &Hierarchy, sol: &Solution, level: u32, progress: &Progress) -> Images {
    let lights: Vec<bool> = (0..scene.lights.len())
        .map(|i| sol.stats.nodes_lit_per_light.get(i).is_none_or(|&n| n > 0))
        .collect();
    render_with(scene, &lights, progress, |s, _| {
        sol.indirect_on(h, s.object as usize, s.p_obj, s.n_obj, level)
    })
}

/// Writes `stem.exr` (linear float RGB) and `stem.png` (gamma 2.2, clamped) in `dir`.
pub fn write_pair(dir: &Path, stem: &str, w: u32, h: u32, px: &[Vec3]) -> Result<()> {
    let exr_path = dir.join(format!("{stem}.exr"));
    // Compressed sequentially: the parallel writer stores blocks in completion order,
    // so the same image would not give the same bytes twice.
    use exr::prelude::{Image, SpecificChannels, Vec2, WritableImage};
    let channels = SpecificChannels::rgb(|pos: Vec2<usize>| {
        let p = px[pos.y() * w as usize + pos.x()];
        (p.x, p.y, p.z)
    });
    Image::from_channels((w as usize, h as usize), channels)
        .write()
        .non_parallel()
        .to_file(&exr_path)
        .map_err(|e| Error::Output {
            path: exr_path.clone(),
            message: e.to_string(),
        })?;
    let png_path = dir.join(format!("{stem}.png"));
    let enc = |v: f32| (v.max(0.0).powf(1.0 / 2.2).min(1.0) * 255.0 + 0.5) as u8;
    let buf: Vec<u8> = px.iter().flat_map(|p| [enc(p.x), enc(p.y), enc(p.z)]).collect();
    image::save_buffer(&png_path, &buf, w, h, image::ColorType::Rgb8).map_err(|e| Error::Output {
        path: png_path,
        message: e.to_string(),
    })
}

/// Writes direct, indirect and total images.
pub fn write_all(dir: &Path, img: &Images) -> Result<()> {
    write_pair(dir, "direct", img.width, img.height, &img.direct)?;
    write_pair(dir, "indirect", img.width, img.height, &img.indirect)?;
    write_pair(dir, "total", img.width, img.height, &img.total())
}
