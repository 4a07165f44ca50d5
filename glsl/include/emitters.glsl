// Twin of src/scene/emitter.rs and src/scene/sky.rs and of the emitter and sky parts of
// Scene::direct (ALGORITHM.md §2.2, §2.3): the direct light of the emitting triangles and
// of the sky at a point, sampled with the CPU's point sets and per-point shifts (seeds
// from node and ray indices, so that both draw the same samples), in single precision.
// Included by surface.glsl after acos_as.
#ifndef EMITTERS_GLSL
#define EMITTERS_GLSL

// splitmix64's finaliser: emitter::mix64.
uint64_t mix64(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9UL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebUL;
    return z ^ (z >> 31);
}

// emitter::node_seed.
uint64_t node_seed(uint j) {
    return mix64(uint64_t(j) ^ 0xd1ec000000000000UL);
}

// emitter::hit_seed.
uint64_t hit_seed(uint j, uint r) {
    return mix64((uint64_t(j) << 32) | uint64_t(r));
}

// The top 24 bits of a 64-bit value as a number in [0, 1) (the CPU keeps 53).
float unit_of(uint64_t v) {
    return float(uint(v >> 40)) * (1.0 / 16777216.0);
}

// emitter::shift.
vec3 sample_shift(uint64_t seed) {
    uint64_t s = mix64(seed);
    return vec3(unit_of(s), unit_of(mix64(s ^ 0x9e37UL)), unit_of(mix64(s ^ 0x79b9UL)));
}

float luminance(vec3 c) {
    return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}

// emitter::solid_angle (Van Oosterom & Strackee).
float solid_angle(vec3 x, vec3 v0, vec3 v1, vec3 v2) {
    vec3 a = v0 - x;
    vec3 b = v1 - x;
    vec3 c = v2 - x;
    float la = length(a);
    float lb = length(b);
    float lc = length(c);
    float num = abs(dot(a, cross(b, c)));
    float den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
    return 2.0 * atan(num, den);
}

float asin_as(float x) {
    return 0.5 * PI - acos_as(x);
}

// emitter::angle_between.
float angle_between(vec3 a, vec3 b) {
    if (dot(a, b) < 0.0) {
        return PI - 2.0 * asin_as(min(length(a + b) / 2.0, 1.0));
    }
    return 2.0 * asin_as(min(length(b - a) / 2.0, 1.0));
}

// `v / |v|`, false where glam's try_normalize gives None.
bool try_normalize(vec3 v, out vec3 u) {
    float l = length(v);
    u = v / l;
    return l > 0.0 && !isinf(l) && !any(isnan(u)) && !any(isinf(u));
}

// emitter::spherical_triangle (Arvo 1995).
bool spherical_triangle(vec3 x, vec3 v0, vec3 v1, vec3 v2, vec2 u, out vec3 w, out float area) {
    w = vec3(0.0);
    area = 0.0;
    vec3 a;
    vec3 b;
    vec3 c;
    if (!try_normalize(v0 - x, a) || !try_normalize(v1 - x, b) || !try_normalize(v2 - x, c)) {
        return false;
    }
    vec3 nab = cross(a, b);
    vec3 nbc = cross(b, c);
    vec3 nca = cross(c, a);
    if (dot(nab, nab) < 1e-24 || dot(nbc, nbc) < 1e-24 || dot(nca, nca) < 1e-24) {
        return false;
    }
    nab = normalize(nab);
    nbc = normalize(nbc);
    nca = normalize(nca);
    float alpha = angle_between(nab, -nca);
    float beta = angle_between(nbc, -nab);
    float gamma = angle_between(nca, -nbc);
    float a_pi = alpha + beta + gamma;
    area = a_pi - PI;
    if (isnan(area) || area <= 1e-9) {
        return false;
    }
    float ap_pi = PI + u.x * (a_pi - PI);
    float cos_alpha = cos(alpha);
    float sin_alpha = sin(alpha);
    float sin_phi = sin(ap_pi) * cos_alpha - cos(ap_pi) * sin_alpha;
    float cos_phi = cos(ap_pi) * cos_alpha + sin(ap_pi) * sin_alpha;
    float k1 = cos_phi + cos_alpha;
    float k2 = sin_phi - sin_alpha * dot(a, b);
    float cos_bp =
        clamp((k2 + (k2 * cos_phi - k1 * sin_phi) * cos_alpha) / ((k2 * sin_phi + k1 * cos_phi) * sin_alpha), -1.0, 1.0);
    float sin_bp = sqrt(max(1.0 - cos_bp * cos_bp, 0.0));
    vec3 cn;
    if (!try_normalize(c - dot(c, a) * a, cn)) {
        return false;
    }
    vec3 cp = cos_bp * a + sin_bp * cn;
    float cos_t = 1.0 - u.y * (1.0 - dot(cp, b));
    float sin_t = sqrt(max(1.0 - cos_t * cos_t, 0.0));
    vec3 bn;
    if (!try_normalize(cp - dot(cp, b) * b, bn)) {
        return false;
    }
    w = cos_t * b + sin_t * bn;
    return !any(isnan(w)) && !any(isinf(w));
}

// emitter::barycentrics: those of a point y in the plane of (v0, v1, v2), brought into
// the triangle (cr: the edges' cross product).
vec2 emitter_barycentrics(vec3 v0, vec3 v1, vec3 v2, vec3 cr, vec3 y) {
    vec3 e1 = v1 - v0;
    vec3 e2 = v2 - v0;
    vec3 p = y - v0;
    float n2 = dot(cr, cr);
    float b1 = clamp(dot(cross(p, e2), cr) / n2, 0.0, 1.0);
    float b2 = clamp(dot(cross(e1, p), cr) / n2, 0.0, 1.0 - b1);
    return vec2(b1, b2);
}

// emitter::sample_triangle: one sample of the triangle (v0, v1, v2) emitting from its
// front, picked with probability `prob`, seen from (x, n) with shadow rays from `o`: the
// geometry term over the density (`weight`), the shadow ray and the point's barycentrics.
bool emitter_sample(vec3 v0, vec3 v1, vec3 v2, float prob, vec3 x, vec3 n, vec3 o, vec2 u, out float weight,
                    out vec3 to_point, out vec2 bc) {
    weight = 0.0;
    to_point = vec3(0.0);
    bc = vec2(0.0);
    if (prob <= 0.0) {
        return false;
    }
    vec3 cr = cross(v1 - v0, v2 - v0);
    vec3 ne;
    if (!try_normalize(cr, ne) || dot(ne, x - v0) <= 0.0) {
        return false;
    }
    vec3 y;
    vec3 w;
    float omega;
    if (solid_angle(x, v0, v1, v2) >= SPHERICAL_MIN && spherical_triangle(x, v0, v1, v2, u, w, omega)) {
        float t = dot(ne, v0 - x) / dot(ne, w);
        if (isnan(t) || t <= 0.0 || isinf(t)) {
            return false;
        }
        float c = dot(n, w);
        if (c <= 0.0) {
            return false;
        }
        y = x + w * t;
        weight = c * omega / prob;
        bc = emitter_barycentrics(v0, v1, v2, cr, y);
    } else {
        // geom::sampling::uniform_triangle.
        float s = sqrt(u.x);
        float b1 = s * (1.0 - u.y);
        float b2 = s * u.y;
        y = v0 + (v1 - v0) * b1 + (v2 - v0) * b2;
        vec3 wv = y - x;
        float d2 = dot(wv, wv);
        vec3 wn = wv / sqrt(d2);
        float cx = dot(n, wn);
        float ce = -dot(ne, wn);
        if (isnan(d2) || d2 <= 0.0 || cx <= 0.0 || ce <= 0.0) {
            return false;
        }
        weight = cx * ce / d2 * 0.5 * length(cr) / prob;
        bc = vec2(b1, b2);
    }
    to_point = y - o;
    return true;
}

// World corners of emitter k.
void emitter_corners(GlobalsRef g, GpuEmitter e, out vec3 v0, out vec3 v1, out vec3 v2) {
    Tri t = g.tris.v[e.tri];
    ObjectInfo ob = g.objects.v[e.object];
    v0 = xform_point(ob.to_world, t.v0);
    v1 = xform_point(ob.to_world, t.v1);
    v2 = xform_point(ob.to_world, t.v2);
}

// Scene::emitter_radiance: the radiance emitter e sends from barycentrics bc.
vec3 emitter_radiance(GlobalsRef g, GpuEmitter e, vec2 bc) {
    if (!TEXTURED || e.texture == NONE) {
        return e.radiance;
    }
    TriUv uv = g.uvs.v[e.tri];
    float b0 = 1.0 - bc.x - bc.y;
    vec2 u = vec2(uv.uv[0] * b0 + uv.uv[2] * bc.x + uv.uv[4] * bc.y, uv.uv[1] * b0 + uv.uv[3] * bc.x + uv.uv[5] * bc.y);
    return e.scale * sample_texture(g, g.textures.v[e.texture], u);
}

// Mean and standard error of `count` samples from their sums (emitter::mean_and_error).
vec3 mean_and_error(vec3 sum, vec3 sum2, uint count, out vec3 se) {
    float nf = float(max(count, 1u));
    vec3 mean = sum / nf;
    vec3 var = count > 1u ? max((sum2 / nf - mean * mean) * (nf / (nf - 1.0)), vec3(0.0)) : vec3(0.0);
    se = sqrt(var / nf);
    return mean;
}

// Emitters::for_each_sample with its shadow rays: the emitters' direct irradiance at
// (x, n) from `count` samples shifted by `seed`, and its standard error.
vec3 emitters_direct(GlobalsRef g, vec3 x, vec3 n, vec3 o, uint64_t seed, uint count, out vec3 se) {
    se = vec3(0.0);
    uint ne = g.num_emitters;
    vec3 shift = sample_shift(seed);
    bool local = ne <= LOCAL_WEIGHTS;
    float cdf[LOCAL_WEIGHTS];
    if (local) {
        float run = 0.0;
        for (uint k = 0u; k < ne; k++) {
            GpuEmitter e = g.emitters.v[k];
            vec3 v0;
            vec3 v1;
            vec3 v2;
            emitter_corners(g, e, v0, v1, v2);
            if (dot(cross(v1 - v0, v2 - v0), x - v0) > 0.0) {
                run += e.lum * solid_angle(x, v0, v1, v2);
            }
            cdf[k] = run;
        }
        if (run <= 0.0) {
            return vec3(0.0);
        }
        for (uint k = 0u; k < ne; k++) {
            cdf[k] /= run;
        }
    }
    vec3 sum = vec3(0.0);
    vec3 sum2 = vec3(0.0);
    for (uint i = 0u; i < count; i++) {
        vec3 u = fract(g.emitter_points.v[i].xyz + shift);
        uint k;
        float prob;
        if (local) {
            k = 0u;
            while (k < ne - 1u && cdf[k] <= u.x) {
                k++;
            }
            prob = cdf[k] - (k > 0u ? cdf[k - 1u] : 0.0);
        } else {
            // The first k with cdf > u (partition point), by bisection.
            uint lo = 0u;
            uint hi = ne;
            while (lo < hi) {
                uint mid = (lo + hi) / 2u;
                if (g.emitters.v[mid].cdf <= u.x) {
                    lo = mid + 1u;
                } else {
                    hi = mid;
                }
            }
            k = min(lo, ne - 1u);
            prob = g.emitters.v[k].prob;
        }
        GpuEmitter e = g.emitters.v[k];
        vec3 v0;
        vec3 v1;
        vec3 v2;
        emitter_corners(g, e, v0, v1, v2);
        float weight;
        vec3 to_point;
        vec2 bc;
        if (emitter_sample(v0, v1, v2, prob, x, n, o, u.yz, weight, to_point, bc) &&
            !occluded_scene(g, o, to_point, SHADOW_TMAX)) {
            vec3 value = emitter_radiance(g, e, bc) * weight;
            sum += value;
            sum2 += value * value;
        }
    }
    return mean_and_error(sum, sum2, count, se);
}

// sky::pick: the index by running sums cdf[base .. base + len] (ending at 1) for u, and
// the remainder of u in its interval.
uint sky_pick(FloatRef cdf, uint base, uint len, float u, out float rem) {
    uint lo = 0u;
    uint hi = len;
    while (lo < hi) {
        uint mid = (lo + hi) / 2u;
        if (cdf.v[base + mid] <= u) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    uint k = min(lo, len - 1u);
    float below = k > 0u ? cdf.v[base + k - 1u] : 0.0;
    float w = cdf.v[base + k] - below;
    rem = w > 0.0 ? clamp((u - below) / w, 0.0, 0.99999994) : 0.5;
    return k;
}

// EnvMap::pixel: the pixel a world direction reads.
uint sky_pixel(GlobalsRef g, vec3 d) {
    float s = sin(g.sky_rotate);
    float c = cos(g.sky_rotate);
    vec3 m = vec3(c * d.x - s * d.z, d.y, s * d.x + c * d.z);
    float l = length(m);
    m = l > 0.0 ? m / l : vec3(0.0);
    float u = fract(atan(m.x, -m.z) / (2.0 * PI));
    float v = acos_as(clamp(m.y, -1.0, 1.0)) / PI;
    uint col = min(uint(u * float(g.sky_width)), g.sky_width - 1u);
    uint row = min(uint(v * float(g.sky_height)), g.sky_height - 1u);
    return row * g.sky_width + col;
}

// EnvMap::pdf.
float sky_pdf(GlobalsRef g, vec3 d) {
    uint k = sky_pixel(g, d);
    float y = d.y / length(d);
    float sin_t = sqrt(max(1.0 - y * y, 0.0));
    if (sin_t <= 0.0) {
        return 0.0;
    }
    return g.sky_prob.v[k] * float(g.sky_width * g.sky_height) / (2.0 * PI * PI * sin_t);
}

// EnvMap::sample: a world direction by the map's luminance.
bool sky_sample(GlobalsRef g, vec2 u, out vec3 d) {
    d = vec3(0.0);
    float fv;
    float fu;
    uint row = sky_pick(g.sky_rows, 0u, g.sky_height, u.x, fv);
    uint col = sky_pick(g.sky_cols, row * g.sky_width, g.sky_width, u.y, fu);
    if (g.sky_prob.v[row * g.sky_width + col] <= 0.0) {
        return false;
    }
    float theta = PI * ((float(row) + fv) / float(g.sky_height));
    float phi = 2.0 * PI * ((float(col) + fu) / float(g.sky_width));
    float sin_t = sin(theta);
    if (sin_t <= 0.0) {
        return false;
    }
    vec3 m = vec3(sin(phi) * sin_t, cos(theta), -cos(phi) * sin_t);
    float s = sin(g.sky_rotate);
    float c = cos(g.sky_rotate);
    d = vec3(c * m.x + s * m.z, m.y, -s * m.x + c * m.z);
    return true;
}

// Sky::radiance: what a ray of direction d that leaves the scene receives.
vec3 sky_radiance(GlobalsRef g, vec3 d) {
    if (g.sky_kind == SKY_CONSTANT) {
        return vec3(g.sky_r, g.sky_g, g.sky_b);
    }
    if (g.sky_kind == SKY_MAP) {
        return g.sky_texels.v[sky_pixel(g, d)].xyz;
    }
    return vec3(0.0);
}

// The sky's part of Scene::direct: its direct irradiance at (x, n) from `count`
// directions shifted by `seed`, and its standard error.
vec3 sky_direct(GlobalsRef g, vec3 x, vec3 n, vec3 o, uint64_t seed, uint count, out vec3 se) {
    se = vec3(0.0);
    vec3 t;
    vec3 b;
    onb(n, t, b);
    vec3 shift = sample_shift(seed ^ 0x5c1e5c1eUL);
    if (g.sky_kind == SKY_CONSTANT) {
        // Cosine-weighted: each escaping direction adds π L, a Bernoulli mean.
        uint open = 0u;
        for (uint k = 0u; k < count; k++) {
            vec2 u = fract(g.emitter_points.v[k].xy + shift.xy);
            vec3 d = cosine_direction(n, t, b, u, 0.0);
            if (!occluded_scene(g, o, d, FAR)) {
                open++;
            }
        }
        float nf = float(max(count, 1u));
        float p = float(open) / nf;
        float s = count > 1u ? sqrt(p * (1.0 - p) / (nf - 1.0)) : 0.0;
        vec3 l = vec3(g.sky_r, g.sky_g, g.sky_b);
        se = l * PI * s;
        return open > 0u ? l * PI * p : vec3(0.0);
    }
    // The even mixture of the map's luminance and the cosine (the balance heuristic).
    vec3 sum = vec3(0.0);
    vec3 sum2 = vec3(0.0);
    for (uint k = 0u; k < count; k++) {
        vec2 u = fract(g.emitter_points.v[k].xy + shift.xy);
        vec3 d;
        if (u.x < 0.5) {
            if (!sky_sample(g, vec2(2.0 * u.x, u.y), d)) {
                continue;
            }
        } else {
            d = cosine_direction(n, t, b, vec2(2.0 * u.x - 1.0, u.y), 0.0);
        }
        float c = dot(n, d);
        if (c <= 0.0) {
            continue;
        }
        float pdf = 0.5 * (sky_pdf(g, d) + c / PI);
        if (!occluded_scene(g, o, d, FAR)) {
            vec3 v = sky_radiance(g, d) * (c / pdf);
            sum += v;
            sum2 += v * v;
        }
    }
    return mean_and_error(sum, sum2, count, se);
}

#endif
