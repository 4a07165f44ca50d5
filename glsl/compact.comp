// Kernel `compact`: the active set of the next level, built on the device: each node of
// first .. first+count whose child flag is set appends itself to `active` through an
// atomic counter, counters[COUNTERS_PER_LEVEL l + COUNTER_ACTIVATED] (l = pc.parent_level, the level
// whose refined nodes activated them). With pc.split (a bounce whose gathers read links)
// a node that holds links goes to `linked_list` instead, through
// counters[COUNTERS_PER_LEVEL l + COUNTER_LINKED]: its gather is kernel `linked`'s. The order of the set varies between runs; nothing depends on it (each
// integral's rays and result depend on its node alone).
#version 460
#include "layout.glsl"

// Push constants: src/gpu/kernels/compact.rs `CompactPush`.
layout(push_constant) uniform CompactPush {
    GlobalsRef g;
    uint first; // first node (global index) of the range
    uint count; // nodes in the range
    uint parent_level; // the level whose refined nodes activated these
    uint split; // 1: nodes that hold links go to linked_list
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
        uint base = COUNTERS_PER_LEVEL * pc.parent_level;
        if (pc.split == 1u && is_linked(g.link_slot.v[j])) {
            g.linked_list.v[atomicAdd(g.counters.v[base + COUNTER_LINKED], 1u)] = j;
        } else {
            g.active_list.v[atomicAdd(g.counters.v[base + COUNTER_ACTIVATED], 1u)] = j;
        }
    }
}
