// Twin of src/hierarchy/{weight,kdtree}.rs and src/transport/reconstruct.rs: the Shepard
// weight, stackful kd-tree range search, the first-leaf approximation, and the three
// reconstructions.
#ifndef HIERARCHY_GLSL
#define HIERARCHY_GLSL

#include "layout.glsl"
#include "sampling.glsl"

// Twin of weight::direction8: the nearest of the 8 tangent directions at k·45°.
uint direction8(float x, float y) {
    const float T = 0.41421357;
    if (abs(y) <= T * abs(x)) {
        return x >= 0.0 ? 0u : 4u;
    }
    if (abs(x) <= T * abs(y)) {
        return y >= 0.0 ? 2u : 6u;
    }
    return x >= 0.0 ? (y >= 0.0 ? 1u : 7u) : (y >= 0.0 ? 3u : 5u);
}

// Twin of weight::clip_ok. Words per plane: (ux | uy << 16), (d | mask << 16).
bool clip_ok(uvec4 clip, vec3 v, vec3 n, float h) {
    if ((clip.y & 0xffffu) == 0xffffu) {
        return true;
    }
    vec3 t;
    vec3 b;
    onb(n, t, b);
    float x = dot(v, t);
    float y = dot(v, b);
    uint k = direction8(x, y);
    bool ok = true;
    for (uint i = 0u; i < 2u; i++) {
        uint u = i == 0u ? clip.x : clip.z;
        uint dm = i == 0u ? clip.y : clip.w;
        uint d = dm & 0xffffu;
        if (d != 0xffffu && ((dm >> 16u) & (1u << k)) != 0u) {
            float ux = float(bitfieldExtract(int(u), 0, 16)) * (1.0 / CLIP_DIR);
            float uy = float(bitfieldExtract(int(u), 16, 16)) * (1.0 / CLIP_DIR);
            if (x * ux + y * uy > float(d) * (1.0 / CLIP_SCALE) * h) {
                ok = false;
            }
        }
    }
    return ok;
}

float node_weight(vec3 p, vec3 n, vec3 xj, vec3 nj, float h, float alpha) {
    float d = length(p - xj) / h + alpha * (1.0 - dot(n, nj));
    if (d >= 1.0) {
        return 0.0;
    }
    float q = 1.0 - d * d;
    return q * q * q;
}

// Whether a point at offset v from a node (normal nj, support h) lies on the node's sheet:
// within g.plane · h of its tangent plane (Hierarchy::on_sheet; 0: any).
bool on_sheet(GlobalsRef g, vec3 v, vec3 nj, float h) {
    return g.plane <= 0.0 || abs(dot(v, nj)) < g.plane * h;
}

// Σ w_j v_j (xyz) and Σ w_j (w) over level l of object `ob`, with the read's support: the
// nodes that weigh in (`support`) and the range of their values' channel means
// (`v_lo`, `v_hi`; Readout::on_surface's doubt).
vec4 read_sums(GlobalsRef g, ObjectInfo ob, uint l, vec3 p, vec3 n, Vec4Ref values, out uint support, out float v_lo,
               out float v_hi) {
    uint base = ob.level_start[l];
    uint count = ob.level_count[l];
    vec4 acc = vec4(0.0);
    support = 0u;
    v_lo = 3.0e38;
    v_hi = -3.0e38;
    if (count == 0u) {
        return acc;
    }
    float h = g.kappa * ob.radius[l];
    float alpha = g.alpha;
    float r2 = h * h;
    NodeRef nodes = g.nodes;
    KdSplitRef splits = g.splits;
    uvec2 stack[KD_STACK];
    uint sp = 1u;
    stack[0] = uvec2(0u, count);
    while (sp > 0u) {
        sp--;
        uint lo = stack[sp].x;
        uint hi = stack[sp].y;
        while (true) {
            if (hi - lo == 1u) {
                Node nd = nodes.v[base + lo];
                vec3 dx = nd.pos - p;
                if (dot(dx, dx) < r2) {
                    float w = node_weight(p, n, nd.pos, nd.normal, h, alpha);
                    if (w > 0.0 && on_sheet(g, p - nd.pos, nd.normal, h) && clip_ok(g.clips.v[base + lo], p - nd.pos, nd.normal, h)) {
                        vec3 v = values.v[base + lo].xyz;
                        acc += vec4(v * w, w);
                        float y = (v.x + v.y + v.z) / 3.0;
                        support++;
                        v_lo = min(v_lo, y);
                        v_hi = max(v_hi, y);
                    }
                }
                break;
            }
            uint mid = (lo + hi) / 2u;
            KdSplit s = splits.v[base + mid];
            float d = p[s.dim] - s.value;
            uvec2 near_ = d < 0.0 ? uvec2(lo, mid) : uvec2(mid, hi);
            uvec2 far_ = d < 0.0 ? uvec2(mid, hi) : uvec2(lo, mid);
            if (abs(d) < h) {
                stack[sp] = far_;
                sp++;
            }
            lo = near_.x;
            hi = near_.y;
        }
    }
    return acc;
}

// Σ w_j v_j (xyz) and Σ w_j (w) over level l of object `ob` (the support unused).
vec4 shepard_sums(GlobalsRef g, ObjectInfo ob, uint l, vec3 p, vec3 n, Vec4Ref values) {
    uint support;
    float v_lo;
    float v_hi;
    return read_sums(g, ob, l, p, n, values, support, v_lo, v_hi);
}

// First kd leaf near p within the support whose normal agrees (n · n_j > cos_min);
// returns its local index or NONE. (No early return from inside the loops: lavapipe's
// compiler mishandled that form.)
uint first_leaf(GlobalsRef g, ObjectInfo ob, uint l, vec3 p, vec3 n, float cos_min) {
    uint base = ob.level_start[l];
    uint count = ob.level_count[l];
    float h = g.kappa * ob.radius[l];
    float r2 = h * h;
    NodeRef nodes = g.nodes;
    KdSplitRef splits = g.splits;
    uvec2 stack[KD_STACK];
    uint sp = count > 0u ? 1u : 0u;
    stack[0] = uvec2(0u, count);
    uint found = NONE;
    while (sp > 0u && found == NONE) {
        sp--;
        uint lo = stack[sp].x;
        uint hi = stack[sp].y;
        while (hi - lo > 1u) {
            uint mid = (lo + hi) / 2u;
            KdSplit s = splits.v[base + mid];
            float d = p[s.dim] - s.value;
            uvec2 near_ = d < 0.0 ? uvec2(lo, mid) : uvec2(mid, hi);
            uvec2 far_ = d < 0.0 ? uvec2(mid, hi) : uvec2(lo, mid);
            if (abs(d) < h) {
                stack[sp] = far_;
                sp++;
            }
            lo = near_.x;
            hi = near_.y;
        }
        Node nd = nodes.v[base + lo];
        vec3 dx = nd.pos - p;
        if (dot(dx, dx) < r2 && dot(n, nd.normal) > cos_min && on_sheet(g, p - nd.pos, nd.normal, h)
            && clip_ok(g.clips.v[base + lo], p - nd.pos, nd.normal, h)) {
            found = lo;
        }
    }
    return found;
}

// Exact Shepard value on level l, falling back to coarser levels on a hole (0 if none).
vec3 recon_exact(GlobalsRef g, ObjectInfo ob, uint l, vec3 p, vec3 n, Vec4Ref values) {
    for (int k = int(l); k >= 0; k--) {
        vec4 s = shepard_sums(g, ob, uint(k), p, n, values);
        if (s.w > 0.0) {
            return s.xyz / s.w;
        }
    }
    return vec3(0.0);
}

// F_l(p) = Σ_{k ≤ l} Σ_j α_j^k B_j^k(p) of the delta hierarchy.
vec3 recon_delta(GlobalsRef g, ObjectInfo ob, uint l, vec3 p, vec3 n, Vec4Ref values) {
    vec3 acc = vec3(0.0);
    for (uint k = 0u; k <= l; k++) {
        vec4 s = shepard_sums(g, ob, k, p, n, values);
        if (s.w > 0.0) {
            acc += s.xyz / s.w;
        }
    }
    return acc;
}

// The node the first-leaf approximation reads (global index), falling back to coarser
// levels; NONE if none (reconstruct::approx_node).
uint approx_node(GlobalsRef g, ObjectInfo ob, uint l, vec3 p, vec3 n) {
    uint node = NONE;
    for (int k = int(l); k >= 0 && node == NONE; k--) {
        uint i = first_leaf(g, ob, uint(k), p, n, g.approx_cos);
        if (i != NONE) {
            node = ob.level_start[k] + i;
        }
    }
    return node;
}

// First-leaf approximation, falling back to coarser levels (0 if none).
vec3 recon_approx(GlobalsRef g, ObjectInfo ob, uint l, vec3 p, vec3 n, Vec4Ref values) {
    uint node = approx_node(g, ob, l, p, n);
    return node != NONE ? values.v[node].xyz : vec3(0.0);
}

// What the transport reads at a hit point (the variant is a specialization constant).
vec3 recon_sender(GlobalsRef g, ObjectInfo ob, vec3 p, vec3 n, Vec4Ref values) {
    if (VARIANT == VARIANT_ORIGINAL) {
        return recon_delta(g, ob, g.sender_level, p, n, values);
    } else if (VARIANT == VARIANT_APPROX) {
        return recon_approx(g, ob, g.sender_level, p, n, values);
    }
    return recon_exact(g, ob, g.sender_level, p, n, values);
}

#endif
