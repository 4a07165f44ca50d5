// Kernel `direct`: direct irradiance at nodes `first .. first + count` by shadow rays
// (ALGORITHM.md §2; emitters and sky sampled), counting per source the nodes it lights
// (counters[LIGHT_COUNTERS + i]).
// CPU twin: transport::cpu::direct_at_node.
#version 460
#include "surface.glsl"

// Push constants: src/gpu/kernels/direct.rs `DirectPush`.
layout(push_constant) uniform DirectPush {
    GlobalsRef g;
    uint first; // first node (global index) of the range
    uint count; // nodes in the range
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
    vec3 x = xform_point(ob.to_world, nd.pos);
    vec3 n = normalize(xform_vector(ob.to_world, nd.normal));
    vec3 se;
    vec3 e = direct_at(g, x, n, true, node_seed(j), g.emitter_samples, se);
    g.direct.v[j] = vec4(e, 0.0);
    // The relative standard error of the sampled part (its mean channel), -1 where
    // nothing lights the node (transport::cpu direct's `direct_error`).
    float m = (e.x + e.y + e.z) / 3.0;
    g.direct_err.v[j] = m > 0.0 ? ((se.x + se.y + se.z) / 3.0) / m : -1.0;
}
