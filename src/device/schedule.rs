//! The order of the transport's kernels, fills and barriers, written once. The staged
//! `Backend` methods of `GpuBackend` each submit one of these stages; the fused bounce
//! submits [`Schedule::bounce`], the same stages in one command buffer, with the finer
//! levels' batches sized on the device. Tests and production run the same recorders.

use std::ops::Range;

use ash::vk;

use super::kernels::gather::{Batch, GatherPush, Grid};
use super::kernels::{Kernels, Recorder};
use super::resources::{Resources, ENERGY_READ_BYTES, LEVEL_COUNTER_BYTES};
use crate::constants::{COUNTERS_PER_LEVEL, COUNTER_ACTIVATED, COUNTER_LINKED, DISPATCH_PER_BATCH, NONE};
use crate::hierarchy::Hierarchy;
use crate::params::SolverParams;

/// Which integrals a gathered level has, and who knows how many.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Active {
    /// Every node of the level (levels 0 and 1).
    Level,
    /// The first `n` nodes of the active list, `n` known on the host.
    Listed(u32),
    /// The active list, its length in the level above's activated-count counter: as many
    /// batches as the level could need, each sized by the device.
    OnDevice,
}

/// The counter slot of the nodes that level `l`'s refined nodes activated (the active
/// count of level `l + 1`; where `compact` split the set, those without links).
pub fn activated_slot(l: u32) -> u32 {
    COUNTERS_PER_LEVEL * l + COUNTER_ACTIVATED
}

/// The counter slot of the activated nodes of level `l + 1` that hold links, where
/// `compact` split the set (the length of the linked list).
pub fn linked_slot(l: u32) -> u32 {
    COUNTERS_PER_LEVEL * l + COUNTER_LINKED
}

/// What the stages are recorded against.
pub struct Schedule<'a> {
    pub k: &'a Kernels,
    pub res: &'a Resources,
    pub h: &'a Hierarchy,
    /// Integrals per batch (of `p.rays` rays; level 1's batches hold `level1_rays` times
    /// fewer).
    pub batch: u32,
    /// The solve's parameters (rays per integral on each level: `rays_at`).
    pub p: &'a SolverParams,
    /// The delta (original) hierarchy.
    pub delta: bool,
    /// The device's largest x grid.
    pub max_groups_x: u32,
    /// A solve drops the links of the last one (else it reads them: a relighting frame).
    pub reset_links: bool,
    /// The levels `0..linked_levels` whose nodes all hold links (0: none known): their
    /// gathers outside the exact first bounce run kernel `linked` and `reduce` alone.
    pub linked_levels: u32,
}

impl Schedule<'_> {
    fn level(&self, l: u32) -> Range<usize> {
        self.h.level_range(l as usize)
    }

    /// Batches a level of the device's sizing may need, per list.
    fn device_batches(&self, l: u32) -> u32 {
        self.level(l).len().div_ceil(self.batch as usize) as u32
    }

    /// Whether a fused bounce splits the finer levels' active sets into nodes that hold
    /// links (gathered by kernel `linked`) and the others: when its gathers read links.
    fn splits(&self, exact_direct: bool) -> bool {
        self.k.linked.is_some() && self.res.state.link_capacity > 0 && !exact_direct
    }

    /// `E_d` at every node, then the mean direct irradiance (the oracle's scale). A solve
    /// starts here: its links start empty, unless it keeps the last solve's.
    pub fn direct(&self, rec: &mut Recorder) {
        if self.reset_links {
            let st = &self.res.state;
            rec.fill(&st.link_slot, 0, st.link_slot.size, NONE);
            rec.fill(&st.link_counters, 0, st.link_counters.size, 0);
            rec.barrier();
        }
        self.k.direct.record(rec, 0..self.h.nodes.len());
        rec.barrier();
        self.k.energy.record(rec, self.level(0), true);
        rec.barrier();
    }

    /// Un-shot := `E_d` in the variant's representation; indirect := 0.
    pub fn init_unshot(&self, rec: &mut Recorder) {
        let st = &self.res.state;
        rec.fill(&st.indirect, 0, st.indirect.size, 0);
        match &self.k.delta {
            Some(delta) if self.delta => {
                for l in 0..self.h.levels {
                    delta.record(rec, self.level(l), l, true);
                    rec.barrier();
                }
            }
            _ => {
                let bytes = 16 * self.h.nodes.len() as u64;
                rec.copy(&st.direct, &st.unshot, &[vk::BufferCopy::default().size(bytes)]);
            }
        }
        rec.barrier();
    }

    /// The gathering integrals of level `l`, batch by batch; with `exact_direct` the hits
    /// read the exact direct irradiance (the first bounce under `exact_first_bounce`).
    pub fn gather(&self, rec: &mut Recorder, l: u32, active: Active, exact_direct: bool) {
        let r = self.level(l);
        rec.fill(&self.res.state.active_flag, 4 * r.start as u64, 4 * r.len() as u64, 0);
        rec.barrier();
        let base = GatherPush {
            globals: rec.globals,
            first: r.start as u32,
            count: 0,
            batch_first: 0,
            from_list: (active != Active::Level) as u32,
            count_slot: NONE,
            exact_direct: exact_direct as u32,
            rays: self.p.rays_at(l),
            pad0: 0,
        };
        // Every node of the level reads its links: no ray, no search (`linked.comp`).
        let linked = active == Active::Level && l < self.linked_levels && !exact_direct;
        match active {
            Active::Level | Active::Listed(_) => {
                let count = match active {
                    Active::Listed(n) => n,
                    _ => r.len() as u32,
                };
                // The rays buffer holds `batch · rays` rays (at least one integral's).
                let per_batch = (self.batch / self.p.slots_at(l)).max(1);
                let mut first = 0;
                while first < count {
                    let n = per_batch.min(count - first);
                    let push = GatherPush {
                        count: n,
                        batch_first: first,
                        ..base
                    };
                    self.gather_batch(rec, &Batch { push, grid: Grid::Host }, linked);
                    first += n;
                }
            }
            Active::OnDevice => {
                // The active list's batches, then (where `compact` split the set) the
                // linked list's, whose grids follow in the argument buffer.
                let nb = self.device_batches(l);
                let lists: &[(u32, u32, bool)] = if self.splits(exact_direct) {
                    &[(1, activated_slot(l - 1), false), (2, linked_slot(l - 1), true)]
                } else {
                    &[(1, activated_slot(l - 1), false)]
                };
                for (k, &(from_list, count_slot, linked)) in lists.iter().enumerate() {
                    for b in 0..nb {
                        let push = GatherPush {
                            count: self.batch,
                            batch_first: b * self.batch,
                            from_list,
                            count_slot,
                            ..base
                        };
                        let grid = Grid::Device {
                            args: &self.res.batch.dispatch_args,
                            at: 4 * (DISPATCH_PER_BATCH * (k as u32 * nb + b)) as u64,
                        };
                        self.gather_batch(rec, &Batch { push, grid }, linked);
                    }
                }
            }
        }
    }

    /// One batch's kernels; `linked`: its integrals all read links.
    fn gather_batch(&self, rec: &mut Recorder, b: &Batch, linked: bool) {
        match (&self.k.linked, linked) {
            (Some(k), true) => {
                k.record(rec, b);
                rec.barrier();
            }
            _ => {
                self.k.hemisphere.record(rec, b);
                rec.barrier();
                self.k.trace.record(rec, b);
                rec.barrier();
                self.k.reconstruct.record(rec, b);
                rec.barrier();
            }
        }
        self.k.reduce.record(rec, b);
        rec.barrier();
    }

    /// Prediction, oracle and new values of level `l`; with `activate`, the next level's
    /// active set (the sparse children of lit nodes with `sparse > 0`; and, with
    /// `next_on_device`, its batches' grids, the set split into the nodes that hold links
    /// and the others where the bounce reads links, `split`).
    pub fn refine(&self, rec: &mut Recorder, l: u32, activate: bool, sparse: u32, next_on_device: bool, split: bool) {
        let r = self.level(l);
        let next = if activate { self.level(l + 1) } else { 0..0 };
        let st = &self.res.state;
        let per_level = 4 * COUNTERS_PER_LEVEL as u64;
        rec.fill(&st.counters, per_level * l as u64, per_level, 0);
        rec.fill(&st.child_flag, 4 * next.start as u64, 4 * next.len() as u64, 0);
        if l >= 1 {
            match (&self.k.delta, &self.k.pulldown) {
                (Some(delta), _) if self.delta => delta.record(rec, r.clone(), l, false),
                (_, Some(pulldown)) => pulldown.record(rec, r.clone(), false),
                _ => {}
            }
        }
        rec.barrier();
        let sparse = if self.delta { 0 } else { sparse };
        self.k.oracle.record(rec, r, l, activate, sparse);
        rec.barrier();
        if activate {
            let split = split && next_on_device;
            self.k.compact.record(rec, next.clone(), l, split);
            rec.barrier();
            if next_on_device {
                let nb = self.device_batches(l + 1);
                let x = self.max_groups_x;
                self.k.batches.record(rec, nb, self.batch, activated_slot(l), x, 0);
                if split {
                    self.k.batches.record(rec, nb, self.batch, linked_slot(l), x, nb);
                }
                rec.indirect_barrier();
            }
        }
    }

    /// Levels `from..` without integrals: pull-down (absolute) or zero deltas.
    pub fn fill(&self, rec: &mut Recorder, from: u32) {
        for l in from..self.h.levels {
            let r = self.level(l);
            match &self.k.pulldown {
                Some(pulldown) if !self.delta => pulldown.record(rec, r, true),
                _ => rec.fill(&self.res.state.next, 16 * r.start as u64, 16 * r.len() as u64, 0),
            }
            rec.barrier();
        }
    }

    /// Indirect += new; un-shot := new; the stop criterion's energies.
    pub fn end_bounce(&self, rec: &mut Recorder) {
        self.k.accumulate.record(rec, 0..self.h.nodes.len());
        rec.barrier();
        self.k.energy.record(rec, self.level(0), false);
        rec.barrier();
    }

    /// A whole bounce gathering levels `0..g`: levels 0 and 1 in batches of known size,
    /// the finer ones in as many device-sized batches as they could need; then the level
    /// counters and energies are copied for the host ([`Resources::readback`]).
    pub fn bounce(&self, rec: &mut Recorder, g: u32, exact_direct: bool, sparse: u32) {
        for l in 0..g {
            let active = if l <= 1 { Active::Level } else { Active::OnDevice };
            self.gather(rec, l, active, exact_direct);
            self.refine(rec, l, l >= 1 && l + 1 < g, sparse, true, self.splits(exact_direct));
        }
        self.fill(rec, g);
        self.end_bounce(rec);
        let st = &self.res.state;
        rec.copy(
            &st.counters,
            &self.res.readback,
            &[vk::BufferCopy::default().size(LEVEL_COUNTER_BYTES)],
        );
        rec.copy(
            &st.energy,
            &self.res.readback,
            &[vk::BufferCopy::default()
                .dst_offset(LEVEL_COUNTER_BYTES)
                .size(ENERGY_READ_BYTES)],
        );
        rec.host_barrier();
    }
}
