//! Kernel `image` (`glsl/image.comp`): the camera's view of a solved scene over a band of
//! pixels, in two passes: one thread per sample and chunk of its gather, then one per
//! pixel summing them (`device::image`).

use std::ops::Range;

use bytemuck::{Pod, Zeroable};

use super::{kernel, per_element, Recorder};
use crate::constants::{IMAGE_PASS_PIXELS, IMAGE_PASS_SAMPLES};

/// The push constants of `image` (GLSL `ImagePush`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct ImagePush {
    pub globals: u64,
    /// Device address of the [`crate::layout::ImageInfo`].
    pub info: u64,
    /// Device address of the band's sample slots: two `vec4` each (direct and 1 if the
    /// sample hit; indirect and 1 if it gathered).
    pub slots: u64,
    /// Device address of the band's pixels: two `vec4` each (direct and the samples that
    /// hit; indirect and the samples gathered).
    pub pixels: u64,
    pub first_pixel: u32,
    /// Pixels in the band.
    pub count: u32,
    /// `IMAGE_PASS_SAMPLES` or `IMAGE_PASS_PIXELS`.
    pub pass: u32,
    pub pad0: u32,
}

kernel!(Image, "image", IMAGE, ImagePush);

impl Image {
    /// Records both passes over the pixels `band` (image indices, row-major), with
    /// `slots_per_pixel` (samples × chunks) slots each, a barrier between them.
    pub fn record(
        &self,
        rec: &mut Recorder,
        info: u64,
        slots: u64,
        pixels: u64,
        band: Range<u32>,
        slots_per_pixel: u32,
    ) {
        let mut push = ImagePush {
            globals: rec.globals,
            info,
            slots,
            pixels,
            first_pixel: band.start,
            count: band.len() as u32,
            pass: IMAGE_PASS_SAMPLES,
            pad0: 0,
        };
        rec.dispatch(&self.0, &push, per_element(band.len() as u64 * slots_per_pixel as u64));
        rec.barrier();
        push.pass = IMAGE_PASS_PIXELS;
        rec.dispatch(&self.0, &push, per_element(band.len() as u64));
    }
}
