// Kernel `accumulate`: end of a bounce: indirect += next, unshot = next, for nodes
// first .. first+count. CPU twin: CpuBackend::end_bounce.
#version 460
#include "layout.glsl"

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
