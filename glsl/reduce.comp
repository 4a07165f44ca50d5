// Kernel `reduce`: the Monte Carlo reduction on the GPU, one workgroup per integral:
// mean and standard error of its N samples, summed in a fixed order (each thread a
// strided run, compensated, then a tree in shared memory), so the result is deterministic
// on a device and a million samples sum to float32 precision.
// The sums are taken about the first sample (a shift) so that the variance does not
// cancel in float32. CPU twin: the tail of transport::cpu::gather_integral.
#version 460
#include "layout.glsl"
#include "gather.glsl"

layout(local_size_x = GATHER_GROUP) in;

shared vec3 s_sum[GATHER_GROUP];
shared vec3 s_sq[GATHER_GROUP];

void main() {
    uint i = group_id();
    if (i >= batch_count()) {
        return;
    }
    GlobalsRef g = pc.g;
    uint n_rays = pc.rays;
    uint base = i * n_rays;
    Vec4Ref contrib = g.contrib;
    vec3 shift = contrib.v[base].xyz;
    // Each thread's run is Kahan-compensated (`precise` keeps the compiler from
    // simplifying the compensation away), then the tree adds 128 partial sums.
    precise vec3 sum = vec3(0.0);
    precise vec3 comp = vec3(0.0);
    precise vec3 sq = vec3(0.0);
    for (uint r = gl_LocalInvocationID.x; r < n_rays; r += GATHER_GROUP) {
        vec3 c = contrib.v[base + r].xyz - shift;
        precise vec3 y = c - comp;
        precise vec3 t2 = sum + y;
        comp = (t2 - sum) - y;
        sum = t2;
        sq += c * c;
    }
    uint t = gl_LocalInvocationID.x;
    s_sum[t] = sum;
    s_sq[t] = sq;
    barrier();
    for (uint s = GATHER_GROUP / 2u; s > 0u; s >>= 1u) {
        if (t < s) {
            s_sum[t] += s_sum[t + s];
            s_sq[t] += s_sq[t + s];
        }
        barrier();
    }
    if (t == 0u) {
        float nf = float(n_rays);
        vec3 m = s_sum[0] / nf;
        vec3 var = n_rays > 1u ? max((s_sq[0] / nf - m * m) * (nf / (nf - 1.0)), vec3(0.0)) : vec3(0.0);
        uint j = integral_node(g, i);
        g.gathered_mean.v[j] = vec4(m + shift, 0.0);
        g.gathered_err.v[j] = vec4(sqrt(var / nf), 0.0);
        g.active_flag.v[j] = 1u;
        if (links_on()) {
            // Links recorded: the node's later gathers read them.
            uint s = g.link_slot.v[j];
            if (s != NONE && (s & LINK_RECORDING) != 0u) {
                g.link_slot.v[j] = s & ~LINK_RECORDING;
            }
        }
    }
}
