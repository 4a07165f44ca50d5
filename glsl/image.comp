// Kernel `image`: the camera's view of a solved scene over a range of pixels, in two
// passes (push constant `pass`). Pass IMAGE_PASS_SAMPLES: one thread per sample of a pixel
// (`spp` per pixel, over the pixel filter) and per chunk of its gather's rays; each takes
// its own primary ray, and at its hit the direct light (every light by a shadow ray, the
// emitters and the sky sampled with the sample's own shift), the emitted radiance and the
// indirect light read from the resident node values: the basis, a gather where the basis
// read is doubted, or a gather everywhere (ALGORITHM.md §6); a ray that leaves the scene
// sees the sky. Pass IMAGE_PASS_PIXELS: one thread per pixel sums its samples' slots.
// (Why so fine-grained: llvmpipe caps the loop iterations one invocation's nest of loops
// may run, LP_MAX_TGSI_LOOP_ITERATIONS = 65535 from the outermost loop's entry, and
// silently ends the loop there; a pixel of 16 samples with gathers ran past it.)
// CPU twin: output::image::render (render_with, Readout::on_surface, Camera).
#version 460
#include "surface.glsl"
#include "hierarchy.glsl"

// What the image reads besides `Globals`: src/layout.rs `ImageInfo`.
layout(buffer_reference, std430, buffer_reference_align = 16) buffer ImageInfoRef {
    vec4 position; // the camera's position (xyz) and the tangent of half its field of view (w)
    vec4 forward;
    vec4 right;
    vec4 up;
    FloatRef normals; // corner normals, 9 floats per triangle (object space; zero: none), or 0
    Vec2Ref halton;   // the gather's directions (halton_table(gather_rays))
    uint width;
    uint height;
    uint spp;
    uint filter_kind; // FILTER_BOX or FILTER_GAUSSIAN
    uint level;       // the output level the basis is read on
    uint seed;
    uint mode;        // IMAGE_BASIS, IMAGE_DOUBT or IMAGE_GATHER
    uint gather_rays;
    uint doubt_nodes;
    float doubt_spread;
    uint chunks;      // chunks a sample's gather is split into (one thread each)
    uint chunk_rays;  // rays of a chunk (the last may have fewer)
    uint short_hops;  // most hops past hits nearer than the output level's support
    uint pad0;
    uint pad1;
    uint pad2;
};

// Push constants: src/device/kernels/image.rs `ImagePush`.
layout(push_constant) uniform ImagePush {
    GlobalsRef g;
    ImageInfoRef info;
    Vec4Ref slots;  // per sample and chunk of the band: direct (xyz; w: 1 if it hit), indirect (xyz; w: 1 if it gathered)
    Vec4Ref pixels; // per pixel of the band: direct (xyz; w: samples that hit), indirect (xyz; w: samples gathered)
    uint first_pixel;
    uint count;     // pixels in the band
    uint pass;      // IMAGE_PASS_SAMPLES or IMAGE_PASS_PIXELS
    uint pad0;
} pc;

layout(local_size_x = LINEAR_GROUP) in;

// emitter::pixel_seed.
uint64_t pixel_seed(uint64_t sid, uint r) {
    return mix64(sid ^ (uint64_t(r) << 40) ^ 0x9ac5000000000000UL);
}

// emitter::pixel_key.
uint pixel_key(uint64_t sid) {
    return uint(mix64(sid ^ 0x6b0e000000000000UL) >> 32);
}

// camera::pixel_hash (lowbias32).
uint pixel_hash(uint x, uint y) {
    uint h = x * 0x9e3779b1u ^ y * 0x85ebca77u;
    h ^= h >> 16;
    h *= 0x7feb352du;
    h ^= h >> 15;
    h *= 0x846ca68bu;
    return h ^ (h >> 16);
}

// Camera::sample_position: where sample k of pixel (x, y) falls (pixel units, y down).
vec2 sample_position(ImageInfoRef info, uint x, uint y, uint k) {
    vec2 c = vec2(float(x) + 0.5, float(y) + 0.5);
    if (info.spp <= 1u) {
        return c;
    }
    uint h = pixel_hash(x, y);
    uint h2 = ((h << 16) | (h >> 16)) ^ 0x9e3779b9u;
    precise float u = (float(k) + 0.5) / float(info.spp) + float(h >> 8) * (1.0 / 16777216.0);
    u = u - floor(u);
    precise float v = float(bitfieldReverse(k)) * (1.0 / 4294967296.0) + float(h2 >> 8) * (1.0 / 16777216.0);
    v = v - floor(v);
    if (info.filter_kind == FILTER_BOX) {
        return vec2(float(x) + u, float(y) + v);
    }
    // The radius by inversion of the Gaussian's radial distribution, cut at 2 pixels.
    const float SIGMA = 0.5;
    const float CUT = 2.0;
    float tail = exp(-CUT * CUT / (2.0 * SIGMA * SIGMA));
    float r = SIGMA * sqrt(-2.0 * log(1.0 - u * (1.0 - tail)));
    float a = TAU * v;
    return c + r * vec2(cos(a), sin(a));
}

// Camera::ray's direction through the image point s.
vec3 camera_direction(ImageInfoRef info, vec2 s) {
    float m = float(min(info.width, info.height));
    float t = info.position.w;
    float x = (2.0 * s.x - float(info.width)) / m * t;
    float y = (float(info.height) - 2.0 * s.y) / m * t;
    return normalize(info.forward.xyz + info.right.xyz * x + info.up.xyz * y);
}

// What Scene::surface gives at a hit.
struct Surf {
    vec3 p;     // world point
    vec3 n;     // world normal on the side the ray met: the shading normal where the mesh has one
    vec3 p_obj; // object-space point
    vec3 n_obj; // object-space geometric normal on the side the ray met
    vec3 a;     // albedo
    uint object;
    bool back;
};

// Scene::surface at the hit (object, tri, tuv = (t, b1, b2)) of a ray of direction d.
Surf surface_at(GlobalsRef g, ImageInfoRef info, uint object, uint tri, vec3 tuv, vec3 d) {
    ObjectInfo ob = g.objects.v[object];
    Tri t = g.tris.v[tri];
    Surf s;
    s.object = object;
    s.p_obj = tri_point(t, tuv.y, tuv.z);
    vec3 front = tri_normal(t);
    s.back = dot(front, xform_vector(ob.to_object, d)) > 0.0;
    s.n_obj = s.back ? -front : front;
    s.a = albedo(g, tri, t, tuv.y, tuv.z);
    s.p = xform_point(ob.to_world, s.p_obj);
    s.n = normalize(xform_vector(ob.to_world, s.n_obj));
    // Scene::shading_normal (interpolate_normal): the corner normals where the triangle
    // has them and they lie on its front.
    if (uint64_t(info.normals) != 0UL) {
        FloatRef c = info.normals;
        uint b = tri * 9u;
        vec3 c0 = vec3(c.v[b], c.v[b + 1u], c.v[b + 2u]);
        if (c0 != vec3(0.0)) {
            float b1 = tuv.y;
            float b2 = tuv.z;
            float b0 = 1.0 - b1 - b2;
            vec3 c1 = vec3(c.v[b + 3u], c.v[b + 4u], c.v[b + 5u]);
            vec3 c2 = vec3(c.v[b + 6u], c.v[b + 7u], c.v[b + 8u]);
            vec3 ns = c0 * b0 + c1 * b1 + c2 * b2;
            float l = length(ns);
            if (l > 0.0 && l < FAR && dot(ns / l, front) > 0.0) {
                vec3 w = xform_vector(ob.to_world, s.back ? -ns / l : ns / l);
                float lw = length(w);
                if (lw > 0.0 && lw < FAR) {
                    s.n = w / lw;
                }
            }
        }
    }
    return s;
}

// Scene::emitted_at: the emission of global triangle `tri` at barycentrics bc (the
// emitters are listed by triangle).
vec3 emitted_at(GlobalsRef g, uint tri, vec2 bc) {
    uint lo = 0u;
    uint hi = g.num_emitters;
    while (lo < hi) {
        uint mid = (lo + hi) / 2u;
        if (g.emitters.v[mid].tri < tri) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    if (lo < g.num_emitters && g.emitters.v[lo].tri == tri) {
        return emitter_radiance(g, g.emitters.v[lo], bc);
    }
    return vec3(0.0);
}

// Solution::indirect_on: the basis on the output level (reconstruct::output).
vec3 basis_at(GlobalsRef g, uint object, vec3 p_obj, vec3 n_obj, uint level) {
    ObjectInfo ob = g.objects.v[object];
    if (VARIANT == VARIANT_ORIGINAL) {
        return recon_delta(g, ob, level, p_obj, n_obj, g.indirect);
    }
    return recon_exact(g, ob, level, p_obj, n_obj, g.indirect);
}

// Readout::past_short_hops, as a loop (GLSL has no recursion): the indirect irradiance at
// a gather hit `s` that a hop of length `t` reached. Where the hop is shorter than the
// output level's support on the hit's object, the path takes one more cosine hop and adds
// ρ E_d at its hit (one emitter and sky sample), up to `short_hops` hops; then the basis.
vec3 past_short_hops(GlobalsRef g, ImageInfoRef info, Surf s, float t, uint key) {
    vec3 sum = vec3(0.0);
    vec3 weight = vec3(1.0);
    for (uint depth = 0u; depth <= info.short_hops; depth++) {
        ObjectInfo ob = g.objects.v[s.object];
        if (depth == info.short_hops || t >= ob.scale * g.kappa * ob.radius[info.level]) {
            return sum + weight * max(basis_at(g, s.object, s.p_obj, s.n_obj, info.level), vec3(0.0));
        }
        vec2 u = vec2(hash_to_unit(hash2(key, 2u * depth + 1u)), hash_to_unit(hash2(key, 2u * depth + 2u)));
        vec3 tb;
        vec3 bb;
        onb(s.n, tb, bb);
        vec3 d = cosine_direction(s.n, tb, bb, u, 0.0);
        uint tri;
        vec3 tuv;
        uint object = trace_scene(g, offset_origin(s.p, s.n, g.scene_scale), d, FAR, tri, tuv);
        if (object == NONE) {
            return sum;
        }
        s = surface_at(g, info, object, tri, tuv, d);
        if (max(s.a.x, max(s.a.y, s.a.z)) <= 0.0) {
            return sum;
        }
        vec3 se;
        weight *= s.a;
        sum += weight * direct_at(g, s.p, s.n, false, (uint64_t(key) << 32) | uint64_t(depth + 1u), 1u, se);
        t = tuv.x;
    }
    return sum;
}

// Readout::gather_with for image sample `sid`, its rays r0 .. r1 of `gather_rays`
// cosine-distributed rays: their part of the mean of each hit's ρ (E_d + E_ind), E_d by
// shadow rays and E_ind the basis clamped at zero.
vec3 gather_at(GlobalsRef g, ImageInfoRef info, vec3 x, vec3 n, uint64_t sid, uint r0, uint r1) {
    uint key = pixel_key(sid);
    float phi0 = integral_rotation(info.seed ^ 0x0f1a6a7eu, key);
    vec3 t;
    vec3 b;
    onb(n, t, b);
    vec3 o = offset_origin(x, n, g.scene_scale);
    vec3 sum = vec3(0.0);
    for (uint r = r0; r < r1; r++) {
        vec3 d = cosine_direction(n, t, b, info.halton.v[r], phi0);
        uint tri;
        vec3 tuv;
        uint object = trace_scene(g, o, d, FAR, tri, tuv);
        if (object == NONE) {
            continue;
        }
        Surf s = surface_at(g, info, object, tri, tuv, d);
        if (max(s.a.x, max(s.a.y, s.a.z)) <= 0.0) {
            continue;
        }
        vec3 se;
        vec3 indirect = info.short_hops > 0u ? past_short_hops(g, info, s, tuv.x, hash2(key, r))
                                             : max(basis_at(g, s.object, s.p_obj, s.n_obj, info.level), vec3(0.0));
        vec3 e = direct_at(g, s.p, s.n, false, pixel_seed(sid, r + 1u), g.emitter_samples, se) + indirect;
        sum += s.a * e;
    }
    return sum / float(max(info.gather_rays, 1u));
}

// Readout::on_surface: chunk `chunk`'s part of the indirect irradiance at a sample's hit
// (the whole of it in chunk 0 where the basis is read); `gathered` is set where it is
// gathered.
vec3 indirect_at(GlobalsRef g, ImageInfoRef info, Surf s, uint64_t sid, uint chunk, out bool gathered) {
    gathered = false;
    uint r0 = chunk * info.chunk_rays;
    uint r1 = min(r0 + info.chunk_rays, info.gather_rays);
    if (info.mode == IMAGE_GATHER) {
        gathered = true;
        return gather_at(g, info, s.p, s.n, sid, r0, r1);
    }
    if (info.mode == IMAGE_BASIS) {
        return chunk == 0u ? basis_at(g, s.object, s.p_obj, s.n_obj, info.level) : vec3(0.0);
    }
    // The support and (absolute hierarchies) the read itself in one pass.
    uint support;
    float v_lo;
    float v_hi;
    vec4 sums = read_sums(g, g.objects.v[s.object], info.level, s.p_obj, s.n_obj, g.indirect, support, v_lo, v_hi);
    bool delta = VARIANT == VARIANT_ORIGINAL;
    vec3 read = !delta && sums.w > 0.0 ? sums.xyz / sums.w : basis_at(g, s.object, s.p_obj, s.n_obj, info.level);
    float mean = (read.x + read.y + read.z) / 3.0;
    bool spread = !delta && support > 0u && v_hi - v_lo > info.doubt_spread * max(mean, 0.0);
    if (support < info.doubt_nodes || spread) {
        gathered = true;
        return gather_at(g, info, s.p, s.n, sid, r0, r1);
    }
    return chunk == 0u ? read : vec3(0.0);
}

// Pass IMAGE_PASS_PIXELS: the pixel's mean over its samples' slots.
void sum_pixel(uint id) {
    ImageInfoRef info = pc.info;
    uint per = max(info.spp, 1u) * info.chunks;
    vec4 d = vec4(0.0);
    vec4 i = vec4(0.0);
    for (uint j = 0u; j < per; j++) {
        d += pc.slots.v[2u * (id * per + j)];
        i += pc.slots.v[2u * (id * per + j) + 1u];
    }
    float inv = 1.0 / float(max(info.spp, 1u));
    pc.pixels.v[2u * id] = vec4(d.xyz * inv, d.w);
    pc.pixels.v[2u * id + 1u] = vec4(i.xyz * inv, i.w);
}

void main() {
    uint id = linear_id();
    ImageInfoRef info = pc.info;
    uint spp = max(info.spp, 1u);
    if (pc.pass == IMAGE_PASS_PIXELS) {
        if (id < pc.count) {
            sum_pixel(id);
        }
        return;
    }
    if (id >= pc.count * spp * info.chunks) {
        return;
    }
    GlobalsRef g = pc.g;
    uint chunk = id % info.chunks;
    uint k = (id / info.chunks) % spp;
    uint pixel = pc.first_pixel + id / (info.chunks * spp);
    uint w = info.width;
    uint x = pixel % w;
    uint y = pixel / w;
    vec3 d = camera_direction(info, sample_position(info, x, y, k));
    uint tri;
    vec3 tuv;
    uint object = trace_scene(g, info.position.xyz, d, FAR, tri, tuv);
    vec4 direct = vec4(0.0);
    vec4 indirect = vec4(0.0);
    if (object == NONE) {
        if (chunk == 0u) {
            direct.xyz = sky_radiance(g, d);
        }
    } else {
        Surf s = surface_at(g, info, object, tri, tuv, d);
        vec3 kd = s.a / PI;
        uint64_t sid = uint64_t(pixel) * uint64_t(spp) + uint64_t(k);
        if (chunk == 0u) {
            vec3 se;
            direct.xyz = kd * direct_at(g, s.p, s.n, false, pixel_seed(sid, 0u), g.emitter_samples, se);
            if (!s.back) {
                direct.xyz += emitted_at(g, tri, tuv.yz);
            }
            direct.w = 1.0;
        }
        bool gathered;
        indirect.xyz = kd * indirect_at(g, info, s, sid, chunk, gathered);
        indirect.w = gathered && chunk == 0u ? 1.0 : 0.0;
    }
    pc.slots.v[2u * id] = direct;
    pc.slots.v[2u * id + 1u] = indirect;
}
