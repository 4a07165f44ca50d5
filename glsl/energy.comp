// Kernel `energy`: sums over the level-0 nodes first .. first+count, one workgroup, fixed
// order. flag = 0: energy[0] = Σ mean(unshot), energy[1] = Σ mean(direct) (the stop
// criterion); flag = 1: energy[4..7] = mean direct irradiance per channel (the oracle's
// ε_abs scale). CPU twins: CpuBackend::{end_bounce, direct}.
#version 460
#include "layout.glsl"

layout(local_size_x = ENERGY_GROUP) in;

shared vec4 s_acc[ENERGY_GROUP];

void main() {
    GlobalsRef g = pc.g;
    uint t = gl_LocalInvocationID.x;
    vec4 acc = vec4(0.0);
    for (uint k = t; k < pc.count; k += ENERGY_GROUP) {
        uint j = pc.first + k;
        vec3 d = g.direct.v[j].xyz;
        if (pc.flag == 1u) {
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
        if (pc.flag == 1u) {
            float n = float(max(pc.count, 1u));
            g.energy.v[4] = a.x / n;
            g.energy.v[5] = a.y / n;
            g.energy.v[6] = a.z / n;
        } else {
            g.energy.v[0] = a.x;
            g.energy.v[1] = a.y;
        }
    }
}
