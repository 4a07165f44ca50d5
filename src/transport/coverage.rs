//! Where gathered light is lost before any estimate is made (a term of the error
//! decomposition, `ALGORITHM.md` §5.4): the gathering rays of the level-0 integrals, cast
//! as the first bounce casts them, sorted into rays that escape, hits where the sender
//! level gives no value (no basis function of any level up to `sender_level` covers the
//! point after the normal test and the clip planes: the hit's light is lost), and hits
//! that get one. The share of the first bounce's light that falls on hits without a value
//! is estimated with the exact direct irradiance there.

use glam::{Vec3, Vec4};
use rayon::prelude::*;
use serde::Serialize;

use super::cpu::node_world;
use super::reconstruct;
use crate::geom::rng::Rng;
use crate::geom::sampling::{cosine_direction, halton_table, integral_rotation, onb};
use crate::geom::Ray;
use crate::hierarchy::Hierarchy;
use crate::params::{SolverParams, Variant};
use crate::scene::Scene;

/// The first bounce's gathering rays from level 0, sorted.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Coverage {
    pub rays: u64,
    /// Rays that hit nothing.
    pub escaped: u64,
    /// Hits where the sender level has no value.
    pub no_value: u64,
    /// Of those, hits on a side that can receive light (`Scene::receives_light`): light of
    /// later bounces lost there.
    pub no_value_receiving: u64,
    /// `Σ ρ E_d` at hits without a value over `Σ ρ E_d` at all hits (mean of the RGB
    /// channels): the share of the first bounce's light that the reconstruction loses.
    pub light_lost: f64,
}

/// Whether the sender level of `p` gives a value at an object-space point of object `o`.
fn has_value(h: &Hierarchy, p: &SolverParams, ones: &[Vec4], o: usize, x: Vec3, n: Vec3) -> bool {
    let s = p.sender_level as usize;
    match p.variant {
        Variant::Approx => reconstruct::approx(h, o, s, x, n, ones, p.approx_cos).is_some(),
        Variant::Modified | Variant::Original => reconstruct::exact(h, o, s, x, n, ones).is_some(),
    }
}

/// Casts the level-0 integrals' rays of `h` for parameters `p` and sorts them.
pub fn first_bounce(scene: &Scene, h: &Hierarchy, p: &SolverParams) -> Coverage {
    let halton = halton_table(p.rays);
    let ones = vec![Vec4::ONE; h.nodes.len()];
    let (rays, escaped, no_value, no_value_receiving, lost, all) = h
        .level_range(0)
        .into_par_iter()
        .map(|j| {
            let (x, n) = node_world(scene, h, j);
            let o = scene.offset(x, n);
            let (t, b) = onb(n);
            let phi0 = integral_rotation(p.seed, j as u32);
            let (mut esc, mut none, mut recv, mut lost, mut all) = (0u64, 0u64, 0u64, 0f64, 0f64);
            let mut rng = Rng::new(p.seed as u64, j as u64);
            for &u in &halton {
                let d = cosine_direction(n, t, b, u, phi0);
                let Some(hit) = scene.intersect(&Ray { o, d }, f32::INFINITY) else {
                    esc += 1;
                    continue;
                };
                let s = scene.surface(&hit, d);
                let light = (s.albedo * scene.direct(s.p, s.n)).dot(Vec3::splat(1.0 / 3.0)) as f64;
                all += light;
                if !has_value(h, p, &ones, s.object as usize, s.p_obj, s.n_obj) {
                    none += 1;
                    lost += light;
                    recv += scene.receives_light(s.p, s.n, &mut rng) as u64;
                }
            }
            (halton.len() as u64, esc, none, recv, lost, all)
        })
        .reduce(
            || (0, 0, 0, 0, 0.0, 0.0),
            |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2, a.3 + b.3, a.4 + b.4, a.5 + b.5),
        );
    Coverage {
        rays,
        escaped,
        no_value,
        no_value_receiving,
        light_lost: if all > 0.0 { lost / all } else { 0.0 },
    }
}
