//! Reading the solved indirect irradiance at output points (probes, pixels; `ALGORITHM.md`
//! §6): the basis evaluated at the point (exact reconstruction on the output level), or a
//! final gather that casts `final_gather` cosine-distributed rays from the point and takes,
//! at each hit `y`, `ρ(y) (E_d(y) + E_ind(y))` with `E_d` exact by shadow rays and `E_ind`
//! read from the basis at `y`. The final gather makes the last hop exact up to Monte Carlo
//! noise: the interpolation of the basis across the receiver (over a column base, under an
//! arch, across a shadow edge) no longer decides the answer, only the smoothed light that
//! arrives from one bounce further away.

use glam::{DVec3, Vec2, Vec3};

use crate::geom::rng::hash2;
use crate::geom::sampling::{cosine_direction, halton_table, integral_rotation, onb};
use crate::geom::Ray;
use crate::hierarchy::Hierarchy;
use crate::params::SolverParams;
use crate::scene::{Scene, Surface};
use crate::transport::Solution;

static DIAG: std::sync::LazyLock<std::sync::Mutex<std::fs::File>> = std::sync::LazyLock::new(|| std::sync::Mutex::new(std::fs::File::create(std::env::var("MESHRAD_DIAG").unwrap()).unwrap()));

/// A value and its standard error (zero for the basis read directly).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Read {
    pub mean: Vec3,
    pub std_err: Vec3,
}

/// How outputs read a solution.
pub struct Readout<'a> {
    scene: &'a Scene,
    h: &'a Hierarchy,
    sol: &'a Solution,
    level: u32,
    seed: u32,
    /// The final gather's directions (empty: read the basis).
    halton: Vec<Vec2>,
}

impl<'a> Readout<'a> {
    /// For probe points, as the parameters ask: the output level, and a final gather of
    /// `final_gather` rays (0: none).
    pub fn new(scene: &'a Scene, h: &'a Hierarchy, sol: &'a Solution, p: &SolverParams) -> Self {
        Self::with_rays(scene, h, sol, p, p.final_gather)
    }

    /// For pixels: a final gather of `final_gather_pixels` rays (0: none).
    pub fn for_pixels(scene: &'a Scene, h: &'a Hierarchy, sol: &'a Solution, p: &SolverParams) -> Self {
        Self::with_rays(scene, h, sol, p, p.final_gather_pixels)
    }

    /// With `rays` final-gather rays instead of the parameters' count.
    pub fn with_rays(scene: &'a Scene, h: &'a Hierarchy, sol: &'a Solution, p: &SolverParams, rays: u32) -> Self {
        Readout {
            scene,
            h,
            sol,
            level: p.output_level(),
            seed: p.seed,
            halton: if rays > 0 { halton_table(rays) } else { Vec::new() },
        }
    }

    /// Whether this readout gathers.
    pub fn gathers(&self) -> bool {
        !self.halton.is_empty()
    }

    /// Indirect irradiance at a world-space point `(x, n)` (a probe). The basis read is
    /// clamped at zero; so is every hit's reading in a gather.
    pub fn at(&self, x: Vec3, n: Vec3) -> Read {
        if self.gathers() {
            self.gather(x, n)
        } else {
            Read {
                mean: self
                    .sol
                    .indirect_at(self.scene, self.h, x, n, self.level)
                    .max(Vec3::ZERO),
                std_err: Vec3::ZERO,
            }
        }
    }

    /// Indirect irradiance at a surface a ray reached (a pixel). The basis read is raw:
    /// the image clamps and counts negative values.
    pub fn on_surface(&self, s: &Surface) -> Vec3 {
        if self.gathers() {
            self.gather(s.p, s.n).mean
        } else {
            self.sol
                .indirect_on(self.h, s.object as usize, s.p_obj, s.n_obj, self.level)
        }
    }

    /// The basis at a hit, in the hit object's space, clamped at zero.
    fn basis(&self, s: &Surface) -> Vec3 {
        self.sol
            .indirect_on(self.h, s.object as usize, s.p_obj, s.n_obj, self.level)
            .max(Vec3::ZERO)
    }

    /// The final gather at `(x, n)`. Its rotation is hashed from the point's coordinates,
    /// so a point gets the same rays whatever else is evaluated and in whatever order.
    fn gather(&self, x: Vec3, n: Vec3) -> Read {
        let key = hash2(hash2(x.x.to_bits(), x.y.to_bits()), x.z.to_bits());
        let phi0 = integral_rotation(self.seed ^ 0x0f1a_6a7e, key);
        let (t, b) = onb(n);
        let o = self.scene.offset(x, n);
        let mut sum = DVec3::ZERO;
        let mut sum2 = DVec3::ZERO;
        for &u in &self.halton {
            let d = cosine_direction(n, t, b, u, phi0);
            let Some(hit) = self.scene.intersect(&Ray { o, d }, f32::INFINITY) else {
                continue;
            };
            let s = self.scene.surface(&hit, d);
            if s.albedo.max_element() <= 0.0 {
                continue;
            }
            let nest: usize = std::env::var("MESHRAD_NEST").ok().and_then(|v| v.parse().ok()).unwrap_or(0);
            let e = if nest > 0 {
                // diagnostic: one-bounce irradiance at the hit by a nested gather
                let (t2, b2) = onb(s.n);
                let o2 = self.scene.offset(s.p, s.n);
                let tab = halton_table(nest as u32);
                let phi = integral_rotation(self.seed ^ 0x1234, hash2(s.p.x.to_bits(), s.p.y.to_bits() ^ s.p.z.to_bits()));
                let mut acc = Vec3::ZERO;
                for &u2 in &tab {
                    let d2 = cosine_direction(s.n, t2, b2, u2, phi);
                    if let Some(h2) = self.scene.intersect(&Ray { o: o2, d: d2 }, f32::INFINITY) {
                        let s2 = self.scene.surface(&h2, d2);
                        acc += s2.albedo * self.scene.direct(s2.p, s2.n);
                    }
                }
                let b1 = acc / nest as f32;
                let nested_at = |p: Vec3, nn: Vec3, m: u32| -> Vec3 {
                    let (t2, b2) = onb(nn);
                    let o2 = self.scene.offset(p, nn);
                    let tab = halton_table(m);
                    let mut acc = Vec3::ZERO;
                    for &u2 in &tab {
                        let d2 = cosine_direction(nn, t2, b2, u2, 0.37);
                        if let Some(h2) = self.scene.intersect(&Ray { o: o2, d: d2 }, f32::INFINITY) {
                            let s2 = self.scene.surface(&h2, d2);
                            acc += s2.albedo * self.scene.direct(s2.p, s2.n);
                        }
                    }
                    acc / m as f32
                };
                if std::env::var("MESHRAD_DIAG").is_ok() {
                    use std::io::Write;
                    let r = self.basis(&s);
                    let o = s.object as usize;
                    let l = self.level as usize;
                    let r5 = self.h.objects[o].radius[l];
                    let nd = self.h.nearest_same_side(o, l, s.p_obj, s.n_obj).map(|j| (glam::Vec3::from(self.h.nodes[j].pos) - s.p_obj).length() / r5).unwrap_or(-1.0);
                    let (_, w) = crate::transport::reconstruct::shepard_sums(self.h, o, l, s.p_obj, s.n_obj, &self.sol.values.indirect);
                    let mut nn = 0; self.h.for_each_weight(o, l, s.p_obj, s.n_obj, |_, _| nn += 1);
                    let mut best = (usize::MAX, 0.0f32);
                    self.h.for_each_weight(o, l, s.p_obj, s.n_obj, |j, w| if w > best.1 { best = (j, w) });
                    let (nodev, nodenest, hitnest, px, pn) = if nn > 0 && nn <= 4 {
                        let (xj, nj) = crate::transport::cpu::node_world(self.scene, self.h, best.0);
                        let v = self.sol.values.indirect[best.0].truncate();
                        let pp = crate::params::SolverParams { seed: self.seed, ..Default::default() };
                        let g = crate::transport::cpu::gather_integral(self.scene, self.h, &pp, &crate::geom::sampling::halton_table(512), &[], best.0, true);
                        let _ = (xj, nj);
                        ((s.albedo * v).dot(Vec3::ONE), (s.albedo * nested_at(xj, nj, 1024)).dot(Vec3::ONE), (s.albedo * g.mean).dot(Vec3::ONE), xj, nj)
                    } else { (0.0, 0.0, 0.0, Vec3::ZERO, Vec3::ZERO) };
                    let lin = crate::transport::reconstruct::linear(self.h, o, l, s.p_obj, s.n_obj, &self.sol.values.indirect).unwrap_or(Vec3::ZERO).max(Vec3::ZERO);
                    let line = format!("{} {} {} {} {} {} {} {} {} {} {} {} {} {} {} {} {} {} {} {} {} {}\n", x.x, x.y, x.z, o, (s.albedo*b1).dot(Vec3::ONE), (s.albedo*r).dot(Vec3::ONE), nd, w, nn, s.n.x, s.n.y, s.n.z, (s.albedo*lin).dot(Vec3::ONE), nodev, nodenest, hitnest, s.p.x, s.p.y, s.p.z, (px - s.p).length(), pn.dot(s.n), self.h.objects[o].radius[l]);
                    DIAG.lock().unwrap().write_all(line.as_bytes()).unwrap();
                }
                if std::env::var("MESHRAD_NEST_ONLY").is_ok() { b1 } else { self.scene.direct(s.p, s.n) + b1 }
            } else {
                self.scene.direct(s.p, s.n) + self.basis(&s)
            };
            let c = (s.albedo * e).as_dvec3();
            sum += c;
            sum2 += c * c;
        }
        let nf = self.halton.len() as f64;
        let mean = sum / nf;
        let var = if nf > 1.0 {
            ((sum2 / nf - mean * mean) * (nf / (nf - 1.0))).max(DVec3::ZERO)
        } else {
            DVec3::ZERO
        };
        Read {
            mean: mean.as_vec3(),
            std_err: (var / nf).as_vec3().map(f32::sqrt),
        }
    }
}
