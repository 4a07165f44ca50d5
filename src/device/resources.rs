//! Every device buffer of a solve, by name: the scene and hierarchy (uploaded once), the
//! per-node state (resident for the whole solve) and the per-batch buffers (rays, hits,
//! samples: they never leave the device). `Globals` is written from these names.

use std::sync::Arc;

use gpu_allocator::MemoryLocation;

use super::globals::{Globals, CONTRIB_BYTES, HIT_BYTES, LINK_RECORD_BYTES, RAY_BYTES};
use crate::constants::{
    COUNTERS_PER_LEVEL, DISPATCH_PER_BATCH, ENERGY_DIRECT, ENERGY_SLOTS, LIGHT_COUNTERS, LINK_COUNTERS, MAX_LEVELS,
};
use crate::error::Result;
use crate::geom::sampling::halton_table;
use crate::gpu::buffer::Buffer;
use crate::gpu::context::Context;
use crate::hierarchy::Hierarchy;
use crate::layout::CwNode;
use crate::params::{BvhKind, SolverParams, Variant};
use crate::scene::Scene;

/// The scene and the hierarchy, uploaded once, read-only on the device.
pub struct SceneBuffers {
    pub tris: Buffer,
    pub uvs: Buffer,
    pub bvh: Buffer,
    pub cw_nodes: Buffer,
    pub cw_prims: Buffer,
    pub materials: Buffer,
    pub textures: Buffer,
    pub texels: Buffer,
    pub srgb: Buffer,
    pub lights: Buffer,
    pub objects: Buffer,
    pub nodes: Buffer,
    pub splits: Buffer,
    pub clips: Buffer,
    pub sides: Buffer,
    pub parent_offset: Buffer,
    pub parents: Buffer,
    pub child_offset: Buffer,
    pub children: Buffer,
    pub halton: Buffer,
    pub emitters: Buffer,
    pub emitter_points: Buffer,
    pub sky_texels: Buffer,
    pub sky_rows: Buffer,
    pub sky_cols: Buffer,
    pub sky_prob: Buffer,
}

/// The CWBVH arrays the device gets: the scene's (which the CPU's rays traverse) for
/// `bvh = "cwbvh"`, none for `bvh2`.
pub fn cwbvh_of<'a>(scene: &'a Scene, p: &SolverParams) -> (&'a [CwNode], &'a [u32]) {
    if p.bvh == BvhKind::Cwbvh {
        (&scene.cw.nodes, &scene.cw.prims)
    } else {
        (&[], &[])
    }
}

/// `Hierarchy::sides` as the kernels read it: per triangle, bit 0 for its front, bit 1
/// for its back.
fn side_bits(sides: &[bool]) -> Vec<u32> {
    sides.chunks(2).map(|s| s[0] as u32 | (s[1] as u32) << 1).collect()
}

impl SceneBuffers {
    fn upload(ctx: &Arc<Context>, scene: &Scene, h: &Hierarchy, p: &SolverParams) -> Result<SceneBuffers> {
        let objects = h.object_infos(scene);
        let (cw_nodes, cw_prims) = cwbvh_of(scene, p);
        let (emitters, points) = scene.emitters.gpu_tables();
        let sky = match &scene.sky {
            Some(crate::scene::sky::Sky::Map(m)) => m.gpu_tables(),
            _ => Default::default(),
        };
        Ok(SceneBuffers {
            tris: Buffer::upload(ctx, "triangles", &scene.tris[..])?,
            uvs: Buffer::upload(ctx, "uvs", &scene.uvs[..])?,
            bvh: Buffer::upload(ctx, "bvh", &scene.bvh[..])?,
            cw_nodes: Buffer::upload(ctx, "cwbvh nodes", cw_nodes)?,
            cw_prims: Buffer::upload(ctx, "cwbvh primitives", cw_prims)?,
            materials: Buffer::upload(ctx, "materials", &scene.materials[..])?,
            textures: Buffer::upload(ctx, "textures", &scene.textures[..])?,
            texels: Buffer::upload(ctx, "texels", &scene.texels[..])?,
            srgb: Buffer::upload(ctx, "srgb", &scene.srgb[..])?,
            lights: Buffer::upload(ctx, "lights", &scene.lights[..])?,
            objects: Buffer::upload(ctx, "objects", &objects[..])?,
            nodes: Buffer::upload(ctx, "nodes", &h.nodes[..])?,
            splits: Buffer::upload(ctx, "kd splits", &h.splits[..])?,
            clips: Buffer::upload(ctx, "support clips", &h.clips[..])?,
            sides: Buffer::upload(ctx, "triangle sides", &side_bits(&h.sides)[..])?,
            parent_offset: Buffer::upload(ctx, "parent offsets", &h.parent_offset[..])?,
            parents: Buffer::upload(ctx, "parents", &h.parents[..])?,
            child_offset: Buffer::upload(ctx, "child offsets", &h.child_offset[..])?,
            children: Buffer::upload(ctx, "children", &h.children[..])?,
            halton: Buffer::upload(ctx, "halton", &halton_table(p.max_rays())[..])?,
            emitters: Buffer::upload(ctx, "emitters", &emitters[..])?,
            emitter_points: Buffer::upload(ctx, "emitter points", &points[..])?,
            sky_texels: Buffer::upload(ctx, "sky texels", &sky.0[..])?,
            sky_rows: Buffer::upload(ctx, "sky rows", &sky.1[..])?,
            sky_cols: Buffer::upload(ctx, "sky columns", &sky.2[..])?,
            sky_prob: Buffer::upload(ctx, "sky probabilities", &sky.3[..])?,
        })
    }

    /// Uploads the emitters' table again (their probabilities change when objects move).
    pub fn upload_emitters(&mut self, ctx: &Arc<Context>, scene: &Scene) -> Result<u64> {
        let (emitters, _) = scene.emitters.gpu_tables();
        self.emitters = Buffer::upload(ctx, "emitters", &emitters[..])?;
        Ok(self.emitters.size)
    }

    /// Bytes uploaded.
    pub fn bytes(&self) -> u64 {
        [
            &self.tris,
            &self.uvs,
            &self.bvh,
            &self.cw_nodes,
            &self.cw_prims,
            &self.materials,
            &self.textures,
            &self.texels,
            &self.srgb,
            &self.lights,
            &self.objects,
            &self.nodes,
            &self.splits,
            &self.clips,
            &self.sides,
            &self.parent_offset,
            &self.parents,
            &self.child_offset,
            &self.children,
            &self.halton,
            &self.emitters,
            &self.emitter_points,
            &self.sky_texels,
            &self.sky_rows,
            &self.sky_cols,
            &self.sky_prob,
        ]
        .iter()
        .map(|b| b.size)
        .sum()
    }
}

/// Per-node state, resident for the whole solve (vec4 per node unless noted).
pub struct NodeState {
    pub direct: Buffer,
    /// Per node (f32): the relative standard error of its sampled direct light.
    pub direct_err: Buffer,
    pub unshot: Buffer,
    pub next: Buffer,
    pub indirect: Buffer,
    pub pred: Buffer,
    pub gathered_mean: Buffer,
    pub gathered_err: Buffer,
    /// u32 per node: gathered in this bounce.
    pub active_flag: Buffer,
    /// u32 per node: activated by a refined parent.
    pub child_flag: Buffer,
    /// u32 per node of the largest level: the active set being gathered.
    pub active_list: Buffer,
    /// The next level's active nodes that hold links (`compact` with `split`).
    pub linked_list: Buffer,
    /// u32 slots `COUNTER*` / `LIGHT_COUNTERS` (`crate::constants`).
    pub counters: Buffer,
    /// f32 slots `ENERGY_*` (`crate::constants`).
    pub energy: Buffer,
    /// u32 per node: its link slot (`NONE`, or the slot, `LINK_RECORDING` while its
    /// first traced gather records).
    pub link_slot: Buffer,
    /// The links: `link_capacity` slots of `rays` records (16 bytes each).
    pub links: Buffer,
    /// u32 slots `LINK_*` (`crate::constants`).
    pub link_counters: Buffer,
    /// Link slots of `rays_per_integral` links (0: none; not the approximate variant, or
    /// `link_memory = 0`); a node takes one, a level-1 node `level1_rays`.
    pub link_capacity: u32,
}

/// Link slots for a solve on `ctx` whose nodes could take `slots`: `link_memory` MiB of
/// records of `rays` rays, at most an eighth of device memory and the largest
/// allocation, and no more than `slots`; 0 unless the approximate variant (the only one whose sender
/// read depends on one node: `transport::links`).
pub fn link_capacity(ctx: &Context, p: &SolverParams, slots: usize) -> u32 {
    if p.variant != Variant::Approx || p.link_memory == 0 {
        return 0;
    }
    let mut budget = ((p.link_memory as u64) << 20).min(ctx.info.device_local_bytes / 8);
    if ctx.info.max_allocation_bytes > 0 {
        budget = budget.min(ctx.info.max_allocation_bytes);
    }
    (budget / (p.rays as u64 * LINK_RECORD_BYTES)).min(slots as u64) as u32
}

/// The buffers of the batches in flight; they never leave the device.
pub struct BatchBuffers {
    pub rays: Buffer,
    pub hits: Buffer,
    pub samples: Buffer,
    /// u32 slots `DISPATCH_*` per batch of a device-sized level (`crate::constants`).
    pub dispatch_args: Buffer,
}

/// Every buffer of a solve.
pub struct Resources {
    pub scene: SceneBuffers,
    pub state: NodeState,
    pub batch: BatchBuffers,
    /// What a fused bounce reads back: the level counters, then the energy sums.
    pub readback: Buffer,
    /// The `Globals` block.
    pub globals: Buffer,
}

/// Bytes of the level counters a bounce reads back.
pub const LEVEL_COUNTER_BYTES: u64 = 4 * (COUNTERS_PER_LEVEL * MAX_LEVELS) as u64;
/// Bytes of the energy sums a bounce reads back (un-shot and direct, the first slots).
pub const ENERGY_READ_BYTES: u64 = 4 * (ENERGY_DIRECT as u64 + 1);

fn vec4_bytes(n: usize) -> u64 {
    (n * 16) as u64
}

impl Resources {
    /// Uploads the scene (with its CWBVH for `bvh = "cwbvh"`) and the hierarchy, and
    /// allocates the state for `batch` integrals in flight.
    pub fn new(ctx: &Arc<Context>, scene: &Scene, h: &Hierarchy, p: &SolverParams, batch: u32) -> Result<Resources> {
        let n = h.nodes.len();
        let largest_level = (0..h.levels as usize)
            .map(|l| h.level_range(l).len())
            .max()
            .unwrap_or(0);
        let z = |name: &str, size: u64| Buffer::zeroed(ctx, name, size);
        let device = |name: &str, size: u64| Buffer::new(ctx, name, size, MemoryLocation::GpuOnly);
        let sc = SceneBuffers::upload(ctx, scene, h, p)?;
        // Slots every node could take: one, `level1_rays` on level 1.
        let slots = (0..h.levels)
            .map(|l| h.level_range(l as usize).len() * p.slots_at(l) as usize)
            .sum();
        let links = link_capacity(ctx, p, slots);
        let state = NodeState {
            direct: z("direct", vec4_bytes(n))?,
            direct_err: z("direct error", (n * 4) as u64)?,
            unshot: z("unshot", vec4_bytes(n))?,
            next: z("next", vec4_bytes(n))?,
            indirect: z("indirect", vec4_bytes(n))?,
            pred: z("pred", vec4_bytes(n))?,
            gathered_mean: z("gathered mean", vec4_bytes(n))?,
            gathered_err: z("gathered error", vec4_bytes(n))?,
            active_flag: z("active flags", (n * 4) as u64)?,
            child_flag: z("child flags", (n * 4) as u64)?,
            active_list: z("active", (largest_level.max(1) * 4) as u64)?,
            linked_list: z("linked", (largest_level.max(1) * 4) as u64)?,
            counters: z("counters", 4 * (LIGHT_COUNTERS as u64 + scene.sources() as u64))?,
            energy: z("energy", 4 * ENERGY_SLOTS as u64)?,
            link_slot: device("link slots", (n * 4) as u64)?,
            links: device("links", links as u64 * p.rays as u64 * LINK_RECORD_BYTES)?,
            link_counters: z("link counters", 4 * LINK_COUNTERS as u64)?,
            link_capacity: links,
        };
        // At least one integral of level 1 (`Schedule::gather` sizes its batches to fit).
        let rays_in_flight = (batch as u64 * p.rays as u64).max(p.max_rays() as u64);
        // The active list's batches, then the linked list's (`Schedule::gather`).
        let batches = 2 * (largest_level.div_ceil(batch as usize) as u64 + 1);
        let bb = BatchBuffers {
            rays: device("rays", rays_in_flight * RAY_BYTES)?,
            hits: device("hits", rays_in_flight * HIT_BYTES)?,
            samples: device("samples", rays_in_flight * CONTRIB_BYTES)?,
            dispatch_args: z("dispatch arguments", 4 * DISPATCH_PER_BATCH as u64 * batches)?,
        };
        let readback = Buffer::new(
            ctx,
            "bounce readback",
            LEVEL_COUNTER_BYTES + ENERGY_READ_BYTES,
            MemoryLocation::GpuToCpu,
        )?;
        let g = globals(&sc, &state, &bb, scene, h, p);
        Ok(Resources {
            globals: Buffer::upload(ctx, "globals", bytemuck::bytes_of(&g))?,
            scene: sc,
            state,
            batch: bb,
            readback,
        })
    }
}

impl Resources {
    /// Rewrites `Globals` (after a buffer it names was made anew, or the lights changed).
    pub fn write_globals(&mut self, ctx: &Arc<Context>, scene: &Scene, h: &Hierarchy, p: &SolverParams) -> Result<u64> {
        let g = globals(&self.scene, &self.state, &self.batch, scene, h, p);
        self.globals = Buffer::upload(ctx, "globals", bytemuck::bytes_of(&g))?;
        Ok(std::mem::size_of::<Globals>() as u64)
    }

    /// After an edit of the lights alone: uploads the lights and rewrites `Globals`.
    /// Triangles, BVHs, textures, nodes, kd-trees, clips and relations stay resident.
    /// Returns the bytes uploaded.
    pub fn relight(&mut self, ctx: &Arc<Context>, scene: &Scene, h: &Hierarchy, p: &SolverParams) -> Result<u64> {
        self.scene.lights = Buffer::upload(ctx, "lights", &scene.lights[..])?;
        Ok(self.scene.lights.size + self.write_globals(ctx, scene, h, p)?)
    }

    /// After objects moved: uploads their transforms (`ObjectInfo`). `Globals` must be
    /// written again before a kernel reads them.
    pub fn upload_objects(&mut self, ctx: &Arc<Context>, scene: &Scene, h: &Hierarchy) -> Result<u64> {
        let objects = h.object_infos(scene);
        self.scene.objects = Buffer::upload(ctx, "objects", &objects[..])?;
        Ok(self.scene.objects.size + self.scene.upload_emitters(ctx, scene)?)
    }

    /// Uploads the hierarchy's clips (when they were not computed on the device).
    pub fn upload_clips(&mut self, ctx: &Arc<Context>, h: &Hierarchy) -> Result<u64> {
        self.scene.clips = Buffer::upload(ctx, "support clips", &h.clips[..])?;
        Ok(self.scene.clips.size)
    }

    /// Uploads the parent and child relations. `Globals` must be written again.
    pub fn upload_relations(&mut self, ctx: &Arc<Context>, h: &Hierarchy) -> Result<u64> {
        let sc = &mut self.scene;
        sc.parent_offset = Buffer::upload(ctx, "parent offsets", &h.parent_offset[..])?;
        sc.parents = Buffer::upload(ctx, "parents", &h.parents[..])?;
        sc.child_offset = Buffer::upload(ctx, "child offsets", &h.child_offset[..])?;
        sc.children = Buffer::upload(ctx, "children", &h.children[..])?;
        Ok([&sc.parent_offset, &sc.parents, &sc.child_offset, &sc.children]
            .iter()
            .map(|b| b.size)
            .sum())
    }
}

/// The `Globals` block: every buffer's address and the solve's scalars.
/// The support scale κ and the weight exponent α are the hierarchy's (its clip planes were
/// built with them), not read again from `p`.
fn globals(
    s: &SceneBuffers,
    st: &NodeState,
    b: &BatchBuffers,
    scene: &Scene,
    h: &Hierarchy,
    p: &SolverParams,
) -> Globals {
    use crate::constants::{SKY_CONSTANT, SKY_MAP, SKY_NONE};
    use crate::scene::sky::Sky;
    // (kind, constant radiance, map width, height, turn)
    let (sky_kind, sky_l, sky_width, sky_height, sky_rotate) = match &scene.sky {
        None => (SKY_NONE, glam::Vec3::ZERO, 0, 0, 0.0),
        Some(Sky::Constant(l)) => (SKY_CONSTANT, *l, 0, 0, 0.0),
        Some(Sky::Map(m)) => (SKY_MAP, glam::Vec3::ZERO, m.width as u32, m.height as u32, m.rotate()),
    };
    Globals {
        tris: s.tris.address,
        uvs: s.uvs.address,
        bvh: s.bvh.address,
        cw_nodes: s.cw_nodes.address,
        cw_prims: s.cw_prims.address,
        materials: s.materials.address,
        textures: s.textures.address,
        texels: s.texels.address,
        srgb: s.srgb.address,
        lights: s.lights.address,
        objects: s.objects.address,
        nodes: s.nodes.address,
        splits: s.splits.address,
        clips: s.clips.address,
        sides: s.sides.address,
        parent_offset: s.parent_offset.address,
        parents: s.parents.address,
        child_offset: s.child_offset.address,
        children: s.children.address,
        halton: s.halton.address,
        direct: st.direct.address,
        unshot: st.unshot.address,
        next: st.next.address,
        indirect: st.indirect.address,
        pred: st.pred.address,
        gathered_mean: st.gathered_mean.address,
        gathered_err: st.gathered_err.address,
        active_flag: st.active_flag.address,
        child_flag: st.child_flag.address,
        active_list: st.active_list.address,
        linked_list: st.linked_list.address,
        counters: st.counters.address,
        rays: b.rays.address,
        hits: b.hits.address,
        contrib: b.samples.address,
        energy: st.energy.address,
        dispatch_args: b.dispatch_args.address,
        link_slot: st.link_slot.address,
        links: st.links.address,
        link_counters: st.link_counters.address,
        num_objects: scene.objects.len() as u32,
        num_lights: scene.lights.len() as u32,
        rays_per_integral: p.rays,
        seed: p.seed,
        scene_scale: scene.scale,
        kappa: h.kappa,
        alpha: h.alpha,
        approx_cos: p.approx_cos,
        eps_rel: p.eps_rel,
        eps_abs: p.eps_abs,
        noise_z: p.noise_z,
        levels: h.levels,
        sender_level: p.sender_level,
        link_capacity: st.link_capacity,
        emitters: s.emitters.address,
        emitter_points: s.emitter_points.address,
        sky_texels: s.sky_texels.address,
        sky_rows: s.sky_rows.address,
        sky_cols: s.sky_cols.address,
        sky_prob: s.sky_prob.address,
        direct_err: st.direct_err.address,
        num_emitters: if scene.emitters.any() {
            scene.emitters.list.len() as u32
        } else {
            0
        },
        emitter_samples: scene.emitters.samples() as u32,
        sky_kind,
        sky_width,
        sky_height,
        sky_rotate,
        sky_r: sky_l.x,
        sky_g: sky_l.y,
        sky_b: sky_l.z,
        plane: h.plane,
    }
}
