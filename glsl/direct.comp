// Kernel `direct`: exact direct irradiance at nodes `first .. first + count` by shadow
// rays (ALGORITHM.md §2), counting per light the nodes it lights
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
    g.direct.v[j] = vec4(direct_at(g, x, n, true), 0.0);
}
