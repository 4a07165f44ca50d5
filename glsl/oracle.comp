// Kernel `oracle`: new values of level l's nodes and the refinement decision
// (ALGORITHM.md §5): a gathered node is refined when |g − pred| exceeds
// max(ε_rel |g|, ε_abs mean E_d) + z σ in any channel. Inactive nodes take the prediction
// (modified) or a zero delta (original). With activate = 1 the children of refined nodes are
// marked for compaction, and so are the sparse children (at most pc.sparse_parents parents,
// SolverParams::sparse_parents in the bounces 1..=sparse_bounces) of lit nodes that are not
// refined (ALGORITHM.md §5.5). counters[COUNTERS_PER_LEVEL l + COUNTER_REFINED] counts refined nodes.
// CPU twins: transport::cpu::oracle and CpuBackend::refine.
#version 460
#include "layout.glsl"

// Push constants: src/gpu/kernels/oracle.rs `OraclePush`.
layout(push_constant) uniform OraclePush {
    GlobalsRef g;
    uint first; // first node (global index) of the range
    uint count; // nodes in the range
    uint level;    // the level of the range
    uint activate; // 1: mark the children of refined nodes for compaction
    uint sparse_parents; // with activate: also the children with at most this many parents of lit nodes (0: off)
    uint pad;
} pc;

layout(local_size_x = LINEAR_GROUP) in;

void main() {
    uint id = linear_id();
    if (id >= pc.count) {
        return;
    }
    GlobalsRef g = pc.g;
    uint j = pc.first + id;
    vec3 m = g.gathered_mean.v[j].xyz;
    if (pc.level == 0u) {
        g.next.v[j] = vec4(m, 0.0);
        return;
    }
    bool is_active = g.active_flag.v[j] == 1u;
    vec3 pred = g.pred.v[j].xyz;
    bool delta = VARIANT == VARIANT_ORIGINAL;
    vec3 mean_direct = vec3(g.energy.v[ENERGY_MEAN_DIRECT], g.energy.v[ENERGY_MEAN_DIRECT + 1u], g.energy.v[ENERGY_MEAN_DIRECT + 2u]);
    vec3 value;
    bool refine = false;
    if (!is_active) {
        g.next.v[j] = delta ? vec4(0.0) : vec4(pred, 0.0);
        value = pred;
    } else {
        g.next.v[j] = vec4(delta ? m - pred : m, 0.0);
        value = m;
        vec3 err = g.gathered_err.v[j].xyz;
        vec3 tau = max(abs(m) * g.eps_rel, mean_direct * g.eps_abs) + err * g.noise_z;
        refine = any(greaterThan(abs(m - pred), tau));
    }
    if (refine) {
        atomicAdd(g.counters.v[COUNTERS_PER_LEVEL * pc.level + COUNTER_REFINED], 1u);
    }
    if (pc.activate == 0u) {
        return;
    }
    // A refined node activates its children; a lit one that is not refined still activates
    // its sparse children (at most sparse_parents parents; CpuBackend::refine).
    bool sparse = !refine && pc.sparse_parents > 0u && any(greaterThan(value, mean_direct * g.eps_abs));
    if (refine || sparse) {
        uint a = g.child_offset.v[j];
        uint b = g.child_offset.v[j + 1u];
        for (uint k = a; k < b; k++) {
            uint c = g.children.v[k];
            if (refine || g.parent_offset.v[c + 1u] - g.parent_offset.v[c] <= pc.sparse_parents) {
                g.child_flag.v[c] = 1u;
            }
        }
    }
}
