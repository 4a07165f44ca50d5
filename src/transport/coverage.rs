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
    /// `Σ ρ Ê_d / Σ ρ E_d` over the same hits, where `Ê_d` is the exact direct irradiance
    /// at the nodes reconstructed at the hit as the transport reads it (the variant's
    /// reconstruction on the sender level) and `E_d` the exact value there: the bias the
    /// sender reconstruction puts into the first bounce (1: none).
    pub sender_direct_ratio: f64,
    /// The same with the exact Shepard sum on the sender level.
    pub sender_exact_direct_ratio: f64,
    /// The same with the outputs' reconstruction (exact, output level).
    pub output_direct_ratio: f64,
}

/// Whether the sender level of `p` gives a value at an object-space point of object `o`.
fn has_value(h: &Hierarchy, p: &SolverParams, ones: &[Vec4], o: usize, x: Vec3, n: Vec3) -> bool {
    let s = p.sender_level as usize;
    match p.variant {
        Variant::Approx => reconstruct::approx(h, o, s, x, n, ones, p.approx_cos).is_some(),
        Variant::Modified | Variant::Original => reconstruct::exact(h, o, s, x, n, ones).is_some(),
    }
}

/// Light sums of one integral's rays (mean of the RGB channels).
#[derive(Clone, Copy, Default)]
struct Sums {
    rays: u64,
    escaped: u64,
    none: u64,
    receiving: u64,
    lost: f64,
    all: f64,
    sender: f64,
    sender_exact: f64,
    output: f64,
}

impl Sums {
    fn add(self, b: Sums) -> Sums {
        Sums {
            rays: self.rays + b.rays,
            escaped: self.escaped + b.escaped,
            none: self.none + b.none,
            receiving: self.receiving + b.receiving,
            lost: self.lost + b.lost,
            all: self.all + b.all,
            sender: self.sender + b.sender,
            sender_exact: self.sender_exact + b.sender_exact,
            output: self.output + b.output,
        }
    }
}

/// Casts the level-0 integrals' rays of `h` for parameters `p` and sorts them.
pub fn first_bounce(scene: &Scene, h: &Hierarchy, p: &SolverParams) -> Coverage {
    let halton = halton_table(p.rays);
    let ones = vec![Vec4::ONE; h.nodes.len()];
    let direct: Vec<Vec4> = (0..h.nodes.len())
        .into_par_iter()
        .map(|j| {
            let (x, n) = node_world(scene, h, j);
            scene.direct(x, n).extend(0.0)
        })
        .collect();
    let sender = reconstruct::Sender::of(p);
    let (sl, ol) = (p.sender_level as usize, p.output_level() as usize);
    let third = Vec3::splat(1.0 / 3.0);
    let t = h
        .level_range(0)
        .into_par_iter()
        .map(|j| {
            let (x, n) = node_world(scene, h, j);
            let o = scene.offset(x, n);
            let (t, b) = onb(n);
            let phi0 = integral_rotation(p.seed, j as u32);
            let mut m = Sums {
                rays: halton.len() as u64,
                ..Default::default()
            };
            let mut rng = Rng::new(p.seed as u64, j as u64);
            for &u in &halton {
                let d = cosine_direction(n, t, b, u, phi0);
                let Some(hit) = scene.intersect(&Ray { o, d }, f32::INFINITY) else {
                    m.escaped += 1;
                    continue;
                };
                let s = scene.surface(&hit, d);
                let (ob, xo, no) = (s.object as usize, s.p_obj, s.n_obj);
                let light = (s.albedo * scene.direct(s.p, s.n)).dot(third) as f64;
                m.all += light;
                let read = |v: Vec3| (s.albedo * v).dot(third) as f64;
                // The delta hierarchy carries E_d as deltas; its absolute field on the sender
                // level is about the exact Shepard sum there.
                m.sender += read(if p.variant.is_delta() {
                    reconstruct::exact(h, ob, sl, xo, no, &direct).unwrap_or(Vec3::ZERO)
                } else {
                    sender.read(h, ob, xo, no, &direct)
                });
                m.sender_exact += read(reconstruct::exact(h, ob, sl, xo, no, &direct).unwrap_or(Vec3::ZERO));
                m.output += read(reconstruct::output(h, false, p.output_linear, ob, ol, xo, no, &direct).max(Vec3::ZERO));
                if !has_value(h, p, &ones, ob, xo, no) {
                    m.none += 1;
                    m.lost += light;
                    m.receiving += scene.receives_light(s.p, s.n, &mut rng) as u64;
                }
            }
            m
        })
        .reduce(Sums::default, Sums::add);
    let ratio = |a: f64| if t.all > 0.0 { a / t.all } else { 0.0 };
    Coverage {
        rays: t.rays,
        escaped: t.escaped,
        no_value: t.none,
        no_value_receiving: t.receiving,
        light_lost: ratio(t.lost),
        sender_direct_ratio: ratio(t.sender),
        sender_exact_direct_ratio: ratio(t.sender_exact),
        output_direct_ratio: ratio(t.output),
    }
}
