// Kernel `compact`: the active set of the next level, built on the device: the nodes
// first .. first+count whose child flag is set, in ascending order (a workgroup-wide
// prefix sum per chunk), into `active`; their number into counters[2l + 1] (l = pc.level,
// the level whose refined nodes activated them).
#version 460
#include "layout.glsl"

layout(local_size_x = 256) in;

shared uint s_scan[256];
shared uint s_base;

void main() {
    GlobalsRef g = pc.g;
    uint t = gl_LocalInvocationID.x;
    if (t == 0u) {
        s_base = 0u;
    }
    barrier();
    for (uint chunk = 0u; chunk < pc.count; chunk += 256u) {
        uint idx = chunk + t;
        uint f = idx < pc.count ? g.child_flag.v[pc.first + idx] : 0u;
        s_scan[t] = f;
        barrier();
        for (uint s = 1u; s < 256u; s <<= 1u) {
            uint v = t >= s ? s_scan[t - s] : 0u;
            barrier();
            s_scan[t] += v;
            barrier();
        }
        if (f == 1u) {
            g.active_list.v[s_base + s_scan[t] - 1u] = pc.first + idx;
        }
        barrier();
        if (t == 255u) {
            s_base += s_scan[255];
        }
        barrier();
    }
    if (t == 0u) {
        g.counters.v[2u * pc.level + 1u] = s_base;
    }
}
