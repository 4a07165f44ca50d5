// Kernel `pulldown`: v_c = Σ_p B_p(x_c) v_p over the parents of nodes first .. first+count
// (paper §5, Fig. 4), from `next`, into `pred` (fill = 0: the oracle's prediction) or into
// `next` (fill = 1: filling a level without integrals). CPU twin: transport::cpu::pull_down.
#version 460
#include "layout.glsl"

// Push constants: src/gpu/kernels/pulldown.rs `PulldownPush`.
layout(push_constant) uniform PulldownPush {
    GlobalsRef g;
    uint first; // first node (global index) of the range
    uint count; // nodes in the range
    uint fill; // 1: into next (a level without integrals); 0: into pred (the prediction)
    uint pad0;
} pc;

layout(local_size_x = LINEAR_GROUP) in;

void main() {
    uint id = linear_id();
    if (id >= pc.count) {
        return;
    }
    GlobalsRef g = pc.g;
    uint c = pc.first + id;
    uint a = g.parent_offset.v[c];
    uint b = g.parent_offset.v[c + 1u];
    ParentRef parents = g.parents;
    Vec4Ref next = g.next;
    vec4 v = vec4(0.0);
    for (uint k = a; k < b; k++) {
        Parent p = parents.v[k];
        v += next.v[p.node] * p.weight;
    }
    // Linear pull-down weights (pulldown_linear) can be negative at an edge: clamp as
    // transport::cpu::pull_down does (a no-op for Shepard weights and non-negative values).
    v = max(v, vec4(0.0));
    if (pc.fill == 1u) {
        next.v[c] = v;
    } else {
        g.pred.v[c] = v;
    }
}
