// The push constants of one gathering batch, shared by its four kernels (hemisphere,
// trace, reconstruct, reduce): src/gpu/kernels/gather.rs `GatherPush`.
#ifndef GATHER_GLSL
#define GATHER_GLSL

#include "layout.glsl"

layout(push_constant) uniform GatherPush {
    GlobalsRef g;
    uint first;       // first node (global index) of the level
    uint count;       // integrals in this batch (for a device-sized batch: at most)
    uint batch_first; // first integral of this batch within the level's integrals
    uint from_list;   // 1: integral i is node active_list[batch_first + i]; 2: linked_list[...]; 0: node first + batch_first + i
    uint count_slot;  // NONE, or the counter holding the level's active count (device-sized batches)
    uint exact_direct; // 1: reconstruct reads the exact direct irradiance at the hits
    uint rays;        // rays per integral of this batch (level 1: level1_rays times g.rays_per_integral)
    uint pad0;
} pc;

// Link slots an integral of this batch takes (a slot holds g.rays_per_integral links).
uint batch_slots() {
    return pc.rays / pc.g.rays_per_integral;
}

// Integrals in this batch: `count`, or, for a device-sized batch, what the level's
// active count (a counter written on the device) leaves from `batch_first`, at most
// `count`.
uint batch_count() {
    if (pc.count_slot == NONE) {
        return pc.count;
    }
    uint total = pc.g.counters.v[pc.count_slot];
    return total > pc.batch_first ? min(total - pc.batch_first, pc.count) : 0u;
}

// The node of integral i of this batch.
uint integral_node(GlobalsRef g, uint i) {
    if (pc.from_list == 2u) {
        return g.linked_list.v[pc.batch_first + i];
    }
    return pc.from_list == 1u ? g.active_list.v[pc.batch_first + i] : pc.first + pc.batch_first + i;
}

// Whether this batch's integrals record links (ALGORITHM.md §5.6): the approximate
// variant with room for links. The first bounce under `exact_first_bounce` records them
// too (its rays are the later bounces' rays) but reads none: its samples are the exact
// direct light at the hits.
bool links_on() {
    return VARIANT == VARIANT_APPROX && pc.g.link_capacity > 0u;
}

// Whether this batch's linked integrals read their links instead of tracing.
bool links_read() {
    return links_on() && pc.exact_direct == 0u;
}

// A linked integral's sample of ray r: the link's albedo times the un-shot value of its
// sender node, the product the traced read makes (kernels `reconstruct` and `linked`).
vec3 link_sample(GlobalsRef g, uint slot, uint r) {
    uvec4 link = g.links.v[slot * g.rays_per_integral + r];
    return link.x != NONE ? uintBitsToFloat(link.yzw) * g.unshot.v[link.x].xyz : vec3(0.0);
}

#endif
