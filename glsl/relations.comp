// Kernel `relations`: the parent and child relations (ALGORITHM.md §3.4) built on the
// device, in CSR as the host's (hierarchy::Hierarchy::build_relations), one mode per
// dispatch (pc.mode), one thread per node:
//   MARK        a node whose clip changed (pc.changed) marks the children within its
//               support (pc.dirty): their parent weights may change;
//   COUNT       per child, whether its list is computed again (every list with pc.all;
//               else a marked child or one with at most one parent: holes and orphans
//               are found by a wider search), and its length into pc.new_offset (then
//               scanned: kernel `scan`);
//   FILL        the lists: kept ones copied from pc.old_offset / pc.old_parents, the
//               others the children's Shepard weights of the level above, normalised, or
//               the nearest same-side parent (a hole), counting holes and orphans per
//               level in pc.stats;
//   CHILD_COUNT, CHILD_FILL, CHILD_SORT   the inverse relation: counted, scanned, filled
//               through per-parent cursors, each parent's children sorted ascending.
// CPU twin: Hierarchy::{for_each_weight, nearest_same_side, build_relations, rearrange}.
#version 460
#include "layout.glsl"
#include "hierarchy.glsl"

// Push constants: src/gpu/kernels/relations.rs `RelationsPush`.
layout(push_constant) uniform RelationsPush {
    GlobalsRef g;
    UintRef old_offset; // the relations being replaced (read unless pc.all)
    ParentRef old_parents;
    UintRef new_offset; // n + 1 words: lengths, then (scanned) offsets
    ParentRef new_parents;
    UintRef child_offset; // n + 1 words: counts, then (scanned) offsets
    UintRef children;
    UintRef dirty; // per node: its list is computed again
    UintRef changed; // per node: its clip changed
    UintRef cursor; // per node: children placed so far
    UintRef stats; // holes per level, orphans per level, lists computed
    uint count; // nodes
    uint mode;
    uint all; // every list is computed again
    uint pad0;
} pc;

layout(local_size_x = LINEAR_GROUP) in;

const uint MARK = 0u;
const uint COUNT = 1u;
const uint FILL = 2u;
const uint CHILD_COUNT = 3u;
const uint CHILD_FILL = 4u;
const uint CHILD_SORT = 5u;

// The nodes of level l of `ob` with w > 0 admitted by their clips at (p, n), in ascending
// order (Hierarchy::parents_of_group): counted, summed, and with `write` stored from `at`.
uint weights(GlobalsRef g, ObjectInfo ob, uint l, vec3 p, vec3 n, bool write, uint at, out float sum) {
    uint base = ob.level_start[l];
    uint count = ob.level_count[l];
    float h = g.kappa * ob.radius[l];
    float r2 = h * h;
    NodeRef nodes = g.nodes;
    KdSplitRef splits = g.splits;
    uvec2 stack[KD_STACK];
    uint sp = count > 0u ? 1u : 0u;
    stack[0] = uvec2(0u, count);
    uint k = 0u;
    sum = 0.0;
    while (sp > 0u) {
        sp--;
        uint lo = stack[sp].x;
        uint hi = stack[sp].y;
        while (hi - lo > 1u) {
            uint mid = (lo + hi) / 2u;
            KdSplit s = splits.v[base + mid];
            float d = p[s.dim] - s.value;
            // The leaves the near-first descent visits, in ascending order (the host's
            // Hierarchy::parents_of_group): the left side is met when d < h, the right
            // one when -d < h.
            bool left = d < h;
            bool right = -d < h;
            if (left && right) {
                stack[sp] = uvec2(mid, hi);
                sp++;
            }
            if (left) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        Node nd = nodes.v[base + lo];
        vec3 dx = nd.pos - p;
        if (dot(dx, dx) < r2) {
            float w = node_weight(p, n, nd.pos, nd.normal, h, g.alpha);
            if (w > 0.0 && clip_ok(g.clips.v[base + lo], p - nd.pos, nd.normal, h)) {
                if (write) {
                    pc.new_parents.v[at + k] = Parent(base + lo, w);
                }
                sum += w;
                k++;
            }
        }
    }
    return k;
}

// The nearest node of level l of `ob` on the side of n whose clip admits p, searched
// within a radius doubling from the support (Hierarchy::nearest_same_side); NONE if none.
uint nearest_same_side(GlobalsRef g, ObjectInfo ob, uint l, vec3 p, vec3 n) {
    uint base = ob.level_start[l];
    uint count = ob.level_count[l];
    float h = g.kappa * ob.radius[l];
    float r = h;
    NodeRef nodes = g.nodes;
    KdSplitRef splits = g.splits;
    uint best = NONE;
    for (uint it = 0u; it < 40u && best == NONE && count > 0u; it++) {
        float r2 = r * r;
        float best_d = 3.0e38;
        uvec2 stack[KD_STACK];
        uint sp = 1u;
        stack[0] = uvec2(0u, count);
        while (sp > 0u) {
            sp--;
            uint lo = stack[sp].x;
            uint hi = stack[sp].y;
            while (hi - lo > 1u) {
                uint mid = (lo + hi) / 2u;
                KdSplit s = splits.v[base + mid];
                float d = p[s.dim] - s.value;
                uvec2 near_ = d < 0.0 ? uvec2(lo, mid) : uvec2(mid, hi);
                uvec2 far_ = d < 0.0 ? uvec2(mid, hi) : uvec2(lo, mid);
                if (abs(d) < r) {
                    stack[sp] = far_;
                    sp++;
                }
                lo = near_.x;
                hi = near_.y;
            }
            Node nd = nodes.v[base + lo];
            vec3 dx = nd.pos - p;
            float d2 = dot(dx, dx);
            if (d2 < r2 && dot(n, nd.normal) > 0.0 && d2 < best_d &&
                clip_ok(g.clips.v[base + lo], p - nd.pos, nd.normal, h)) {
                best_d = d2;
                best = base + lo;
            }
        }
        r *= 2.0;
    }
    return best;
}

// A node whose clip changed marks the children (level l + 1) within its support.
void mark(GlobalsRef g, uint j) {
    if (pc.changed.v[j] == 0u) {
        return;
    }
    Node nd = g.nodes.v[j];
    if (nd.level + 1u >= g.levels) {
        return;
    }
    ObjectInfo ob = g.objects.v[nd.object];
    uint l = nd.level + 1u;
    uint base = ob.level_start[l];
    uint count = ob.level_count[l];
    float r = g.kappa * ob.radius[nd.level] * 1.0001;
    float r2 = r * r;
    vec3 p = nd.pos;
    uvec2 stack[KD_STACK];
    uint sp = count > 0u ? 1u : 0u;
    stack[0] = uvec2(0u, count);
    while (sp > 0u) {
        sp--;
        uint lo = stack[sp].x;
        uint hi = stack[sp].y;
        while (hi - lo > 1u) {
            uint mid = (lo + hi) / 2u;
            KdSplit s = g.splits.v[base + mid];
            float d = p[s.dim] - s.value;
            uvec2 near_ = d < 0.0 ? uvec2(lo, mid) : uvec2(mid, hi);
            uvec2 far_ = d < 0.0 ? uvec2(mid, hi) : uvec2(lo, mid);
            if (abs(d) < r) {
                stack[sp] = far_;
                sp++;
            }
            lo = near_.x;
            hi = near_.y;
        }
        vec3 dx = g.nodes.v[base + lo].pos - p;
        if (dot(dx, dx) < r2) {
            pc.dirty.v[base + lo] = 1u;
        }
    }
}

void main() {
    uint c = linear_id();
    if (c >= pc.count) {
        return;
    }
    GlobalsRef g = pc.g;
    if (pc.mode == MARK) {
        mark(g, c);
        return;
    }
    if (pc.mode == CHILD_SORT) {
        uint lo = pc.child_offset.v[c];
        uint hi = pc.child_offset.v[c + 1u];
        for (uint i = lo + 1u; i < hi; i++) {
            uint x = pc.children.v[i];
            uint k = i;
            while (k > lo && pc.children.v[k - 1u] > x) {
                pc.children.v[k] = pc.children.v[k - 1u];
                k--;
            }
            pc.children.v[k] = x;
        }
        return;
    }
    if (pc.mode == CHILD_COUNT || pc.mode == CHILD_FILL) {
        uint lo = pc.new_offset.v[c];
        uint hi = pc.new_offset.v[c + 1u];
        for (uint i = lo; i < hi; i++) {
            uint p = pc.new_parents.v[i].node;
            if (pc.mode == CHILD_COUNT) {
                atomicAdd(pc.child_offset.v[p], 1u);
            } else {
                uint k = atomicAdd(pc.cursor.v[p], 1u);
                pc.children.v[pc.child_offset.v[p] + k] = c;
            }
        }
        return;
    }
    Node nd = g.nodes.v[c];
    if (nd.level == 0u) {
        if (pc.mode == COUNT) {
            pc.new_offset.v[c] = 0u;
        }
        return;
    }
    ObjectInfo ob = g.objects.v[nd.object];
    uint l = nd.level - 1u;
    if (pc.mode == COUNT) {
        uint kept = pc.all != 0u ? 0u : pc.old_offset.v[c + 1u] - pc.old_offset.v[c];
        bool redo = pc.all != 0u || pc.dirty.v[c] != 0u || kept <= 1u;
        pc.dirty.v[c] = redo ? 1u : 0u;
        if (!redo) {
            pc.new_offset.v[c] = kept;
            return;
        }
        atomicAdd(pc.stats.v[2u * MAX_LEVELS], 1u);
        float sum;
        uint k = weights(g, ob, l, nd.pos, nd.normal, false, 0u, sum);
        if (k == 0u) {
            k = nearest_same_side(g, ob, l, nd.pos, nd.normal) != NONE ? 1u : 0u;
        }
        pc.new_offset.v[c] = k;
        return;
    }
    // FILL
    uint at = pc.new_offset.v[c];
    if (pc.dirty.v[c] == 0u) {
        uint lo = pc.old_offset.v[c];
        uint hi = pc.old_offset.v[c + 1u];
        for (uint i = lo; i < hi; i++) {
            pc.new_parents.v[at + i - lo] = pc.old_parents.v[i];
        }
        return;
    }
    float sum;
    uint k = weights(g, ob, l, nd.pos, nd.normal, true, at, sum);
    if (sum > 0.0) {
        for (uint i = at; i < at + k; i++) {
            pc.new_parents.v[i].weight /= sum;
        }
        return;
    }
    uint j = nearest_same_side(g, ob, l, nd.pos, nd.normal);
    if (j != NONE) {
        pc.new_parents.v[at] = Parent(j, 1.0);
        atomicAdd(pc.stats.v[nd.level], 1u);
    } else {
        atomicAdd(pc.stats.v[MAX_LEVELS + nd.level], 1u);
    }
}
