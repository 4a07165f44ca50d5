//! Median-split kd-tree over the node centres of one level of one object, one node per
//! leaf (paper §4.2). The nodes themselves are reordered; the tree needs no child
//! pointers: the range `[lo, hi)` splits at `mid = (lo + hi) / 2`, and the split plane of
//! that inner node is stored at index `mid` (every `mid` is unique), 8 bytes each.
//! GLSL twins: `kd_range` / `kd_first_leaf` in `glsl/include/hierarchy.glsl`.

use glam::Vec3;

use crate::layout::{KdSplit, Node};

/// Stack entries for traversal: enough for 2^31 nodes.
pub const KD_STACK: usize = crate::constants::KD_STACK as usize;

/// Reorders `nodes` into kd order and fills `splits` (same length). Large ranges build
/// their halves in parallel: the same tree on any number of threads.
pub fn build(nodes: &mut [Node], splits: &mut [KdSplit]) {
    if nodes.len() < 2 {
        return;
    }
    let (mut a, mut b) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for n in nodes.iter() {
        a = a.min(Vec3::from(n.pos));
        b = b.max(Vec3::from(n.pos));
    }
    let ext = b - a;
    let dim = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    // The range [lo, hi) splits at (lo + hi) / 2 = lo + len / 2: local index len / 2.
    let mid = nodes.len() / 2;
    nodes.select_nth_unstable_by(mid, |p, q| p.pos[dim].total_cmp(&q.pos[dim]));
    splits[mid] = KdSplit {
        value: nodes[mid].pos[dim],
        dim: dim as u32,
    };
    let (nl, nr) = nodes.split_at_mut(mid);
    let (sl, sr) = splits.split_at_mut(mid);
    if nl.len() + nr.len() >= 1 << 15 {
        rayon::join(|| build(nl, sl), || build(nr, sr));
    } else {
        build(nl, sl);
        build(nr, sr);
    }
}

/// Near-first traversal of the leaves whose node may lie within `r` of `p`: calls
/// `visit(i)` for each (local index) until it returns `true`.
#[inline]
fn traverse(nodes: &[Node], splits: &[KdSplit], p: Vec3, r: f32, mut visit: impl FnMut(usize) -> bool) {
    let mut stack = [(0u32, 0u32); KD_STACK];
    let mut sp = usize::from(!nodes.is_empty());
    stack[0] = (0, nodes.len() as u32);
    while sp > 0 {
        sp -= 1;
        let (mut lo, mut hi) = stack[sp];
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            let s = splits[mid as usize];
            let d = p[s.dim as usize] - s.value;
            let (near, far) = if d < 0.0 {
                ((lo, mid), (mid, hi))
            } else {
                ((mid, hi), (lo, mid))
            };
            if d.abs() < r {
                stack[sp] = far;
                sp += 1;
            }
            (lo, hi) = near;
        }
        if visit(lo as usize) {
            return;
        }
    }
}

/// Calls `f(i)` for every node `i` (local index) with `|x_i − p| < r`.
#[inline]
pub fn range(nodes: &[Node], splits: &[KdSplit], p: Vec3, r: f32, mut f: impl FnMut(usize)) {
    let r2 = r * r;
    traverse(nodes, splits, p, r, |i| {
        if (Vec3::from(nodes[i].pos) - p).length_squared() < r2 {
            f(i);
        }
        false
    });
}

/// Calls `f(i)`, in ascending order, for every leaf that the descent of [`range`] visits
/// for some point of the box `[lo, hi]` (a superset of the nodes within `r` of any of
/// them): one walk for a group of nearby queries.
#[inline]
pub fn box_leaves(splits: &[KdSplit], lo: Vec3, hi: Vec3, r: f32, mut f: impl FnMut(usize)) {
    let mut stack = [(0u32, 0u32); KD_STACK];
    let mut sp = usize::from(!splits.is_empty());
    stack[0] = (0, splits.len() as u32);
    while sp > 0 {
        sp -= 1;
        let (mut a, mut b) = stack[sp];
        while b - a > 1 {
            let mid = (a + b) / 2;
            let s = splits[mid as usize];
            let dim = s.dim as usize;
            // A point p meets the left side when p - value < r, the right one when
            // value - p < r.
            let left = lo[dim] - s.value < r;
            let right = s.value - hi[dim] < r;
            if left && right {
                stack[sp] = (mid, b);
                sp += 1;
            }
            if left {
                b = mid;
            } else {
                a = mid;
            }
        }
        f(a as usize);
    }
}

/// The first leaf met by a near-first descent for `p` whose node lies within `r` and that
/// `ok(i)` accepts (normal agreement, support clip): the approximate reconstruction
/// (paper §5.1).
#[inline]
pub fn first_leaf(nodes: &[Node], splits: &[KdSplit], p: Vec3, r: f32, ok: impl Fn(usize) -> bool) -> Option<usize> {
    let r2 = r * r;
    let mut found = None;
    traverse(nodes, splits, p, r, |i| {
        if (Vec3::from(nodes[i].pos) - p).length_squared() < r2 && ok(i) {
            found = Some(i);
        }
        found.is_some()
    });
    found
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::rng::Rng;

    fn cloud(n: usize) -> Vec<Node> {
        let mut rng = Rng::new(3, 0);
        (0..n)
            .map(|i| Node {
                pos: [rng.next_f32(), rng.next_f32(), rng.next_f32() * 0.1],
                level: 0,
                normal: [0.0, 0.0, 1.0],
                object: i as u32,
            })
            .collect()
    }

    #[test]
    fn range_matches_brute_force() {
        for n in [1, 2, 3, 7, 100, 1000] {
            let mut nodes = cloud(n);
            let mut splits = vec![KdSplit::default(); n];
            build(&mut nodes, &mut splits);
            let mut rng = Rng::new(9, 1);
            for _ in 0..200 {
                let p = Vec3::new(rng.next_f32(), rng.next_f32(), 0.05);
                let r = rng.next_f32() * 0.3;
                let mut got = Vec::new();
                range(&nodes, &splits, p, r, |i| got.push(i));
                got.sort();
                let want: Vec<usize> = (0..n)
                    .filter(|&i| (Vec3::from(nodes[i].pos) - p).length_squared() < r * r)
                    .collect();
                assert_eq!(got, want);
            }
        }
    }

    #[test]
    fn first_leaf_is_close() {
        let mut nodes = cloud(2000);
        let mut splits = vec![KdSplit::default(); nodes.len()];
        build(&mut nodes, &mut splits);
        let p = Vec3::new(0.5, 0.5, 0.05);
        let up = |i: usize| Vec3::from(nodes[i].normal).dot(Vec3::Z) > 0.5;
        let i = first_leaf(&nodes, &splits, p, 0.2, up).unwrap();
        assert!((Vec3::from(nodes[i].pos) - p).length() < 0.2);
        let down = |i: usize| Vec3::from(nodes[i].normal).dot(-Vec3::Z) > 0.5;
        assert!(first_leaf(&nodes, &splits, p, 0.2, down).is_none());
    }
}
