// Kernel `poisson`: one Poisson-disk level of one object by dart throwing, on the device
// (ALGORITHM.md §3.2), with exactly the host's result: candidate i (of the first
// pc.count of the object's pool, in pool order) is accepted iff no earlier accepted
// candidate on the same side lies closer than r and it is not in a crevice. That is the
// lexicographically first maximal independent set of the conflict graph, which rounds
// of RESOLVE build in parallel: a candidate with an accepted earlier neighbour is out; one
// whose earlier neighbours are all out is decided by its crevice test; the others wait
// for the next round. Every round decides at least the first undecided candidate, and
// with candidates in random order the chains of waiting are short (Blelloch, Fineman &
// Shun 2012), so a level takes tens of rounds. The neighbours come from a hashed grid of
// the candidates, cells 2r wide as on the host: COUNT counts each bucket's candidates
// (kernel `scan` makes them offsets), SCATTER lists them by bucket.
// CPU twin: hierarchy::poisson::dart_throw with hierarchy::{in_crevice, in_crevice_within}
// as `usable`.
#version 460
#include "geometry.glsl"
#include "sampling.glsl"

// Push constants: src/gpu/kernels/poisson.rs `PoissonPush`.
layout(push_constant) uniform PoissonPush {
    GlobalsRef g;
    FloatRef cands; // the object's pool: per candidate, object-space position and normal (6 floats)
    UintRef state; // per candidate of the level: UNDECIDED, IN or OUT
    UintRef memo; // per candidate of the pool: 0 not tested, OPEN or CREVICE (kept across levels)
    UintRef table; // per bucket and one more: counts, then (scanned) offsets
    UintRef fill; // per bucket: candidates listed so far
    Vec4Ref sorted; // the candidates by bucket: (position, index bits), (normal, 0)
    UintRef counters; // [0] crevices found; [1 + k] candidates left undecided by round k
    uint count; // candidates of the level: the first `count` of the pool
    uint mask; // buckets - 1
    float r; // the level's radius (object space)
    float r2; // r * r, as the host rounds it
    float inv_cell; // 0.5 / r
    float d_min; // crevice distance: world units, object units with `within`; 0: no test
    float diag; // the object's diagonal (ray offsets in object space, `within`)
    uint object;
    uint within; // 1: reach = "object", the crevice test against this object alone
    uint stage;
    uint round;
    uint pad0;
} pc;

layout(local_size_x = LINEAR_GROUP) in;

const uint COUNT = 0u;
const uint SCATTER = 1u;
const uint RESOLVE = 2u;

const uint UNDECIDED = 0u;
const uint IN = 1u;
const uint OUT = 2u;

const uint OPEN = 1u;
const uint CREVICE = 2u;

vec3 cand_pos(uint i) {
    return vec3(pc.cands.v[6u * i], pc.cands.v[6u * i + 1u], pc.cands.v[6u * i + 2u]);
}

vec3 cand_normal(uint i) {
    return vec3(pc.cands.v[6u * i + 3u], pc.cands.v[6u * i + 4u], pc.cands.v[6u * i + 5u]);
}

// poisson::Grid::cell: floor(p / 2r) per axis.
ivec3 cell(vec3 p) {
    precise vec3 c = p * pc.inv_cell;
    return ivec3(floor(c));
}

uint bucket(ivec3 k) {
    uvec3 u = uvec3(k);
    return ((u.x * 73856093u) ^ (u.y * 19349663u) ^ (u.z * 83492791u)) & pc.mask;
}

// The crevice test's 8 stratified cosine-distributed rays (hierarchy::crevice_rays and
// in_crevice_within_traced): whether 7 of them meet something within d_min. Stops once
// two got through.
bool in_crevice(GlobalsRef g, ObjectInfo ob, vec3 pos, vec3 nrm, uint index) {
    vec3 origin;
    vec3 n;
    if (pc.within != 0u) {
        n = nrm;
        origin = offset_origin(pos, n, pc.diag);
    } else {
        vec3 x = xform_point(ob.to_world, pos);
        n = normalize(xform_vector(ob.to_world, nrm));
        origin = offset_origin(x, n, g.scene_scale);
    }
    vec3 t;
    vec3 b;
    onb(n, t, b);
    float phi0 = integral_rotation(0x0c0eu, index);
    uint open_ = 0u;
    for (uint k = 0u; k < 8u && open_ < 2u; k++) {
        vec2 u = vec2((float(k) + 0.5) / 8.0, fract(float(k) * 0.618034));
        vec3 d = cosine_direction(n, t, b, u, phi0);
        bool blocked;
        if (pc.within != 0u) {
            float tm = pc.d_min;
            uint tri;
            vec3 tuv;
            blocked = trace_object(g, ob, origin, d, tm, true, tri, tuv);
        } else {
            blocked = occluded_scene(g, origin, d, pc.d_min);
        }
        if (!blocked) {
            open_++;
        }
    }
    return open_ < 2u;
}

// The candidates of bucket `b` before `i` that conflict with it (closer than r, same
// side): IN if one of them is in, else UNDECIDED if one of them is undecided, else OUT.
uint visit(uint b, uint i, vec3 p, vec3 n) {
    uint end = pc.table.v[b + 1u];
    uint found = OUT;
    for (uint k = pc.table.v[b]; k < end; k++) {
        vec4 pj = pc.sorted.v[2u * k];
        uint j = floatBitsToUint(pj.w);
        if (j >= i) {
            continue;
        }
        precise vec3 d = pj.xyz - p;
        precise float d2 = d.x * d.x + d.y * d.y + d.z * d.z;
        vec3 nj = pc.sorted.v[2u * k + 1u].xyz;
        precise float side = nj.x * n.x + nj.y * n.y + nj.z * n.z;
        if (d2 < pc.r2 && side > 0.0) {
            uint s = pc.state.v[j];
            if (s == IN) {
                return IN;
            }
            if (s == UNDECIDED) {
                found = UNDECIDED;
            }
        }
    }
    return found;
}

void main() {
    uint i = linear_id();
    if (i >= pc.count) {
        return;
    }
    vec3 p = cand_pos(i);
    if (pc.stage == COUNT) {
        atomicAdd(pc.table.v[bucket(cell(p))], 1u);
        return;
    }
    if (pc.stage == SCATTER) {
        uint b = bucket(cell(p));
        uint at = pc.table.v[b] + atomicAdd(pc.fill.v[b], 1u);
        pc.sorted.v[2u * at] = vec4(p, uintBitsToFloat(i));
        pc.sorted.v[2u * at + 1u] = vec4(cand_normal(i), 0.0);
        return;
    }
    // RESOLVE
    if (pc.state.v[i] != UNDECIDED) {
        return;
    }
    vec3 n = cand_normal(i);
    // Every point within r lies in a cell between those of p - r and p + r
    // (poisson::Grid::conflicts); the same distance and side test as the host's.
    precise vec3 plo = p - vec3(pc.r);
    precise vec3 phi = p + vec3(pc.r);
    ivec3 lo = cell(plo);
    ivec3 hi = cell(phi);
    // The own cell first, where most candidates meet an accepted neighbour.
    ivec3 own = cell(p);
    uint w = visit(bucket(own), i, p, n);
    if (w == IN) {
        pc.state.v[i] = OUT;
        return;
    }
    bool waiting = w == UNDECIDED;
    uint seen = bucket(own);
    for (int x = lo.x; x <= hi.x; x++) {
        for (int y = lo.y; y <= hi.y; y++) {
            for (int z = lo.z; z <= hi.z; z++) {
                uint b = bucket(ivec3(x, y, z));
                if (b == seen) {
                    continue;
                }
                w = visit(b, i, p, n);
                if (w == IN) {
                    pc.state.v[i] = OUT;
                    return;
                }
                waiting = waiting || w == UNDECIDED;
            }
        }
    }
    if (waiting) {
        atomicAdd(pc.counters.v[1u + pc.round], 1u);
        return;
    }
    // Every earlier neighbour is out: the candidate is in unless it lies in a crevice
    // (the test memoised per pool candidate, across the object's levels).
    uint m = pc.memo.v[i];
    if (m == 0u) {
        GlobalsRef g = pc.g;
        m = pc.d_min > 0.0 && in_crevice(g, g.objects.v[pc.object], p, n, i) ? CREVICE : OPEN;
        pc.memo.v[i] = m;
        if (m == CREVICE) {
            atomicAdd(pc.counters.v[0], 1u);
        }
    }
    pc.state.v[i] = m == OPEN ? IN : OUT;
}
