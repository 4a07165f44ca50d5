//! The parent and child relations (`ALGORITHM.md` §3.7): per child, the nodes of the level
//! above whose weight is positive at its centre and whose clips admit it, with the
//! pull-down weights `B_p^l(x_c)` (normalised), as CSR; and the children, the inverse
//! relation. GLSL twin: `glsl/relations.comp` (`crate::device::arrange`).

use glam::Vec3;
use rayon::prelude::*;

use super::weight::{clip_ok, node_weight};
use super::{kdtree, Hierarchy};
use crate::layout::Parent;

/// The parent lists of a run of consecutive children ([`Hierarchy::parents_of_group`]):
/// concatenated, with each child's length and the holes among them per level.
struct GroupParents {
    parents: Vec<Parent>,
    lens: Vec<u32>,
    holes: Vec<u32>,
    /// Scratch: the parent-level nodes near the current group, their positions by
    /// coordinate (a child's distances to all of them in one vectorised loop), and the
    /// ones within the support of the current child.
    near: Vec<u32>,
    near_x: Vec<f32>,
    near_y: Vec<f32>,
    near_z: Vec<f32>,
    within: Vec<u32>,
}

impl Hierarchy {
    /// The parent lists of `children`, consecutive nodes of one object and level `l ≥ 1`
    /// (a marked child's when `dirty` is given; the others keep theirs): the nodes of level
    /// `l − 1` with `w_j > 0` whose clips admit the child, in ascending order, normalised;
    /// where none, the nearest same-side node (a hole). The nodes a child's own kd descent
    /// would find ([`Self::for_each_weight`]), through one walk over the group's bounds
    /// (GLSL twin: `weights` in `glsl/relations.comp`).
    fn parents_of_group(&self, children: std::ops::Range<usize>, dirty: Option<&[bool]>, out: &mut GroupParents) {
        let first = &self.nodes[children.start];
        let (o, l) = (first.object as usize, first.level as usize - 1);
        let todo = |c: usize| dirty.is_none_or(|d| d[c]);
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for c in children.clone().filter(|&c| todo(c)) {
            lo = lo.min(Vec3::from(self.nodes[c].pos));
            hi = hi.max(Vec3::from(self.nodes[c].pos));
        }
        let (nodes, splits, base) = self.level(o, l);
        let h = self.support(o, l);
        // The nodes near the group, their positions packed for the children's scans.
        out.near.clear();
        out.near_x.clear();
        out.near_y.clear();
        out.near_z.clear();
        if lo.x <= hi.x {
            // A loose prefilter (its margin covers the rounding of `lo - h`); the exact
            // test is the distance below.
            let m = 1.01 * h + 1e-6 * lo.abs().max(hi.abs()).max_element();
            kdtree::box_leaves(splits, lo, hi, h, |i| {
                let x = Vec3::from(nodes[i].pos);
                if x.cmpgt(lo - m).all() && x.cmplt(hi + m).all() {
                    out.near.push(i as u32);
                    out.near_x.push(x.x);
                    out.near_y.push(x.y);
                    out.near_z.push(x.z);
                }
            });
        }
        let r2 = h * h;
        for c in children {
            let at = out.parents.len();
            if !todo(c) {
                out.parents.extend_from_slice(self.parents_of(c));
                out.lens.push((out.parents.len() - at) as u32);
                continue;
            }
            let nd = &self.nodes[c];
            let (p, nrm) = (Vec3::from(nd.pos), Vec3::from(nd.normal));
            // The near nodes within the support, in order: `(x − p)²` as
            // `length_squared` sums it, for all at once, then compacted without branches.
            let k = out.near.len();
            out.within.clear();
            out.within.resize(k, 0);
            let mut m = 0;
            for (j, ((&x, &y), &z)) in out.near_x.iter().zip(&out.near_y).zip(&out.near_z).enumerate() {
                let (dx, dy, dz) = (x - p.x, y - p.y, z - p.z);
                out.within[m] = j as u32;
                m += usize::from(dx * dx + dy * dy + dz * dz < r2);
            }
            let mut sum = 0.0f32;
            for &j in &out.within[..m] {
                let i = out.near[j as usize];
                let x = Vec3::new(out.near_x[j as usize], out.near_y[j as usize], out.near_z[j as usize]);
                let nn = Vec3::from(nodes[i as usize].normal);
                let w = node_weight(p, nrm, x, nn, h, self.alpha);
                if w > 0.0 && clip_ok(&self.clips[base + i as usize], p - x, nn, h) {
                    out.parents.push(Parent {
                        node: (base + i as usize) as u32,
                        weight: w,
                    });
                    sum += w;
                }
            }
            if sum > 0.0 {
                for q in &mut out.parents[at..] {
                    q.weight /= sum;
                }
            } else if let Some(j) = self.nearest_same_side(o, l, p, nrm) {
                out.parents.push(Parent {
                    node: j as u32,
                    weight: 1.0,
                });
                out.holes[l + 1] += 1;
            }
            out.lens.push((out.parents.len() - at) as u32);
        }
    }

    /// The parent and child relations; with `dirty`, only the marked children's parent
    /// lists are computed again (the others keep theirs). In steps: the children in
    /// groups, each group's parent lists, their lengths into the CSR offsets, the lists
    /// concatenated into place, and the inverse relation.
    pub(super) fn build_relations(&mut self, dirty: Option<&[bool]>) {
        let groups = self.child_groups();
        let lists = self.group_parent_lists(&groups, dirty);
        let (lens, holes) = self.parent_counts(&lists);
        let orphans = self.set_parent_offsets(&lens);
        let total = self.parent_offset[self.nodes.len()] as usize;
        self.parents = concat_parents(&lists, total);
        self.stats.parent_holes_per_level = holes;
        self.stats.orphans_per_level = orphans;
        self.build_children();
    }

    /// Groups of up to GROUP consecutive children of one (object, level): neighbours in
    /// kd order, so one kd walk over their bounds serves them all. In node order, so
    /// that their lists concatenate into the CSR (level 0 has none).
    fn child_groups(&self) -> Vec<std::ops::Range<usize>> {
        let m = self.levels as usize;
        const GROUP: usize = 16;
        let mut groups = Vec::new();
        for ol in &self.objects {
            for l in 1..m {
                let s = ol.start[l] as usize;
                let e = s + ol.count[l] as usize;
                groups.extend((s..e).step_by(GROUP).map(|a| a..(a + GROUP).min(e)));
            }
        }
        groups.sort_by_key(|g| g.start);
        groups
    }

    /// The parent lists of `groups` ([`Self::parents_of_group`]), in parallel: the groups
    /// tile the nodes after level 0 in order; runs of them fill one output.
    fn group_parent_lists(&self, groups: &[std::ops::Range<usize>], dirty: Option<&[bool]>) -> Vec<GroupParents> {
        let m = self.levels as usize;
        groups
            .par_chunks(64)
            .map(|run| {
                let mut out = GroupParents {
                    parents: Vec::new(),
                    lens: Vec::new(),
                    holes: vec![0; m],
                    near: Vec::new(),
                    near_x: Vec::new(),
                    near_y: Vec::new(),
                    near_z: Vec::new(),
                    within: Vec::new(),
                };
                for g in run {
                    self.parents_of_group(g.clone(), dirty, &mut out);
                }
                out
            })
            .collect()
    }

    /// Every node's parent count, in node order, and the holes per level, from the runs'
    /// lists.
    fn parent_counts(&self, lists: &[GroupParents]) -> (Vec<u32>, Vec<u32>) {
        let m = self.levels as usize;
        let mut holes = vec![0u32; m];
        // Level 0 has no parents.
        let mut lens = vec![0u32; self.level_start[1] as usize];
        for g in lists {
            for (a, b) in holes.iter_mut().zip(&g.holes) {
                *a += b;
            }
            lens.extend_from_slice(&g.lens);
        }
        debug_assert_eq!(lens.len(), self.nodes.len());
        (lens, holes)
    }

    /// The parents' CSR offsets from every node's parent count `lens`; returns the orphans
    /// per level (children with no parent).
    fn set_parent_offsets(&mut self, lens: &[u32]) -> Vec<u32> {
        let n = self.nodes.len();
        let m = self.levels as usize;
        let mut orphans = vec![0u32; m];
        self.parent_offset = Vec::with_capacity(n + 1);
        let mut acc = 0u32;
        for (c, &k) in lens.iter().enumerate() {
            let l = self.nodes[c].level as usize;
            if k == 0 && l > 0 {
                orphans[l] += 1;
            }
            self.parent_offset.push(acc);
            acc += k;
        }
        self.parent_offset.push(acc);
        orphans
    }

    /// Children: the inverse relation, in ascending order.
    fn build_children(&mut self) {
        let n = self.nodes.len();
        let mut counts = vec![0u32; n + 1];
        for q in &self.parents {
            counts[q.node as usize] += 1;
        }
        self.child_offset = Vec::with_capacity(n + 1);
        let mut acc = 0;
        for c in &counts[..n] {
            self.child_offset.push(acc);
            acc += c;
        }
        self.child_offset.push(acc);
        let mut fill = self.child_offset.clone();
        self.children = vec![0; acc as usize];
        for c in 0..n {
            for q in &self.parents[self.parent_offset[c] as usize..self.parent_offset[c + 1] as usize] {
                let k = &mut fill[q.node as usize];
                self.children[*k as usize] = c as u32;
                *k += 1;
            }
        }
    }

    /// Parents of node `c`.
    #[inline]
    pub fn parents_of(&self, c: usize) -> &[Parent] {
        &self.parents[self.parent_offset[c] as usize..self.parent_offset[c + 1] as usize]
    }

    /// Children of node `p`.
    #[inline]
    pub fn children_of(&self, p: usize) -> &[u32] {
        &self.children[self.child_offset[p] as usize..self.child_offset[p + 1] as usize]
    }
}

/// The runs' parent lists concatenated (`total` in all, the last CSR offset), copied into
/// place in parallel.
fn concat_parents(lists: &[GroupParents], total: usize) -> Vec<Parent> {
    let mut parents: Vec<Parent> = Vec::with_capacity(total);
    let mut rest = &mut parents.spare_capacity_mut()[..total];
    let mut parts = Vec::with_capacity(lists.len());
    for g in lists {
        let (part, tail) = std::mem::take(&mut rest).split_at_mut(g.parents.len());
        parts.push((part, &g.parents));
        rest = tail;
    }
    parts.into_par_iter().for_each(|(dst, src)| {
        for (d, q) in dst.iter_mut().zip(src) {
            d.write(*q);
        }
    });
    // SAFETY: the runs' parts tile the first `total` slots (their lengths sum to
    // `total`, the last offset), and every slot of each part was written above.
    unsafe { parents.set_len(total) };
    parents
}
