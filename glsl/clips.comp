// Kernel `clips`: the support clips of the nodes `0 .. count` that an arrangement
// computes (ALGORITHM.md §3.3), on the device: all of them (pc.boxes == ALL), or after
// objects moved those of a moved object (pc.moved[o] != 0) and those whose clip rays can
// reach one of the moved objects' world boxes before and after (pc.box_list: lo, hi).
// Each selected node casts its 8 tangent rays against the whole scene and writes its clip
// record into g.clips; pc.out_count[0] counts the selected nodes. A node whose clip
// changed is flagged in pc.changed (kernel `relations` marks the children it weighs) and
// appends (node, clip) to pc.out_nodes / pc.out_clips through pc.out_count[1] (the order
// varies between runs; the host sorts by node).
// CPU twin: hierarchy::{ClipSelection::contains, node_clip}.
#version 460
#include "geometry.glsl"
#include "hierarchy.glsl"

// Push constants: src/gpu/kernels/clips.rs `ClipsPush`.
layout(push_constant) uniform ClipsPush {
    GlobalsRef g;
    Vec4Ref box_list; // 2 per box: lo, hi (world space)
    UintRef moved; // per object: 1 if it moved
    UintRef out_nodes; // the selected nodes, in the order they finished
    Uvec4Ref out_clips; // their clips
    UintRef out_count; // two words: the selected nodes, the changed clips
    UintRef changed; // per node: 1 if its clip changed
    uint count; // nodes
    uint boxes; // boxes in box_list, or ALL: every node is selected
    float eps; // margin of the box test, world units
    uint pad0;
} pc;

layout(local_size_x = LINEAR_GROUP) in;

const uint ALL = 0xffffffffu;

// cos and sin of k·45° as the CPU's f32 arithmetic gives them.
const float COS8[8] = float[8](1.0, 0.70710677, -4.371139e-8, -0.70710677, -1.0, -0.70710665, 1.1924881e-8,
                               0.70710700);
const float SIN8[8] = float[8](0.0, 0.70710677, 1.0, 0.70710677, -8.742278e-8, -0.70710690, -1.0,
                               -0.70710653);

// f32::round: half away from zero (GLSL's round() may round half to even).
float round_away(float x) {
    return sign(x) * floor(abs(x) + 0.5);
}

bool selected(GlobalsRef g, Node nd, ObjectInfo ob) {
    if (pc.boxes == ALL || pc.moved.v[nd.object] != 0u) {
        return true;
    }
    vec3 x = xform_point(ob.to_world, nd.pos);
    float r = 1.2 * (g.kappa * ob.radius[nd.level]) * ob.scale + pc.eps;
    for (uint k = 0u; k < pc.boxes; k++) {
        vec3 lo = pc.box_list.v[2u * k].xyz;
        vec3 hi = pc.box_list.v[2u * k + 1u].xyz;
        vec3 v = clamp(x, lo, hi) - x;
        if (dot(v, v) <= r * r) {
            return true;
        }
    }
    return false;
}

void main() {
    uint j = linear_id();
    if (j >= pc.count) {
        return;
    }
    GlobalsRef g = pc.g;
    Node nd = g.nodes.v[j];
    ObjectInfo ob = g.objects.v[nd.object];
    if (!selected(g, nd, ob)) {
        return;
    }
    // hierarchy::walls_across_support
    float h_obj = g.kappa * ob.radius[nd.level];
    float h = h_obj * ob.scale;
    vec3 n = normalize(xform_vector(ob.to_world, nd.normal));
    vec3 x = xform_point(ob.to_world, nd.pos);
    vec3 origin = offset_origin(x, n, g.scene_scale) + n * (0.02 * h);
    vec3 t;
    vec3 b;
    onb(nd.normal, t, b);
    ivec2 pq[8];
    float pdist[8];
    uint pmask[8];
    uint np = 0u;
    for (uint k = 0u; k < 8u; k++) {
        vec3 d_obj = t * COS8[k] + b * SIN8[k];
        vec3 d = normalize(xform_vector(ob.to_world, d_obj));
        uint tri;
        vec3 tuv;
        uint hit = trace_scene(g, origin, d, 1.1 * h, tri, tuv);
        if (hit == NONE) {
            continue;
        }
        ObjectInfo hob = g.objects.v[hit];
        vec3 hn = normalize(xform_vector(hob.to_world, tri_normal(g.tris.v[tri])));
        if (abs(dot(hn, n)) >= 0.5) {
            continue;
        }
        vec3 hn_obj = xform_vector(ob.to_object, hn);
        float mx = dot(hn_obj, t);
        float my = dot(hn_obj, b);
        float len = sqrt(mx * mx + my * my);
        if (len < 1e-3) {
            continue;
        }
        float s = mx * dot(d_obj, t) + my * dot(d_obj, b) < 0.0 ? -1.0 : 1.0;
        ivec2 q = ivec2(round_away(s * mx / len * CLIP_DIR), round_away(s * my / len * CLIP_DIR));
        float ux = float(q.x) / CLIP_DIR;
        float uy = float(q.y) / CLIP_DIR;
        vec3 p_obj = xform_point(ob.to_object, origin + d * tuv.x) - nd.pos;
        float dist = (dot(p_obj, t) * ux + dot(p_obj, b) * uy) / h_obj;
        if (dist <= 0.0) {
            continue;
        }
        uint bit = 1u << direction8(dot(d_obj, t), dot(d_obj, b));
        bool merged = false;
        for (uint i = 0u; i < np && !merged; i++) {
            if ((float(pq[i].x) * float(q.x) + float(pq[i].y) * float(q.y)) / (CLIP_DIR * CLIP_DIR) > 0.95) {
                pdist[i] = min(pdist[i], dist);
                pmask[i] |= bit;
                merged = true;
            }
        }
        if (!merged) {
            pq[np] = q;
            pdist[np] = dist;
            pmask[np] = bit;
            np++;
        }
    }
    // hierarchy::widen_to_neighbour_sectors
    for (uint i = 0u; i < np; i++) {
        float ux = float(pq[i].x) / CLIP_DIR;
        float uy = float(pq[i].y) / CLIP_DIR;
        float len = sqrt(ux * ux + uy * uy);
        uint hits = pmask[i];
        for (uint k = 0u; k < 8u; k++) {
            bool near_ = (hits & (1u << ((k + 1u) % 8u))) != 0u || (hits & (1u << ((k + 7u) % 8u))) != 0u;
            if ((hits & (1u << k)) != 0u || !near_) {
                continue;
            }
            float angle = acos(clamp((COS8[k] * ux + SIN8[k] * uy) / len, -1.0, 1.0));
            float best = cos(max(angle - PI / 8.0, 0.0)) * len;
            if (best > 0.0 && pdist[i] / best < 1.0) {
                pmask[i] |= 1u << k;
            }
        }
    }
    // hierarchy::encode_clip: the nearest two (a stable order: the earlier of equals).
    uvec4 clip = uvec4(0u, 0xffffu, 0u, 0xffffu);
    uint taken = 0u;
    for (uint slot = 0u; slot < 2u && slot < np; slot++) {
        uint best = NONE;
        for (uint i = 0u; i < np; i++) {
            if ((taken & (1u << i)) == 0u && (best == NONE || pdist[i] < pdist[best])) {
                best = i;
            }
        }
        taken |= 1u << best;
        uint dq = uint(min(floor(pdist[best] * float(CLIP_SCALE)), 65534.0));
        uint u = (uint(pq[best].x) & 0xffffu) | ((uint(pq[best].y) & 0xffffu) << 16u);
        uint dm = dq | (pmask[best] << 16u);
        if (slot == 0u) {
            clip.xy = uvec2(u, dm);
        } else {
            clip.zw = uvec2(u, dm);
        }
    }
    atomicAdd(pc.out_count.v[0], 1u);
    if (g.clips.v[j] != clip) {
        g.clips.v[j] = clip;
        pc.changed.v[j] = 1u;
        uint at = atomicAdd(pc.out_count.v[1], 1u);
        pc.out_nodes.v[at] = j;
        pc.out_clips.v[at] = clip;
    }
}
