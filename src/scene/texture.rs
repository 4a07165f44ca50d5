//! Albedo textures (`map_Kd`): RGBA8 texels decoded from sRGB through one shared table,
//! bilinear, repeating, OBJ uv convention (v up). GLSL twin: `sample_albedo` in
//! `glsl/include/surface.glsl`.

use std::path::Path;

use glam::{Vec2, Vec3};

use super::source::Source;
use crate::error::{Error, Result};
use crate::layout::TextureInfo;

/// sRGB → linear for the 256 8-bit codes (the exact piecewise curve).
pub fn srgb_table() -> [f32; 256] {
    let mut t = [0.0f32; 256];
    for (i, v) in t.iter_mut().enumerate() {
        let c = i as f64 / 255.0;
        *v = if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        } as f32;
    }
    t
}

/// Loads an image as packed RGBA8 texels; returns (width, height, texels).
pub fn load(source: &Source, rel: &Path) -> Result<(u32, u32, Vec<u32>)> {
    let bytes = source.read(rel)?;
    let img = image::load_from_memory(&bytes).map_err(|e| Error::Texture {
        path: source.display(rel),
        message: e.to_string(),
    })?;
    let rgba = img.to_rgba8();
    let (w, h) = rgba.dimensions();
    if w == 0 || h == 0 {
        return Err(Error::Texture {
            path: source.display(rel),
            message: "image is empty".into(),
        });
    }
    let texels = rgba
        .pixels()
        .map(|p| u32::from_le_bytes([p[0], p[1], p[2], p[3]]))
        .collect();
    Ok((w, h, texels))
}

#[inline]
fn texel(texels: &[u32], info: &TextureInfo, x: i32, y: i32, lut: &[f32; 256]) -> Vec3 {
    let wrap = |i: i32, n: u32| {
        let n = n as i32;
        (if i < 0 {
            i + n
        } else if i >= n {
            i - n
        } else {
            i
        }) as u32
    };
    let (xw, yw) = (wrap(x, info.width), wrap(y, info.height));
    let p = texels[(info.offset + yw * info.width + xw) as usize];
    Vec3::new(
        lut[(p & 0xff) as usize],
        lut[((p >> 8) & 0xff) as usize],
        lut[((p >> 16) & 0xff) as usize],
    )
}

/// Bilinear, repeating lookup of linear albedo at `uv`.
pub fn sample(texels: &[u32], info: &TextureInfo, uv: Vec2, lut: &[f32; 256]) -> Vec3 {
    // Repeat: wrap uv into [0, 1) first, so texel indices stay within one period.
    let x = (uv.x - uv.x.floor()) * info.width as f32 - 0.5;
    let y = (1.0 - (uv.y - uv.y.floor())) * info.height as f32 - 0.5;
    let (fx, fy) = (x.floor(), y.floor());
    let (tx, ty) = (x - fx, y - fy);
    let (ix, iy) = (fx as i32, fy as i32);
    let a = texel(texels, info, ix, iy, lut);
    let b = texel(texels, info, ix + 1, iy, lut);
    let c = texel(texels, info, ix, iy + 1, lut);
    let d = texel(texels, info, ix + 1, iy + 1, lut);
    (a * (1.0 - tx) + b * tx) * (1.0 - ty) + (c * (1.0 - tx) + d * tx) * ty
}

/// Mean linear albedo of a texture, per channel.
pub fn mean(texels: &[u32], info: &TextureInfo, lut: &[f32; 256]) -> Vec3 {
    let n = (info.width * info.height) as usize;
    let s = texels[info.offset as usize..info.offset as usize + n]
        .iter()
        .fold(glam::DVec3::ZERO, |acc, &p| {
            acc + glam::DVec3::new(
                lut[(p & 0xff) as usize] as f64,
                lut[((p >> 8) & 0xff) as usize] as f64,
                lut[((p >> 16) & 0xff) as usize] as f64,
            )
        });
    (s / n as f64).as_vec3()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_endpoints() {
        let t = srgb_table();
        assert_eq!(t[0], 0.0);
        assert_eq!(t[255], 1.0);
        assert!((t[188] - 0.5029).abs() < 1e-3);
    }

    #[test]
    fn bilinear_centre_and_wrap() {
        let lut = srgb_table();
        // 2×1 texture: black, white. v = 0.5 (middle row).
        let texels = vec![0xff00_0000, 0xffff_ffff];
        let info = TextureInfo {
            offset: 0,
            width: 2,
            height: 1,
            pad: 0,
        };
        let at = |u: f32| sample(&texels, &info, Vec2::new(u, 0.5), &lut).x;
        assert!((at(0.25) - 0.0).abs() < 1e-6);
        assert!((at(0.75) - 1.0).abs() < 1e-6);
        assert!((at(0.5) - 0.5).abs() < 1e-6);
        assert!((at(1.25) - at(0.25)).abs() < 1e-6);
        assert!((at(0.0) - 0.5).abs() < 1e-6, "wraps between last and first texel");
    }
}
