//! Emissive surfaces (`ALGORITHM.md` §2.2): the triangles whose material emits (MTL
//! `Ke`, glTF `emissiveFactor`), as Mitsuba's `area` emitter: radiance `L_e` leaving
//! its front (the side its winding normal points to) only, uniform over the surface or
//! that factor times an emission texture (MTL `map_Ke`, glTF `emissiveTexture`) read
//! per texel at each sample. Their direct irradiance at a
//! point is estimated by sampling them: `emitter_samples` samples from a 3-D Halton set
//! shifted per receiving point (so the estimate is deterministic and the same however the
//! work is split), each a triangle and a direction uniform in its solid angle, with a
//! shadow ray, and the standard error of the mean ([`Emitters::for_each_sample`]). GLSL
//! twin: `glsl/include/emitters.glsl`.

use glam::{DVec3, Vec2, Vec3};

use crate::geom::sampling::uniform_triangle;
use crate::geom::transform::{xform_point, Affine};
use crate::layout::{Tri, NONE};

/// One emitting triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emitter {
    /// Global triangle index.
    pub tri: u32,
    /// Its object.
    pub object: u32,
    /// Emitted radiance `L_e` (RGB), its mean over the triangle where it is textured: the
    /// triangle's selection weight (power) follows it.
    pub radiance: Vec3,
    /// The material's emission factor, and the emission texture it multiplies
    /// (`layout::NONE` for none: then `L_e` is `radiance` everywhere on the triangle).
    pub scale: Vec3,
    pub texture: u32,
}

/// One emitting triangle's emission: its mean radiance, the factor and the texture (see
/// [`Emitter`]); a mean of zero is no emitter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emission {
    pub mean: Vec3,
    pub scale: Vec3,
    pub texture: u32,
}

/// The scene's emitting triangles and how they are sampled.
#[derive(Clone, Debug, Default)]
pub struct Emitters {
    pub list: Vec<Emitter>,
    /// Selection probability of each (∝ world area × luminance of `L_e`).
    prob: Vec<f64>,
    /// Running sums of `prob` (the last is 1).
    cdf: Vec<f64>,
    /// The base point set: 3-D Halton points (bases 2, 3, 5), as many as the most samples
    /// any point takes (a probe's; [`Emitters::most`]).
    points: Vec<[f64; 3]>,
    /// Samples per node and pixel (`emitter_samples`), the first of `points`.
    per_point: usize,
    /// Each object's placement (as of the last [`Emitters::place`]).
    to_world: Vec<Affine>,
}

/// A receiving point: world position, unit normal, and its shadow rays' origin.
#[derive(Clone, Copy, Debug)]
pub struct Receiver {
    pub x: Vec3,
    pub n: Vec3,
    pub o: Vec3,
}

/// One emitter sample seen from a receiving point: the radiance it sends there times the
/// geometry term over the sampling density (before visibility), and the shadow ray.
#[derive(Clone, Copy, Debug)]
pub struct EmitterSample {
    pub value: Vec3,
    /// From the shadow ray's origin to the sampled point (`t` in `(0, SHADOW_TMAX)`).
    pub to_point: Vec3,
}

/// Luminance weights of linear RGB (Rec. 709).
fn luminance(c: Vec3) -> f64 {
    0.2126 * c.x as f64 + 0.7152 * c.y as f64 + 0.0722 * c.z as f64
}

/// A receiving point's Cranley–Patterson shift of a sample set: three numbers in [0, 1)
/// from its seed.
pub fn shift(seed: u64) -> [f64; 3] {
    let s = mix64(seed);
    [s, mix64(s ^ 0x9e37), mix64(s ^ 0x79b9)].map(|v| (v >> 11) as f64 / (1u64 << 53) as f64)
}

/// Point `i` of the 2-D Halton set in bases 2 and 3.
pub fn halton2(i: u64) -> [f64; 2] {
    [radical_inverse(i, 2), radical_inverse(i, 3)]
}

fn radical_inverse(mut i: u64, base: u64) -> f64 {
    let (mut f, mut r) = (1.0f64, 0.0f64);
    while i > 0 {
        f /= base as f64;
        r += f * (i % base) as f64;
        i /= base;
    }
    r
}

/// The sample sets' shift for a point known only by where it is (probe points, pixels,
/// reference path vertices): a function of its position and normal bits.
pub fn point_seed(x: Vec3, n: Vec3) -> u64 {
    let bits = |v: Vec3| (v.x.to_bits() as u64) << 32 ^ (v.y.to_bits() as u64) << 16 ^ v.z.to_bits() as u64;
    mix64(bits(x)) ^ bits(n)
}

/// The sample sets' shift for node `j`'s direct light (CPU and kernels alike).
pub fn node_seed(j: u32) -> u64 {
    mix64(j as u64 ^ 0xd1ec_0000_0000_0000)
}

/// The sample's shift for the direct light at ray `r` of node `j`'s gathering integral
/// (the exact first bounce; CPU and kernels alike).
pub fn hit_seed(j: u32, r: u32) -> u64 {
    mix64((j as u64) << 32 | r as u64)
}

/// The sample sets' shift for the direct light of image sample `sample` (pixel index ×
/// spp + sample): `r` = 0 at the sample's own hit, `r + 1` at ray `r` of its gather. The
/// CPU image and the `image` kernel draw the same samples from it; a point's coordinates
/// ([`point_seed`]) can differ in their last bit between the two.
pub fn pixel_seed(sample: u64, r: u32) -> u64 {
    mix64(sample ^ ((r as u64) << 40) ^ 0x9ac5_0000_0000_0000)
}

/// The rotation key of image sample `sample`'s gather (CPU and the `image` kernel alike).
pub fn pixel_key(sample: u64) -> u32 {
    (mix64(sample ^ 0x6b0e_0000_0000_0000) >> 32) as u32
}

/// A 64-bit mix (splitmix64's finaliser).
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// World-space corners of triangle `t` of an object placed by `to_world`.
fn world_tri(t: &Tri, to_world: &Affine) -> [Vec3; 3] {
    [t.v0, t.v1, t.v2].map(|v| xform_point(to_world, Vec3::from(v)))
}

impl Emitters {
    /// The emitting triangles (`emission(tri)`: the emission of a global triangle, a
    /// zero mean for none) of objects placed by `to_world` (with their global triangle
    /// ranges). A textured triangle whose mean is zero (all its texels black) is no
    /// emitter: it costs nothing.
    pub fn new(
        tris: &[Tri],
        objects: &[(Affine, std::ops::Range<u32>)],
        emission: impl Fn(u32) -> Emission,
        samples: u32,
        probe_samples: u32,
    ) -> Emitters {
        let mut list = Vec::new();
        for (o, (_, range)) in objects.iter().enumerate() {
            for t in range.clone() {
                let e = emission(t);
                if e.mean.max_element() > 0.0 {
                    list.push(Emitter {
                        tri: t,
                        object: o as u32,
                        radiance: e.mean,
                        scale: e.scale,
                        texture: e.texture,
                    });
                }
            }
        }
        let mut e = Emitters {
            list,
            per_point: samples as usize,
            points: (1..=samples.max(probe_samples) as u64)
                .map(|i| [radical_inverse(i, 2), radical_inverse(i, 3), radical_inverse(i, 5)])
                .collect(),
            ..Default::default()
        };
        e.place(tris, &objects.iter().map(|o| o.0).collect::<Vec<_>>());
        e
    }

    /// Recomputes the selection probabilities for objects placed by `to_world` (after a
    /// move: a scale changes the areas).
    pub fn place(&mut self, tris: &[Tri], to_world: &[Affine]) {
        self.to_world = to_world.to_vec();
        let w: Vec<f64> = self
            .list
            .iter()
            .map(|e| {
                let [a, b, c] = world_tri(&tris[e.tri as usize], &to_world[e.object as usize]);
                0.5 * (b - a).as_dvec3().cross((c - a).as_dvec3()).length() * luminance(e.radiance)
            })
            .collect();
        let total: f64 = w.iter().sum();
        self.prob = w.iter().map(|x| if total > 0.0 { x / total } else { 0.0 }).collect();
        let mut run = 0.0;
        self.cdf = self
            .prob
            .iter()
            .map(|p| {
                run += p;
                run
            })
            .collect();
        if let Some(last) = self.cdf.last_mut() {
            *last = 1.0;
        }
    }

    /// Whether the scene has emitting surfaces (with power).
    pub fn any(&self) -> bool {
        self.cdf.last().is_some_and(|&c| c > 0.0)
    }

    /// A point of the emitting surfaces drawn by power (`u`: three uniform numbers) and
    /// the front normal there, world space: where a light path starts.
    pub fn sample_point(&self, tris: &[Tri], u: [f32; 3]) -> Option<(Vec3, Vec3)> {
        if !self.any() {
            return None;
        }
        let k = self.cdf.partition_point(|&c| c <= u[0] as f64).min(self.list.len() - 1);
        let e = &self.list[k];
        let [a, b, c] = world_tri(&tris[e.tri as usize], &self.to_world[e.object as usize]);
        let (b1, b2) = uniform_triangle(Vec2::new(u[1], u[2]));
        let n = (b - a).cross(c - a).try_normalize()?;
        Some((a + (b - a) * b1 + (c - a) * b2, n))
    }

    /// Samples per node and pixel (`emitter_samples`): the GPU kernels' count.
    pub fn samples(&self) -> usize {
        self.per_point
    }

    /// The most samples a point can take: a probe's (`max(final_gather,
    /// emitter_samples)` when the scene was loaded).
    pub fn most(&self) -> usize {
        self.points.len()
    }

    /// The kernels' tables: the emitters with their probabilities, and the base point set
    /// (x, y, z; w unused).
    pub fn gpu_tables(&self) -> (Vec<crate::layout::GpuEmitter>, Vec<[f32; 4]>) {
        let list = self
            .list
            .iter()
            .enumerate()
            .map(|(k, e)| crate::layout::GpuEmitter {
                tri: e.tri,
                object: e.object,
                prob: self.prob[k] as f32,
                cdf: self.cdf[k] as f32,
                radiance: e.radiance.into(),
                lum: luminance(e.radiance) as f32,
                scale: e.scale.into(),
                texture: e.texture,
            })
            .collect();
        let points = self
            .points
            .iter()
            .map(|p| [p[0] as f32, p[1] as f32, p[2] as f32, 0.0])
            .collect();
        (list, points)
    }

    /// Calls `f` with the first `count` samples for the receiving point `(x, n)` (world
    /// space; `o` the shadow rays' origin, `seed` the point's shift of the base set), the
    /// zero ones included (they count in the mean). `textured(e, b1, b2)` is the emitted
    /// radiance at barycentrics `(b1, b2)` of an emitter with a texture.
    ///
    /// A sample picks a triangle, then a direction uniformly within the solid angle the
    /// triangle subtends at `x` (Arvo 1995, as pbrt-v4's `SampleSphericalTriangle`): the
    /// estimate is `L_e cos θ_x Ω / P(t)`, bounded however close the triangle is (a
    /// point-on-area sample has a `1/r²` that makes the variance grow without bound
    /// near an emitter's edge). With up to [`LOCAL_WEIGHTS`] emitting triangles, `P(t)`
    /// is proportional to `luminance(L_e) Ω_t` at `x` (zero for triangles `x` is behind);
    /// with more, to their power.
    pub fn for_each_sample(
        &self,
        tris: &[Tri],
        at: Receiver,
        seed: u64,
        count: usize,
        textured: impl Fn(&Emitter, f32, f32) -> Vec3,
        mut f: impl FnMut(Option<EmitterSample>),
    ) {
        let Receiver { x, n, o } = at;
        let shift = shift(seed);
        let xd = x.as_dvec3();
        let corners = |k: usize| {
            let e = &self.list[k];
            world_tri(&tris[e.tri as usize], &self.to_world[e.object as usize]).map(|v| v.as_dvec3())
        };
        // Per-point selection weights, on the stack.
        let local = self.list.len() <= LOCAL_WEIGHTS;
        let mut cdf = [0.0f64; LOCAL_WEIGHTS];
        if local {
            let mut run = 0.0;
            for (k, c) in cdf.iter_mut().enumerate().take(self.list.len()) {
                let v = corners(k);
                let front = (v[1] - v[0]).cross(v[2] - v[0]).dot(xd - v[0]) > 0.0;
                if front {
                    run += luminance(self.list[k].radiance) * solid_angle(xd, &v);
                }
                *c = run;
            }
            if run <= 0.0 {
                for _ in 0..count.min(self.points.len()) {
                    f(None);
                }
                return;
            }
            for c in cdf.iter_mut().take(self.list.len()) {
                *c /= run;
            }
        }
        for p in self.points.iter().take(count) {
            let u: [f64; 3] = std::array::from_fn(|k| (p[k] + shift[k]).fract());
            let (k, prob) = if local {
                let k = cdf[..self.list.len()]
                    .partition_point(|&c| c <= u[0])
                    .min(self.list.len() - 1);
                (k, cdf[k] - if k > 0 { cdf[k - 1] } else { 0.0 })
            } else {
                let k = self.cdf.partition_point(|&c| c <= u[0]).min(self.list.len() - 1);
                (k, self.prob[k])
            };
            let v = corners(k);
            let e = &self.list[k];
            f(
                sample_triangle(&v, prob, xd, n.as_dvec3(), [u[1], u[2]]).map(|(y, weight, b)| {
                    let l = if e.texture == NONE {
                        e.radiance
                    } else {
                        textured(e, b[0], b[1])
                    };
                    EmitterSample {
                        value: (l.as_dvec3() * weight).as_vec3(),
                        to_point: y.as_vec3() - o,
                    }
                }),
            );
        }
    }
}

/// One sample of triangle `v` (world corners, emitting from its front, picked with
/// probability `prob`) seen from `x` (normal `n`): the point sampled, the geometry term
/// over the sampling density (what multiplies the radiance there), and the point's
/// barycentrics (where a texture is read).
fn sample_triangle(v: &[DVec3; 3], prob: f64, x: DVec3, n: DVec3, u: [f64; 2]) -> Option<(DVec3, f64, [f32; 2])> {
    if prob <= 0.0 {
        return None;
    }
    let cross = (v[1] - v[0]).cross(v[2] - v[0]);
    let ne = cross.try_normalize()?;
    if ne.dot(x - v[0]) <= 0.0 {
        return None;
    }
    // Below `SPHERICAL_MIN` steradians, a point by area: the 1/r² that makes area
    // sampling noisy near an emitter varies little over a triangle this small, and the
    // spherical construction's angle sums lose their precision in single precision (the
    // kernels' twin).
    let spherical = if solid_angle(x, v) >= SPHERICAL_MIN {
        spherical_triangle(x, v, u)
    } else {
        None
    };
    let (y, weight, b) = match spherical {
        // Uniform in the solid angle: 1/pdf = Ω; the point where the direction meets
        // the triangle's plane.
        Some((w, omega)) => {
            let t = ne.dot(v[0] - x) / ne.dot(w);
            if t.is_nan() || t <= 0.0 || !t.is_finite() {
                return None;
            }
            let c = n.dot(w);
            if c <= 0.0 {
                return None;
            }
            let y = x + w * t;
            (y, c * omega / prob, barycentrics(v, cross, y))
        }
        // A triangle too small for the spherical construction: a point by area.
        None => {
            let (b1, b2) = uniform_triangle(Vec2::new(u[0] as f32, u[1] as f32));
            let y = v[0] + (v[1] - v[0]) * b1 as f64 + (v[2] - v[0]) * b2 as f64;
            let w = y - x;
            let d2 = w.length_squared();
            let wn = w / d2.sqrt();
            let (cx, ce) = (n.dot(wn), -ne.dot(wn));
            if d2.is_nan() || d2 <= 0.0 || cx <= 0.0 || ce <= 0.0 {
                return None;
            }
            (y, cx * ce / d2 * 0.5 * cross.length() / prob, [b1, b2])
        }
    };
    Some((y, weight, b))
}

/// The barycentrics `(b1, b2)` of a point `y` in the plane of triangle `v` (`cross` its
/// edges' cross product), brought into the triangle.
fn barycentrics(v: &[DVec3; 3], cross: DVec3, y: DVec3) -> [f32; 2] {
    let (e1, e2, p) = (v[1] - v[0], v[2] - v[0], y - v[0]);
    let n2 = cross.length_squared();
    let b1 = (p.cross(e2).dot(cross) / n2).clamp(0.0, 1.0);
    let b2 = (e1.cross(p).dot(cross) / n2).clamp(0.0, 1.0 - b1);
    [b1 as f32, b2 as f32]
}

/// Triangles subtending less than this solid angle (sr) are sampled by area.
pub const SPHERICAL_MIN: f64 = crate::constants::SPHERICAL_MIN as f64;

/// Up to this many emitting triangles, each receiving point weighs them by the solid
/// angle they subtend there.
pub const LOCAL_WEIGHTS: usize = crate::constants::LOCAL_WEIGHTS as usize;

/// Solid angle of triangle `v` seen from `x` (Van Oosterom & Strackee 1983).
pub fn solid_angle(x: DVec3, v: &[DVec3; 3]) -> f64 {
    let [a, b, c] = v.map(|p| p - x);
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let num = a.dot(b.cross(c)).abs();
    let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * num.atan2(den)
}

/// `π − 2 asin` / `2 asin` form of the angle between unit vectors (accurate near 0 and π).
fn angle_between(a: DVec3, b: DVec3) -> f64 {
    if a.dot(b) < 0.0 {
        std::f64::consts::PI - 2.0 * ((a + b).length() / 2.0).min(1.0).asin()
    } else {
        2.0 * ((b - a).length() / 2.0).min(1.0).asin()
    }
}

/// A direction uniform within the spherical triangle that triangle `v` subtends at `x`,
/// and that solid angle (Arvo 1995; pbrt-v4 `SampleSphericalTriangle`); `None` when the
/// triangle is too small or edge-on for it.
pub fn spherical_triangle(x: DVec3, v: &[DVec3; 3], u: [f64; 2]) -> Option<(DVec3, f64)> {
    use std::f64::consts::PI;
    let [a, b, c] = v.map(|p| (p - x).normalize_or_zero());
    let (nab, nbc, nca) = (a.cross(b), b.cross(c), c.cross(a));
    if nab.length_squared() < 1e-24 || nbc.length_squared() < 1e-24 || nca.length_squared() < 1e-24 {
        return None;
    }
    let (nab, nbc, nca) = (nab.normalize(), nbc.normalize(), nca.normalize());
    let alpha = angle_between(nab, -nca);
    let beta = angle_between(nbc, -nab);
    let gamma = angle_between(nca, -nbc);
    let a_pi = alpha + beta + gamma;
    let area = a_pi - PI;
    if area.is_nan() || area <= 1e-9 {
        return None;
    }
    let ap_pi = PI + u[0] * (a_pi - PI);
    let (cos_alpha, sin_alpha) = (alpha.cos(), alpha.sin());
    let sin_phi = ap_pi.sin() * cos_alpha - ap_pi.cos() * sin_alpha;
    let cos_phi = ap_pi.cos() * cos_alpha + ap_pi.sin() * sin_alpha;
    let k1 = cos_phi + cos_alpha;
    let k2 = sin_phi - sin_alpha * a.dot(b);
    let cos_bp = ((k2 + (k2 * cos_phi - k1 * sin_phi) * cos_alpha) / ((k2 * sin_phi + k1 * cos_phi) * sin_alpha))
        .clamp(-1.0, 1.0);
    let sin_bp = (1.0 - cos_bp * cos_bp).max(0.0).sqrt();
    let cp = cos_bp * a + sin_bp * (c - c.dot(a) * a).try_normalize()?;
    let cos_t = 1.0 - u[1] * (1.0 - cp.dot(b));
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let w = cos_t * b + sin_t * (cp - cp.dot(b) * b).try_normalize()?;
    w.is_finite().then_some((w, area))
}

/// Mean and standard error of the mean of `n` samples from their sums.
pub fn mean_and_error(sum: DVec3, sum2: DVec3, n: usize) -> (Vec3, Vec3) {
    let nf = n.max(1) as f64;
    let mean = sum / nf;
    let var = if n > 1 {
        ((sum2 / nf - mean * mean) * (nf / (nf - 1.0))).max(DVec3::ZERO)
    } else {
        DVec3::ZERO
    };
    (mean.as_vec3(), (var / nf).map(f64::sqrt).as_vec3())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Directions from the spherical construction hit the triangle, cover it evenly (the
    /// fraction in a sub-triangle is its share of the solid angle), and its area is the
    /// closed-form solid angle.
    #[test]
    fn spherical_triangle_samples_the_solid_angle() {
        let x = DVec3::new(0.1, -0.2, 0.0);
        let v = [
            DVec3::new(-1.0, 0.3, 1.0),
            DVec3::new(2.0, 0.0, 1.5),
            DVec3::new(0.2, 1.5, 0.7),
        ];
        let mid = (v[0] + v[1]) * 0.5;
        let sub = [v[0], mid, v[2]];
        let ne = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        let (mut inside, mut in_sub, n) = (0, 0, 20_000);
        for i in 0..n {
            let u = [radical_inverse(i + 1, 2), radical_inverse(i + 1, 3)];
            let (w, omega) = spherical_triangle(x, &v, u).expect("a proper triangle");
            assert!((omega - solid_angle(x, &v)).abs() < 1e-9 * omega.max(1.0), "{omega}");
            let t = ne.dot(v[0] - x) / ne.dot(w);
            let y = x + w * t;
            let inside_of = |p: &[DVec3; 3]| {
                let s = |a: DVec3, b: DVec3| (b - a).cross(y - a).dot(ne);
                s(p[0], p[1]) >= -1e-9 && s(p[1], p[2]) >= -1e-9 && s(p[2], p[0]) >= -1e-9
            };
            inside += inside_of(&v) as usize;
            in_sub += inside_of(&sub) as usize;
        }
        assert_eq!(inside, n as usize);
        let share = solid_angle(x, &sub) / solid_angle(x, &v);
        let got = in_sub as f64 / n as f64;
        assert!((got - share).abs() < 0.01, "{got} vs {share}");
        // Edge-on: no construction (the caller samples by area).
        assert!(spherical_triangle(
            DVec3::new(0.0, 0.0, 1.0),
            &v.map(|p| DVec3::new(p.x, p.y, 1.0)),
            [0.5, 0.5]
        )
        .is_none());
    }
}
