// Twin of src/geom/{ray,transform,bvh}.rs: transforms, the watertight ray–triangle test,
// the scale-aware origin offset, BVH2 traversal.
#ifndef GEOMETRY_GLSL
#define GEOMETRY_GLSL

#include "layout.glsl"

// "No hit" distance. GLSL does not promise infinities, so a huge finite value stands in
// for the CPU's f32::INFINITY; both are only compared.
const float FAR = 3.0e38;

// `precise` everywhere a hit point or ray is computed: no fused multiply-add, so the GPU
// rounds as the CPU reference does (the approximate reconstruction's first kd leaf can
// change with the last bit of a hit point lying on a split plane).
vec3 xform_point(vec4 m[3], vec3 p) {
    precise vec3 r = vec3(m[0].x * p.x + m[0].y * p.y + m[0].z * p.z + m[0].w,
                          m[1].x * p.x + m[1].y * p.y + m[1].z * p.z + m[1].w,
                          m[2].x * p.x + m[2].y * p.y + m[2].z * p.z + m[2].w);
    return r;
}

vec3 xform_vector(vec4 m[3], vec3 v) {
    precise vec3 r = vec3(m[0].x * v.x + m[0].y * v.y + m[0].z * v.z,
                          m[1].x * v.x + m[1].y * v.y + m[1].z * v.z,
                          m[2].x * v.x + m[2].y * v.y + m[2].z * v.z);
    return r;
}

vec3 tri_normal(Tri t) {
    vec3 c = cross(t.v1 - t.v0, t.v2 - t.v0);
    float l = length(c);
    return l > 0.0 ? c / l : vec3(0.0);
}

vec3 tri_point(Tri t, float b1, float b2) {
    precise vec3 p = t.v0 + (t.v1 - t.v0) * b1 + (t.v2 - t.v0) * b2;
    return p;
}

vec3 offset_origin(vec3 p, vec3 n, float scale) {
    float near_ = scale * (1.0 / OFFSET_NEAR_DIV);
    float fine = scale * (1.0 / OFFSET_FINE_DIV);
    vec3 o;
    for (int i = 0; i < 3; i++) {
        int of = int(OFFSET_ULPS * n[i]);
        int bits = floatBitsToInt(p[i]);
        float moved = intBitsToFloat(bits + (p[i] < 0.0 ? -of : of));
        o[i] = abs(p[i]) < near_ ? p[i] + fine * n[i] : moved;
    }
    return o;
}

vec3 safe_inverse(vec3 d) {
    vec3 r;
    for (int i = 0; i < 3; i++) {
        r[i] = abs(d[i]) < 1e-30 ? (d[i] < 0.0 ? -1e30 : 1e30) : 1.0 / d[i];
    }
    return r;
}

// Per-ray constants of the watertight test (Woop, Benthin & Wald 2013).
struct WRay { vec3 o; int kx; int ky; int kz; vec3 s; };

WRay watertight_ray(vec3 o, vec3 d) {
    vec3 a = abs(d);
    int kz = a.x > a.y ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2);
    int kx = (kz + 1) % 3;
    int ky = (kx + 1) % 3;
    if (d[kz] < 0.0) {
        int t = kx;
        kx = ky;
        ky = t;
    }
    WRay w;
    w.o = o;
    w.kx = kx;
    w.ky = ky;
    w.kz = kz;
    w.s = vec3(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
    return w;
}

// Returns true and (t, b1, b2) when the ray hits `tri` in (0, tmax).
bool intersect_tri(WRay w, Tri tri, float tmax, out vec3 tuv) {
    precise vec3 a = tri.v0 - w.o;
    precise vec3 b = tri.v1 - w.o;
    precise vec3 c = tri.v2 - w.o;
    precise float ax = a[w.kx] - w.s.x * a[w.kz];
    precise float ay = a[w.ky] - w.s.y * a[w.kz];
    precise float bx = b[w.kx] - w.s.x * b[w.kz];
    precise float by = b[w.ky] - w.s.y * b[w.kz];
    precise float cx = c[w.kx] - w.s.x * c[w.kz];
    precise float cy = c[w.ky] - w.s.y * c[w.kz];
    precise float u = cx * by - cy * bx;
    precise float v = ax * cy - ay * cx;
    precise float ww = bx * ay - by * ax;
    if ((u < 0.0 || v < 0.0 || ww < 0.0) && (u > 0.0 || v > 0.0 || ww > 0.0)) {
        return false;
    }
    precise float det = u + v + ww;
    if (det == 0.0) {
        return false;
    }
    precise float az = w.s.z * a[w.kz];
    precise float bz = w.s.z * b[w.kz];
    precise float cz = w.s.z * c[w.kz];
    precise float t = (u * az + v * bz + ww * cz) / det;
    if (!(t > 0.0 && t < tmax)) {
        return false;
    }
    tuv = vec3(t, v / det, ww / det);
    return true;
}

float slab(BvhNode n, vec3 o, vec3 inv, float tmax) {
    vec3 t0 = (n.lo - o) * inv;
    vec3 t1 = (n.hi - o) * inv;
    vec3 mn = min(t0, t1);
    vec3 mx = max(t0, t1);
    float tnear = max(max(max(mn.x, mn.y), mn.z), 0.0);
    float tfar = min(min(mx.x, mx.y), mx.z) * SLAB_FAR;
    return (tnear <= tfar && tnear < tmax) ? tnear : FAR;
}

// Twin of texture.rs `wrap_coord`: a coordinate into [0, 1] by wrap mode m
// (0 repeat, 1 clamp, 2 mirror).
float wrap_coord(float u, uint m) {
    if (m == 1u) {
        return clamp(u, 0.0, 1.0);
    }
    if (m == 2u) {
        float t = u - 2.0 * floor(u * 0.5);
        return t > 1.0 ? 2.0 - t : t;
    }
    return u - floor(u);
}

// Twin of texture.rs `wrap_index`.
uint wrap_index(int i, uint n, uint m) {
    int k = int(n);
    if (m == 0u) {
        return uint(i < 0 ? i + k : (i >= k ? i - k : i));
    }
    return uint(clamp(i, 0, k - 1));
}

// Twin of texture::bilinear_at: the texel below and left of uv's footprint (returned) and
// the weights toward the next ones (t), uv wrapped into [0, 1] first so that texel
// indices stay within one step of the image.
ivec2 bilinear_at(TextureInfo info, vec2 uv, out vec2 t) {
    float x = wrap_coord(uv.x, info.wrap & 3u) * float(info.width) - 0.5;
    float y = (1.0 - wrap_coord(uv.y, (info.wrap >> 2u) & 3u)) * float(info.height) - 0.5;
    float fx = floor(x);
    float fy = floor(y);
    t = vec2(x - fx, y - fy);
    return ivec2(int(fx), int(fy));
}

// Twin of texture::sample_alpha: a texture's alpha byte (linear), bilinear.
float sample_alpha(GlobalsRef g, TextureInfo info, vec2 uv) {
    vec2 t;
    ivec2 i = bilinear_at(info, uv, t);
    float a[4];
    for (int k = 0; k < 4; k++) {
        uint xw = wrap_index(i.x + (k & 1), info.width, info.wrap & 3u);
        uint yw = wrap_index(i.y + (k >> 1), info.height, (info.wrap >> 2u) & 3u);
        a[k] = float(g.texels.v[info.offset + yw * info.width + xw] >> 24u) * (1.0 / 255.0);
    }
    return (a[0] * (1.0 - t.x) + a[1] * t.x) * (1.0 - t.y) + (a[2] * (1.0 - t.x) + a[3] * t.x) * t.y;
}

// Twin of Scene::stops: whether a ray that meets global triangle t at barycentrics
// (b1, b2) stops there (false on a cutout's cut-out part). Only a textured scene has
// cutouts.
bool opaque_at(GlobalsRef g, uint t, float b1, float b2) {
    if (!TEXTURED) {
        return true;
    }
    Material m = g.materials.v[g.tris.v[t].material];
    if (m.alpha_texture == NONE) {
        return true;
    }
    TriUv uv = g.uvs.v[t];
    float b0 = 1.0 - b1 - b2;
    vec2 u = vec2(uv.uv[0] * b0 + uv.uv[2] * b1 + uv.uv[4] * b2, uv.uv[1] * b0 + uv.uv[3] * b1 + uv.uv[5] * b2);
    return m.opacity * sample_alpha(g, g.textures.v[m.alpha_texture], u) >= m.cutoff;
}

// Closest (or with `any`, first) hit of an object-space ray in the BVH at `root`.
// On a hit, `tri` holds the global triangle index and `tuv` (t, b1, b2); tmax shrinks.
bool trace_bvh(GlobalsRef g, BvhRef bvh, TriRef tris, uint root, vec3 o, vec3 d, inout float tmax, bool any_hit,
               out uint tri, out vec3 tuv) {
    vec3 inv = safe_inverse(d);
    WRay w = watertight_ray(o, d);
    bool found = false;
    tri = NONE;
    tuv = vec3(0.0);
    uint stack[BVH_STACK];
    uint sp = 0u;
    if (slab(bvh.v[root], o, inv, tmax) >= FAR) {
        return false;
    }
    uint cur = root;
    while (true) {
        BvhNode n = bvh.v[cur];
        bool descended = false;
        if (n.prim_count > 0u) {
            for (uint i = n.first_index; i < n.first_index + n.prim_count; i++) {
                vec3 h;
                if (intersect_tri(w, tris.v[i], tmax, h) && opaque_at(g, i, h.y, h.z)) {
                    tmax = h.x;
                    tuv = h;
                    tri = i;
                    found = true;
                    if (any_hit) {
                        return true;
                    }
                }
            }
        } else {
            uint a = n.first_index;
            float ta = slab(bvh.v[a], o, inv, tmax);
            float tb = slab(bvh.v[a + 1u], o, inv, tmax);
            uint near_ = ta <= tb ? a : a + 1u;
            uint far_ = ta <= tb ? a + 1u : a;
            float tn = min(ta, tb);
            float tf = max(ta, tb);
            if (tn < FAR) {
                if (tf < FAR) {
                    stack[sp] = far_;
                    sp++;
                }
                cur = near_;
                descended = true;
            }
        }
        if (!descended) {
            bool popped = false;
            while (sp > 0u) {
                sp--;
                cur = stack[sp];
                if (slab(bvh.v[cur], o, inv, tmax) < FAR) {
                    popped = true;
                    break;
                }
            }
            if (!popped) {
                return found;
            }
        }
    }
    return found;
}

#include "cwbvh.glsl"

// The object's BVH, by the BVH_KIND specialization constant.
bool trace_object(GlobalsRef g, ObjectInfo ob, vec3 o, vec3 d, inout float tmax, bool any_hit, out uint tri,
                  out vec3 tuv) {
    if (BVH_KIND == BVH_CWBVH) {
        return trace_cwbvh(g, g.cw_nodes, g.cw_prims, g.tris, ob.cw_root, o, d, tmax, any_hit, tri, tuv);
    }
    return trace_bvh(g, g.bvh, g.tris, ob.bvh_offset, o, d, tmax, any_hit, tri, tuv);
}

// Closest hit over all objects of a world-space ray. Returns the object or NONE.
uint trace_scene(GlobalsRef g, vec3 o, vec3 d, float tmax, out uint tri, out vec3 tuv) {
    uint object = NONE;
    tri = NONE;
    tuv = vec3(0.0);
    ObjectRef objects = g.objects;
    for (uint k = 0u; k < g.num_objects; k++) {
        ObjectInfo ob = objects.v[k];
        vec3 oo = xform_point(ob.to_object, o);
        vec3 od = xform_vector(ob.to_object, d);
        uint t;
        vec3 h;
        if (trace_object(g, ob, oo, od, tmax, false, t, h)) {
            object = k;
            tri = t;
            tuv = h;
        }
    }
    return object;
}

// Whether anything blocks a world-space ray in (0, tmax).
bool occluded_scene(GlobalsRef g, vec3 o, vec3 d, float tmax) {
    ObjectRef objects = g.objects;
    bool hit = false;
    for (uint k = 0u; k < g.num_objects && !hit; k++) {
        ObjectInfo ob = objects.v[k];
        vec3 oo = xform_point(ob.to_object, o);
        vec3 od = xform_vector(ob.to_object, d);
        uint t;
        vec3 h;
        float tm = tmax;
        hit = trace_object(g, ob, oo, od, tm, true, t, h);
    }
    return hit;
}

#endif
