//! Images from the camera: per pixel, the primary hit's exact direct irradiance (shadow
//! rays) and its indirect irradiance evaluated from the hierarchy (the Shepard sum per
//! pixel, equivalent to the paper's splatting), as radiance `ρ E / π`.

use std::path::Path;

use glam::Vec3;
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::hierarchy::Hierarchy;
use crate::output::Outputs;
use crate::params::SolverParams;
use crate::progress::Progress;
use crate::scene::{Scene, Surface};
use crate::transport::readout::Readout;
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
                        // An emitter shows its own radiance (`Scene::emitted`).
                        let d = k * scene.direct_from(s.p, s.n, lights) + scene.emitted(&s);
                        (d, k * indirect(&s, y * w + x))
                    }
                    // A ray that leaves the scene sees the sky (`[sky]`; black without).
                    None => (scene.sky_radiance(ray.d), Vec3::ZERO),
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

/// Renders the camera view of a solution, reading the indirect light as `params` ask
/// (the output level, or a final gather of `final_gather_pixels` rays per pixel). Every light is tested at every pixel:
/// a light that reaches no node (a narrow beam between them) still lights the surfaces
/// it reaches.
pub fn render(scene: &Scene, h: &Hierarchy, sol: &Solution, params: &SolverParams, progress: &Progress) -> Images {
    let lights = vec![true; scene.sources()];
    let read = Readout::for_pixels(scene, h, sol, params);
    render_with(scene, &lights, progress, |s, _| read.on_surface(s))
}

/// Encodes `stem.exr` (linear float RGB) and `stem.png` (gamma 2.2, clamped) for `dir`.
pub fn encode_pair(dir: &Path, stem: &str, w: u32, h: u32, px: &[Vec3], out: &mut Outputs) -> Result<()> {
    let exr_path = dir.join(format!("{stem}.exr"));
    // Compressed sequentially: the parallel writer stores blocks in completion order,
    // so the same image would not give the same bytes twice.
    use exr::prelude::{Image, SpecificChannels, Vec2, WritableImage};
    let channels = SpecificChannels::rgb(|pos: Vec2<usize>| {
        let p = px[pos.y() * w as usize + pos.x()];
        (p.x, p.y, p.z)
    });
    let mut exr_bytes = std::io::Cursor::new(Vec::new());
    Image::from_channels((w as usize, h as usize), channels)
        .write()
        .non_parallel()
        .to_buffered(&mut exr_bytes)
        .map_err(|e| Error::Output {
            path: exr_path.clone(),
            message: e.to_string(),
        })?;
    out.add(exr_path, exr_bytes.into_inner());
    let png_path = dir.join(format!("{stem}.png"));
    let enc = |v: f32| (v.max(0.0).powf(1.0 / 2.2).min(1.0) * 255.0 + 0.5) as u8;
    let buf: Vec<u8> = px.iter().flat_map(|p| [enc(p.x), enc(p.y), enc(p.z)]).collect();
    let mut png = Vec::new();
    use image::ImageEncoder as _;
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(&buf, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| Error::Output {
            path: png_path.clone(),
            message: e.to_string(),
        })?;
    out.add(png_path, png);
    Ok(())
}

/// Encodes direct, indirect and total images for `dir`.
pub fn encode_all(dir: &Path, img: &Images, out: &mut Outputs) -> Result<()> {
    encode_pair(dir, "direct", img.width, img.height, &img.direct, out)?;
    encode_pair(dir, "indirect", img.width, img.height, &img.indirect, out)?;
    encode_pair(dir, "total", img.width, img.height, &img.total(), out)
}

/// The files [`encode_all`] writes in `dir`.
pub fn file_names(dir: &Path) -> Vec<std::path::PathBuf> {
    ["direct", "indirect", "total"]
        .iter()
        .flat_map(|s| [dir.join(format!("{s}.exr")), dir.join(format!("{s}.png"))])
        .collect()
}

/// Writes direct, indirect and total images (all or none).
pub fn write_all(dir: &Path, img: &Images) -> Result<()> {
    let mut out = Outputs::default();
    encode_all(dir, img, &mut out)?;
    out.commit()
}
