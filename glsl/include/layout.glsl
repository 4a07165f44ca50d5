// Mirrors of the host structs in src/layout.rs and src/gpu/globals.rs, by name.
// Every buffer is reached through its device address (GL_EXT_buffer_reference): no
// descriptor sets, and no per-binding size limit (lavapipe's is 128 MiB).
#ifndef LAYOUT_GLSL
#define LAYOUT_GLSL

#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "constants.glsl"

// Specialization constants, set per solve (src/gpu/pipeline.rs): the variant, whether
// any material is textured (texture sampling is compiled out otherwise), and the BVH.
layout(constant_id = SPEC_VARIANT) const uint VARIANT = VARIANT_MODIFIED;
layout(constant_id = SPEC_TEXTURED) const bool TEXTURED = true;
layout(constant_id = SPEC_BVH_KIND) const uint BVH_KIND = BVH_BVH2;

struct Tri { vec3 v0; uint material; vec3 v1; uint pad0; vec3 v2; uint pad1; };
struct TriUv { float uv[6]; };
struct Node { vec3 pos; uint level; vec3 normal; uint object; };
struct KdSplit { float value; uint dim; };
struct Parent { uint node; float weight; };
struct Material { vec3 kd; uint texture; uint alpha_texture; float opacity; float cutoff; uint pad; };
struct TextureInfo { uint offset; uint width; uint height; uint wrap; };
struct GpuLight { vec3 position; uint kind; vec3 direction; float cutoff; vec3 power; float beam; };
struct ObjectInfo {
    vec4 to_object[3];
    vec4 to_world[3];
    float scale;
    uint tri_offset;
    uint tri_count;
    uint bvh_offset;
    uint level_start[MAX_LEVELS];
    uint level_count[MAX_LEVELS];
    float radius[MAX_LEVELS];
    uint cw_root;
    uint pad0;
    uint pad1;
    uint pad2;
};
struct BvhNode { vec3 lo; float pad0; vec3 hi; float pad1; uint prim_count; uint first_index; uint meta1; uint meta2; };
struct CwNode { vec3 p; uint e_imask; uint child_base; uint prim_base; uvec2 meta; uvec2 lox; uvec2 hix; uvec2 loy; uvec2 hiy; uvec2 loz; uvec2 hiz; };
struct GpuEmitter { uint tri; uint object; float prob; float cdf; vec3 radiance; float lum; vec3 scale; uint texture; };
struct Ray { vec4 o; vec4 d; };
struct HitRecord { uint object; uint tri; float b1; float b2; };

layout(buffer_reference, std430, buffer_reference_align = 16) buffer TriRef { Tri v[]; };
layout(buffer_reference, std430, buffer_reference_align = 8) buffer TriUvRef { TriUv v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer NodeRef { Node v[]; };
layout(buffer_reference, std430, buffer_reference_align = 8) buffer KdSplitRef { KdSplit v[]; };
layout(buffer_reference, std430, buffer_reference_align = 8) buffer ParentRef { Parent v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer MaterialRef { Material v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer TextureInfoRef { TextureInfo v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer LightRef { GpuLight v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer ObjectRef { ObjectInfo v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer BvhRef { BvhNode v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer CwNodeRef { CwNode v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer EmitterRef { GpuEmitter v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer RayRef { Ray v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer HitRef { HitRecord v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer Vec4Ref { vec4 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 8) buffer Vec2Ref { vec2 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) buffer FloatRef { float v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) buffer UintRef { uint v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer Uvec4Ref { uvec4 v[]; };

// Everything a kernel can reach: src/gpu/globals.rs `Globals`.
layout(buffer_reference, std430, buffer_reference_align = 16) buffer GlobalsRef {
    TriRef tris;
    TriUvRef uvs;
    BvhRef bvh;
    CwNodeRef cw_nodes;
    UintRef cw_prims;
    MaterialRef materials;
    TextureInfoRef textures;
    UintRef texels;
    FloatRef srgb;
    LightRef lights;
    ObjectRef objects;
    NodeRef nodes;
    KdSplitRef splits;
    Uvec4Ref clips;
    UintRef sides;
    UintRef parent_offset;
    ParentRef parents;
    UintRef child_offset;
    UintRef children;
    Vec2Ref halton;
    Vec4Ref direct;
    Vec4Ref unshot;
    Vec4Ref next;
    Vec4Ref indirect;
    Vec4Ref pred;
    Vec4Ref gathered_mean;
    Vec4Ref gathered_err;
    UintRef active_flag;
    UintRef child_flag;
    UintRef active_list;
    UintRef linked_list;
    UintRef counters;
    RayRef rays;
    HitRef hits;
    Vec4Ref contrib;
    FloatRef energy;
    UintRef dispatch_args;
    UintRef link_slot;
    Uvec4Ref links;
    UintRef link_counters;
    uint num_objects;
    uint num_lights;
    uint rays_per_integral;
    uint seed;
    float scene_scale;
    float kappa;
    float alpha;
    float approx_cos;
    float eps_rel;
    float eps_abs;
    float noise_z;
    uint levels;
    uint sender_level;
    uint link_capacity;
    EmitterRef emitters;
    Vec4Ref emitter_points;
    Vec4Ref sky_texels;
    FloatRef sky_rows;
    FloatRef sky_cols;
    FloatRef sky_prob;
    FloatRef direct_err;
    uint num_emitters;
    uint emitter_samples;
    uint sky_kind;
    uint sky_width;
    uint sky_height;
    float sky_rotate;
    float sky_r;
    float sky_g;
    float sky_b;
    float plane;
};

// Push constants are declared by each kernel (its own block, `<Name>Push`, mirrored by
// src/gpu/kernels/<name>.rs); the four kernels of a gathering batch share
// `GatherPush` (gather.glsl).

// Linear invocation index over a 2-D grid of 1-D workgroups of LINEAR_GROUP threads
// (grids may exceed 65535 groups). Not gl_WorkGroupSize: this file is included before a
// kernel declares its local size, where glslang still takes it as 1.
uint linear_id() {
    return (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * LINEAR_GROUP + gl_LocalInvocationID.x;
}

// Linear workgroup index.
uint group_id() {
    return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
}

// Whether a node's gathers read its links (its slot word: recorded by an earlier gather,
// not NONE and not marked as recording).
bool is_linked(uint slot) {
    return slot != NONE && (slot & LINK_RECORDING) == 0u;
}

#endif
