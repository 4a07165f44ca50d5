//! The levels' density (paper §3, `ALGORITHM.md` §3.2): each object's reachable area, the
//! world-space Poisson radius of each level, how many candidates each level throws darts
//! from, and the candidate pools (`poisson::candidates`) that serve them all.

use super::poisson::{self, Candidate};
use crate::error::{Error, Result};
use crate::params::SolverParams;
use crate::scene::Scene;

/// The levels' density: each object's reachable area (world units²) and the world-space
/// Poisson radius of each level (§3: `r_0 = sqrt(0.7 A / N_0)`, halved per level).
pub(super) struct Density {
    pub(super) areas: Vec<f64>,
    pub(super) radius: Vec<f64>,
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
        let r0 = (0.7 * area / p.coarsest as f64).sqrt();
        let d = Density {
            radius: (0..m).map(|l| r0 / (1u64 << l) as f64).collect(),
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
                &sides[r.start * 2..r.end * 2],
                count,
                (p.seed as u64) << 32 | i as u64,
            )
        })
        .collect()
}
