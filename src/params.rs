//! Solver parameters: the `[solver]` table of a scene file, overridable from the CLI.
//! Names and defaults follow `ALGORITHM.md` (§3, §5) and the paper's Table 1.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

pub use crate::constants::MAX_LEVELS;

/// The three variants of the paper's Table 2.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Variant {
    /// Delta hierarchy (Lehtinen et al.), exact reconstruction over levels 0..=s.
    Original,
    /// Absolute hierarchy (paper §5), exact Shepard reconstruction on the sender level.
    Modified,
    /// Absolute hierarchy, first kd-tree leaf with normal rejection (paper §5.1).
    Approx,
}

impl Variant {
    /// All variants, in the order of the paper's Table 2.
    pub const ALL: [Variant; 3] = [Variant::Original, Variant::Modified, Variant::Approx];

    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Variant::Original => "original",
            Variant::Modified => "modified",
            Variant::Approx => "approx",
        }
    }

    /// Whether finer levels store differences (the original hierarchy).
    pub fn is_delta(self) -> bool {
        self == Variant::Original
    }
}

/// The BVH the GPU traverses (the CPU's rays always traverse the CWBVH).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BvhKind {
    /// Binary BVH, 48-byte nodes.
    Bvh2,
    /// Compressed wide BVH8 (Ylitie et al. 2017), 80-byte nodes.
    Cwbvh,
}

/// Where the GPU backend throws the Poisson-disk levels' darts (`ALGORITHM.md` §3.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DartThrowing {
    /// On the host's cores, as the CPU backend does.
    Host,
    /// On the device (kernel `poisson`), the same nodes but for the float rounding of the
    /// crevice rays.
    Device,
}

/// What decides which surface sides get nodes (`ALGORITHM.md` §3, §6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Reach {
    /// Light paths from the scene's lights through the whole arrangement: only the sides
    /// this lighting reaches get nodes, and the crevice test ray-casts the whole scene.
    /// The hierarchy then depends on where everything is.
    Lights,
    /// Each object alone: the sides that light from anywhere outside it could reach (both
    /// sides of an open sheet, the outside of a closed mesh), and crevices within it. The
    /// hierarchy of an object then depends on that object (and the scene's total area)
    /// only, so it survives moving objects and lights (`meshrad animate`, `session`).
    Object,
}

impl Reach {
    /// The name used in files.
    pub fn name(self) -> &'static str {
        match self {
            Reach::Lights => "lights",
            Reach::Object => "object",
        }
    }
}

/// Every parameter of the solver. Unknown keys are an error.
/// The most that `free_path` multiplies the coarsest level's node count by (a level and a
/// half): the node memory stays within 8× what `coarsest` plans for.
pub const FREE_PATH_MAX_RAISE: f64 = 8.0;

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SolverParams {
    /// Number of hierarchy levels `m`.
    pub levels: u32,
    /// Target node count `N_0` of the coarsest level (sets `r_0 = sqrt(0.7 A / N_0)`).
    pub coarsest: u32,
    /// The coarsest level's Poisson radius is at most `free_path` times the scene's mean
    /// free path (the mean distance a cosine-weighted ray from a surface travels to the
    /// next surface), so a node never spans more than the light it gathers varies over:
    /// `coarsest` is raised where the scene is finer than its count (Sponza's galleries),
    /// at most [`FREE_PATH_MAX_RAISE`]-fold (`ALGORITHM.md` §3.2), and the rays per
    /// integral are lowered as much (`rays`). 0: off (the paper's fixed count).
    pub free_path: f32,
    /// Rays per gathering integral `N` at the asked density; where `free_path` raised the
    /// node count k-fold, the solve takes `rays / k`, rounded up to a multiple of 32 and
    /// at least 32 (`Hierarchy::gather_params`, stats.json `solve.rays_per_integral`).
    pub rays: u32,
    /// Level 1's integrals take `level1_rays` times `rays` (`ALGORITHM.md` §5.2): level 1
    /// is the finest level gathered in full in every bounce, and every region the oracle
    /// does not refine inherits its values by pull-down, so its Monte Carlo noise is what
    /// the image shows away from edges. 1: the paper's one count.
    pub level1_rays: u32,
    /// The most bounces `K` of indirect light; the loop stops earlier once the un-shot
    /// energy falls below `stop_threshold`.
    pub bounces: u32,
    /// Hierarchy variant and reconstruction.
    pub variant: Variant,
    /// Seed of every random choice (candidates, dart throwing, rotations).
    pub seed: u32,
    /// Level `s` reconstructed at hit points (default: 5, the finest of the default
    /// levels; the paper's Table 1 reads 4).
    pub sender_level: u32,
    /// The first bounce reads the exact direct irradiance at its hits (one shadow ray per
    /// hit and light) instead of the sender level's reconstruction of it, which smears
    /// sunlit patches narrower than a node spacing (ledges, slits of light) into the
    /// shadow around them or loses them (`ALGORITHM.md` §5.2). Off: the paper's transport.
    pub exact_first_bounce: bool,
    /// Number `G` of levels that may get gathering integrals (where the oracle refines);
    /// finer levels are pulled down. Default: every level.
    pub gather_levels: Option<u32>,
    /// Level used for outputs (images, probes); default: the finest.
    pub output_level: Option<u32>,
    /// Rays of a final gather at each probe point: the last hop traced, the basis read at
    /// its hits (0: the basis read at the point itself).
    pub final_gather: u32,
    /// A final-gather ray (a probe's, or a pixel's where it gathers) that hits a surface
    /// nearer than the output level's support there (a gap behind a panel, the inside of
    /// a board, a crevice: where the basis cannot resolve the light) takes one more cosine
    /// hop instead of reading the basis at that hit, up to this many hops (`ALGORITHM.md`
    /// §6); 0: the basis at every hit.
    pub short_hops: u32,
    /// The probes' basis read (`final_gather = 0`): 0 at a point the crevice test
    /// (`crevice_distance`, `ALGORITHM.md` §3.3) calls a crevice, where the hierarchy holds
    /// no node and nodes on the open surface beside it would answer (`ALGORITHM.md` §6).
    pub basis_crevice: bool,
    /// The probes' basis read (`final_gather = 0`): a node counts only if the segment
    /// between the point and the node, both lifted a tenth of the support off their
    /// surfaces, meets nothing (a surface between them: the point lies inside a board or
    /// behind a moulding's face; `ALGORITHM.md` §6).
    pub basis_visibility: bool,
    /// Rays of a final gather at each pixel's primary hit (0: the basis read there).
    pub final_gather_pixels: u32,
    /// Without `final_gather_pixels`: rays of a final gather at the pixel samples whose
    /// basis read is doubted (`doubt_nodes`, `doubt_spread`; `ALGORITHM.md` §6); 0: the
    /// basis everywhere.
    pub doubt_gather: u32,
    /// A pixel sample's basis read is doubted where fewer nodes than this support it.
    pub doubt_nodes: u32,
    /// ... or (absolute hierarchies) where its nodes' values spread by more than this
    /// fraction of the read.
    pub doubt_spread: f32,
    /// A node with at most this many parents is gathered whenever a parent carries light
    /// (a value above the oracle's absolute floor), instead of taking its parents' weighted
    /// mean: its surface is narrower than the parent level resolves (a ledge, a strip, the
    /// edge of a ceiling), and their mean is not the light such a strip catches
    /// (`ALGORITHM.md` §5.5). Default 3: Sponza's median estimate/reference 0.970 → 0.973;
    /// 0 is the paper's oracle. Absolute hierarchies only.
    pub sparse_parents: u32,
    /// The bounces `1..=sparse_bounces` in which `sparse_parents` applies; the later ones
    /// use the paper's oracle.
    pub sparse_bounces: u32,
    /// MiB the gathering rays' links may take: the first time a node is gathered with the
    /// sender read, each ray keeps its sender node and albedo, and later bounces gather
    /// over them instead of tracing (`approx` only; same results bit for bit; `ALGORITHM.md`
    /// §5.6). Nodes that find it full are traced every time. Also bounded by what the
    /// memory limit leaves. 0: off.
    pub link_memory: u32,
    /// Shadow rays per point to emitting surfaces (MTL `Ke`) and the sky for the direct
    /// irradiance at nodes and pixels (probe points take `max(final_gather, this)`) (`ALGORITHM.md` §2.2; its standard error is in
    /// stats.json). A gathering ray's hit and a reference path's vertex take one, as their
    /// means average many. Read when the scene loads.
    pub emitter_samples: u32,
    /// The highest albedo a material may have: an albedo above it but at most 1 (a
    /// glTF's default white, MTL `Kd 1 1 1`; for a textured material the texture's mean
    /// times the factor) is lowered to it, with one note naming the materials; above 1
    /// is an error. At 1 a closed scene's series would not converge. Read when the
    /// scene loads.
    pub max_albedo: f32,
    /// Support `h_l = kappa * r_l`.
    pub kappa: f32,
    /// Weight of the normal difference in the distance `δ`.
    pub alpha: f32,
    /// Oracle: relative threshold `ε_rel`.
    pub eps_rel: f32,
    /// Oracle: absolute threshold `ε_abs`, times the mean direct irradiance.
    pub eps_abs: f32,
    /// Oracle: noise allowance, in standard errors of the gathered value (default 1; 2
    /// hides the peaks next to thin bright senders, `ALGORITHM.md` §5.4).
    pub noise_z: f32,
    /// Approximate reconstruction: accept a leaf when `n · n_j > approx_cos`.
    pub approx_cos: f32,
    /// Reads of a field at a point (every variant's reconstruction, at hits and at
    /// outputs) take a node only if the point lies within `plane_offset · h` of the node's
    /// tangent plane: a node on another sheet facing the same way (the floor above a
    /// slab's inner face, a step, a parallel wall) is not part of the point's surface
    /// (`ALGORITHM.md` §5.3). 0: off (the paper's reads). The pull-down weights keep the
    /// paper's weight.
    pub plane_offset: f32,
    /// Stop when a bounce's un-shot energy falls below this fraction of the direct energy
    /// (about the fraction of the indirect light that the remaining bounces would add).
    pub stop_threshold: f32,
    /// Candidate pool per level, as a multiple of the level's expected node count.
    pub candidate_factor: f32,
    /// Upper bound on the candidate pool of one object.
    pub max_candidates: u32,
    /// Which sides get nodes: `"lights"` (from the lights, through the arrangement; what
    /// `solve` takes when unset) or `"object"` (per object, independent of the
    /// arrangement; what `animate` and `session` take when unset, and need).
    pub reach: Option<Reach>,
    /// Light paths traced to find which surface sides light can reach (§3); with
    /// `reach = "object"`, lines through each object's bounding sphere, per object.
    pub reach_paths: u32,
    /// Bounces of those paths.
    pub reach_bounces: u32,
    /// Candidates in a gap narrower than this many finest-level radii get no node (0: off).
    pub crevice_distance: f32,
    /// Cut each node's support at surfaces standing across it (walls on a floor).
    pub support_clip: bool,
    /// GPU: gathering integrals in flight per batch (0: sized from the device).
    pub batch_integrals: u32,
    /// GPU: the BVH layout traversed (default `cwbvh`, what the CPU's rays traverse).
    pub bvh: BvhKind,
    /// GPU: where the Poisson-disk levels are thrown, `"host"` or `"device"`; unset: on
    /// the device unless it is a CPU (lavapipe), where the host's native code is faster,
    /// or the largest level's candidates would take more than half its memory (64 bytes
    /// each). The CPU backend always throws them on the host.
    pub dart_throwing: Option<DartThrowing>,
}

impl Default for SolverParams {
    fn default() -> Self {
        SolverParams {
            levels: 6,
            coarsest: 226,
            free_path: 1.0,
            rays: 512,
            level1_rays: 8,
            bounces: 100,
            variant: Variant::Approx,
            seed: 0,
            sender_level: 5,
            exact_first_bounce: true,
            gather_levels: None,
            output_level: None,
            final_gather: 1024,
            short_hops: 8,
            basis_crevice: true,
            basis_visibility: true,
            final_gather_pixels: 0,
            doubt_gather: 16,
            doubt_nodes: 4,
            doubt_spread: 1.0,
            sparse_parents: 3,
            sparse_bounces: 10_000,
            link_memory: 2048,
            emitter_samples: 64,
            max_albedo: 0.98,
            kappa: 2.0,
            alpha: 1.0,
            eps_rel: 0.1,
            eps_abs: 0.002,
            noise_z: 1.0,
            approx_cos: 0.5,
            plane_offset: 0.25,
            stop_threshold: 1e-4,
            candidate_factor: 8.0,
            max_candidates: 8_000_000,
            reach: None,
            reach_paths: 1 << 17,
            reach_bounces: 6,
            crevice_distance: 1.0,
            support_clip: true,
            batch_integrals: 0,
            bvh: BvhKind::Cwbvh,
            dart_throwing: None,
        }
    }
}

impl SolverParams {
    /// How many times `rays` an integral on `level` takes (`level1_rays` on level 1, else
    /// 1): also the link slots its node takes.
    pub fn slots_at(&self, level: u32) -> u32 {
        if level == 1 {
            self.level1_rays
        } else {
            1
        }
    }

    /// Rays of an integral on `level`.
    pub fn rays_at(&self, level: u32) -> u32 {
        self.rays * self.slots_at(level)
    }

    /// The most rays of any integral (the Halton table's length).
    pub fn max_rays(&self) -> u32 {
        self.rays * self.level1_rays
    }

    /// `G`: the levels that may be gathered.
    pub fn gather_levels(&self) -> u32 {
        self.gather_levels.unwrap_or(self.levels)
    }

    /// Which sides get nodes (unset: from the lights).
    /// Whether a scene loaded with these parameters is the scene loaded with `other`: the
    /// loader reads `max_albedo` (albedos above it are lowered) and `emitter_samples` and
    /// `final_gather` (the emitters' sample set), in `scene::builder::Builder::finish`.
    pub fn loads_as(&self, other: &SolverParams) -> bool {
        self.max_albedo == other.max_albedo
            && self.emitter_samples == other.emitter_samples
            && self.final_gather == other.final_gather
    }

    pub fn reach(&self) -> Reach {
        self.reach.unwrap_or(Reach::Lights)
    }

    /// The level used for outputs.
    pub fn output_level(&self) -> u32 {
        self.output_level.unwrap_or(self.levels - 1)
    }

    /// Checks every value; the error names the parameter.
    pub fn validate(&self) -> Result<()> {
        let range = |name: &str, v: u32, lo: u32, hi: u32| -> Result<()> {
            if v < lo || v > hi {
                Err(Error::param(name, format!("{v} is outside {lo}..={hi}")))
            } else {
                Ok(())
            }
        };
        let finite = |name: &str, v: f32, lo: f32, hi: f32| -> Result<()> {
            if !v.is_finite() || v < lo || v > hi {
                Err(Error::param(name, format!("{v} is outside [{lo}, {hi}]")))
            } else {
                Ok(())
            }
        };
        range("levels", self.levels, 1, MAX_LEVELS)?;
        range("coarsest", self.coarsest, 1, 10_000_000)?;
        range("rays", self.rays, 1, 1 << 16)?;
        range("level1_rays", self.level1_rays, 1, 64)?;
        range(
            "rays × level1_rays",
            self.rays.saturating_mul(self.level1_rays),
            1,
            1 << 20,
        )?;
        range("bounces", self.bounces, 0, 10_000)?;
        range("sender_level", self.sender_level, 0, self.levels - 1)?;
        range("gather_levels", self.gather_levels(), 1, self.levels)?;
        range("output_level", self.output_level(), 0, self.levels - 1)?;
        range("final_gather", self.final_gather, 0, 1 << 16)?;
        range("final_gather_pixels", self.final_gather_pixels, 0, 1 << 16)?;
        range("short_hops", self.short_hops, 0, 64)?;
        range("doubt_gather", self.doubt_gather, 0, 1 << 16)?;
        range("doubt_nodes", self.doubt_nodes, 0, 1 << 10)?;
        finite("doubt_spread", self.doubt_spread, 0.0, 1e6)?;
        range("sparse_parents", self.sparse_parents, 0, 1 << 16)?;
        range("sparse_bounces", self.sparse_bounces, 0, 10_000)?;
        range("link_memory", self.link_memory, 0, 1 << 24)?;
        range("emitter_samples", self.emitter_samples, 1, 1 << 16)?;
        range("max_candidates", self.max_candidates, 1, 200_000_000)?;
        range("reach_paths", self.reach_paths, 1024, 1 << 28)?;
        range("reach_bounces", self.reach_bounces, 1, 64)?;
        finite("kappa", self.kappa, 1e-3, 100.0)?;
        if self.kappa <= 0.0 {
            return Err(Error::param("kappa", "must be positive"));
        }
        finite("alpha", self.alpha, 0.0, 1e3)?;
        finite("eps_rel", self.eps_rel, 0.0, 1e6)?;
        finite("eps_abs", self.eps_abs, 0.0, 1e6)?;
        finite("noise_z", self.noise_z, 0.0, 1e3)?;
        // At 1 no leaf could pass the normal test: every gathered ray would find nothing.
        finite("approx_cos", self.approx_cos, -1.0, 0.99)?;
        finite("plane_offset", self.plane_offset, 0.0, 4.0)?;
        finite("free_path", self.free_path, 0.0, 1e3)?;
        finite("stop_threshold", self.stop_threshold, 0.0, 1.0)?;
        finite("candidate_factor", self.candidate_factor, 1.0, 1e3)?;
        finite("crevice_distance", self.crevice_distance, 0.0, 100.0)?;
        finite("max_albedo", self.max_albedo, 0.0, 0.999)?;
        Ok(())
    }
}
