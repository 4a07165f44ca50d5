// Kernel `oracle`: new values of level l's nodes and the refinement decision
// (ALGORITHM.md §5): a gathered node is refined when |g − pred| exceeds
// max(ε_rel |g|, ε_abs mean E_d) + z σ in any channel. Inactive nodes take the prediction
// (modified) or a zero delta (original). With flag = 1 the children of refined nodes are
// marked for compaction. counters[2l] counts refined nodes.
// CPU twins: transport::cpu::oracle and CpuBackend::refine.
#version 460
#include "layout.glsl"

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
    if (!is_active) {
        g.next.v[j] = delta ? vec4(0.0) : vec4(pred, 0.0);
        return;
    }
    g.next.v[j] = vec4(delta ? m - pred : m, 0.0);
    vec3 err = g.gathered_err.v[j].xyz;
    vec3 mean_direct = vec3(g.energy.v[4], g.energy.v[5], g.energy.v[6]);
    vec3 tau = max(abs(m) * g.eps_rel, mean_direct * g.eps_abs) + err * g.noise_z;
    if (any(greaterThan(abs(m - pred), tau))) {
        atomicAdd(g.counters.v[2u * pc.level], 1u);
        if (pc.flag == 1u) {
            uint a = g.child_offset.v[j];
            uint b = g.child_offset.v[j + 1u];
            for (uint k = a; k < b; k++) {
                g.child_flag.v[g.children.v[k]] = 1u;
            }
        }
    }
}
