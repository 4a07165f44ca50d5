// Kernel `batches`: indirect dispatch arguments for the batches of a level whose active
// count the device just computed (counters[pc.count_slot]): for batch b (pc.batches
// batches of pc.batch_size integrals), the ray kernels' grid at
// dispatch_args[DISPATCH_PER_BATCH (pc.first_batch + b) + DISPATCH_RAYS] and the
// reduction's at [... + DISPATCH_REDUCE]; grids wider than pc.max_groups_x fold into y.
#version 460
#include "layout.glsl"

// Push constants: src/gpu/kernels/batches.rs `BatchesPush`.
layout(push_constant) uniform BatchesPush {
    GlobalsRef g;
    uint batches;      // batches the level could need (its size / batch_size, rounded up)
    uint batch_size;   // integrals per batch
    uint count_slot;   // the counter holding the level's active count
    uint max_groups_x; // the device's largest x grid
    uint first_batch;  // where this list's grids start, in batches
    uint pad0;
} pc;

layout(local_size_x = LINEAR_GROUP) in;

void grid(uint at, uint groups) {
    uint x = min(groups, pc.max_groups_x);
    uint y = x == 0u ? 0u : (groups + x - 1u) / x;
    pc.g.dispatch_args.v[at] = x;
    pc.g.dispatch_args.v[at + 1u] = y;
    pc.g.dispatch_args.v[at + 2u] = 1u;
}

void main() {
    uint b = gl_GlobalInvocationID.x;
    if (b >= pc.batches) {
        return;
    }
    GlobalsRef g = pc.g;
    uint batch = pc.batch_size;
    uint total = g.counters.v[pc.count_slot];
    uint n = total > b * batch ? min(total - b * batch, batch) : 0u;
    uint at = DISPATCH_PER_BATCH * (pc.first_batch + b);
    grid(at + DISPATCH_RAYS, (n * g.rays_per_integral + LINEAR_GROUP - 1u) / LINEAR_GROUP);
    grid(at + DISPATCH_REDUCE, n);
}
