//! Images from the camera: per pixel, the primary hit's exact direct irradiance (shadow
//! rays) and its indirect irradiance evaluated from the hierarchy (the Shepard sum per
//! pixel, equivalent to the paper's splatting), as radiance `ρ E / π`.

use std::path::Path;

use glam::Vec3;
use rayon::prelude::*;

use crate::engine::Engine;
use crate::error::{Error, Result};
use crate::hierarchy::Hierarchy;
use crate::output::Outputs;
use crate::params::SolverParams;
use crate::progress::Progress;
use crate::reference::{self, ReferenceOptions};
use crate::scene::emitter::pixel_seed;
use crate::scene::{Camera, Scene, Surface};
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
    /// Pixel samples whose indirect light was gathered because the basis read was
    /// doubted (`doubt_gather`), and those that read the basis.
    pub doubted_samples: u64,
    pub basis_samples: u64,
    /// The device's times where the image was drawn there ([`render_on`]); `None` on the
    /// CPU.
    pub device: Option<DeviceSeconds>,
}

/// How long an image drawn on the device took.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct DeviceSeconds {
    /// The `image` kernel (GPU timestamps; 0 where the device has none).
    pub image_kernel: f64,
    /// The whole pass: the pipeline (at the first image), uploads, the bands and their
    /// readbacks.
    pub image_pass: f64,
}

impl Images {
    /// Direct plus indirect.
    pub fn total(&self) -> Vec<Vec3> {
        self.direct.iter().zip(&self.indirect).map(|(a, b)| *a + *b).collect()
    }
}

/// Renders the view of `cam`: per pixel, [`Camera::spp`] samples spread over
/// the pixel filter's footprint ([`Camera::sample_position`]), each with
/// its own primary hit, its direct irradiance from the lights `lights` (exact, shadow
/// rays), its emitted radiance and its indirect irradiance `indirect(surface, sample)`
/// (`sample` = pixel index × spp + k, a stream for estimators that need one), as radiance
/// `ρ E / π`; the pixel is their mean. Negative indirect pixels are clamped and counted.
pub fn render_with(
    scene: &Scene,
    cam: &Camera,
    lights: &[bool],
    progress: &Progress,
    indirect: impl Fn(&Surface, u64) -> Vec3 + Sync,
) -> Images {
    let (w, hgt) = (cam.width as usize, cam.height as usize);
    let spp = cam.spp.max(1);
    let bar = progress.bar(hgt as u64, "image");
    let rows: Vec<(Vec<Vec3>, Vec<Vec3>)> = (0..hgt)
        .into_par_iter()
        .map(|y| {
            let mut d = Vec::with_capacity(w);
            let mut i = Vec::with_capacity(w);
            for x in 0..w {
                let (mut ds, mut is) = (Vec3::ZERO, Vec3::ZERO);
                for k in 0..spp {
                    let (px, py) = cam.sample_position(x as u32, y as u32, k);
                    let ray = cam.ray(px, py);
                    match scene.intersect(&ray, f32::INFINITY) {
                        Some(hit) => {
                            let s = scene.surface(&hit, ray.d);
                            let kd = s.albedo / std::f32::consts::PI;
                            let sample = (y * w + x) as u64 * spp as u64 + k as u64;
                            // The emitters' and sky's samples are shifted per image
                            // sample, as the `image` kernel shifts them. An emitter shows
                            // its own radiance (`Scene::emitted`).
                            let seed = pixel_seed(sample, 0);
                            ds += kd * scene.direct_from_seeded(s.p, s.n, lights, seed)
                                + scene.emitted(&s, hit.b1, hit.b2);
                            is += kd * indirect(&s, sample);
                        }
                        // A ray that leaves the scene sees the sky (`[sky]`; black without).
                        None => ds += scene.sky_radiance(ray.d),
                    }
                }
                let n = 1.0 / spp as f32;
                d.push(ds * n);
                i.push(is * n);
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
        doubted_samples: 0,
        basis_samples: 0,
        device: None,
    }
}

/// Renders the camera view of a solution, reading the indirect light as `params` ask
/// (the output level, or a final gather of `final_gather_pixels` rays per pixel). Every light is tested at every pixel:
/// a light that reaches no node (a narrow beam between them) still lights the surfaces
/// it reaches.
pub fn render(scene: &Scene, h: &Hierarchy, sol: &Solution, params: &SolverParams, progress: &Progress) -> Images {
    let lights = vec![true; scene.sources()];
    let read = Readout::for_pixels(scene, h, sol, params);
    let mut img = render_with(scene, &scene.camera, &lights, progress, |s, sample| {
        read.on_surface(s, sample)
    });
    (img.basis_samples, img.doubted_samples) = read.doubt_counts();
    img
}

/// Reference images (`meshrad reference --camera`, `bench accuracy`'s image front): exact
/// direct light and path-traced indirect irradiance (`opts`: paths per pixel, bounces,
/// seed), over the camera's pixel filter. The `opts.samples` paths of a pixel are spread
/// over up to 256 sub-pixel positions (stratified as the solver's samples), so the edges
/// converge with the paths.
pub fn reference_image(scene: &Scene, opts: &ReferenceOptions, progress: &Progress) -> Images {
    let all = vec![true; scene.sources()];
    let mut cam = scene.camera.clone();
    let spp = opts.samples.clamp(1, 256);
    cam.spp = spp;
    let per = ReferenceOptions {
        samples: opts.samples.div_ceil(spp),
        ..*opts
    };
    render_with(scene, &cam, &all, progress, |s, sample| {
        reference::indirect(scene, s.p, s.n, &per, sample).mean.as_vec3()
    })
}

/// [`render`] where `engine` solved: on the device that holds the solve's node values
/// when it is one (kernel `image`: only the pixels cross the bus), else on the CPU. The
/// two agree to float tolerance (`tests/gpu.rs`).
pub fn render_on(
    engine: &mut Engine,
    scene: &Scene,
    h: &Hierarchy,
    sol: &Solution,
    params: &SolverParams,
    progress: &Progress,
) -> Result<Images> {
    let Some(px) = engine.render_on_device(scene, params, progress) else {
        return Ok(render(scene, h, sol, params, progress));
    };
    let px = px?;
    let mut indirect = px.indirect;
    let mut clamped = 0;
    for v in &mut indirect {
        if v.min_element() < 0.0 {
            clamped += 1;
            *v = v.max(Vec3::ZERO);
        }
    }
    let (basis_samples, doubted_samples) = if px.doubting {
        (px.hit_samples - px.gathered_samples, px.gathered_samples)
    } else {
        (0, 0)
    };
    Ok(Images {
        width: scene.camera.width,
        height: scene.camera.height,
        direct: px.direct,
        indirect,
        clamped,
        doubted_samples,
        basis_samples,
        device: Some(DeviceSeconds {
            image_kernel: px.kernel_seconds,
            image_pass: px.seconds,
        }),
    })
}

/// How bright the PNGs are drawn: `2^ev` times the linear radiance before gamma 2.2. The
/// EXRs stay linear and untouched.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Exposure {
    /// [`auto_ev`] of the total image.
    #[default]
    Auto,
    /// A fixed exposure in stops (EV).
    Ev(f32),
}

impl std::str::FromStr for Exposure {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        if s.eq_ignore_ascii_case("auto") {
            return Ok(Exposure::Auto);
        }
        match s.parse::<f32>() {
            Ok(v) if v.is_finite() && v.abs() <= MAX_EV => Ok(Exposure::Ev(v)),
            Ok(v) => Err(format!("{v} stops is outside ±{MAX_EV}")),
            Err(_) => Err(format!("`{s}` is neither `auto` nor a number of stops (EV)")),
        }
    }
}

/// Most stops of exposure either way.
pub const MAX_EV: f32 = 40.0;

/// The exposure applied to the PNGs, as stats.json reports it.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct AppliedExposure {
    /// `"auto"` or `"fixed"`.
    pub mode: &'static str,
    /// Stops: the PNGs show `2^ev` times the linear radiance.
    pub ev: f32,
}

impl Exposure {
    /// The stops this exposure applies to an image whose total radiance is `total`.
    pub fn resolve(self, total: &[Vec3]) -> AppliedExposure {
        match self {
            Exposure::Ev(ev) => AppliedExposure { mode: "fixed", ev },
            Exposure::Auto => AppliedExposure {
                mode: "auto",
                ev: auto_ev(total),
            },
        }
    }
}

/// The automatic exposure: the stops that put the 99th percentile of the lit pixels'
/// luminance at white, so at most one lit pixel in a hundred clips, whatever the lights'
/// units; rounded to 1/100 stop. A black image gets 0. (On the Cornell box this is
/// +1.56, the same as the photographic key 0.18 at the log-average luminance.)
pub fn auto_ev(px: &[Vec3]) -> f32 {
    let mut lum: Vec<f32> = px
        .iter()
        .map(|p| 0.2126 * p.x + 0.7152 * p.y + 0.0722 * p.z)
        .filter(|&y| y > 0.0 && y.is_finite())
        .collect();
    if lum.is_empty() {
        return 0.0;
    }
    let k = ((lum.len() - 1) as f64 * 0.99).round() as usize;
    let (_, p99, _) = lum.select_nth_unstable_by(k, f32::total_cmp);
    let ev = (1.0 / *p99).log2().clamp(-MAX_EV, MAX_EV);
    (ev * 100.0).round() / 100.0
}

/// Encodes `stem.exr` (linear float RGB) and `stem.png` (`2^ev` times the radiance,
/// gamma 2.2, clamped) for `dir`.
pub fn encode_pair(dir: &Path, stem: &str, w: u32, h: u32, px: &[Vec3], ev: f32, out: &mut Outputs) -> Result<()> {
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
    let scale = 2f32.powf(ev);
    let enc = |v: f32| ((v * scale).max(0.0).powf(1.0 / 2.2).min(1.0) * 255.0 + 0.5) as u8;
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

/// Encodes direct, indirect and total images for `dir`, the PNGs all at one exposure
/// (resolved on the total image), which it returns.
pub fn encode_all(dir: &Path, img: &Images, exposure: Exposure, out: &mut Outputs) -> Result<AppliedExposure> {
    let total = img.total();
    let applied = exposure.resolve(&total);
    let ev = applied.ev;
    encode_pair(dir, "direct", img.width, img.height, &img.direct, ev, out)?;
    encode_pair(dir, "indirect", img.width, img.height, &img.indirect, ev, out)?;
    encode_pair(dir, "total", img.width, img.height, &total, ev, out)?;
    Ok(applied)
}

/// The files [`encode_all`] writes in `dir`.
pub fn file_names(dir: &Path) -> Vec<std::path::PathBuf> {
    ["direct", "indirect", "total"]
        .iter()
        .flat_map(|s| [dir.join(format!("{s}.exr")), dir.join(format!("{s}.png"))])
        .collect()
}

/// Writes direct, indirect and total images (all or none).
pub fn write_all(dir: &Path, img: &Images, exposure: Exposure) -> Result<AppliedExposure> {
    let mut out = Outputs::default();
    let applied = encode_all(dir, img, exposure, &mut out)?;
    out.commit()?;
    Ok(applied)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auto_exposure_puts_the_99th_percentile_at_white() {
        // 1000 lit pixels of luminance 0.001 … 1.0 and some black ones: the 99th
        // percentile is 0.99 (+0.01 EV); ten times the radiance is 3.32 stops less.
        let mut px: Vec<Vec3> = (1..=1000).map(|k| Vec3::splat(k as f32 / 1000.0)).collect();
        px.extend(std::iter::repeat_n(Vec3::ZERO, 500));
        assert_eq!(auto_ev(&px), 0.01);
        let brighter: Vec<Vec3> = px.iter().map(|p| *p * 10.0).collect();
        assert_eq!(auto_ev(&brighter), -3.31);
        assert_eq!(auto_ev(&[Vec3::ZERO; 4]), 0.0);
        assert_eq!("auto".parse::<Exposure>(), Ok(Exposure::Auto));
        assert_eq!("-1.5".parse::<Exposure>(), Ok(Exposure::Ev(-1.5)));
        assert!("nan".parse::<Exposure>().is_err());
    }
}
