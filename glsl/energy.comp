// Kernel `energy`: sums over the level-0 nodes first .. first+count, one workgroup, fixed
// order. mean_direct = 0: energy[ENERGY_UNSHOT] = Σ mean(unshot), energy[ENERGY_DIRECT] =
// Σ mean(direct) (the stop criterion); mean_direct = 1: three slots from
// energy[ENERGY_MEAN_DIRECT] = mean direct irradiance per channel (the oracle's ε_abs scale). CPU twins: CpuBackend::{end_bounce, direct}.
#version 460
#include "layout.glsl"

// Push constants: src/gpu/kernels/energy.rs `EnergyPush`.
layout(push_constant) uniform EnergyPush {
    GlobalsRef g;
    uint first;       // first level-0 node
    uint count;       // level-0 nodes
    uint mean_direct; // 1: mean direct per channel; 0: the stop criterion's sums
    uint pad0;
} pc;

layout(local_size_x = ENERGY_GROUP) in;

shared vec4 s_acc[ENERGY_GROUP];

void main() {
    GlobalsRef g = pc.g;
    uint t = gl_LocalInvocationID.x;
    vec4 acc = vec4(0.0);
    for (uint k = t; k < pc.count; k += ENERGY_GROUP) {
        uint j = pc.first + k;
        vec3 d = g.direct.v[j].xyz;
        if (pc.mean_direct == 1u) {
            acc += vec4(d, 0.0);
        } else {
            vec3 u = g.unshot.v[j].xyz;
            acc += vec4((u.x + u.y + u.z) / 3.0, (d.x + d.y + d.z) / 3.0, 0.0, 0.0);
        }
    }
    s_acc[t] = acc;
    barrier();
    for (uint s = ENERGY_GROUP / 2u; s > 0u; s >>= 1u) {
        if (t < s) {
            s_acc[t] += s_acc[t + s];
        }
        barrier();
    }
    if (t == 0u) {
        vec4 a = s_acc[0];
        if (pc.mean_direct == 1u) {
            float n = float(max(pc.count, 1u));
            g.energy.v[ENERGY_MEAN_DIRECT] = a.x / n;
            g.energy.v[ENERGY_MEAN_DIRECT + 1u] = a.y / n;
            g.energy.v[ENERGY_MEAN_DIRECT + 2u] = a.z / n;
        } else {
            g.energy.v[ENERGY_UNSHOT] = a.x;
            g.energy.v[ENERGY_DIRECT] = a.y;
        }
    }
}
