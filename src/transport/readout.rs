//! Reading the solved indirect irradiance at output points (probes, pixels; `ALGORITHM.md`
//! §6): the basis evaluated at the point (exact reconstruction on the output level), or a
//! final gather that casts `final_gather` cosine-distributed rays from the point and takes,
//! at each hit `y`, `ρ(y) (E_d(y) + E_ind(y))` with `E_d` exact by shadow rays and `E_ind`
//! read from the basis at `y`. The final gather makes the last hop exact up to Monte Carlo
//! noise: the interpolation of the basis across the receiver (over a column base, under an
//! arch, across a shadow edge) no longer decides the answer, only the smoothed light that
//! arrives from one bounce further away.

use glam::{Vec2, Vec3};

use crate::geom::rng::hash2;
use crate::geom::sampling::{cosine_direction, halton_table, integral_rotation, onb};
use crate::geom::Ray;
use crate::hierarchy::Hierarchy;
use crate::params::SolverParams;
use crate::scene::{Scene, Surface};
use crate::transport::estimator::Estimator;
use crate::transport::Solution;

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
        let mut est = Estimator::default();
        for &u in &self.halton {
            let d = cosine_direction(n, t, b, u, phi0);
            let Some(hit) = self.scene.intersect(&Ray { o, d }, f32::INFINITY) else {
                continue;
            };
            let s = self.scene.surface(&hit, d);
            if s.albedo.max_element() <= 0.0 {
                continue;
            }
            let e = self.scene.direct(s.p, s.n) + self.basis(&s);
            est.add(s.albedo * e);
        }
        let g = est.finish(self.halton.len());
        Read {
            mean: g.mean,
            std_err: g.std_err,
        }
    }
}
