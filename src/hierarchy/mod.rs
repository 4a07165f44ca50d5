//! The meshless hierarchy (paper §3, `ALGORITHM.md` §3): per object, `m` Poisson-disk
//! levels of basis-function centres in object space, a kd-tree per level, and parent
//! relations carrying the pull-down weights `B_p^l(x_c)`.
//!
//! Layout (shared with the GPU): all nodes in one array, level-major, then by object;
//! the nodes of one (object, level) are contiguous and in kd order.
//!
//! By concept: `build.rs` the build and the arrangement; `density.rs` the levels' density
//! and candidate pools; `poisson.rs` candidates and dart throwing; `crevice.rs` the
//! crevice test; `clips.rs` support clip planes; `relations.rs` parents, children and
//! pull-down weights; `kdtree.rs` the kd-trees; `weight.rs` the Shepard weight.

mod build;
mod clips;
mod crevice;
mod density;
pub mod kdtree;
pub mod poisson;
mod relations;
pub mod weight;

pub use build::{LevelJob, LevelsElsewhere, Thrown};
pub use clips::{cpu_clips, may_meet_wall, node_clip, node_clip_traced, world_normals, ClipSelection};
pub use crevice::{
    in_crevice, in_crevice_traced, in_crevice_within, in_crevice_within_traced, object_diagonal, CreviceTest,
};

use glam::Vec3;
use serde::Serialize;

use crate::params::SolverParams;

use crate::layout::{KdSplit, Node, ObjectInfo, Parent};
use crate::params::MAX_LEVELS;
use crate::scene::{reach, Scene};
use weight::{clip_ok, node_weight};

/// The most triangles near a node or candidate that its rays are tested against one by
/// one; beyond, they are traced through the BVH.
const NEAR_CAP: usize = 32;

/// The half-width of the cube about `origin` that holds rays of length `len` from it, with
/// a margin for rounding.
fn ray_cube(origin: Vec3, len: f32) -> f32 {
    len * 1.01 + 1e-5 * origin.abs().max_element()
}

/// Where the objects were when a hierarchy was last arranged (their transforms, and the
/// scene's bounds, which set the ray offsets).
#[derive(Clone, Debug)]
pub struct Arrangement {
    pub objects: Vec<crate::scene::SceneObject>,
    pub bounds: (Vec3, Vec3),
    pub scale: f32,
}

impl Arrangement {
    /// The scene's arrangement now.
    pub fn of(scene: &Scene) -> Arrangement {
        Arrangement {
            objects: scene.objects.clone(),
            bounds: scene.bounds,
            scale: scene.scale,
        }
    }
}

/// Where one object's nodes of each level live, and the levels' radii in object space.
#[derive(Clone, Debug, Default)]
pub struct ObjectLevels {
    pub start: Vec<u32>,
    pub count: Vec<u32>,
    pub radius: Vec<f32>,
}

/// What building the hierarchy did, for stats.json.
#[derive(Clone, Debug, Default, Serialize)]
pub struct HierarchyStats {
    pub nodes_per_level: Vec<u32>,
    pub candidates_per_level: Vec<u64>,
    /// World-space Poisson radius `r_l`.
    pub radius_per_level: Vec<f32>,
    /// Children whose parent level has no weight at their centre (nearest parent used).
    pub parent_holes_per_level: Vec<u32>,
    /// Children with no same-side node on the parent level at all.
    pub orphans_per_level: Vec<u32>,
    pub reachable_area: f64,
    /// The scene's mean free path (world units; `solver.free_path`), when measured.
    pub free_path: Option<f64>,
    /// The coarsest level's target node count: `coarsest`, or more where the mean free
    /// path raised it.
    pub coarsest_nodes: f64,
    /// Candidates found in a crevice (a gap narrower than the finest level's radius, e.g.
    /// under an object resting on the floor), of those tested: on the host the crevice
    /// test runs on the candidates that no node of an earlier chunk of the dart throwing
    /// covers, on the device on those whose earlier neighbours were all left out.
    pub crevice_candidates_dropped: usize,
    /// Where the Poisson-disk levels were thrown: `"host"` or `"device"`
    /// (`dart_throwing`).
    pub poisson_on: &'static str,
    /// On the device: the rounds of decisions over all (object, level) pairs (at least
    /// one submission of 4 per pair; 0 on the host).
    pub poisson_rounds: usize,
    pub reachable_sides: usize,
    pub seconds_reach: f64,
    pub seconds_candidates: f64,
    pub seconds_poisson: f64,
    pub seconds_kdtree: f64,
    pub seconds_clips: f64,
    /// Nodes whose support a nearby surface cuts (a wall standing on their floor).
    pub clipped_nodes: usize,
    pub seconds_parents: f64,
}

/// The hierarchy of every object.
#[derive(Clone, Debug)]
pub struct Hierarchy {
    pub levels: u32,
    pub kappa: f32,
    pub alpha: f32,
    /// Reads take a node only within `plane · h` of its tangent plane (0: any;
    /// `SolverParams::plane_offset`).
    pub plane: f32,
    pub nodes: Vec<Node>,
    pub splits: Vec<KdSplit>,
    /// Per node, the free distance of its support in 8 tangent sectors (`weight::clip_ok`).
    pub clips: Vec<weight::Clip>,
    /// Global start of each level (`levels + 1` entries).
    pub level_start: Vec<u32>,
    pub objects: Vec<ObjectLevels>,
    /// CSR: the parents of node `i` are `parents[parent_offset[i]..parent_offset[i + 1]]`.
    pub parent_offset: Vec<u32>,
    pub parents: Vec<Parent>,
    /// CSR: children of node `i`.
    pub child_offset: Vec<u32>,
    pub children: Vec<u32>,
    pub stats: HierarchyStats,
    /// The triangle sides that got nodes (two flags per global triangle).
    pub sides: Vec<bool>,
    /// Under `reach = "object"`: what decides the sides, to tell after an edit whether
    /// they still hold (`crate::editor`).
    pub object_reach: Option<reach::ObjectReach>,
}

impl Hierarchy {
    /// The parameters a solve over this hierarchy runs with: `p`, with the rays per
    /// gathering integral this hierarchy's density asks for (fewer than `p.rays` only
    /// where the mean free path raised the node count, `ALGORITHM.md` §3.2; stats.json
    /// `solve.rays_per_integral`). [`crate::Engine`] applies it.
    pub fn gather_params(&self, p: &SolverParams) -> SolverParams {
        let mut q = p.clone();
        let raise = self.stats.coarsest_nodes / p.coarsest.max(1) as f64;
        q.rays = density::traded_rays(p.rays, raise);
        q
    }

    /// Whether side `back` of global triangle `tri` got nodes. A hit on a side without
    /// them (no light reaches it: the inside of a closed solid, the back of a wall) reads
    /// nothing as a sender (`ALGORITHM.md` §5.1), without a search.
    #[inline]
    pub fn side_has_nodes(&self, tri: u32, back: bool) -> bool {
        self.sides[2 * tri as usize + back as usize]
    }

    /// Support `h_l` of level `l` of object `o`, object space.
    #[inline]
    pub fn support(&self, o: usize, l: usize) -> f32 {
        self.kappa * self.objects[o].radius[l]
    }

    /// The nodes and splits of (object, level), and the global index of the first.
    #[inline]
    pub fn level(&self, o: usize, l: usize) -> (&[Node], &[KdSplit], usize) {
        let ol = &self.objects[o];
        let s = ol.start[l] as usize;
        let e = s + ol.count[l] as usize;
        (&self.nodes[s..e], &self.splits[s..e], s)
    }

    /// Calls `f(global index, w)` for every node of (o, l) with `w_j(p) > 0` whose clip
    /// admits `p`: the paper's basis, which the parents and pull-down weights use (§3.7).
    #[inline]
    pub fn for_each_weight(&self, o: usize, l: usize, p: Vec3, n: Vec3, f: impl FnMut(usize, f32)) {
        self.weights(o, l, p, n, false, f)
    }

    /// [`Hierarchy::for_each_weight`] for a read of a field at `p`: only the nodes of its
    /// own sheet ([`Hierarchy::on_sheet`], `ALGORITHM.md` §5.3).
    #[inline]
    pub fn for_each_read_weight(&self, o: usize, l: usize, p: Vec3, n: Vec3, f: impl FnMut(usize, f32)) {
        self.weights(o, l, p, n, true, f)
    }

    #[inline]
    fn weights(&self, o: usize, l: usize, p: Vec3, n: Vec3, read: bool, mut f: impl FnMut(usize, f32)) {
        let (nodes, splits, base) = self.level(o, l);
        let h = self.support(o, l);
        kdtree::range(nodes, splits, p, h, |i| {
            let nd = &nodes[i];
            let (x, nj) = (Vec3::from(nd.pos), Vec3::from(nd.normal));
            let w = node_weight(p, n, x, nj, h, self.alpha);
            if w > 0.0 && (!read || self.on_sheet(p - x, nj, h)) && clip_ok(&self.clips[base + i], p - x, nj, h) {
                f(base + i, w);
            }
        });
    }

    /// Whether a point at offset `v` from a node (normal `nj`, support `h`) lies on the
    /// node's sheet: within `plane · h` of its tangent plane (`ALGORITHM.md` §5.3). GLSL
    /// twin: `on_sheet` in `glsl/include/hierarchy.glsl`.
    #[inline]
    pub fn on_sheet(&self, v: Vec3, nj: Vec3, h: f32) -> bool {
        self.plane <= 0.0 || v.dot(nj).abs() < self.plane * h
    }

    /// The nearest node of (o, l) on the same side as `n` (n · n_j > 0) whose clip planes
    /// admit `p`, if any.
    pub fn nearest_same_side(&self, o: usize, l: usize, p: Vec3, n: Vec3) -> Option<usize> {
        let (nodes, splits, base) = self.level(o, l);
        if nodes.is_empty() {
            return None;
        }
        let h = self.support(o, l);
        let mut r = h;
        for _ in 0..40 {
            let mut best = None;
            let mut best_d = f32::INFINITY;
            kdtree::range(nodes, splits, p, r, |i| {
                let nd = &nodes[i];
                let (x, nj) = (Vec3::from(nd.pos), Vec3::from(nd.normal));
                let d = (x - p).length_squared();
                if n.dot(nj) > 0.0 && d < best_d && clip_ok(&self.clips[base + i], p - x, nj, h) {
                    best_d = d;
                    best = Some(base + i);
                }
            });
            if best.is_some() {
                return best;
            }
            r *= 2.0;
        }
        None
    }

    /// The global node range of level `l`.
    #[inline]
    pub fn level_range(&self, l: usize) -> std::ops::Range<usize> {
        self.level_start[l] as usize..self.level_start[l + 1] as usize
    }

    /// The per-object records shared with the GPU.
    pub fn object_infos(&self, scene: &Scene) -> Vec<ObjectInfo> {
        scene
            .objects
            .iter()
            .zip(&self.objects)
            .zip(&scene.cw.roots)
            .map(|((o, ol), &root)| {
                let mut info = o.info(root);
                for l in 0..(self.levels as usize).min(MAX_LEVELS as usize) {
                    info.level_start[l] = ol.start[l];
                    info.level_count[l] = ol.count[l];
                    info.radius[l] = ol.radius[l];
                }
                info
            })
            .collect()
    }
}
