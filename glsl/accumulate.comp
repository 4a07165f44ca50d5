// Kernel `accumulate`: end of a bounce: indirect += next, unshot = next, for nodes
// first .. first+count. CPU twin: CpuBackend::end_bounce.
#version 460
#include "layout.glsl"

// Push constants: src/gpu/kernels/accumulate.rs `AccumulatePush`.
layout(push_constant) uniform AccumulatePush {
    GlobalsRef g;
    uint first; // first node (global index) of the range
    uint count; // nodes in the range
} pc;

layout(local_size_x = LINEAR_GROUP) in;

void main() {
    uint id = linear_id();
    if (id >= pc.count) {
        return;
    }
    GlobalsRef g = pc.g;
    uint j = pc.first + id;
    vec4 v = g.next.v[j];
    g.indirect.v[j] += v;
    g.unshot.v[j] = v;
}
