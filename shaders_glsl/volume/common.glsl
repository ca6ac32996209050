#ifndef VOLUME_COMMON_GLSL
#define VOLUME_COMMON_GLSL
// Shared by the volume renderers: parameters, camera rays, box clipping, sampling, transfer
// function, gradients. Units: world space; the volume box spans [box_min, box_max] and the
// transfer function's extinction is per world unit (largest box axis = 1).
#include "../common/hash.glsl"

layout(set = 0, binding = 0, std140) uniform Params {
    mat4 inv_view_proj;
    vec4 box_min;     // xyz; w = ray-march step in world units
    vec4 box_max;     // xyz; w = iso value
    vec4 light_dir;   // xyz towards the light; w = early-termination transmittance
    vec4 background;  // rgb; a = light intensity
    vec4 voxel;       // xyz = 1 / dims (texture-space voxel size)
    uvec4 flags;      // x: bit0 empty-space skipping, bit1 jitter; y: frame; z: block size in voxels;
                      // w: Monte Carlo seed (the random stream)
    uvec4 grid;       // xyz: occupancy grid dims (= the page table's: one cell per brick)
    uvec4 dims;       // xyz: voxel dims (the sparse layout's atlas is not the volume's size)
    vec4 atlas;       // xyz: 1 / the sparse layout's atlas extent in texels
} P;
layout(set = 0, binding = 1) uniform sampler3D volume_tex;
layout(set = 0, binding = 2) uniform sampler2D tf_tex;

const uint FLAG_ESS = 1u;
const uint FLAG_JITTER = 2u;

struct Ray { vec3 o; vec3 d; };

// Primary ray through point j ∈ [0, 1)² of pixel p; NDC y points down in Vulkan, the image's top
// row looks along +Y.
Ray camera_ray_at(ivec2 p, ivec2 size, vec2 j) {
    vec2 ndc = (vec2(p) + j) / vec2(size) * 2.0 - 1.0;
    ndc.y = -ndc.y;
    vec4 n = P.inv_view_proj * vec4(ndc, 0.0, 1.0);
    vec4 f = P.inv_view_proj * vec4(ndc, 1.0, 1.0);
    Ray r;
    r.o = n.xyz / n.w;
    r.d = normalize(f.xyz / f.w - r.o);
    return r;
}

// Primary ray through pixel p: its centre, or a point hashed from pixel and frame when jittering.
Ray camera_ray(ivec2 p, ivec2 size) {
    vec2 j = vec2(0.5);
    if ((P.flags.x & FLAG_JITTER) != 0u) {
        uint h = pcg_hash(uint(p.x) + 65536u * uint(p.y) + pcg_hash(P.flags.y));
        j = vec2(h & 0xffffu, h >> 16) / 65536.0;
    }
    return camera_ray_at(p, size, j);
}

// Slab test; returns (t_enter, t_exit), empty when t_enter >= t_exit.
vec2 intersect_box(Ray r, vec3 lo, vec3 hi) {
    vec3 inv = 1.0 / r.d;
    vec3 t0 = (lo - r.o) * inv;
    vec3 t1 = (hi - r.o) * inv;
    vec3 tmin = min(t0, t1);
    vec3 tmax = max(t0, t1);
    return vec2(max(max(tmin.x, tmin.y), max(tmin.z, 0.0)), min(min(tmax.x, tmax.y), tmax.z));
}

vec3 to_tex(vec3 world) { return (world - P.box_min.xyz) / (P.box_max.xyz - P.box_min.xyz); }

// Grid cells (occupancy, majorant) per unit of texture space along each axis. A cell is a block
// of P.flags.z voxels, as the host measured it, so when the voxel count is not a multiple of the
// block the last cell reaches past the volume: scaling by the cell count instead would shift
// every cell boundary off its block's and skip or under-bound voxels.
vec3 cells_per_tex() { return 1.0 / (P.voxel.xyz * float(P.flags.z)); }

// `filter=exact`: the volume and the transfer-function table are interpolated in f32 from texel
// fetches, with the weights a linear filter with clamp-to-edge uses, instead of by the texture
// unit. Hardware filters weigh texels with fixed-point fractions (subTexelPrecisionBits, 8 on an
// H200: a lerp may be off by 2⁻⁹ of its texels' difference, and the weights' sum off 1 by as
// much), which moved an EAM transmittance exp(−1.5) by 8e-5; llvmpipe filters in f32. A constant
// (0 unless the host sets it), so the default costs nothing; docs/accuracy.md gives the costs.
layout(constant_id = 2) const bool EXACT_FILTER = false;

// `volume_layout=sparse` (docs/volume-rendering.md): volume_tex and gradient_tex are atlases of
// 9³-texel slots, each an 8³ brick and its apron (the next voxel along each axis, clamped), and
// the page table maps a brick to its slot: x | y << 10 | z << 20 in slots. Uniform bricks share
// one slot per distinct (value, gradient), so the lookup has no branch (llvmpipe would run both
// sides) and a shared slot filters exactly as the dense texels it stands for. A constant: the
// dense layout folds the lookups away and samples as before; its page table is a 1³ placeholder.
layout(constant_id = 3) const bool SPARSE = false;
layout(set = 0, binding = 15, r32ui) uniform readonly uimage3D page_table;
const int BRICK = 8;
const int SLOT = BRICK + 1;

// Bit 31 of a page-table word: the brick may be visible under the current transfer function
// (the occupancy grid's bit for the brick's slot). EAM's empty-space skipping reads it with the
// slot, so the sparse layout costs one lookup per sample where the dense one has one too.
const uint PAGE_OCCUPIED = 0x80000000u;

uint page_word(ivec3 b) {
    return imageLoad(page_table, b).r;
}

// Texel origin in the atlas of the slot a page-table word names.
ivec3 word_origin(uint e) {
    return ivec3(e & 1023u, (e >> 10) & 1023u, (e >> 20) & 1023u) * SLOT;
}

// Texel origin in the atlas of the slot of brick `b` (page-table coordinates).
ivec3 slot_origin(ivec3 b) {
    return word_origin(page_word(b));
}

// Where dense texture coordinate `uvw` lies among the volume's texels: clamped to the outermost
// texel centres (where a clamp-to-edge filter returns the edge texels already).
vec3 texel_position(vec3 uvw) {
    vec3 dims = vec3(P.dims.xyz);
    return clamp(uvw * dims, vec3(0.5), dims - 0.5);
}

// The brick of texel position `x`: the one holding its lower filter texel, so the footprint is
// that brick and its apron. x − 0.5 ≤ dims − 1 keeps it inside the page table without a clamp.
ivec3 brick_of(vec3 x) {
    return ivec3((x - 0.5) * (1.0 / float(BRICK)));
}

// Atlas texture coordinates of texel position `x` in brick `b`, whose page-table word is `e`.
vec3 atlas_at(vec3 x, ivec3 b, uint e) {
    return (vec3(word_origin(e)) + (x - vec3(b * BRICK))) * P.atlas.xyz;
}

// Where dense texture coordinate `uvw` lies in the atlases, in their texture coordinates.
vec3 atlas_uvw(vec3 uvw) {
    vec3 x = texel_position(uvw);
    ivec3 b = brick_of(x);
    return atlas_at(x, b, page_word(b));
}

float trilinear_exact(vec3 uvw) {
    ivec3 size = SPARSE ? ivec3(P.dims.xyz) : textureSize(volume_tex, 0);
    vec3 x = clamp(uvw * vec3(size) - 0.5, vec3(0.0), vec3(size - 1));
    ivec3 a = ivec3(x);
    ivec3 b = min(a + 1, size - 1);
    vec3 f = x - vec3(a);
    if (SPARSE) {
        // Brick of the lower texel; the upper one is its neighbour or the apron (b - a ≤ 1).
        ivec3 shift = slot_origin(a / BRICK) - (a / BRICK) * BRICK;
        a += shift;
        b += shift;
    }
    float c00 = mix(texelFetch(volume_tex, a, 0).r, texelFetch(volume_tex, ivec3(b.x, a.y, a.z), 0).r, f.x);
    float c10 = mix(texelFetch(volume_tex, ivec3(a.x, b.y, a.z), 0).r, texelFetch(volume_tex, ivec3(b.x, b.y, a.z), 0).r, f.x);
    float c01 = mix(texelFetch(volume_tex, ivec3(a.x, a.y, b.z), 0).r, texelFetch(volume_tex, ivec3(b.x, a.y, b.z), 0).r, f.x);
    float c11 = mix(texelFetch(volume_tex, ivec3(a.x, b.y, b.z), 0).r, texelFetch(volume_tex, b, 0).r, f.x);
    return mix(mix(c00, c10, f.y), mix(c01, c11, f.y), f.z);
}

// The value lookup at dense texture coordinate `uvw` whose atlas coordinates `at` (sparse
// layout; ignored in the dense one) the caller already has.
float sample_volume_at(vec3 uvw, vec3 at) {
    if (EXACT_FILTER) return trilinear_exact(uvw);
    return texture(volume_tex, SPARSE ? at : uvw).r;
}

// Every volume renderer's value lookup, in either layout and either filter.
float sample_volume(vec3 uvw) {
    return sample_volume_at(uvw, SPARSE && !EXACT_FILTER ? atlas_uvw(uvw) : uvw);
}

// Every renderer's gradient-magnitude lookup: a macro because each shader declares
// `gradient_tex` at its own binding (after this file); the same atlas position as the value's.
#define sample_gradient(uvw) texture(gradient_tex, SPARSE ? atlas_uvw(uvw) : (uvw)).r
#define sample_gradient_at(uvw, at) texture(gradient_tex, SPARSE ? (at) : (uvw)).r

// Central differences, in value change per voxel along each axis.
vec3 gradient(vec3 uvw) {
    vec3 h = P.voxel.xyz;
    return 0.5 * vec3(
        sample_volume(uvw + vec3(h.x, 0, 0)) - sample_volume(uvw - vec3(h.x, 0, 0)),
        sample_volume(uvw + vec3(0, h.y, 0)) - sample_volume(uvw - vec3(0, h.y, 0)),
        sample_volume(uvw + vec3(0, 0, h.z)) - sample_volume(uvw - vec3(0, 0, h.z)));
}

// Transfer function: (rgb emission, extinction). Table texel i sits at value i/(N-1).
vec4 transfer(float v, float grad_mag) {
    ivec2 isize = textureSize(tf_tex, 0);
    vec2 size = vec2(isize);
    vec2 x = vec2(clamp(v, 0.0, 1.0), clamp(grad_mag, 0.0, 1.0)) * (size - 1.0);
    if (EXACT_FILTER) {
        ivec2 a = ivec2(x);
        ivec2 b = min(a + 1, isize - 1);
        vec2 f = x - vec2(a);
        vec4 r0 = mix(texelFetch(tf_tex, a, 0), texelFetch(tf_tex, ivec2(b.x, a.y), 0), f.x);
        vec4 r1 = mix(texelFetch(tf_tex, ivec2(a.x, b.y), 0), texelFetch(tf_tex, b, 0), f.x);
        return mix(r0, r1, f.y);
    }
    return texture(tf_tex, (x + 0.5) / size);
}
#endif
