// Kernel `hemisphere`: the gathering rays of one batch of integrals (paper §4.2): Halton
// points mapped to the cosine-weighted hemisphere of the node, rotated about its normal
// by the integral's random angle. Integral i of the batch is node `integral_node(i)`
// (gather.glsl). With links (gather.glsl `links_on`), a node whose links are recorded
// casts nothing (but in the exact first bounce, `links_read`), and a node's first traced
// gather gets a slot for them.
// CPU twin: transport::cpu::gather_integral.
#version 460
#include "geometry.glsl"
#include "sampling.glsl"
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
    uint j = integral_node(g, i);
    if (links_on()) {
        // The integral's first thread counts it and, at a node's first traced gather,
        // hands out a link slot; a linked integral casts no ray.
        uint s = g.link_slot.v[j];
        if (r == 0u) {
            if (is_linked(s) && links_read()) {
                atomicAdd(g.link_counters.v[LINK_LINKED], 1u);
                atomicAdd(g.link_counters.v[LINK_LINKED_SLOTS], batch_slots());
            } else {
                atomicAdd(g.link_counters.v[LINK_TRACED], 1u);
                if (s == NONE) {
                    uint k = batch_slots();
                    uint slot = atomicAdd(g.link_counters.v[LINK_TAKEN], k);
                    if (slot + k <= g.link_capacity) {
                        atomicAdd(g.link_counters.v[LINK_NODES], 1u);
                        g.link_slot.v[j] = slot | LINK_RECORDING;
                    } else {
                        atomicAdd(g.link_counters.v[LINK_TRACED_FULL], 1u);
                    }
                }
            }
        }
        if (is_linked(s) && links_read()) {
            return;
        }
    }
    Node nd = g.nodes.v[j];
    ObjectInfo ob = g.objects.v[nd.object];
    vec3 x = xform_point(ob.to_world, nd.pos);
    vec3 n = normalize(xform_vector(ob.to_world, nd.normal));
    vec3 o = offset_origin(x, n, g.scene_scale);
    vec3 t;
    vec3 b;
    onb(n, t, b);
    vec3 d = cosine_direction(n, t, b, g.halton.v[r], integral_rotation(g.seed, j));
    g.rays.v[id] = Ray(vec4(o, 0.0), vec4(d, 0.0));
}
