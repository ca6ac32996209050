#ifndef COMMON_HASH_GLSL
#define COMMON_HASH_GLSL
// PCG-style integer hash (Jarzynski & Olano 2020): per-pixel independent random streams.
uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}
#endif
