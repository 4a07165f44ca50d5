//! Kernel `image` (`glsl/image.comp`): the camera's view of a solved scene, one thread
//! per pixel of a band of rows (`device::image`).

use std::ops::Range;

use bytemuck::{Pod, Zeroable};

use super::{kernel, per_element, Recorder};

/// The push constants of `image` (GLSL `ImagePush`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct ImagePush {
    pub globals: u64,
    /// Device address of the [`crate::layout::ImageInfo`].
    pub info: u64,
    /// Device address of the band's pixels: two `vec4` each (direct and the samples that
    /// hit; indirect and the samples gathered).
    pub pixels: u64,
    pub first_row: u32,
    pub rows: u32,
}

kernel!(Image, "image", IMAGE, ImagePush);

impl Image {
    /// Records the kernel over the image rows `rows` of an image `width` pixels wide.
    pub fn record(&self, rec: &mut Recorder, info: u64, pixels: u64, rows: Range<u32>, width: u32) {
        let push = ImagePush {
            globals: rec.globals,
            info,
            pixels,
            first_row: rows.start,
            rows: rows.len() as u32,
        };
        rec.dispatch(&self.0, &push, per_element(rows.len() as u64 * width as u64));
    }
}
