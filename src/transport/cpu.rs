//! The CPU reference backend: every stage of the transport on plain arrays, parallel over
//! integrals with rayon. It is the oracle the GPU kernels are tested against, so each
//! stage computes exactly what its kernel computes (same formulas, same samples).

use glam::{Vec2, Vec3, Vec4, Vec4Swizzles};
use rayon::prelude::*;

use super::{reconstruct, Backend, Energy, NodeValues, Refined};
use crate::error::Result;
use crate::geom::sampling::{cosine_direction, halton_table, integral_rotation, onb};
use crate::geom::transform::{xform_point, xform_vector};
use crate::geom::Ray;
use crate::hierarchy::Hierarchy;
use crate::params::{SolverParams, Variant};
use crate::progress::Progress;
use crate::scene::Scene;

/// One gathering integral's Monte Carlo result: mean and standard error per channel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Gathered {
    pub mean: Vec3,
    pub std_err: Vec3,
}

/// World-space position and unit normal of node `j`.
#[inline]
pub fn node_world(scene: &Scene, h: &Hierarchy, j: usize) -> (Vec3, Vec3) {
    let nd = &h.nodes[j];
    let o = &scene.objects[nd.object as usize];
    (
        xform_point(&o.to_world, Vec3::from(nd.pos)),
        xform_vector(&o.to_world, Vec3::from(nd.normal)).normalize(),
    )
}

/// Exact direct irradiance at node `j` (kernel `direct`); `lit[i]` is set when light `i`
/// contributes.
pub fn direct_at_node(scene: &Scene, h: &Hierarchy, j: usize, lit: &mut [bool]) -> Vec3 {
    let (x, n) = node_world(scene, h, j);
    let mut e = Vec3::ZERO;
    scene.direct_each(x, n, |i, v| {
        lit[i] = true;
        e += v;
    });
    e
}

/// One gathering integral at node `j` (kernels `hemisphere`, `trace`, `reconstruct`,
/// `reduce`): `(1/N) Σ_r ρ(y_r) ΔE(y_r)` over cosine-weighted Halton directions rotated
/// by the integral's angle, with `ΔE` read from the sender level of `unshot` — or, with
/// `exact_direct` (the first bounce under `exact_first_bounce`), the exact direct
/// irradiance at each hit by shadow rays, the value the first bounce's un-shot field
/// stands for.
pub fn gather_integral(
    scene: &Scene,
    h: &Hierarchy,
    p: &SolverParams,
    halton: &[Vec2],
    unshot: &[Vec4],
    j: usize,
    exact_direct: bool,
) -> Gathered {
    let (x, n) = node_world(scene, h, j);
    let o = scene.offset(x, n);
    let (t, b) = onb(n);
    let phi0 = integral_rotation(p.seed, j as u32);
    let mut sum = glam::DVec3::ZERO;
    let mut sum2 = glam::DVec3::ZERO;
    for &u in halton {
        let d = cosine_direction(n, t, b, u, phi0);
        let ray = Ray { o, d };
        if let Some(hit) = scene.intersect(&ray, f32::INFINITY) {
            let s = scene.surface(&hit, d);
            let e = if exact_direct {
                scene.direct(s.p, s.n)
            } else {
                reconstruct::Sender::of(p).read(h, s.object as usize, s.p_obj, s.n_obj, unshot)
            };
            let c = (s.albedo * e).as_dvec3();
            sum += c;
            sum2 += c * c;
        }
    }
    let nf = halton.len() as f64;
    let mean = sum / nf;
    let var = if halton.len() > 1 {
        ((sum2 / nf - mean * mean) * (nf / (nf - 1.0))).max(glam::DVec3::ZERO)
    } else {
        glam::DVec3::ZERO
    };
    Gathered {
        mean: mean.as_vec3(),
        std_err: (var / nf).as_vec3().map(f32::sqrt),
    }
}

/// The oracle (`ALGORITHM.md` §5): refine when the gathered value differs from the
/// prediction by more than `max(ε_rel |g|, ε_abs mean E_d) + z σ` in any channel.
#[inline]
pub fn oracle(p: &SolverParams, g: &Gathered, predicted: Vec3, mean_direct: Vec3) -> bool {
    let diff = (g.mean - predicted).abs();
    let tau = (g.mean.abs() * p.eps_rel).max(mean_direct * p.eps_abs) + g.std_err * p.noise_z;
    diff.cmpgt(tau).any()
}

/// Pull-down `Σ_p B_p(x_c) v_p` (paper §5, Fig. 4).
#[inline]
pub fn pull_down(h: &Hierarchy, values: &[Vec4], c: usize) -> Vec4 {
    h.parents_of(c)
        .iter()
        .fold(Vec4::ZERO, |acc, q| acc + values[q.node as usize] * q.weight)
        .max(Vec4::ZERO)
}

/// The CPU backend's state.
pub struct CpuBackend<'a> {
    scene: &'a Scene,
    h: &'a Hierarchy,
    p: SolverParams,
    halton: Vec<Vec2>,
    direct: Vec<Vec4>,
    unshot: Vec<Vec4>,
    next: Vec<Vec4>,
    indirect: Vec<Vec4>,
    gathered: Vec<Gathered>,
    is_active: Vec<bool>,
    active: Vec<u32>,
    mean_direct: Vec3,
    progress: Progress,
}

impl<'a> CpuBackend<'a> {
    pub fn new(scene: &'a Scene, h: &'a Hierarchy, p: &SolverParams, progress: &Progress) -> Self {
        let n = h.nodes.len();
        CpuBackend {
            scene,
            h,
            p: p.clone(),
            halton: halton_table(p.rays),
            direct: vec![Vec4::ZERO; n],
            unshot: vec![Vec4::ZERO; n],
            next: vec![Vec4::ZERO; n],
            indirect: vec![Vec4::ZERO; n],
            gathered: vec![Gathered::default(); n],
            is_active: vec![false; n],
            active: Vec::new(),
            mean_direct: Vec3::ZERO,
            progress: progress.clone(),
        }
    }

    /// Per-node state: (direct, unshot, next, indirect), for checks against the GPU.
    pub fn state(&self) -> (&[Vec4], &[Vec4], &[Vec4], &[Vec4]) {
        (&self.direct, &self.unshot, &self.next, &self.indirect)
    }

    /// The gathered value of node `j` in the last gather of its level.
    pub fn gathered(&self, j: usize) -> Option<Gathered> {
        self.is_active[j].then_some(self.gathered[j])
    }

    /// The active nodes of `level`.
    fn active_list(&self, level: u32) -> Vec<u32> {
        if level <= 1 {
            self.h.level_range(level as usize).map(|j| j as u32).collect()
        } else {
            self.active.clone()
        }
    }

    /// Predicted value at node `j` of level `l ≥ 1` from the coarser levels of `next`.
    fn predict(&self, j: usize) -> Vec3 {
        let nd = &self.h.nodes[j];
        if self.p.variant.is_delta() {
            reconstruct::delta_sum(
                self.h,
                nd.object as usize,
                nd.level as usize - 1,
                Vec3::from(nd.pos),
                Vec3::from(nd.normal),
                &self.next,
            )
        } else {
            pull_down(self.h, &self.next, j).xyz()
        }
    }
}

impl Backend for CpuBackend<'_> {
    fn name(&self) -> String {
        "cpu".into()
    }

    fn direct(&mut self) -> Result<Vec<u32>> {
        let (scene, h) = (self.scene, self.h);
        let bar = self.progress.bar(h.nodes.len() as u64, "direct");
        let nl = scene.lights.len();
        let lit: Vec<Vec<bool>> = self
            .direct
            .par_iter_mut()
            .enumerate()
            .map(|(j, e)| {
                let mut lit = vec![false; nl];
                *e = direct_at_node(scene, h, j, &mut lit).extend(0.0);
                if j % 1024 == 0 {
                    bar.inc(1024);
                }
                lit
            })
            .collect();
        bar.finish();
        let counts = (0..nl).map(|i| lit.iter().filter(|l| l[i]).count() as u32).collect();
        let l0 = h.level_range(0);
        let count = l0.len().max(1) as f32;
        self.mean_direct = self.direct[l0].iter().map(|v| v.xyz()).sum::<Vec3>() / count;
        Ok(counts)
    }

    fn init_unshot(&mut self) -> Result<()> {
        self.indirect.fill(Vec4::ZERO);
        if !self.p.variant.is_delta() {
            self.unshot.copy_from_slice(&self.direct);
            return Ok(());
        }
        // Delta coefficients of E_d: α^0 = f, α^l = f − F_{l−1}(x_j) (paper §3).
        for l in 0..self.h.levels as usize {
            let range = self.h.level_range(l);
            let vals: Vec<Vec4> = range
                .clone()
                .into_par_iter()
                .map(|j| {
                    let nd = &self.h.nodes[j];
                    let f = self.direct[j].xyz();
                    if l == 0 {
                        return f.extend(0.0);
                    }
                    let pred = reconstruct::delta_sum(
                        self.h,
                        nd.object as usize,
                        l - 1,
                        Vec3::from(nd.pos),
                        Vec3::from(nd.normal),
                        &self.unshot,
                    );
                    (f - pred).extend(0.0)
                })
                .collect();
            self.unshot[range].copy_from_slice(&vals);
        }
        Ok(())
    }

    fn gather(&mut self, level: u32, exact: bool) -> Result<u32> {
        let list = self.active_list(level);
        let (scene, h, p, halton, unshot) = (self.scene, self.h, &self.p, &self.halton, &self.unshot);
        let bar = self.progress.bar(list.len() as u64, &format!("level {level}"));
        let results: Vec<Gathered> = list
            .par_iter()
            .map(|&j| {
                let g = gather_integral(scene, h, p, halton, unshot, j as usize, exact);
                bar.inc(1);
                g
            })
            .collect();
        bar.finish();
        self.is_active[h.level_range(level as usize)].fill(false);
        for (&j, g) in list.iter().zip(results) {
            self.gathered[j as usize] = g;
            self.is_active[j as usize] = true;
        }
        Ok(list.len() as u32)
    }

    fn refine(&mut self, level: u32, activate: bool) -> Result<Refined> {
        let range = self.h.level_range(level as usize);
        let delta = self.p.variant.is_delta();
        let out: Vec<(Vec4, bool)> = range
            .clone()
            .into_par_iter()
            .map(|j| {
                let g = &self.gathered[j];
                let active = self.is_active[j];
                if level == 0 {
                    return (g.mean.extend(0.0), false);
                }
                let pred = self.predict(j);
                match (active, delta) {
                    (true, false) => (g.mean.extend(0.0), oracle(&self.p, g, pred, self.mean_direct)),
                    (true, true) => ((g.mean - pred).extend(0.0), oracle(&self.p, g, pred, self.mean_direct)),
                    (false, false) => (pred.extend(0.0), false),
                    (false, true) => (Vec4::ZERO, false),
                }
            })
            .collect();
        let mut refined = 0;
        let mut flags = vec![false; if activate { self.h.nodes.len() } else { 0 }];
        let k_sparse = std::env::var("MESHRAD_SPARSE").ok().and_then(|v| v.parse::<usize>().ok()).unwrap_or(0);
        let floor = self.mean_direct * self.p.eps_abs;
        for (j, (v, r)) in range.zip(out) {
            self.next[j] = v;
            if activate && k_sparse > 0 && !r && v.xyz().cmpgt(floor).any() {
                for &c in self.h.children_of(j) {
                    if self.h.parents_of(c as usize).len() <= k_sparse {
                        flags[c as usize] = true;
                    }
                }
            }
            if r {
                refined += 1;
                if activate {
                    for &c in self.h.children_of(j) {
                        flags[c as usize] = true;
                    }
                }
            }
        }
        if activate {
            let next_range = self.h.level_range(level as usize + 1);
            self.active = next_range.filter(|&c| flags[c]).map(|c| c as u32).collect();
        }
        Ok(Refined {
            refined,
            activated: if activate { self.active.len() as u32 } else { 0 },
        })
    }

    fn fill(&mut self, from: u32) -> Result<()> {
        for l in from as usize..self.h.levels as usize {
            let range = self.h.level_range(l);
            if self.p.variant == Variant::Original {
                self.next[range].fill(Vec4::ZERO);
            } else {
                let vals: Vec<Vec4> = range
                    .clone()
                    .into_par_iter()
                    .map(|c| pull_down(self.h, &self.next, c))
                    .collect();
                self.next[range].copy_from_slice(&vals);
            }
        }
        Ok(())
    }

    fn end_bounce(&mut self) -> Result<Energy> {
        for (e, n) in self.indirect.iter_mut().zip(&self.next) {
            *e += *n;
        }
        std::mem::swap(&mut self.unshot, &mut self.next);
        let l0 = self.h.level_range(0);
        let lum = |v: &Vec4| (v.x as f64 + v.y as f64 + v.z as f64) / 3.0;
        Ok(Energy {
            unshot: self.unshot[l0.clone()].iter().map(lum).sum(),
            direct: self.direct[l0].iter().map(lum).sum(),
        })
    }

    fn values(&mut self) -> Result<NodeValues> {
        Ok(NodeValues {
            direct: self.direct.clone(),
            indirect: self.indirect.clone(),
        })
    }
}
