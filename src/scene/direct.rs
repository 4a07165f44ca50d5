//! Direct light: what the lights, the emitting surfaces and the sky give a surface point,
//! and what a surface emits.

use glam::{Vec2, Vec3};

use super::{emitter, light, sky, Scene, Surface};
use crate::geom::Ray;

impl Scene {
    /// Whether the side `n` of the surface point `p` can receive light: it is lit directly,
    /// or one of 64 cosine-distributed rays from it reaches a reflecting surface that is (so
    /// that the first bounce can bring light there). A side that neither test finds (inside a
    /// closed solid, the back of a wall of a closed room) is no receiver.
    pub fn receives_light(&self, p: Vec3, n: Vec3, rng: &mut crate::geom::rng::Rng) -> bool {
        if self.direct(p, n).max_element() > 0.0 {
            return true;
        }
        let (t, b) = crate::geom::sampling::onb(n);
        let o = self.offset(p, n);
        (0..64).any(|_| {
            let d = crate::geom::sampling::cosine_direction(n, t, b, Vec2::new(rng.next_f32(), rng.next_f32()), 0.0);
            self.intersect(&Ray { o, d }, f32::INFINITY).is_some_and(|hit| {
                let s = self.surface(&hit, d);
                s.albedo.max_element() > 0.0 && self.direct(s.p, s.n).max_element() > 0.0
            })
        })
    }

    /// Direct irradiance at a world-space point `(x, n)` (`ALGORITHM.md` §2): every light
    /// exactly, each with a shadow ray, and the emitting surfaces estimated with
    /// `emitter_samples` shadow rays.
    pub fn direct(&self, x: Vec3, n: Vec3) -> Vec3 {
        self.direct_with_error(x, n).0
    }

    /// [`Scene::direct`] and its standard error (the emitters' sampling; lights are exact).
    pub fn direct_with_error(&self, x: Vec3, n: Vec3) -> (Vec3, Vec3) {
        self.direct_with_samples(x, n, self.emitters.samples())
    }

    /// [`Scene::direct_with_error`] with `samples` emitter and sky samples (at most
    /// [`emitter::Emitters::most`]): a probe's direct light, which takes as many as its
    /// final gather (`ALGORITHM.md` §2.2).
    pub fn direct_with_samples(&self, x: Vec3, n: Vec3, samples: usize) -> (Vec3, Vec3) {
        let (mut e, mut se) = (Vec3::ZERO, Vec3::ZERO);
        self.direct_sources(x, n, samples, emitter::point_seed(x, n), |_, v, s| {
            e += v;
            se += s;
        });
        (e, se)
    }

    /// [`Scene::direct`] with one emitter sample: the direct light at a gathering ray's
    /// hit or a reference path's vertex, whose means average many such estimates.
    pub fn direct_one(&self, x: Vec3, n: Vec3) -> Vec3 {
        let mut e = Vec3::ZERO;
        self.direct_sources(x, n, 1, emitter::point_seed(x, n), |_, v, _| e += v);
        e
    }

    /// Direct irradiance from the sources `which` only (indexed as [`Scene::sources`]).
    pub fn direct_from(&self, x: Vec3, n: Vec3, which: &[bool]) -> Vec3 {
        let mut e = Vec3::ZERO;
        self.direct_each(x, n, |i, v| {
            if which[i] {
                e += v
            }
        });
        e
    }

    /// [`Scene::direct_from`] with the sample sets shifted by `seed` (an image sample's
    /// [`emitter::pixel_seed`]).
    pub fn direct_from_seeded(&self, x: Vec3, n: Vec3, which: &[bool], seed: u64) -> Vec3 {
        let mut e = Vec3::ZERO;
        self.direct_sources(x, n, self.emitters.samples(), seed, |i, v, _| {
            if which[i] {
                e += v
            }
        });
        e
    }

    /// [`Scene::direct`] with the sample sets shifted by `seed` (a gather ray's hit of an
    /// image sample: [`emitter::pixel_seed`]).
    pub fn direct_seeded(&self, x: Vec3, n: Vec3, seed: u64) -> Vec3 {
        let mut e = Vec3::ZERO;
        self.direct_sources(x, n, self.emitters.samples(), seed, |_, v, _| e += v);
        e
    }

    /// Light sources: the lights, then the emitting surfaces as one more if there are any,
    /// then the sky if there is one.
    pub fn sources(&self) -> usize {
        self.lights.len() + self.emitters.any() as usize + self.sky.is_some() as usize
    }

    /// Calls `f(source index, irradiance)` for each source that reaches `(x, n)`
    /// ([`Scene::sources`]; the emitters with `emitter_samples` shadow rays).
    pub fn direct_each(&self, x: Vec3, n: Vec3, mut f: impl FnMut(usize, Vec3)) {
        self.direct_sources(x, n, self.emitters.samples(), emitter::point_seed(x, n), |i, v, _| {
            f(i, v)
        });
    }

    /// [`Scene::direct_each`] with each source's standard error (zero for the lights).
    pub fn direct_each_with_error(&self, x: Vec3, n: Vec3, f: impl FnMut(usize, Vec3, Vec3)) {
        self.direct_sources(x, n, self.emitters.samples(), emitter::point_seed(x, n), f);
    }

    /// [`Scene::direct_each_with_error`] with the sample sets shifted by `seed` (a node's
    /// [`emitter::node_seed`]: the GPU kernels draw the same samples).
    pub fn direct_each_seeded(&self, x: Vec3, n: Vec3, seed: u64, f: impl FnMut(usize, Vec3, Vec3)) {
        self.direct_sources(x, n, self.emitters.samples(), seed, f);
    }

    /// [`Scene::direct_one`] with the sample shifted by `seed` (a gathering ray's
    /// [`emitter::hit_seed`]).
    pub fn direct_one_seeded(&self, x: Vec3, n: Vec3, seed: u64) -> Vec3 {
        let mut e = Vec3::ZERO;
        self.direct_sources(x, n, 1, seed, |_, v, _| e += v);
        e
    }

    /// [`Scene::direct_each`] with `samples` emitter samples, and each source's standard
    /// error.
    fn direct_sources(&self, x: Vec3, n: Vec3, samples: usize, seed: u64, mut f: impl FnMut(usize, Vec3, Vec3)) {
        let o = self.offset(x, n);
        for (i, l) in self.lights.iter().enumerate() {
            if let Some(s) = light::light_sample(l, x, n, o) {
                let ray = Ray { o, d: s.to_light };
                if !self.occluded(&ray, s.tmax) {
                    f(i, s.irradiance, Vec3::ZERO);
                }
            }
        }
        if !self.emitters.any() && self.sky.is_none() {
            return;
        }
        let count = samples.min(self.emitters.most());
        if self.emitters.any() {
            let (mut sum, mut sum2) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
            self.emitters.for_each_sample(
                &self.tris,
                emitter::Receiver { x, n, o },
                seed,
                samples,
                |e, b1, b2| self.emitted_at(e.tri, b1, b2),
                |s| {
                    if let Some(s) = s {
                        let ray = Ray { o, d: s.to_point };
                        if !self.occluded(&ray, crate::constants::SHADOW_TMAX) {
                            let v = s.value.as_dvec3();
                            sum += v;
                            sum2 += v * v;
                        }
                    }
                },
            );
            let (mean, err) = emitter::mean_and_error(sum, sum2, count);
            if mean.max_element() > 0.0 {
                f(self.lights.len(), mean, err);
            }
        }
        let sky_index = self.lights.len() + self.emitters.any() as usize;
        match &self.sky {
            None => {}
            Some(sky::Sky::Constant(l)) => {
                // Cosine-weighted directions (2-D Halton, shifted per point): each one that
                // leaves the scene adds π L_sky (1/pdf = π/cos), a Bernoulli mean.
                let (t, b) = crate::geom::sampling::onb(n);
                let shift = emitter::shift(seed ^ 0x5c1e_5c1e);
                let mut open = 0usize;
                for k in 0..count {
                    let h = emitter::halton2(k as u64 + 1);
                    let u = Vec2::new((h[0] + shift[0]).fract() as f32, (h[1] + shift[1]).fract() as f32);
                    let d = crate::geom::sampling::cosine_direction(n, t, b, u, 0.0);
                    open += !self.occluded(&Ray { o, d }, f32::INFINITY) as usize;
                }
                let nf = count.max(1) as f32;
                let p = open as f32 / nf;
                let se = if count > 1 {
                    (p * (1.0 - p) / (nf - 1.0)).sqrt()
                } else {
                    0.0
                };
                if open > 0 {
                    let pi = std::f32::consts::PI;
                    f(sky_index, *l * pi * p, *l * pi * se);
                }
            }
            Some(sky::Sky::Map(m)) => {
                // Directions (2-D Halton, shifted per point) from the even mixture of the
                // map's luminance and the cosine (the first number picks which, then is
                // reused): each that faces the point and leaves the scene adds
                // L cos / pdf with pdf the mixture's (the balance heuristic).
                let (t, b) = crate::geom::sampling::onb(n);
                let shift = emitter::shift(seed ^ 0x5c1e_5c1e);
                let (mut sum, mut sum2) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
                for k in 0..count {
                    let h = emitter::halton2(k as u64 + 1);
                    let u = [(h[0] + shift[0]).fract(), (h[1] + shift[1]).fract()];
                    let d = if u[0] < 0.5 {
                        match m.sample([2.0 * u[0], u[1]]) {
                            Some((d, _, _)) => d,
                            None => continue,
                        }
                    } else {
                        let v = Vec2::new((2.0 * u[0] - 1.0) as f32, u[1] as f32);
                        crate::geom::sampling::cosine_direction(n, t, b, v, 0.0)
                    };
                    let c = n.dot(d);
                    if c <= 0.0 {
                        continue;
                    }
                    let pdf = 0.5 * (m.pdf(d) + c as f64 / std::f64::consts::PI);
                    if !self.occluded(&Ray { o, d }, f32::INFINITY) {
                        let v = m.radiance(d).as_dvec3() * (c as f64 / pdf);
                        sum += v;
                        sum2 += v * v;
                    }
                }
                let (mean, err) = emitter::mean_and_error(sum, sum2, count);
                if mean.max_element() > 0.0 {
                    f(sky_index, mean, err);
                }
            }
        }
    }

    /// The sky's radiance seen along a ray of direction `d` that leaves the scene (zero
    /// without a sky).
    pub fn sky_radiance(&self, d: Vec3) -> Vec3 {
        self.sky.as_ref().map_or(Vec3::ZERO, |s| s.radiance(d))
    }

    /// The radiance a surface point sends toward the ray that found it by emitting: its
    /// material's `L_e` (at the hit's barycentrics `(b1, b2)` where it is textured) on an
    /// emitting triangle's front, zero elsewhere.
    pub fn emitted(&self, s: &Surface, b1: f32, b2: f32) -> Vec3 {
        if s.back {
            return Vec3::ZERO;
        }
        self.emitted_at(s.tri, b1, b2)
    }

    /// The radiance the front of global triangle `tri` emits at barycentrics `(b1, b2)`:
    /// its material's emission times its emission texture there, if it has one.
    pub fn emitted_at(&self, tri: u32, b1: f32, b2: f32) -> Vec3 {
        let m = self.tris[tri as usize].material as usize;
        let l = self.emission[m];
        let t = self.emission_textures[m];
        if t == crate::layout::NONE || l == Vec3::ZERO {
            return l;
        }
        l * super::texture::sample(
            &self.texels,
            &self.textures[t as usize],
            self.uv_at(tri, b1, b2),
            &self.srgb,
        )
    }
}
