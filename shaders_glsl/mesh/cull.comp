#version 460
// Triangle culling for one raster view (after Wihlidal, "Optimizing the Graphics Pipeline with
// Compute", GDC 2016). llvmpipe's geometry front end fetches, shades, sets up and bins every
// triangle of a draw on one thread, whatever the triangle covers (~0.1 µs each, most of a 72k-
// triangle pass); this pass keeps only the triangles that can cover a sample of the view, in
// their order, so the view's image stays the same bit for bit.
// A workgroup per chunk of one mesh's triangles, and one subgroup per workgroup (its size is
// the device's least subgroup size, a specialization constant): the survivors' places are a
// ballot's prefix, with no shared memory or barrier (llvmpipe runs a barrier by switching every
// SIMD row's coroutine). They are compacted to the front of the chunk's index range in the
// view's own index buffer, and the chunk's indirect draw draws them.
#extension GL_KHR_shader_subgroup_ballot : require
#define MESH_FRAME_NO_DRAW
#include "frame.glsl"
// SIMD width: the workgroup is the device's least subgroup size (specialization constant 0):
// 8 on llvmpipe at 256 bits, one full row; the reflected default of 1 is never dispatched.
layout(local_size_x_id = 0) in;
// The scene's vertex positions (xyz, 1) and indices as texels: llvmpipe gathers a texel per
// lane in one vector operation.
layout(set = 0, binding = 1, rgba32f) readonly uniform imageBuffer positions;
layout(set = 0, binding = 2, r32ui) readonly uniform uimageBuffer indices;
// Per chunk: first index, triangles, 1 where back faces may be culled (single-sided), unused;
// then its triangles' bounding box (minimum, maximum corner).
struct Chunk {
    uvec4 range;
    vec4 lo;
    vec4 hi;
};
layout(set = 0, binding = 3, std430) readonly buffer Chunks { Chunk chunk[]; };
layout(set = 0, binding = 4, std430) writeonly buffer Kept { uint kept[]; };
// A VkDrawIndexedIndirectCommand per chunk.
layout(set = 0, binding = 5, std430) writeonly buffer Draws { uint draws[]; };
// Triangles kept per draw view this frame (engine/mesh/cull.rs CullStats).
layout(set = 0, binding = 6, std430) buffer Stats { uint kept_triangles[]; };
layout(push_constant) uniform Push {
    uint view;
    float facing;  // +1: cull signed area < 0 (the camera's back faces), −1: > 0 (light views), 0: none
    vec2 origin;   // the viewport's corner and size, framebuffer pixels
    vec2 size;
} P;

vec4 clip_position(uint v, mat4 m) {
    return m * imageLoad(positions, int(v));
}

// The side planes of the clip volume (|x|, |y| ≤ w) clip-space point c lies beyond, one bit
// each (x > w, x < −w, y > w, y < −w): points all beyond one plane have no fragment between them.
uvec4 beyond(vec4 c) {
    return uvec4(bvec4(c.x > c.w, c.x < -c.w, c.y > c.w, c.y < -c.w));
}

// Whether a triangle may produce a fragment; `false` only where it provably cannot.
bool may_cover(vec4 a, vec4 b, vec4 c, bool cull_facing) {
    if (any(notEqual(beyond(a) & beyond(b) & beyond(c), uvec4(0u)))) return false;
    // A vertex at or behind the eye: clipping makes new vertices; keep the triangle.
    if (min(a.w, min(b.w, c.w)) <= 0.0) return true;
    vec2 p0 = P.origin + (a.xy / a.w * 0.5 + 0.5) * P.size;
    vec2 p1 = P.origin + (b.xy / b.w * 0.5 + 0.5) * P.size;
    vec2 p2 = P.origin + (c.xy / c.w * 0.5 + 0.5) * P.size;
    vec2 lo = min(p0, min(p1, p2));
    vec2 hi = max(p0, max(p1, p2));
    // Margin for the rasterizer's vertex snapping (llvmpipe: 1/256 pixel) and for float rounding,
    // which grows with the coordinates.
    vec2 mag = max(abs(lo), abs(hi));
    float m = 1.0 / 64.0 + max(mag.x, mag.y) * (1.0 / 262144.0);
    // No sample centre (k + 0.5) in the box along x or along y.
    if (any(greaterThan(ceil(lo - m - 0.5), floor(hi + m - 0.5)))) return false;
    if (cull_facing) {
        // Vulkan's signed area in framebuffer coordinates (> 0: counter-clockwise, front with the
        // pipelines' front face); culled only beyond what snapping each vertex could change.
        vec2 e = p1 - p0;
        vec2 f = p2 - p0;
        float area = -0.5 * (e.x * f.y - e.y * f.x);
        float perimeter = length(e) + length(f) + length(p2 - p1);
        if (P.facing * area < -perimeter * (1.0 / 128.0)) return false;
    }
    return true;
}

// All eight corners of the box lo–hi outside one side plane of the clip volume: so is every
// point inside it (a half-space is convex), and every triangle of the chunk would be culled.
bool box_outside(vec3 lo, vec3 hi, mat4 m) {
    uvec4 all_beyond = uvec4(1u);
    for (uint k = 0u; k < 8u; ++k) {
        vec3 p = mix(lo, hi, vec3(uvec3(k, k >> 1, k >> 2) & 1u));
        all_beyond &= beyond(m * vec4(p, 1.0));
    }
    return any(notEqual(all_beyond, uvec4(0u)));
}

void main() {
    Chunk chunk_ = chunk[gl_WorkGroupID.x];
    uvec4 ch = chunk_.range;
    mat4 m = view_matrix(P.view);
    // A chunk wholly outside the view draws nothing and loads none of its triangles.
    if (box_outside(chunk_.lo.xyz, chunk_.hi.xyz, m)) ch.y = 0u;
    bool cull_facing = P.facing != 0.0 && ch.z != 0u;
    // A device that splits the workgroup after all keeps every triangle, in place.
    bool one_subgroup = gl_NumSubgroups == 1u;
    uint total = 0u;
    for (uint block = 0u; block < ch.y; block += gl_WorkGroupSize.x) {
        uint t = block + gl_LocalInvocationIndex;
        bool keep = false;
        uvec3 tri = uvec3(0u);
        if (t < ch.y) {
            int i = int(ch.x + 3u * t);
            tri = uvec3(imageLoad(indices, i).x, imageLoad(indices, i + 1).x, imageLoad(indices, i + 2).x);
            keep = !one_subgroup ||
                   may_cover(clip_position(tri.x, m), clip_position(tri.y, m), clip_position(tri.z, m), cull_facing);
        }
        uvec4 ballot = subgroupBallot(keep);
        uint at = one_subgroup ? total + subgroupBallotExclusiveBitCount(ballot) : t;
        total += one_subgroup ? subgroupBallotBitCount(ballot) : 0u;
        if (keep) {
            uint o = ch.x + 3u * at;
            kept[o] = tri.x;
            kept[o + 1u] = tri.y;
            kept[o + 2u] = tri.z;
        }
    }
    if (gl_LocalInvocationIndex == 0u) {
        uint d = 5u * gl_WorkGroupID.x;
        total = one_subgroup ? total : ch.y;
        atomicAdd(kept_triangles[P.view], total);
        draws[d] = 3u * total;                           // indexCount
        draws[d + 1u] = 1u;                              // instanceCount
        draws[d + 2u] = ch.x;                            // firstIndex
        draws[d + 3u] = 0u;                              // vertexOffset (the indices are global)
        draws[d + 4u] = 0u;                              // firstInstance
    }
}
