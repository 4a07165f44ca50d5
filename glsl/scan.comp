// Kernel `scan`: the exclusive prefix sum of pc.count words of pc.data, in place, in
// three dispatches (pc.mode): BLOCKS scans each block of SCAN_BLOCK words and writes
// its total to pc.sums; SUMS scans the block totals in one workgroup; ADD adds each
// block's offset. Integer sums: exact, whatever the order. For the relations' CSR
// offsets (kernel `relations`); no CPU twin (the host's is a loop).
#version 460
#include "layout.glsl"

// Push constants: src/gpu/kernels/scan.rs `ScanPush`.
layout(push_constant) uniform ScanPush {
    GlobalsRef g;
    UintRef data;
    UintRef sums; // one word per block
    uint count; // words of data
    uint mode;
} pc;

layout(local_size_x = LINEAR_GROUP) in;

const uint BLOCKS = 0u;
const uint SUMS = 1u;
const uint ADD = 2u;
const uint PER_THREAD = 4u;
const uint SCAN_BLOCK = LINEAR_GROUP * PER_THREAD;

shared uint s_part[LINEAR_GROUP];

// Exclusive scan of the threads' values across the workgroup; returns this thread's
// offset, and the total in `total`.
uint group_scan(uint v, out uint total) {
    uint t = gl_LocalInvocationID.x;
    s_part[t] = v;
    barrier();
    for (uint s = 1u; s < LINEAR_GROUP; s <<= 1u) {
        uint add = t >= s ? s_part[t - s] : 0u;
        barrier();
        s_part[t] += add;
        barrier();
    }
    total = s_part[LINEAR_GROUP - 1u];
    uint incl = s_part[t];
    barrier();
    return incl - v;
}

void main() {
    uint t = gl_LocalInvocationID.x;
    if (pc.mode == SUMS) {
        // One workgroup walks the block totals, SCAN_BLOCK at a time.
        uint blocks = (pc.count + SCAN_BLOCK - 1u) / SCAN_BLOCK;
        uint carry = 0u;
        for (uint first = 0u; first < blocks; first += SCAN_BLOCK) {
            uint v[PER_THREAD];
            uint own = 0u;
            for (uint i = 0u; i < PER_THREAD; i++) {
                uint k = first + t * PER_THREAD + i;
                v[i] = k < blocks ? pc.sums.v[k] : 0u;
                own += v[i];
            }
            uint total;
            uint off = group_scan(own, total) + carry;
            for (uint i = 0u; i < PER_THREAD; i++) {
                uint k = first + t * PER_THREAD + i;
                if (k < blocks) {
                    pc.sums.v[k] = off;
                }
                off += v[i];
            }
            carry += total;
        }
        return;
    }
    uint block = group_id();
    uint first = block * SCAN_BLOCK;
    if (first >= pc.count) {
        return;
    }
    if (pc.mode == ADD) {
        uint add = pc.sums.v[block];
        for (uint i = 0u; i < PER_THREAD; i++) {
            uint k = first + t * PER_THREAD + i;
            if (k < pc.count) {
                pc.data.v[k] += add;
            }
        }
        return;
    }
    // BLOCKS
    uint v[PER_THREAD];
    uint own = 0u;
    for (uint i = 0u; i < PER_THREAD; i++) {
        uint k = first + t * PER_THREAD + i;
        v[i] = k < pc.count ? pc.data.v[k] : 0u;
        own += v[i];
    }
    uint total;
    uint off = group_scan(own, total);
    for (uint i = 0u; i < PER_THREAD; i++) {
        uint k = first + t * PER_THREAD + i;
        if (k < pc.count) {
            pc.data.v[k] = off;
        }
        off += v[i];
    }
    if (t == 0u) {
        pc.sums.v[block] = total;
    }
}
