// Kernel `batches`: indirect dispatch arguments for the batches of a level whose active
// count the device just computed (counters[pc.aux]): for batch b (pc.count batches of
// pc.offset integrals), the ray kernels' grid at dispatch_args[6b .. 6b+3] and the
// reduction's at [6b+3 .. 6b+6]; grids wider than pc.level workgroups fold into y.
#version 460
#include "layout.glsl"

layout(local_size_x = LINEAR_GROUP) in;

void grid(uint at, uint groups) {
    uint x = min(groups, pc.level);
    uint y = x == 0u ? 0u : (groups + x - 1u) / x;
    pc.g.dispatch_args.v[at] = x;
    pc.g.dispatch_args.v[at + 1u] = y;
    pc.g.dispatch_args.v[at + 2u] = 1u;
}

void main() {
    uint b = gl_GlobalInvocationID.x;
    if (b >= pc.count) {
        return;
    }
    GlobalsRef g = pc.g;
    uint batch = pc.offset;
    uint total = g.counters.v[pc.aux];
    uint n = total > b * batch ? min(total - b * batch, batch) : 0u;
    grid(6u * b, (n * g.rays_per_integral + LINEAR_GROUP - 1u) / LINEAR_GROUP);
    grid(6u * b + 3u, n);
}
