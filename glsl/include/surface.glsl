// Twin of src/scene/{texture,light}.rs and Scene::{albedo, direct}: albedo at a surface
// point, the lights' direct irradiance with shadow rays.
#ifndef SURFACE_GLSL
#define SURFACE_GLSL

#include "geometry.glsl"
#include "sampling.glsl"

vec3 texel(GlobalsRef g, TextureInfo info, int x, int y) {
    uint xw = wrap_index(x, info.width, info.wrap & 3u);
    uint yw = wrap_index(y, info.height, (info.wrap >> 2u) & 3u);
    uint p = g.texels.v[info.offset + yw * info.width + xw];
    FloatRef lut = g.srgb;
    return vec3(lut.v[p & 0xffu], lut.v[(p >> 8u) & 0xffu], lut.v[(p >> 16u) & 0xffu]);
}

vec3 sample_texture(GlobalsRef g, TextureInfo info, vec2 uv) {
    vec2 t;
    ivec2 i = bilinear_at(info, uv, t);
    vec3 a = texel(g, info, i.x, i.y);
    vec3 b = texel(g, info, i.x + 1, i.y);
    vec3 c = texel(g, info, i.x, i.y + 1);
    vec3 d = texel(g, info, i.x + 1, i.y + 1);
    return (a * (1.0 - t.x) + b * t.x) * (1.0 - t.y) + (c * (1.0 - t.x) + d * t.x) * t.y;
}

// Albedo at barycentrics (b1, b2) of global triangle `t`.
vec3 albedo(GlobalsRef g, uint t, Tri tri, float b1, float b2) {
    Material m = g.materials.v[tri.material];
    if (!TEXTURED || m.texture == NONE) {
        return m.kd;
    }
    TriUv uv = g.uvs.v[t];
    float b0 = 1.0 - b1 - b2;
    vec2 u = vec2(uv.uv[0] * b0 + uv.uv[2] * b1 + uv.uv[4] * b2, uv.uv[1] * b0 + uv.uv[3] * b1 + uv.uv[5] * b2);
    return m.kd * sample_texture(g, g.textures.v[m.texture], u);
}

// acos by Abramowitz & Stegun 4.4.46: twin of light::acos_as (drivers' acos is coarse).
float acos_as(float x) {
    float a = min(abs(x), 1.0);
    precise float p = -0.0012624911;
    p = p * a + 0.0066700901;
    p = p * a - 0.0170881256;
    p = p * a + 0.0308918810;
    p = p * a - 0.0501743046;
    p = p * a + 0.0889789874;
    p = p * a - 0.2145988016;
    p = p * a + 1.5707963050;
    precise float r = sqrt(1.0 - a) * p;
    return x < 0.0 ? PI - r : r;
}

float spot_falloff(float theta, float beam, float cutoff) {
    if (theta <= beam) {
        return 1.0;
    }
    if (theta >= cutoff) {
        return 0.0;
    }
    return (cutoff - theta) / (cutoff - beam);
}

// Unoccluded irradiance of light `l` at (x, n) and its shadow ray from `o`.
bool light_sample(GpuLight l, vec3 x, vec3 n, vec3 o, out vec3 e, out vec3 to_light, out float tmax) {
    e = vec3(0.0);
    to_light = vec3(0.0);
    tmax = 0.0;
    if (l.kind == LIGHT_DIRECTIONAL) {
        vec3 w = -l.direction;
        float c = dot(n, w);
        if (c <= 0.0) {
            return false;
        }
        e = l.power * c;
        to_light = w;
        tmax = FAR;
        return true;
    }
    vec3 v = l.position - x;
    float d2 = dot(v, v);
    if (d2 <= 0.0) {
        return false;
    }
    vec3 w = v / sqrt(d2);
    float c = dot(n, w);
    if (c <= 0.0) {
        return false;
    }
    e = l.power * (c / d2);
    if (l.kind == LIGHT_SPOT) {
        float cos_t = clamp(dot(l.direction, -w), -1.0, 1.0);
        float f = spot_falloff(acos_as(cos_t), l.beam, l.cutoff);
        if (f <= 0.0) {
            return false;
        }
        e *= f;
    }
    to_light = l.position - o;
    tmax = SHADOW_TMAX;
    return true;
}

#include "emitters.glsl"

// Direct irradiance at a world-space point (x, n) (Scene::direct): every light exactly,
// with a shadow ray; the emitting triangles and the sky from `samples` samples shifted by
// `seed`, with their standard error `se` (zero for the lights). With `count`, each
// source that reaches the point adds one to counters[LIGHT_COUNTERS + i] (the lights, then
// the emitters as one, then the sky: Scene::sources).
vec3 direct_at(GlobalsRef g, vec3 x, vec3 n, bool count, uint64_t seed, uint samples, out vec3 se) {
    vec3 o = offset_origin(x, n, g.scene_scale);
    vec3 e = vec3(0.0);
    se = vec3(0.0);
    LightRef lights = g.lights;
    for (uint i = 0u; i < g.num_lights; i++) {
        vec3 el;
        vec3 tl;
        float tm;
        if (light_sample(lights.v[i], x, n, o, el, tl, tm) && !occluded_scene(g, o, tl, tm)) {
            e += el;
            if (count) {
                atomicAdd(g.counters.v[LIGHT_COUNTERS + i], 1u);
            }
        }
    }
    uint k = min(samples, g.emitter_samples);
    uint source = g.num_lights;
    if (g.num_emitters > 0u) {
        vec3 s;
        vec3 v = emitters_direct(g, x, n, o, seed, k, s);
        if (max(v.x, max(v.y, v.z)) > 0.0) {
            e += v;
            se += s;
            if (count) {
                atomicAdd(g.counters.v[LIGHT_COUNTERS + source], 1u);
            }
        }
        source++;
    }
    if (g.sky_kind != SKY_NONE) {
        vec3 s;
        vec3 v = sky_direct(g, x, n, o, seed, k, s);
        if (max(v.x, max(v.y, v.z)) > 0.0) {
            e += v;
            se += s;
            if (count) {
                atomicAdd(g.counters.v[LIGHT_COUNTERS + source], 1u);
            }
        }
    }
    return e;
}

#endif
