//! What depends on where the objects are, computed on the device where the transport
//! runs (`ALGORITHM.md` §3.3, §3.8): the support clips (kernel `clips`) and the parent
//! and child relations (kernels `relations` and `scan`), for a whole hierarchy or, after
//! objects moved, for the nodes the move can change. The twin of
//! [`Hierarchy::arrange`] / [`Hierarchy::rearrange`]; the host keeps a copy of the result
//! (the changed clips and the relations come back), so that outputs, probes and stats
//! read the same hierarchy the device solved with.
//!
//! Data flow: up go the moved objects' boxes and flags (bytes); the clips are written in
//! place on the device; the relations are built into new buffers (one readback of their
//! size between the two submissions) and replace the old ones.

use std::sync::Arc;
use std::time::Instant;

use gpu_allocator::MemoryLocation;

use super::kernels::clips::{Clips, ClipsPush, ALL};
use super::kernels::relations::{self, Relations, RelationsPush};
use super::kernels::scan::Scan;
use super::kernels::submit;
use super::resources::Resources;
use crate::constants::MAX_LEVELS;
use crate::error::Result;
use crate::gpu::buffer::Buffer;
use crate::gpu::context::Context;
use crate::gpu::pipeline::Specialization;
use crate::gpu::profiler::Profiler;
use crate::hierarchy::weight::{Clip, NO_CLIP};
use crate::hierarchy::{ClipSelection, Hierarchy};
use crate::layout::Parent;
use crate::params::SolverParams;
use crate::progress::Progress;
use crate::scene::Scene;

/// The arrangement's pipelines.
pub struct ArrangeKernels {
    clips: Clips,
    relations: Relations,
    scan: Scan,
}

impl ArrangeKernels {
    pub fn new(ctx: &Arc<Context>, spec: Specialization) -> Result<ArrangeKernels> {
        Ok(ArrangeKernels {
            clips: Clips::new(ctx, spec)?,
            relations: Relations::new(ctx, spec)?,
            scan: Scan::new(ctx, spec)?,
        })
    }
}

/// The device an arrangement runs on: its context, the arrangement's pipelines, the
/// profiler that times them, and the solve's resident buffers.
pub struct Device<'a> {
    pub ctx: &'a Arc<Context>,
    pub kernels: &'a ArrangeKernels,
    pub prof: &'a mut Profiler,
    pub res: &'a mut Resources,
}

/// What an arrangement on the device did.
#[derive(Clone, Copy, Debug, Default)]
pub struct Arranged {
    /// Support clips computed (every node's for a whole arrangement).
    pub clips_computed: usize,
    /// Parent lists computed (the others were kept).
    pub parents_computed: usize,
    /// Bytes sent to the device (selection; not the transforms).
    pub bytes_up: u64,
    /// Bytes read back (changed clips, relations, counts).
    pub bytes_down: u64,
}

/// Brings `h` and its copy on the device (`d.res`, whose `Globals` name the objects as
/// `scene` places them) to `scene`'s arrangement: the clips of the nodes `sel` selects,
/// and the relations: all of them for [`ClipSelection::All`] (a hierarchy from
/// [`Hierarchy::build_unarranged`], or a move that changed the scene's bounds), else the
/// lists of the children a changed clip weighs and of those with at most one parent.
/// The result is what [`Hierarchy::arrange`] gives, but for the float rounding of the
/// device; on one device, a rearrangement is exactly the whole arrangement's result.
/// Rewrites `Globals`.
pub fn arrange(
    d: &mut Device,
    scene: &Scene,
    h: &mut Hierarchy,
    p: &SolverParams,
    sel: &ClipSelection,
    progress: &Progress,
) -> Result<Arranged> {
    let n = h.nodes.len();
    let mut out = Arranged::default();
    let all = matches!(sel, ClipSelection::All) || !p.support_clip;
    let changed = Buffer::zeroed(d.ctx, "changed clips", 4 * n as u64)?;

    let t = Instant::now();
    progress.stage("support clipping");
    if p.support_clip {
        let c = clips(d, scene, h, sel, &changed)?;
        out.clips_computed = c.computed;
        out.bytes_up += c.bytes_up;
        out.bytes_down += c.bytes_down;
        for (i, c) in c.changed {
            h.clips[i] = c;
        }
    } else {
        h.clips = vec![NO_CLIP; n];
        d.res.upload_clips(d.ctx, h)?;
        d.res.write_globals(d.ctx, scene, h, p)?;
        out.bytes_up += 16 * n as u64;
        out.clips_computed = n;
    }
    h.stats.seconds_clips = t.elapsed().as_secs_f64();
    h.stats.clipped_nodes = h.clips.iter().filter(|c| **c != NO_CLIP).count();

    let t = Instant::now();
    progress.stage("parent relations");
    let (computed, down) = relations(d, scene, h, p, all, &changed)?;
    out.parents_computed = computed;
    out.bytes_down += down;
    h.stats.seconds_parents = t.elapsed().as_secs_f64();
    Ok(out)
}

/// What kernel `clips` gave back.
struct ClipsOut {
    /// Nodes selected.
    computed: usize,
    /// The changed clips, in node order.
    changed: Vec<(usize, Clip)>,
    bytes_up: u64,
    bytes_down: u64,
}

/// Kernel `clips` over the selection; `changed` gets a flag per changed clip.
fn clips(d: &mut Device, scene: &Scene, h: &Hierarchy, sel: &ClipSelection, changed: &Buffer) -> Result<ClipsOut> {
    let ctx = d.ctx;
    let n = h.nodes.len();
    let (boxes, moved, eps) = match sel {
        ClipSelection::All => (Vec::new(), vec![0u32; scene.objects.len()], 0.0),
        ClipSelection::Near { moved, boxes, eps } => (
            boxes
                .iter()
                .flat_map(|(lo, hi)| [lo.extend(0.0), hi.extend(0.0)])
                .collect::<Vec<glam::Vec4>>(),
            moved.iter().map(|&m| m as u32).collect(),
            *eps,
        ),
    };
    let box_list = Buffer::upload(ctx, "clip boxes", &boxes[..])?;
    let moved_flags = Buffer::upload(ctx, "moved objects", &moved[..])?;
    let out_nodes = Buffer::new(ctx, "changed clip nodes", 4 * n as u64, MemoryLocation::GpuOnly)?;
    let out_clips = Buffer::new(ctx, "changed clip records", 16 * n as u64, MemoryLocation::GpuOnly)?;
    let out_count = Buffer::zeroed(ctx, "clip counts", 8)?;
    let push = ClipsPush {
        box_list: box_list.address,
        moved: moved_flags.address,
        out_nodes: out_nodes.address,
        out_clips: out_clips.address,
        out_count: out_count.address,
        changed: changed.address,
        count: n as u32,
        boxes: match sel {
            ClipSelection::All => ALL,
            ClipSelection::Near { boxes, .. } => boxes.len() as u32,
        },
        eps,
        ..Default::default()
    };
    submit(ctx, d.prof, d.res.globals.address, |rec| {
        d.kernels.clips.record(rec, &push)
    })?;
    let counts: Vec<u32> = out_count.download(0, 2)?;
    let (computed, m) = (counts[0] as usize, counts[1] as usize);
    let nodes: Vec<u32> = out_nodes.download(0, m)?;
    let records: Vec<[u32; 4]> = out_clips.download(0, m)?;
    let mut v: Vec<(usize, Clip)> = nodes
        .into_iter()
        .zip(records)
        .map(|(j, c)| (j as usize, bytemuck::cast(c)))
        .collect();
    v.sort_unstable_by_key(|(j, _)| *j);
    Ok(ClipsOut {
        computed,
        changed: v,
        bytes_up: box_list.size + moved_flags.size,
        bytes_down: 8 + 20 * m as u64,
    })
}

/// Kernels `relations` and `scan`: the relations built on the device into new buffers
/// that replace `res`'s, and copied into `h` with their stats. Returns (lists computed,
/// bytes down).
fn relations(
    d: &mut Device,
    scene: &Scene,
    h: &mut Hierarchy,
    p: &SolverParams,
    all: bool,
    changed: &Buffer,
) -> Result<(usize, u64)> {
    let (ctx, k) = (d.ctx, d.kernels);
    let (prof, res) = (&mut *d.prof, &mut *d.res);
    let n = h.nodes.len();
    let words = |name: &str, count: usize| Buffer::zeroed(ctx, name, 4 * count as u64);
    let new_offset = words("parent offsets", n + 1)?;
    let child_offset = words("child offsets", n + 1)?;
    let dirty = words("dirty parent lists", n)?;
    let cursor = words("child cursors", n)?;
    let stats = words("relation counts", 2 * MAX_LEVELS as usize + 1)?;
    let sums = words("scan sums", Scan::blocks(n as u64 + 1) as usize)?;
    let mut push = RelationsPush {
        old_offset: res.scene.parent_offset.address,
        old_parents: res.scene.parents.address,
        new_offset: new_offset.address,
        child_offset: child_offset.address,
        dirty: dirty.address,
        changed: changed.address,
        cursor: cursor.address,
        stats: stats.address,
        count: n as u32,
        all: all as u32,
        ..Default::default()
    };
    let globals = res.globals.address;
    // The lists' lengths, scanned into offsets: the last one is their total.
    submit(ctx, prof, globals, |rec| {
        if !all {
            k.relations.record(rec, &push, relations::MARK);
            rec.barrier();
        }
        k.relations.record(rec, &push, relations::COUNT);
        rec.barrier();
        k.scan.record(rec, new_offset.address, sums.address, n as u32 + 1);
    })?;
    let total = new_offset.download::<u32>(n, 1)?[0] as usize;
    let new_parents = Buffer::new(
        ctx,
        "parents",
        (total * std::mem::size_of::<Parent>()) as u64,
        MemoryLocation::GpuOnly,
    )?;
    let children = Buffer::new(ctx, "children", 4 * total as u64, MemoryLocation::GpuOnly)?;
    push.new_parents = new_parents.address;
    push.children = children.address;
    submit(ctx, prof, globals, |rec| {
        k.relations.record(rec, &push, relations::FILL);
        rec.barrier();
        k.relations.record(rec, &push, relations::CHILD_COUNT);
        rec.barrier();
        k.scan.record(rec, child_offset.address, sums.address, n as u32 + 1);
        k.relations.record(rec, &push, relations::CHILD_FILL);
        rec.barrier();
        k.relations.record(rec, &push, relations::CHILD_SORT);
    })?;
    let counts: Vec<u32> = stats.download(0, 2 * MAX_LEVELS as usize + 1)?;
    let m = h.levels as usize;
    h.stats.parent_holes_per_level = counts[..m].to_vec();
    h.stats.orphans_per_level = counts[MAX_LEVELS as usize..][..m].to_vec();
    let computed = counts[2 * MAX_LEVELS as usize] as usize;
    // The host's copy: what outputs, probes and checks read.
    h.parent_offset = new_offset.download(0, n + 1)?;
    h.parents = new_parents.download(0, total)?;
    h.child_offset = child_offset.download(0, n + 1)?;
    h.children = children.download(0, total)?;
    let down = 4 + 4 * (2 * MAX_LEVELS as u64 + 1) + (8 * (n as u64 + 1)) + 12 * total as u64;
    let sc = &mut res.scene;
    sc.parent_offset = new_offset;
    sc.parents = new_parents;
    sc.child_offset = child_offset;
    sc.children = children;
    res.write_globals(ctx, scene, h, p)?;
    Ok((computed, down))
}
