// Traversal of a compressed wide BVH (CWBVH, Ylitie, Karras & Laine 2017) as obvhs builds
// it: 8-wide nodes of 80 bytes with child boxes quantised to a per-node grid, children
// visited in ray-octant order, leaves of up to 3 triangles. A port of obvhs'
// `traverse!` macro and `CwBvhNode::intersect_ray_basic`, with boxes entered from t = 0
// and widened by SLAB_FAR (the CPU's twin: geom::bvh::trace_cw); triangles are reached
// through `cw_prims` (the triangles stay in the BVH2's order, which box queries and
// `bvh = "bvh2"` use).
#ifndef CWBVH_GLSL
#define CWBVH_GLSL

#include "layout.glsl"

uint cw_byte(uvec2 v, uint c) {
    return ((c < 4u ? v.x : v.y) >> (8u * (c & 3u))) & 0xffu;
}

// Which children (high byte: inner nodes in octant order) and which leaf triangles (low
// 24 bits) the ray reaches within tmax.
uint cw_intersect(CwNode nd, vec3 o, vec3 inv, uint oct_inv4, float tmax) {
    vec3 extent = vec3(uintBitsToFloat((nd.e_imask & 0xffu) << 23), uintBitsToFloat(((nd.e_imask >> 8u) & 0xffu) << 23),
                       uintBitsToFloat(((nd.e_imask >> 16u) & 0xffu) << 23));
    vec3 adj_inv = extent * inv;
    vec3 adj_o = (nd.p - o) * inv;
    bvec3 neg = lessThan(inv, vec3(0.0));
    uint oct = oct_inv4 & 0xffu;
    uint hitmask = 0u;
    for (uint c = 0u; c < 8u; c++) {
        uint meta = cw_byte(nd.meta, c);
        if (meta == 0u) {
            continue;
        }
        vec3 lo = vec3(cw_byte(nd.lox, c), cw_byte(nd.loy, c), cw_byte(nd.loz, c));
        vec3 hi = vec3(cw_byte(nd.hix, c), cw_byte(nd.hiy, c), cw_byte(nd.hiz, c));
        vec3 qmin = mix(lo, hi, neg);
        vec3 qmax = mix(hi, lo, neg);
        vec3 t0 = qmin * adj_inv + adj_o;
        vec3 t1 = qmax * adj_inv + adj_o;
        float tn = max(max(max(t0.x, t0.y), t0.z), 0.0);
        float tf = min(min(min(t1.x, t1.y), t1.z), tmax) * SLAB_FAR;
        if (tn <= tf) {
            bool inner = ((meta & (meta << 1u)) & 0x10u) != 0u;
            uint bit_index = (inner ? (meta ^ oct) : meta) & 0x1fu;
            uint child_bits = (meta >> 5u) & 7u;
            hitmask |= child_bits << bit_index;
        }
    }
    return hitmask;
}

// Closest (or with `any`, first) hit in the CWBVH rooted at `root`; as trace_bvh.
bool trace_cwbvh(GlobalsRef g, CwNodeRef nodes, UintRef prims, TriRef tris, uint root, vec3 o, vec3 d,
                 inout float tmax, bool any_hit, out uint tri, out vec3 tuv) {
    vec3 inv = safe_inverse(d);
    WRay w = watertight_ray(o, d);
    uint oct_inv4 = (d.x < 0.0 ? 0u : 0x04040404u) | (d.y < 0.0 ? 0u : 0x02020202u) | (d.z < 0.0 ? 0u : 0x01010101u);
    bool found = false;
    tri = NONE;
    tuv = vec3(0.0);
    uvec2 stack[CWBVH_STACK];
    uint sp = 0u;
    uvec2 cur = uvec2(root, 0x80000000u);
    uvec2 prim = uvec2(0u);
    bool done = false;
    while (!done) {
        while (prim.y != 0u) {
            uint local = uint(findMSB(prim.y));
            prim.y &= ~(1u << local);
            uint t = prims.v[prim.x + local];
            vec3 h;
            if (intersect_tri(w, tris.v[t], tmax, h) && opaque_at(g, t, h.y, h.z)) {
                tmax = h.x;
                tuv = h;
                tri = t;
                found = true;
                if (any_hit) {
                    prim.y = 0u;
                    cur.y = 0u;
                    sp = 0u;
                }
            }
        }
        if ((cur.y & 0xff000000u) != 0u) {
            uint hits_imask = cur.y;
            uint child_offset = uint(findMSB(hits_imask));
            cur.y &= ~(1u << child_offset);
            if ((cur.y & 0xff000000u) != 0u) {
                stack[sp] = cur;
                sp++;
            }
            uint slot = (child_offset - 24u) ^ (oct_inv4 & 0xffu);
            uint rel = bitCount(hits_imask & ~(0xffffffffu << slot));
            CwNode nd = nodes.v[cur.x + rel];
            uint hitmask = cw_intersect(nd, o, inv, oct_inv4, tmax);
            cur = uvec2(nd.child_base, (hitmask & 0xff000000u) | (nd.e_imask >> 24u));
            prim = uvec2(nd.prim_base, hitmask & 0x00ffffffu);
        } else {
            cur = uvec2(0u);
        }
        if (prim.y == 0u && (cur.y & 0xff000000u) == 0u) {
            if (sp == 0u) {
                done = true;
            } else {
                sp--;
                cur = stack[sp];
            }
        }
    }
    return found;
}

#endif
