//! The levels' density (paper §3, `ALGORITHM.md` §3.2): each object's reachable area, the
//! world-space Poisson radius of each level, how many candidates each level throws darts
//! from, and the candidate pools (`poisson::candidates`) that serve them all.

use super::poisson::{self, Candidate};
use crate::error::{Error, Result};
use crate::params::{SolverParams, FREE_PATH_MAX_RAISE};
use crate::scene::Scene;

/// The levels' density: each object's reachable area (world units²) and the world-space
/// Poisson radius of each level (§3: `r_0 = sqrt(0.7 A / N_0)`, halved per level).
pub(super) struct Density {
    pub(super) areas: Vec<f64>,
    pub(super) radius: Vec<f64>,
    /// The scene's mean free path ([`free_path`]; `None` when `free_path` is off or no
    /// ray met a surface).
    pub(super) free_path: Option<f64>,
    /// The coarsest level's node count the radius gives (`coarsest`, or more when the
    /// mean free path raised it).
    pub(super) coarsest: f64,
}

impl Density {
    /// Checks that light reaches some surface and that the candidate cap leaves the finest
    /// level its density (else the solve would lose light silently).
    pub(super) fn plan(scene: &Scene, p: &SolverParams, sides: &[bool]) -> Result<Density> {
        let m = p.levels as usize;
        let areas: Vec<f64> = scene
            .objects
            .iter()
            .map(|o| {
                let r = o.tri_offset as usize..(o.tri_offset + o.tri_count) as usize;
                let s = o.transform.scale as f64;
                poisson::reachable_area(&scene.tris[r.clone()], &sides[r.start * 2..r.end * 2]) * s * s
            })
            .collect();
        let area: f64 = areas.iter().sum();
        if area <= 0.0 {
            return Err(Error::SceneValue {
                path: scene.path.clone(),
                key: "light".into(),
                message: format!(
                    "none of the {} light paths traced (solver key reach_paths) reached a surface: check the \
                     lights' positions and directions",
                    p.reach_paths
                ),
            });
        }
        let mut r0 = (0.7 * area / p.coarsest as f64).sqrt();
        let free = (p.free_path > 0.0)
            .then(|| free_path(scene, p, sides, &areas, FREE_PATH_RAYS))
            .flatten();
        if let Some(fp) = free {
            let floor = r0 / FREE_PATH_MAX_RAISE.sqrt();
            r0 = r0.min(p.free_path as f64 * fp).max(floor);
        }
        let d = Density {
            radius: (0..m).map(|l| r0 / (1u64 << l) as f64).collect(),
            free_path: free,
            coarsest: 0.7 * area / (r0 * r0),
            areas,
        };
        for (i, &a) in d.areas.iter().enumerate() {
            let need = d.expected(a, m - 1).ceil();
            if need > p.max_candidates as f64 {
                return Err(Error::param(
                    "max_candidates",
                    format!(
                        "{} caps the candidate pool of object {i} ({}) below the {need} nodes its finest level \
                         needs; raise it, or lower coarsest or levels",
                        p.max_candidates, scene.objects[i].name
                    ),
                ));
            }
        }
        Ok(d)
    }

    /// Nodes a Poisson-disk set of level `l` holds on area `a`.
    fn expected(&self, a: f64, l: usize) -> f64 {
        0.7 * a / (self.radius[l] * self.radius[l])
    }

    /// Candidates of object `o`'s pool (of `pool` in all) that level `l` throws darts
    /// from: `candidate_factor` times the level's expected count, at least 64.
    pub(super) fn take(&self, p: &SolverParams, o: usize, l: usize, pool: usize) -> usize {
        let want = (p.candidate_factor as f64 * self.expected(self.areas[o], l)).ceil() as usize;
        want.clamp(pool.min(64), pool)
    }
}

/// Rays per gathering integral where the mean free path raised the node count `raise`-fold
/// (`ALGORITHM.md` §3.2): `rays / raise`, rounded up to a multiple of 32 and at least 32
/// (or `rays`, if fewer), so that a level's integrals trace about the rays they would at
/// the asked density. A read averages about seven nodes' integrals, so `raise`-fold
/// denser nodes with `1/raise` of the rays each carry about the same noise over the same
/// area; what the density buys is resolution between surfaces.
pub(crate) fn traded_rays(rays: u32, raise: f64) -> u32 {
    if raise.is_nan() || raise <= 1.0 {
        return rays;
    }
    let r = ((rays as f64 / raise / 32.0).ceil() as u32).saturating_mul(32);
    r.clamp(rays.min(32), rays)
}

/// Rays [`free_path`] traces (its standard error is then about 1 % of the mean).
const FREE_PATH_RAYS: usize = 8192;

/// The scene's mean free path: the mean distance that cosine-weighted rays from points
/// drawn uniformly by area over the reachable sides travel before they hit a surface
/// (rays that leave the scene are not counted); `None` when none hits. In a closed convex
/// room it is the mean chord `4V/S`; it is the length over which the light a surface
/// receives from the others changes.
fn free_path(scene: &Scene, p: &SolverParams, sides: &[bool], areas: &[f64], rays: usize) -> Option<f64> {
    use crate::geom::sampling::{cosine_direction, onb};
    use crate::geom::transform::{xform_point, xform_vector};
    use crate::geom::Ray;
    let total: f64 = areas.iter().sum();
    let mut rng = crate::geom::rng::Rng::new(p.seed as u64, 0xf4ee_9a70);
    let (mut sum, mut hits) = (0.0f64, 0usize);
    for (i, o) in scene.objects.iter().enumerate() {
        let count = (rays as f64 * areas[i] / total).round() as usize;
        if count == 0 {
            continue;
        }
        let r = o.tri_offset as usize..(o.tri_offset + o.tri_count) as usize;
        let cands = poisson::candidates(
            &scene.tris[r.clone()],
            &[],
            &sides[r.start * 2..r.end * 2],
            count,
            (p.seed as u64) << 32 | 0x8000_0000 | i as u64,
            &|t, b1, b2| scene.stops((r.start + t) as u32, b1, b2),
        );
        for c in cands {
            let x = xform_point(&o.to_world, c.pos);
            let n = xform_vector(&o.to_world, c.normal).normalize_or_zero();
            let (t, b) = onb(n);
            let dir = cosine_direction(n, t, b, glam::Vec2::new(rng.next_f32(), rng.next_f32()), 0.0);
            let ray = Ray {
                o: scene.offset(x, n),
                d: dir,
            };
            if let Some(h) = scene.intersect(&ray, f32::INFINITY) {
                sum += h.t as f64;
                hits += 1;
            }
        }
    }
    (hits > 0).then(|| sum / hits as f64)
}

/// Candidates per object on its reachable sides, enough for the finest level, within
/// `max_candidates`.
pub(super) fn candidate_pools(scene: &Scene, p: &SolverParams, sides: &[bool], d: &Density) -> Vec<Vec<Candidate>> {
    let m = p.levels as usize;
    scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let r = o.tri_offset as usize..(o.tri_offset + o.tri_count) as usize;
            let want = (p.candidate_factor as f64 * d.expected(d.areas[i], m - 1)).ceil();
            let count = (want as u64).min(p.max_candidates as u64) as usize;
            poisson::candidates(
                &scene.tris[r.clone()],
                scene.normals.get(r.clone()).unwrap_or(&[]),
                &sides[r.start * 2..r.end * 2],
                count,
                (p.seed as u64) << 32 | i as u64,
                &|t, b1, b2| scene.stops((r.start + t) as u32, b1, b2),
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::traded_rays;

    #[test]
    fn rays_trade_for_the_raised_density() {
        assert_eq!(traded_rays(512, 1.0), 512);
        assert_eq!(traded_rays(512, 1.0 + 1e-12), 512);
        assert_eq!(traded_rays(512, 4.93), 128);
        assert_eq!(traded_rays(512, 8.0), 64);
        assert_eq!(traded_rays(100, 8.0), 32);
        assert_eq!(traded_rays(16, 8.0), 16);
        assert_eq!(traded_rays(512, f64::NAN), 512);
    }
}
