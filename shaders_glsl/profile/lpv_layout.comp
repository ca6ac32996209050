#version 460
// LPV SH grid layouts: one propagation-like gather step over an N³ grid of 12 floats per cell
// (3 colour channels × 4 SH coefficients): each cell reads its six face neighbours' 12
// coefficients and writes its own 12. LAYOUT 0: coefficient-major floats [channel·4+k][cell]
// (the engine's LPV grids, lpv/common.glsl); 1: cell-major vec4s [cell][channel]; 2: one
// RGBA32F 3D storage image per channel. The arithmetic is identical in all three.
#ifndef LAYOUT
#define LAYOUT 0
#endif
// 8 wide: llvmpipe vectorizes only along x (8 lanes at 256 bits), as the LPV cell passes.
layout(local_size_x = 8, local_size_y = 4, local_size_z = 2) in;
layout(push_constant) uniform Push { uint n; } pc;

#if LAYOUT == 2
layout(set = 0, binding = 0, rgba32f) readonly uniform image3D src_r;
layout(set = 0, binding = 1, rgba32f) readonly uniform image3D src_g;
layout(set = 0, binding = 2, rgba32f) readonly uniform image3D src_b;
layout(set = 0, binding = 3, rgba32f) writeonly uniform image3D dst_r;
layout(set = 0, binding = 4, rgba32f) writeonly uniform image3D dst_g;
layout(set = 0, binding = 5, rgba32f) writeonly uniform image3D dst_b;

void load(ivec3 c, out vec4 v[3]) {
    v[0] = imageLoad(src_r, c);
    v[1] = imageLoad(src_g, c);
    v[2] = imageLoad(src_b, c);
}

void store(ivec3 c, vec4 v[3]) {
    imageStore(dst_r, c, v[0]);
    imageStore(dst_g, c, v[1]);
    imageStore(dst_b, c, v[2]);
}
#else
uint cell_linear(ivec3 c) { return uint(c.x) + pc.n * (uint(c.y) + pc.n * uint(c.z)); }
#if LAYOUT == 1
layout(set = 0, binding = 0, std430) readonly buffer Src { vec4 v[]; } src;
layout(set = 0, binding = 1, std430) writeonly buffer Dst { vec4 v[]; } dst;

void load(ivec3 c, out vec4 v[3]) {
    uint cl = cell_linear(c);
    for (uint ch = 0u; ch < 3u; ++ch) v[ch] = src.v[cl * 3u + ch];
}

void store(ivec3 c, vec4 v[3]) {
    uint cl = cell_linear(c);
    for (uint ch = 0u; ch < 3u; ++ch) dst.v[cl * 3u + ch] = v[ch];
}
#else
layout(set = 0, binding = 0, std430) readonly buffer Src { float v[]; } src;
layout(set = 0, binding = 1, std430) writeonly buffer Dst { float v[]; } dst;

void load(ivec3 c, out vec4 v[3]) {
    uint cells = pc.n * pc.n * pc.n;
    uint cl = cell_linear(c);
    for (uint ch = 0u; ch < 3u; ++ch) {
        for (uint k = 0u; k < 4u; ++k) v[ch][k] = src.v[(ch * 4u + k) * cells + cl];
    }
}

void store(ivec3 c, vec4 v[3]) {
    uint cells = pc.n * pc.n * pc.n;
    uint cl = cell_linear(c);
    for (uint ch = 0u; ch < 3u; ++ch) {
        for (uint k = 0u; k < 4u; ++k) dst.v[(ch * 4u + k) * cells + cl] = v[ch][k];
    }
}
#endif
#endif

const ivec3 DIRS[6] = ivec3[6](ivec3(1, 0, 0), ivec3(-1, 0, 0), ivec3(0, 1, 0), ivec3(0, -1, 0), ivec3(0, 0, 1), ivec3(0, 0, -1));

void main() {
    ivec3 cell = ivec3(gl_GlobalInvocationID);
    ivec3 n = ivec3(pc.n);
    if (any(greaterThanEqual(cell, n))) return;
    vec4 o[3] = vec4[3](vec4(0.0), vec4(0.0), vec4(0.0));
    for (int i = 0; i < 6; ++i) {
        ivec3 from = cell - DIRS[i];
        if (any(lessThan(from, ivec3(0))) || any(greaterThanEqual(from, n))) continue;
        vec4 s[3];
        load(from, s);
        // Dyadic stand-ins for the SH basis toward the cell and the face's cosine lobe: the cost
        // of the real step's evaluate-and-reproject, but exact, so layouts compare bit for bit.
        vec3 d = vec3(DIRS[i]);
        vec4 basis = vec4(0.5, -0.5 * d.y, 0.5 * d.z, -0.5 * d.x);
        vec4 lobe = vec4(0.25, -0.5 * d.y, 0.5 * d.z, -0.5 * d.x);
        for (int ch = 0; ch < 3; ++ch) o[ch] += 0.25 * s[ch] + dot(s[ch], basis) * lobe;
    }
    store(cell, o);
}
