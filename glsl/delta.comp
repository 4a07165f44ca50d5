// Kernel `delta`: the original (delta) hierarchy's prediction at nodes of level l ≥ 1,
// F_{l-1}(x_j) = Σ_{k<l} Σ_i α_i^k B_i^k(x_j) (paper §3, §4.2: "the Irradiance
// Reconstruction stage with the basis functions' positions as input").
// init = 0: pred = F_{l-1} of `next` (the oracle's prediction).
// init = 1: unshot = direct − F_{l-1} of `unshot` (delta coefficients of E_d).
// CPU twins: CpuBackend::predict and CpuBackend::init_unshot.
#version 460
#include "hierarchy.glsl"

// Push constants: src/gpu/kernels/delta.rs `DeltaPush`.
layout(push_constant) uniform DeltaPush {
    GlobalsRef g;
    uint first; // first node (global index) of the range
    uint count; // nodes in the range
    uint level; // the level of the range
    uint init;  // 1: delta coefficients of E_d into unshot; 0: prediction into pred
} pc;

layout(local_size_x = LINEAR_GROUP) in;

void main() {
    uint id = linear_id();
    if (id >= pc.count) {
        return;
    }
    GlobalsRef g = pc.g;
    uint j = pc.first + id;
    Node nd = g.nodes.v[j];
    ObjectInfo ob = g.objects.v[nd.object];
    if (pc.init == 1u) {
        vec3 f = g.direct.v[j].xyz;
        if (pc.level == 0u) {
            g.unshot.v[j] = vec4(f, 0.0);
        } else {
            g.unshot.v[j] = vec4(f - recon_delta(g, ob, pc.level - 1u, nd.pos, nd.normal, g.unshot), 0.0);
        }
    } else {
        g.pred.v[j] = vec4(recon_delta(g, ob, pc.level - 1u, nd.pos, nd.normal, g.next), 0.0);
    }
}
