// Kernel `reconstruct`: the un-shot irradiance at each hit point, read from the sender
// level by the variant's reconstruction (exact Shepard, delta sum, or first kd leaf),
// times the albedo there: one Monte Carlo sample `ρ(y) ΔE(y)` per ray. In the first
// bounce under `exact_first_bounce` the un-shot field is E_d itself, read exactly at the
// hit by shadow rays. With links (gather.glsl `links_on`), a linked integral's sample is
// its link's albedo times the un-shot value of its sender node, and a node's first
// traced gather (the exact first bounce's too) records the links. A hit on a triangle
// side without nodes reads nothing. CPU twin: the loop body of
// transport::cpu::gather_integral and transport::links::gather.
#version 460
#include "surface.glsl"
#include "hierarchy.glsl"
#include "gather.glsl"

layout(local_size_x = LINEAR_GROUP) in;

void main() {
    uint id = linear_id();
    GlobalsRef g = pc.g;
    uint n_rays = pc.rays;
    if (id >= batch_count() * n_rays) {
        return;
    }
    uint r = id % n_rays;
    uint s = links_on() ? g.link_slot.v[integral_node(g, id / n_rays)] : NONE;
    bool recording = s != NONE && (s & LINK_RECORDING) != 0u;
    if (is_linked(s) && links_read()) {
        // The link: the same product the traced read makes.
        g.contrib.v[id] = vec4(link_sample(g, s, r), 0.0);
        return;
    }
    HitRecord h = g.hits.v[id];
    vec3 c = vec3(0.0);
    uint sender = NONE;
    vec3 a = vec3(0.0);
    if (h.object != NONE) {
        ObjectInfo ob = g.objects.v[h.object];
        Tri tri = g.tris.v[h.tri];
        vec3 p = tri_point(tri, h.b1, h.b2);
        vec3 n = tri_normal(tri);
        vec3 d = xform_vector(ob.to_object, g.rays.v[id].d.xyz);
        bool back = dot(n, d) > 0.0;
        if (back) {
            n = -n;
        }
        // A side without nodes reads nothing (Hierarchy::side_has_nodes).
        bool side = ((g.sides.v[h.tri] >> (back ? 1u : 0u)) & 1u) != 0u;
        a = albedo(g, h.tri, tri, h.b1, h.b2);
        if (VARIANT == VARIANT_APPROX && side && (pc.exact_direct == 0u || recording)) {
            sender = approx_node(g, ob, g.sender_level, p, n);
        }
        vec3 e = vec3(0.0);
        if (pc.exact_direct == 1u) {
            vec3 se;
            e = direct_at(g, xform_point(ob.to_world, p), normalize(xform_vector(ob.to_world, n)), false,
                          hit_seed(integral_node(g, id / n_rays), r), 1u, se);
        } else if (VARIANT == VARIANT_APPROX) {
            e = sender != NONE ? g.unshot.v[sender].xyz : vec3(0.0);
        } else if (side) {
            e = recon_sender(g, ob, p, n, g.unshot);
        }
        c = a * e;
    }
    g.contrib.v[id] = vec4(c, 0.0);
    if (recording) {
        // The node's first traced gather: keep what later gathers read.
        g.links.v[(s & ~LINK_RECORDING) * g.rays_per_integral + r] = uvec4(sender, floatBitsToUint(a));
    }
}
