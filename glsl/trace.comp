// Kernel `trace`: closest hit of each gathering ray over all objects (rays go into each
// object's space; one BVH2 per object), but for integrals read from links.
// CPU twin: Scene::intersect.
#version 460
#include "geometry.glsl"
#include "gather.glsl"

layout(local_size_x = LINEAR_GROUP) in;

void main() {
    uint id = linear_id();
    GlobalsRef g = pc.g;
    if (id >= batch_count() * pc.rays) {
        return;
    }
    if (links_read() && is_linked(g.link_slot.v[integral_node(g, id / pc.rays)])) {
        return;
    }
    Ray ray = g.rays.v[id];
    uint tri;
    vec3 tuv;
    uint object = trace_scene(g, ray.o.xyz, ray.d.xyz, FAR, tri, tuv);
    g.hits.v[id] = HitRecord(object, tri, tuv.y, tuv.z);
}
