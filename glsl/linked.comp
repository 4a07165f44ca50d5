// Kernel `linked`: the samples of a batch whose integrals all read links (ALGORITHM.md
// §5.6): each ray's sample is its link's albedo times the un-shot value of its sender
// node, the product `reconstruct` writes for a linked integral, and the integral's first
// thread counts it as `hemisphere` does. The schedule dispatches it, and `reduce` after
// it, instead of hemisphere, trace and reconstruct for batches whose every node holds
// links: levels 0 and 1 after a solve's first bounce, when the links have room for all
// their nodes (`Schedule::linked_levels`), and the finer levels' linked lists (`compact`
// with `split`, batches with from_list 2). A small kernel of its own
// because lavapipe runs a shader's branches masked: in `reconstruct` a linked ray pays
// for the traced path it skips. CPU twin: transport::links::gather.
#version 460
#include "layout.glsl"
#include "gather.glsl"

layout(local_size_x = LINEAR_GROUP) in;

void main() {
    uint id = linear_id();
    GlobalsRef g = pc.g;
    uint n_rays = pc.rays;
    if (id >= batch_count() * n_rays) {
        return;
    }
    uint i = id / n_rays;
    uint r = id - i * n_rays;
    uint s = g.link_slot.v[integral_node(g, i)];
    if (r == 0u) {
        atomicAdd(g.link_counters.v[LINK_LINKED], 1u);
        atomicAdd(g.link_counters.v[LINK_LINKED_SLOTS], batch_slots());
    }
    g.contrib.v[id] = vec4(link_sample(g, s, r), 0.0);
}
