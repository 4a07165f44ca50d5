// Kernel `compact`: the active set of the next level, built on the device: each node of
// first .. first+count whose child flag is set appends itself to `active` through an
// atomic counter, counters[2l + 1] (l = pc.level, the level whose refined nodes activated
// them). The order of the set varies between runs; nothing depends on it (each
// integral's rays and result depend on its node alone).
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
    if (g.child_flag.v[j] == 1u) {
        g.active_list.v[atomicAdd(g.counters.v[2u * pc.level + 1u], 1u)] = j;
    }
}
