//! The camera's view of a solve on the device that solved it (kernel `image`,
//! `glsl/image.comp`): primary rays, shadow rays, the emitters and the sky, the basis read
//! and the gathers run over the resident scene and node values, band by band of rows; only
//! the pixels come back. CPU twin: `output::image::render`.

use std::sync::Arc;
use std::time::Instant;

use glam::{Vec3, Vec4};

use super::backend::specialization;
use super::kernels::image::Image;
use super::kernels::submit;
use super::GpuResident;
use crate::constants::{
    FILTER_BOX, FILTER_GAUSSIAN, IMAGE_BAND_SLOTS, IMAGE_BASIS, IMAGE_CHUNK_RAYS, IMAGE_DOUBT, IMAGE_GATHER,
    IMAGE_PIXEL_SLOTS,
};
use crate::error::{Error, Result};
use crate::geom::sampling::halton_table;
use crate::gpu::buffer::Buffer;
use crate::gpu::context::Context;
use crate::layout::ImageInfo;
use crate::params::SolverParams;
use crate::progress::Progress;
use crate::scene::camera::Filter;
use crate::scene::Scene;

/// What the images drawn on a resident state keep between them: the `image` pipeline and
/// the scene's corner normals (36 bytes a triangle, where it has any), built and uploaded
/// at the first image.
pub struct ImageState {
    kernel: Image,
    normals: Option<Buffer>,
}

/// The pixels of an image drawn on the device, as radiance (`output::image::Images`
/// before its negative indirect pixels are clamped).
pub struct Pixels {
    pub direct: Vec<Vec3>,
    pub indirect: Vec<Vec3>,
    /// Samples whose primary ray hit a surface, and those of them that gathered.
    pub hit_samples: u64,
    pub gathered_samples: u64,
    /// Whether the read gathered only where the basis was doubted (`doubt_gather`).
    pub doubting: bool,
    /// The `image` kernel's time (GPU timestamps; 0 where the device has none) and the
    /// whole pass's wall time.
    pub kernel_seconds: f64,
    pub seconds: f64,
}

impl GpuResident {
    /// Draws `scene.camera`'s view of the last solve on this state (its node values are
    /// resident), reading the indirect light as `p` asks: the basis, a gather of
    /// `doubt_gather` rays where the basis read is doubted, or `final_gather_pixels` rays
    /// everywhere ([`crate::transport::readout::Readout::for_pixels`]). `p` must be the
    /// parameters the state was solved with.
    pub fn render(
        &mut self,
        ctx: &Arc<Context>,
        scene: &Scene,
        p: &SolverParams,
        progress: &Progress,
    ) -> Result<Pixels> {
        let t0 = Instant::now();
        let cam = &scene.camera;
        let (w, h) = (cam.width, cam.height);
        if self.image.is_none() {
            // The corner normals are in object space: a rigid edit leaves them as they are,
            // and a rebuild makes a new resident state.
            let normals = if scene.normals.is_empty() {
                None
            } else {
                let mut flat: Vec<f32> = scene.normals.iter().flatten().copied().collect();
                flat.resize(scene.tris.len() * 9, 0.0);
                Some(Buffer::upload(ctx, "corner normals", &flat)?)
            };
            self.image = Some(ImageState {
                kernel: Image::new(ctx, specialization(p, scene))?,
                normals,
            });
        }
        let (mode, rays) = if p.final_gather_pixels > 0 {
            (IMAGE_GATHER, p.final_gather_pixels)
        } else if p.doubt_gather > 0 {
            (IMAGE_DOUBT, p.doubt_gather)
        } else {
            (IMAGE_BASIS, 0)
        };
        let halton = Buffer::upload(ctx, "image gather directions", &halton_table(rays))?;
        // A sample's gather in chunks of at most IMAGE_CHUNK_RAYS rays, one thread each, and
        // at most IMAGE_PIXEL_SLOTS slots a pixel (larger chunks beyond that).
        let spp = cam.spp.max(1);
        let max_chunks = (IMAGE_PIXEL_SLOTS / spp).max(1);
        let chunks = rays.div_ceil(IMAGE_CHUNK_RAYS).clamp(1, max_chunks);
        let chunk_rays = rays.div_ceil(chunks);
        let per_pixel = spp * chunks;
        let v4 = |v: Vec3, w: f32| [v.x, v.y, v.z, w];
        let info = ImageInfo {
            position: v4(cam.position, cam.tan_half),
            forward: v4(cam.forward, 0.0),
            right: v4(cam.right, 0.0),
            up: v4(cam.up, 0.0),
            normals: self
                .image
                .as_ref()
                .and_then(|i| i.normals.as_ref())
                .map_or(0, |b| b.address),
            halton: halton.address,
            width: w,
            height: h,
            spp: cam.spp.max(1),
            filter_kind: match cam.filter {
                Filter::Box => FILTER_BOX,
                Filter::Gaussian => FILTER_GAUSSIAN,
            },
            level: p.output_level(),
            seed: p.seed,
            mode,
            gather_rays: rays,
            doubt_nodes: p.doubt_nodes,
            doubt_spread: p.doubt_spread,
            chunks,
            chunk_rays,
            short_hops: p.short_hops,
            pad: [0; 3],
        };
        let info_buf = Buffer::upload(ctx, "image info", std::slice::from_ref(&info))?;
        let n = w as usize * h as usize;
        let band_pixels = (IMAGE_BAND_SLOTS / per_pixel).clamp(1, n as u32);
        let slots = Buffer::new(
            ctx,
            "image sample slots",
            band_pixels as u64 * per_pixel as u64 * 32,
            gpu_allocator::MemoryLocation::GpuOnly,
        )?;
        let band = Buffer::new(
            ctx,
            "image band",
            band_pixels as u64 * 32,
            gpu_allocator::MemoryLocation::GpuOnly,
        )?;
        let (mut direct, mut indirect) = (Vec::with_capacity(n), Vec::with_capacity(n));
        let (mut hits, mut gathered) = (0u64, 0u64);
        let before = self.prof.totals.get(Image::NAME).map_or(0.0, |t| t.0);
        let bar = progress.bar(n as u64, "image (device)");
        let kernel = &self.image.as_ref().expect("built above").kernel;
        let globals = self.res.globals.address;
        let mut first = 0u32;
        while (first as usize) < n {
            let count = band_pixels.min(n as u32 - first);
            submit(ctx, &mut self.prof, globals, |rec| {
                kernel.record(
                    rec,
                    info_buf.address,
                    slots.address,
                    band.address,
                    first..first + count,
                    per_pixel,
                );
            })?;
            let px: Vec<Vec4> = band.download(0, 2 * count as usize)?;
            for pair in px.chunks_exact(2) {
                direct.push(pair[0].truncate());
                indirect.push(pair[1].truncate());
                hits += pair[0].w as u64;
                gathered += pair[1].w as u64;
            }
            bar.inc(count as u64);
            first += count;
        }
        bar.finish();
        let errors = ctx.validation_errors();
        if errors > 0 {
            return Err(Error::Gpu(format!(
                "the validation layer reported {errors} error(s) by the image; see stderr"
            )));
        }
        Ok(Pixels {
            direct,
            indirect,
            hit_samples: hits,
            gathered_samples: gathered,
            doubting: mode == IMAGE_DOUBT,
            kernel_seconds: self.prof.totals.get(Image::NAME).map_or(0.0, |t| t.0) - before,
            seconds: t0.elapsed().as_secs_f64(),
        })
    }
}
