// Kernel `compact`: the active set of the next level, built on the device: each node of
// first .. first+count whose child flag is set appends itself to `active` through an
// atomic counter, counters[COUNTERS_PER_LEVEL l + COUNTER_ACTIVATED] (l = pc.parent_level, the level
// whose refined nodes activated them). The order of the set varies between runs; nothing depends on it (each
// integral's rays and result depend on its node alone).
#version 460
#include "layout.glsl"

// Push constants: src/gpu/kernels/compact.rs `CompactPush`.
layout(push_constant) uniform CompactPush {
    GlobalsRef g;
    uint first; // first node (global index) of the range
    uint count; // nodes in the range
    uint parent_level; // the level whose refined nodes activated these
    uint pad0;
} pc;

layout(local_size_x = LINEAR_GROUP) in;

void main() {
    uint id = linear_id();
    if (id >= pc.count) {
        return;
    }
    GlobalsRef g = pc.g;
    uint j = pc.first + id;
    if (g.child_flag.v[j] == 1u) {
        g.active_list.v[atomicAdd(g.counters.v[COUNTERS_PER_LEVEL * pc.parent_level + COUNTER_ACTIVATED], 1u)] = j;
    }
}
