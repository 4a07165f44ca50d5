// Twin of src/geom/rng.rs and src/geom/sampling.rs.
#ifndef SAMPLING_GLSL
#define SAMPLING_GLSL

const float TAU = 6.28318530717958647692;
const float PI = 3.14159265358979323846;

uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

float hash_to_unit(uint h) {
    return float(h >> 8u) * (1.0 / 16777216.0);
}

uint hash2(uint a, uint b) {
    return pcg_hash(a ^ pcg_hash(b + 0x9e3779b9u));
}

void onb(vec3 n, out vec3 t, out vec3 b) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float c = n.x * n.y * a;
    t = vec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
    b = vec3(c, s + n.y * n.y * a, -n.y);
}

float integral_rotation(uint seed, uint node) {
    return hash_to_unit(hash2(node, seed)) * TAU;
}

vec3 cosine_direction(vec3 n, vec3 t, vec3 b, vec2 u, float phi0) {
    float r = sqrt(u.x);
    float phi = u.y * TAU + phi0;
    float z = sqrt(max(1.0 - u.x, 0.0));
    return t * (r * cos(phi)) + b * (r * sin(phi)) + n * z;
}

#endif
