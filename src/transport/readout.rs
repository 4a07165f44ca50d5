//! Reading the solved indirect irradiance at output points (probes, pixels; `ALGORITHM.md`
//! §6): the basis evaluated at the point (exact reconstruction on the output level), or a
//! final gather that casts `final_gather` cosine-distributed rays from the point and takes,
//! at each hit `y`, `ρ(y) (E_d(y) + E_ind(y))` with `E_d` exact by shadow rays and `E_ind`
//! read from the basis at `y`. The final gather makes the last hop exact up to Monte Carlo
//! noise: the interpolation of the basis across the receiver (over a column base, under an
//! arch, across a shadow edge) no longer decides the answer, only the smoothed light that
//! arrives from one bounce further away. A gather ray whose hit lies nearer than the
//! basis resolves hops on instead of reading it there (`short_hops`).

use glam::{Vec2, Vec3};

use crate::geom::rng::{hash2, hash_to_unit};
use crate::geom::sampling::{cosine_direction, halton_table, integral_rotation, onb};
use crate::geom::Ray;
use crate::hierarchy::poisson::Candidate;
use crate::hierarchy::{in_crevice, Hierarchy};
use crate::params::SolverParams;
use crate::scene::emitter::{pixel_key, pixel_seed};
use crate::scene::{Scene, Surface};
use crate::transport::cpu::node_world;
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
    /// Where the basis is read: the gather at hits where it is doubted (pixels only).
    doubt: Option<Doubt>,
    /// Most hops a gather ray continues where it lands nearer than the basis resolves
    /// (`SolverParams::short_hops`).
    short_hops: u32,
    /// The probes' basis read: the crevice distance in finest-level radii where a point
    /// in a crevice reads 0 (`SolverParams::basis_crevice`; 0: no test).
    crevice: f32,
    /// The probes' basis read takes only the nodes a segment from the point reaches
    /// (`SolverParams::basis_visibility`).
    visibility: bool,
}

/// A final gather at the pixel samples whose basis read cannot be trusted (`ALGORITHM.md`
/// §6, issue #33): fewer than `min_nodes` nodes support the read, or (absolute
/// hierarchies) their values spread by more than `max_spread` of the read.
struct Doubt {
    halton: Vec<Vec2>,
    min_nodes: u32,
    max_spread: f32,
    delta: bool,
    gathered: std::sync::atomic::AtomicU64,
    read: std::sync::atomic::AtomicU64,
}

impl<'a> Readout<'a> {
    /// For probe points, as the parameters ask: the output level, and a final gather of
    /// `final_gather` rays (0: none).
    pub fn new(scene: &'a Scene, h: &'a Hierarchy, sol: &'a Solution, p: &SolverParams) -> Self {
        Self::with_rays(scene, h, sol, p, p.final_gather)
    }

    /// For pixels: a final gather of `final_gather_pixels` rays (0: none); without it,
    /// the basis, and a gather of `doubt_gather` rays at the samples where the basis is
    /// doubted (`doubt_nodes`, `doubt_spread`; 0 rays: never).
    pub fn for_pixels(scene: &'a Scene, h: &'a Hierarchy, sol: &'a Solution, p: &SolverParams) -> Self {
        let mut r = Self::with_rays(scene, h, sol, p, p.final_gather_pixels);
        if r.halton.is_empty() && p.doubt_gather > 0 {
            r.doubt = Some(Doubt {
                halton: halton_table(p.doubt_gather),
                min_nodes: p.doubt_nodes,
                max_spread: p.doubt_spread,
                delta: p.variant.is_delta(),
                gathered: Default::default(),
                read: Default::default(),
            });
        }
        r
    }

    /// Pixel samples that read the basis and that gathered where it was doubted (both 0
    /// without [`Readout::for_pixels`]'s doubt).
    pub fn doubt_counts(&self) -> (u64, u64) {
        use std::sync::atomic::Ordering::Relaxed;
        self.doubt
            .as_ref()
            .map_or((0, 0), |d| (d.read.load(Relaxed), d.gathered.load(Relaxed)))
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
            doubt: None,
            short_hops: p.short_hops,
            crevice: if p.basis_crevice { p.crevice_distance } else { 0.0 },
            visibility: p.basis_visibility,
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
                mean: self.basis_at(x, n).max(Vec3::ZERO),
                std_err: Vec3::ZERO,
            }
        }
    }

    /// The probes' basis read at a world-space point `(x, n)` (`final_gather = 0`;
    /// `ALGORITHM.md` §6): the exact reconstruction on the output level of the object that
    /// answers there ([`Solution::locate`]), with two tests of the point's own
    /// surroundings that the hierarchy's weights cannot make. Where the crevice test of
    /// the build (§3.3) calls the point a crevice, the read is 0: the build put no node
    /// there because no light enters, and the nodes that would answer lie on the open
    /// surface beside it. And a node counts only if the segment from the point to the
    /// node, each lifted a tenth of the support along its normal, meets no surface: a
    /// point inside a board or behind a moulding's face does not take the light of the
    /// face in front of it. The lift keeps curved surfaces' own chords clear (the
    /// weight's normal term ends a node's reach on a sphere before the chord sinks 5 % of
    /// the support into it). Where the output level has no node at the point (a hole),
    /// the next coarser level answers, as in [`reconstruct::exact`]; where it has nodes
    /// and every one is hidden, the point is sealed off from the light they hold and
    /// reads 0 (a coarser level's longer lift would step over the board that hides
    /// them).
    fn basis_at(&self, x: Vec3, n: Vec3) -> Vec3 {
        let Some((o, p, nn)) = self.sol.locate(self.scene, self.h, x, n, self.level) else {
            return Vec3::ZERO;
        };
        if self.crevice > 0.0 {
            let obj = &self.scene.objects[o];
            let finest = self.h.levels as usize - 1;
            let d_min = self.crevice * obj.transform.scale * self.h.objects[o].radius[finest];
            let index = hash2(x.x.to_bits() ^ x.y.to_bits().rotate_left(11), x.z.to_bits());
            if in_crevice(self.scene, o, &Candidate { pos: p, normal: nn }, d_min, index) {
                return Vec3::ZERO;
            }
        }
        if !self.visibility {
            return self.sol.indirect_on(self.h, o, p, nn, self.level);
        }
        let scale = self.scene.objects[o].transform.scale;
        let values = &self.sol.values.indirect;
        let level_read = |l: usize| {
            let lift = 0.1 * scale * self.h.support(o, l);
            let from = x + n * lift;
            let (mut sum, mut wsum, mut any) = (Vec3::ZERO, 0.0f32, false);
            self.h.for_each_read_weight(o, l, p, nn, |j, w| {
                any = true;
                let (xj, nj) = node_world(self.scene, self.h, j);
                let to = xj + nj * lift;
                let d = to - from;
                let len = d.length();
                if len > 0.0 && self.scene.occluded(&Ray { o: from, d: d / len }, len) {
                    return;
                }
                sum += values[j].truncate() * w;
                wsum += w;
            });
            // None: a hole; Some(0): every node hidden.
            any.then(|| if wsum > 0.0 { sum / wsum } else { Vec3::ZERO })
        };
        let l = self.level as usize;
        if self.sol.variant.is_delta() {
            (0..=l).filter_map(level_read).fold(Vec3::ZERO, |a, v| a + v)
        } else {
            (0..=l).rev().find_map(level_read).unwrap_or(Vec3::ZERO)
        }
    }

    /// Indirect irradiance at a surface a ray of image sample `sample` reached (a pixel's;
    /// its gathers are rotated and their emitter samples shifted by `sample`, as the
    /// `image` kernel does). The basis read is raw: the image clamps and counts negative
    /// values.
    pub fn on_surface(&self, s: &Surface, sample: u64) -> Vec3 {
        let key = Some(sample);
        if self.gathers() {
            self.gather_with(s.p, s.n, &self.halton, key).mean
        } else if let Some(d) = &self.doubt {
            use std::sync::atomic::Ordering::Relaxed;
            match self.trusted_read(d, s.object as usize, s.p_obj, s.n_obj) {
                Some(read) => {
                    d.read.fetch_add(1, Relaxed);
                    read
                }
                None => {
                    d.gathered.fetch_add(1, Relaxed);
                    self.gather_with(s.p, s.n, &d.halton, key).mean
                }
            }
        } else {
            self.sol
                .indirect_on(self.h, s.object as usize, s.p_obj, s.n_obj, self.level)
        }
    }

    /// The basis read on object `o` at `(p_obj, n_obj)` where it is trusted; `None` where
    /// it is doubted: fewer than `min_nodes` nodes support it, or (absolute hierarchies)
    /// their values spread by more than `max_spread` of the read.
    fn trusted_read(&self, d: &Doubt, o: usize, p_obj: Vec3, n_obj: Vec3) -> Option<Vec3> {
        let l = self.level as usize;
        let (mut count, mut lo, mut hi) = (0u32, f32::INFINITY, f32::NEG_INFINITY);
        let (mut sum, mut wsum) = (Vec3::ZERO, 0.0f32);
        let values = &self.sol.values.indirect;
        // The support and (absolute hierarchies) the read itself in one pass: the
        // Shepard sums of `reconstruct::shepard_sums`, in its order.
        self.h.for_each_read_weight(o, l, p_obj, n_obj, |j, w| {
            count += 1;
            let v = values[j];
            sum += v.truncate() * w;
            wsum += w;
            let y = (v.x + v.y + v.z) / 3.0;
            lo = lo.min(y);
            hi = hi.max(y);
        });
        let read = if !d.delta && wsum > 0.0 {
            sum / wsum
        } else {
            self.sol.indirect_on(self.h, o, p_obj, n_obj, self.level)
        };
        let mean = (read.x + read.y + read.z) / 3.0;
        let spread = !d.delta && count > 0 && hi - lo > d.max_spread * mean.max(0.0);
        (count >= d.min_nodes && !spread).then_some(read)
    }

    /// For reading world-space points as the image reads its pixels (`probe --read
    /// image`): [`Readout::for_pixels`] with each gather as many rays as a pixel's `spp`
    /// samples take in all (`final_gather_pixels` or `doubt_gather`, × `spp`).
    pub fn for_image_points(scene: &'a Scene, h: &'a Hierarchy, sol: &'a Solution, p: &SolverParams) -> Self {
        let spp = scene.camera.spp.max(1);
        let mut q = p.clone();
        q.final_gather_pixels = q.final_gather_pixels.saturating_mul(spp).min(1 << 16);
        q.doubt_gather = q.doubt_gather.saturating_mul(spp).min(1 << 16);
        Self::for_pixels(scene, h, sol, &q)
    }

    /// Indirect irradiance at a world-space point `(x, n)` as a pixel of the image that
    /// saw it would read it ([`Readout::for_image_points`]): the basis on the object with
    /// the most basis weight there ([`Solution::locate`]) where it is trusted, and a gather
    /// where it is doubted (or everywhere, with `final_gather_pixels`); clamped at zero.
    pub fn image_at(&self, x: Vec3, n: Vec3) -> Vec3 {
        if self.gathers() {
            return self.gather(x, n).mean.max(Vec3::ZERO);
        }
        let Some((o, p_obj, n_obj)) = self.sol.locate(self.scene, self.h, x, n, self.level) else {
            return Vec3::ZERO;
        };
        let read = match &self.doubt {
            Some(d) => match self.trusted_read(d, o, p_obj, n_obj) {
                Some(read) => read,
                None => self.gather_with(x, n, &d.halton, None).mean,
            },
            None => self.sol.indirect_on(self.h, o, p_obj, n_obj, self.level),
        };
        read.max(Vec3::ZERO)
    }

    /// The basis at a hit, in the hit object's space, clamped at zero.
    fn basis(&self, s: &Surface) -> Vec3 {
        self.sol
            .indirect_on(self.h, s.object as usize, s.p_obj, s.n_obj, self.level)
            .max(Vec3::ZERO)
    }

    /// The indirect irradiance at a gather hit `s` that a hop of length `t` reached: the
    /// basis, unless the hop is shorter than the output level's support on the hit's
    /// object. Then the hit lies in a gap the basis does not resolve (the light between a
    /// panel and its wall, inside a board, at the bottom of a crevice: nodes a support
    /// away, on the open side, would answer for it), and the path takes one more
    /// cosine-distributed hop instead, `ρ (E_d + E_ind)` at its hit (`E_d` with one
    /// emitter and sky sample), up to `short_hops` hops (`ALGORITHM.md` §6). A path that
    /// leaves the scene or meets a black surface carries nothing, as in the gather itself.
    /// The `image` kernel's `past_short_hops` is its twin, as a loop.
    fn past_short_hops(&self, s: &Surface, t: f32, key: u32, depth: u32) -> Vec3 {
        let o = s.object as usize;
        let support = self.scene.objects[o].transform.scale * self.h.support(o, self.level as usize);
        if depth >= self.short_hops || t >= support {
            return self.basis(s);
        }
        let u = Vec2::new(
            hash_to_unit(hash2(key, 2 * depth + 1)),
            hash_to_unit(hash2(key, 2 * depth + 2)),
        );
        let (tb, bb) = onb(s.n);
        let d = cosine_direction(s.n, tb, bb, u, 0.0);
        let ray = Ray {
            o: self.scene.offset(s.p, s.n),
            d,
        };
        let Some(hit) = self.scene.intersect(&ray, f32::INFINITY) else {
            return Vec3::ZERO;
        };
        let z = self.scene.surface(&hit, d);
        if z.albedo.max_element() <= 0.0 {
            return Vec3::ZERO;
        }
        // One emitter and sky sample, as at a gathering ray's hit: the gather's mean
        // averages many such paths.
        let direct = self
            .scene
            .direct_one_seeded(z.p, z.n, (u64::from(key) << 32) | u64::from(depth + 1));
        z.albedo * (direct + self.past_short_hops(&z, hit.t, key, depth + 1))
    }

    /// The final gather at `(x, n)`. Its rotation is hashed from the point's coordinates,
    /// so a point gets the same rays whatever else is evaluated and in whatever order.
    fn gather(&self, x: Vec3, n: Vec3) -> Read {
        self.gather_with(x, n, &self.halton, None)
    }

    /// [`Readout::gather`] over the directions `halton`; for an image sample `sample`, its
    /// rotation and the direct light's samples at its hits come from the sample's index
    /// (`emitter::pixel_key`, `emitter::pixel_seed`) instead of the point.
    fn gather_with(&self, x: Vec3, n: Vec3, halton: &[Vec2], sample: Option<u64>) -> Read {
        let key = match sample {
            Some(k) => pixel_key(k),
            None => hash2(hash2(x.x.to_bits(), x.y.to_bits()), x.z.to_bits()),
        };
        let phi0 = integral_rotation(self.seed ^ 0x0f1a_6a7e, key);
        let (t, b) = onb(n);
        let o = self.scene.offset(x, n);
        let mut est = Estimator::default();
        for (r, &u) in halton.iter().enumerate() {
            let d = cosine_direction(n, t, b, u, phi0);
            let Some(hit) = self.scene.intersect(&Ray { o, d }, f32::INFINITY) else {
                continue;
            };
            let s = self.scene.surface(&hit, d);
            if s.albedo.max_element() <= 0.0 {
                continue;
            }
            let direct = match sample {
                Some(k) => self.scene.direct_seeded(s.p, s.n, pixel_seed(k, r as u32 + 1)),
                None => self.scene.direct(s.p, s.n),
            };
            let indirect = if self.short_hops > 0 {
                self.past_short_hops(&s, hit.t, hash2(key, r as u32), 0)
            } else {
                self.basis(&s)
            };
            est.add(s.albedo * (direct + indirect));
        }
        let g = est.finish(halton.len());
        Read {
            mean: g.mean,
            std_err: g.std_err,
        }
    }
}
