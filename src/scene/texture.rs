//! Albedo textures (`map_Kd`): RGBA8 texels decoded from sRGB through one shared table,
//! bilinear, repeating, OBJ uv convention (v up). GLSL twin: `sample_albedo` in
//! `glsl/include/surface.glsl`.

use std::path::Path;

use glam::{Vec2, Vec3};

use crate::error::{Error, Result};
use crate::layout::{TextureInfo, WRAP_CLAMP, WRAP_MIRROR, WRAP_REPEAT};

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

/// Bytes a texture of `w × h` pixels takes while it is decoded: the decoder's image (up to
/// 16 bytes a pixel, RGBA f32), its RGBA8 copy and the packed texels (4 bytes each).
pub const DECODE_BYTES_PER_PIXEL: u64 = 24;
/// Bytes a decoded texture keeps for the run, per pixel.
pub const KEPT_BYTES_PER_PIXEL: u64 = 4;

/// An image file's width and height from its header alone, without decoding it (`None`
/// where the header cannot be read: decoding then names the error).
pub fn dimensions(bytes: &[u8]) -> Option<(u32, u32)> {
    image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .ok()?
        .into_dimensions()
        .ok()
}

/// Decodes an image file's bytes (`shown` names it in errors) as packed RGBA8 texels.
pub fn decode(bytes: &[u8], shown: &Path) -> Result<(u32, u32, Vec<u32>)> {
    let img = image::load_from_memory(bytes).map_err(|e| Error::Texture {
        path: shown.into(),
        message: e.to_string(),
    })?;
    let rgba = img.to_rgba8();
    let (w, h) = rgba.dimensions();
    if w == 0 || h == 0 {
        return Err(Error::Texture {
            path: shown.into(),
            message: "image is empty".into(),
        });
    }
    let texels = rgba
        .pixels()
        .map(|p| u32::from_le_bytes([p[0], p[1], p[2], p[3]]))
        .collect();
    Ok((w, h, texels))
}

/// Decodes a mask image (MTL `map_d`) as packed RGBA8 texels whose alpha byte is the
/// mask: the image's alpha channel where it has one, else its red channel.
pub fn decode_mask(bytes: &[u8], shown: &Path) -> Result<(u32, u32, Vec<u32>)> {
    let has_alpha = image::load_from_memory(bytes)
        .map(|i| i.color().has_alpha())
        .map_err(|e| Error::Texture {
            path: shown.into(),
            message: e.to_string(),
        })?;
    let (w, h, px) = decode(bytes, shown)?;
    let px = px
        .into_iter()
        .map(|p| {
            if has_alpha {
                p
            } else {
                (p & 0x00ff_ffff) | (p & 0xff) << 24
            }
        })
        .collect();
    Ok((w, h, px))
}

/// Bilinear lookup of a texture's alpha byte (linear, in [0, 1]) at `uv`, as [`sample`]
/// reads its colour: what a cutout tests. GLSL twin: `sample_alpha` in
/// `glsl/include/geometry.glsl`.
pub fn sample_alpha(texels: &[u32], info: &TextureInfo, uv: Vec2) -> f32 {
    let (ix, iy, tx, ty) = bilinear_at(info, uv);
    let a = |x: i32, y: i32| {
        let xw = wrap_index(x, info.width, info.wrap & 3);
        let yw = wrap_index(y, info.height, (info.wrap >> 2) & 3);
        (texels[(info.offset + yw * info.width + xw) as usize] >> 24) as f32 * (1.0 / 255.0)
    };
    (a(ix, iy) * (1.0 - tx) + a(ix + 1, iy) * tx) * (1.0 - ty)
        + (a(ix, iy + 1) * (1.0 - tx) + a(ix + 1, iy + 1) * tx) * ty
}

/// A texture coordinate brought into [0, 1] by wrap mode `m` (`TextureInfo::wrap`).
#[inline]
fn wrap_coord(u: f32, m: u32) -> f32 {
    match m {
        WRAP_CLAMP => u.clamp(0.0, 1.0),
        WRAP_MIRROR => {
            let t = u - 2.0 * (u * 0.5).floor();
            if t > 1.0 {
                2.0 - t
            } else {
                t
            }
        }
        _ => u - u.floor(),
    }
}

/// A texel index at most one step outside `[0, n)` brought back by wrap mode `m`: the
/// next period for repeat, the edge texel for clamp and mirror.
#[inline]
fn wrap_index(i: i32, n: u32, m: u32) -> u32 {
    let n = n as i32;
    if m == WRAP_REPEAT {
        (if i < 0 {
            i + n
        } else if i >= n {
            i - n
        } else {
            i
        }) as u32
    } else {
        i.clamp(0, n - 1) as u32
    }
}

#[inline]
fn texel(texels: &[u32], info: &TextureInfo, x: i32, y: i32, lut: &[f32; 256]) -> Vec3 {
    let xw = wrap_index(x, info.width, info.wrap & 3);
    let yw = wrap_index(y, info.height, (info.wrap >> 2) & 3);
    let p = texels[(info.offset + yw * info.width + xw) as usize];
    Vec3::new(
        lut[(p & 0xff) as usize],
        lut[((p >> 8) & 0xff) as usize],
        lut[((p >> 16) & 0xff) as usize],
    )
}

/// The texel below and left of `uv`'s bilinear footprint and the weights toward the next
/// ones, `uv` wrapped into [0, 1] first so that texel indices stay within one step of the
/// image. GLSL twin: `bilinear_at` in `glsl/include/geometry.glsl`.
#[inline]
fn bilinear_at(info: &TextureInfo, uv: Vec2) -> (i32, i32, f32, f32) {
    let x = wrap_coord(uv.x, info.wrap & 3) * info.width as f32 - 0.5;
    let y = (1.0 - wrap_coord(uv.y, (info.wrap >> 2) & 3)) * info.height as f32 - 0.5;
    let (fx, fy) = (x.floor(), y.floor());
    (fx as i32, fy as i32, x - fx, y - fy)
}

/// Bilinear lookup of linear albedo at `uv` (v up), wrapped by the texture's modes.
pub fn sample(texels: &[u32], info: &TextureInfo, uv: Vec2, lut: &[f32; 256]) -> Vec3 {
    let (ix, iy, tx, ty) = bilinear_at(info, uv);
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

/// Mean linear value of a texture over a triangle with corner uvs `uv` (u0 v0 u1 v1 u2
/// v2): bilinear reads at points of a 2-D Halton set spread uniformly over the triangle,
/// about four for each texel it covers (16 to 4096). What an emitting triangle's
/// selection weight follows: a triangle whose texels are all black gets zero.
pub fn mean_over(texels: &[u32], info: &TextureInfo, uv: &[f32; 6], lut: &[f32; 256]) -> Vec3 {
    let (a, b, c) = (
        Vec2::new(uv[0], uv[1]),
        Vec2::new(uv[2], uv[3]),
        Vec2::new(uv[4], uv[5]),
    );
    let texels_covered = 0.5 * ((b - a).perp_dot(c - a)).abs() as f64 * info.width as f64 * info.height as f64;
    let n = if texels_covered.is_finite() {
        (4.0 * texels_covered).ceil().clamp(16.0, 4096.0) as u64
    } else {
        16
    };
    let mut sum = glam::DVec3::ZERO;
    for i in 1..=n {
        let h = crate::scene::emitter::halton2(i);
        let (b1, b2) = crate::geom::sampling::uniform_triangle(Vec2::new(h[0] as f32, h[1] as f32));
        let p = a + (b - a) * b1 + (c - a) * b2;
        sum += sample(texels, info, p, lut).as_dvec3();
    }
    (sum / n as f64).as_vec3()
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
            wrap: 0,
        };
        let at = |u: f32| sample(&texels, &info, Vec2::new(u, 0.5), &lut).x;
        assert!((at(0.25) - 0.0).abs() < 1e-6);
        assert!((at(0.75) - 1.0).abs() < 1e-6);
        assert!((at(0.5) - 0.5).abs() < 1e-6);
        assert!((at(1.25) - at(0.25)).abs() < 1e-6);
        assert!((at(0.0) - 0.5).abs() < 1e-6, "wraps between last and first texel");
    }

    /// A triangle's mean follows the texels under it: zero over the black half, one over
    /// the white half, between over both.
    #[test]
    fn mean_over_a_triangle_reads_its_texels() {
        let lut = srgb_table();
        // 64×64: left half black, right half white.
        let texels: Vec<u32> = (0..64 * 64)
            .map(|i| if i % 64 < 32 { 0xff00_0000 } else { 0xffff_ffff })
            .collect();
        let info = TextureInfo {
            offset: 0,
            width: 64,
            height: 64,
            wrap: WRAP_CLAMP | WRAP_CLAMP << 2,
        };
        let m = |uv: [f32; 6]| mean_over(&texels, &info, &uv, &lut).x;
        assert_eq!(m([0.05, 0.1, 0.4, 0.1, 0.2, 0.9]), 0.0);
        assert!((m([0.6, 0.1, 0.95, 0.1, 0.8, 0.9]) - 1.0).abs() < 1e-6);
        // A square's lower-left half-triangle over both halves: the white part's share of
        // its area (the bilinear blend at the border is symmetric).
        let both = m([0.0, 0.0, 1.0, 0.0, 0.0, 1.0]);
        assert!((both - 0.25).abs() < 0.02, "{both}");
    }

    #[test]
    fn clamp_and_mirror() {
        let lut = srgb_table();
        let texels = vec![0xff00_0000, 0xffff_ffff];
        let mut info = TextureInfo {
            offset: 0,
            width: 2,
            height: 1,
            wrap: WRAP_CLAMP | WRAP_CLAMP << 2,
        };
        let at = |info: &TextureInfo, u: f32| sample(&texels, info, Vec2::new(u, 0.5), &lut).x;
        assert!(at(&info, 0.0).abs() < 1e-6, "clamp: the edge texel, not the far one");
        assert!((at(&info, 1.0) - 1.0).abs() < 1e-6);
        assert!((at(&info, 7.3) - 1.0).abs() < 1e-6);
        assert!(at(&info, -2.0).abs() < 1e-6);
        info.wrap = WRAP_MIRROR;
        assert!((at(&info, 1.25) - at(&info, 0.75)).abs() < 1e-6, "mirrored about 1");
        assert!((at(&info, -0.25) - at(&info, 0.25)).abs() < 1e-6, "mirrored about 0");
        assert!((at(&info, 2.25) - at(&info, 0.25)).abs() < 1e-6, "period 2");
        assert!(at(&info, 1.0) > 0.99);
    }
}
