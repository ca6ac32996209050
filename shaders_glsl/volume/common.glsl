#ifndef VOLUME_COMMON_GLSL
#define VOLUME_COMMON_GLSL
// Shared by the volume renderers: parameters, camera rays, box clipping, sampling, transfer
// function, gradients. Units: world space; the volume box spans [box_min, box_max] and the
// transfer function's extinction is per world unit (largest box axis = 1).
#include "../common/hash.glsl"

// Crop box (6) and clip planes (6): `engine/volume/render/clip_settings.rs`.
const uint MAX_CLIP_PLANES = 12u;
// Whether anything is clipped. A constant because llvmpipe pays for the plane loop even when it
// runs zero times: DOS, which tests every slice sample, took 1.26x as long per slice with it.
// True unless a pass says otherwise, so a pass that does not specialize it still clips.
layout(constant_id = 8) const bool CLIPPING = true;

// With OPAQUE_BLOCKS (the host sets it on llvmpipe) the uniform blocks of the volume shaders are
// read at an index that is not a compile-time constant (`g_block`, always 0; `load_params` sets
// it). lavapipe (Mesa 22.3) inlines uniform values that steer a shader's branches into it, and
// where that halves the shader it does so again at every dispatch: a clone and optimisation of
// the shader's NIR and a compile answered from Mesa's disk cache, 1.5–9 ms a dispatch for these
// shaders whatever the image size (measured: one disk-cache read a frame, 200 a frame for DOS's
// slices). A value read at a variable offset is not inlinable. Other devices read the blocks at
// constant offsets, as a GPU's compiler prefers.
layout(constant_id = 10) const bool OPAQUE_BLOCKS = false;
uint g_block = 0u;
struct ParamsData {
    mat4 inv_view_proj;
    vec4 box_min;     // xyz; w = ray-march step in world units
    vec4 box_max;     // xyz; w = iso value
    vec4 light_dir;   // xyz towards the light; w = early-termination transmittance
    vec4 background;  // rgb; a = light intensity
    vec4 voxel;       // xyz = 1 / dims (texture-space voxel size)
    uvec4 flags;      // x: bit0 empty-space skipping, bit1 jitter; y: frame; z: block size in voxels;
                      // w: Monte Carlo seed (the random stream)
    uvec4 grid;       // xyz: occupancy/majorant grid dims (a cell per brick, or k³ bricks: cells.rs)
    uvec4 dims;       // xyz: voxel dims (the sparse layout's atlas is not the volume's size);
                      // w: slot layers per atlas (sparse)
    vec4 atlas;       // xyz: 1 / the sparse layout's atlas extent in texels
    vec4 clip[MAX_CLIP_PLANES];  // clipping: kept where dot(xyz, x) <= w (world units)
    uvec4 clip_count; // x: planes of `clip` in use; 0 (no clipping) leaves every interval the box's;
                      // y: 1 when Monte Carlo paths past the camera segment see the unclipped volume
    vec4 emission;    // x: emission scale S; zw: the temperature grid's range in kelvin (0, 0: none)
};
layout(set = 0, binding = 0, std140) uniform Params { ParamsData p[1]; } PB;
#define P PB.p[g_block]
layout(set = 0, binding = 1) uniform sampler3D volume_tex;
layout(set = 0, binding = 2) uniform sampler2D tf_tex;

// What per-sample code needs of P, read once per invocation by `load_params()`, the first call of
// every volume shader's main. llvmpipe reloads a uniform-block member at each use inside a loop
// that fetches a texture and redoes what is derived from it: the sparse lookup's uses of
// P.dims and P.atlas cost MIP about 0.3 × its dense time per sample (measured; hoisted, sparse
// MIP went from 1.69 to about 1.4 × dense, dense unchanged). The values, and the arithmetic on
// them, are those of reading P at the use.
struct Hoisted {
    vec3 box_min;
    vec3 box_extent;    // box_max − box_min
    vec3 voxel;         // 1 / dims
    vec3 dims;          // voxel dims
    vec3 atlas;         // 1 / the sparse atlas' extent in texels
    vec3 slot_atlas;    // a slot's edge (SLOT texels) in atlas texture coordinates
    int slot_layers;    // slot layers per atlas (sparse)
    float cell_bricks;  // bricks per occupancy cell along each axis (sparse)
    vec3 cells;         // grid cells per unit of texture space (`cells_per_tex`)
    vec3 grid;          // grid cells along each axis
    ivec3 volume_size;  // texels of the volume (the dense image, or the dims of a sparse one)
    ivec2 tf_size;      // transfer-function table texels
};
Hoisted H;

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

// Interval `t` of ray `r` cut to the kept side of every clip plane. The kept region (box, crop
// box, half-spaces) is convex, so a ray meets it in one interval: cutting the interval before
// marching or tracking leaves no work in the clipped part, and to Monte Carlo paths the clipped
// part is vacuum. With no planes the loop does not run and `t` is returned as it came.
vec2 clip_interval(Ray r, vec2 t) {
    if (!CLIPPING) return t;
    uint n = min(P.clip_count.x, MAX_CLIP_PLANES);
    for (uint i = 0u; i < n; ++i) {
        vec4 c = P.clip[i];
        float dn = dot(c.xyz, r.d);
        float s = (c.w - dot(c.xyz, r.o)) / dn;
        if (dn > 0.0) {
            t.y = min(t.y, s);
        } else if (dn < 0.0) {
            t.x = max(t.x, s);
        } else if (dot(c.xyz, r.o) > c.w) {
            t.y = min(t.y, t.x);  // parallel to the plane, on the clipped side: empty
        }
    }
    return t;
}

// Whether point `x` is on the kept side of every clip plane (slice-based DOS, which has no rays).
bool clip_keeps(vec3 x) {
    if (!CLIPPING) return true;
    uint n = min(P.clip_count.x, MAX_CLIP_PLANES);
    bool keep = true;
    for (uint i = 0u; i < n; ++i) keep = keep && dot(P.clip[i].xyz, x) <= P.clip[i].w;
    return keep;
}

// The part of ray `r` every renderer integrates over: the volume's box, clipped.
vec2 volume_interval(Ray r) { return clip_interval(r, intersect_box(r, P.box_min.xyz, P.box_max.xyz)); }

vec3 to_tex(vec3 world) { return (world - H.box_min) / H.box_extent; }

// Grid cells (occupancy, majorant) per unit of texture space along each axis. A cell is a block
// of P.flags.z voxels, as the host measured it, so when the voxel count is not a multiple of the
// block the last cell reaches past the volume: scaling by the cell count instead would shift
// every cell boundary off its block's and skip or under-bound voxels.
vec3 cells_per_tex() { return H.cells; }

// `filter=exact`: the volume and the transfer-function table are interpolated in f32 from texel
// fetches, with the weights a linear filter with clamp-to-edge uses, instead of by the texture
// unit. Hardware filters weigh texels with fixed-point fractions (subTexelPrecisionBits, 8 on an
// H200: a lerp may be off by 2⁻⁹ of its texels' difference, and the weights' sum off 1 by as
// much), which moved an EAM transmittance exp(−1.5) by 8e-5; llvmpipe filters in f32. A constant
// (0 unless the host sets it), so the default costs nothing; docs/accuracy.md gives the costs.
layout(constant_id = 2) const bool EXACT_FILTER = false;

// The transfer function depends on the gradient magnitude (its table's rows differ). Most do not,
// and then every medium lookup (Monte Carlo, EAM, LAO, DOS) leaves out the gradient's filtered 3D
// fetch: a third of a Monte Carlo lookup's fetches, 0.75× the frame time on vpt's scene at 512²
// (llvmpipe runs a skipped branch anyway; a constant is folded). The host sets it from the table.
layout(constant_id = 0) const bool TF_GRADIENT = true;

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

// A volume whose slots exceed one allocation fills up to four atlases of one size, slot layers
// numbered on along z from one atlas into the next (P.dims.w layers each), so a page-table word
// needs no atlas field. A constant: one atlas (every dense volume, most sparse ones) folds the
// choice away; the further atlases sit at fixed bindings (placeholders when unused).
layout(constant_id = 4) const int ATLASES = 1;
layout(set = 0, binding = 16) uniform sampler3D volume_atlas1;
layout(set = 0, binding = 17) uniform sampler3D volume_atlas2;
layout(set = 0, binding = 18) uniform sampler3D volume_atlas3;
layout(set = 0, binding = 19) uniform sampler3D gradient_atlas1;
layout(set = 0, binding = 20) uniform sampler3D gradient_atlas2;
layout(set = 0, binding = 21) uniform sampler3D gradient_atlas3;

// Bit 31 of a page-table word: the brick may be visible under the current transfer function
// (the bit of the occupancy cell holding the brick). EAM's empty-space skipping reads it with the
// slot, so the sparse layout costs one lookup per sample where the dense one has one too.
const uint PAGE_OCCUPIED = 0x80000000u;

// A page table past a few thousand bricks whose pages are mostly one word (the background
// around far-apart data) takes two levels (`engine/volume/device/page_images.rs`): a directory word per
// page of 8³ bricks names the page's origin in a pool of pages, x | y << 10 | z << 20 in pages.
// A constant: flat tables (every small volume) fold the second lookup away.
layout(constant_id = 5) const int PAGE_LEVELS = 1;
layout(set = 0, binding = 22, r32ui) uniform readonly uimage3D page_directory;
const int PAGE = 8;

uint page_word(ivec3 b) {
    if (PAGE_LEVELS == 2) {
        uint d = imageLoad(page_directory, b / PAGE).r;
        ivec3 page = ivec3(d & 1023u, (d >> 10) & 1023u, d >> 20);
        return imageLoad(page_table, page * PAGE + (b & (PAGE - 1))).r;
    }
    return imageLoad(page_table, b).r;
}

// View-dependent residency (`engine/volume/device/resident.rs`, docs/volume-rendering.md): a
// level-0 brick's word may name the slot of a coarser pyramid brick covering it, of level L (voxels
// 2^L times as large, block means). Such words pack the slot in 9 bits per axis and L in bits
// 27–30 (bit 31 stays the occupancy bit). A constant: every other volume folds it away.
layout(constant_id = 9) const bool LOD_WORDS = false;
const uint LOD_SHIFT = 27u;

// The pyramid level of the brick a page-table word names (0 without residency).
uint word_level(uint e) { return LOD_WORDS ? (e >> LOD_SHIFT) & 15u : 0u; }

// The slot (xyz, in slots) a page-table word names, in its atlas (w).
ivec4 word_slot_index(uint e) {
    ivec3 s = LOD_WORDS ? ivec3(e & 511u, (e >> 9) & 511u, (e >> 18) & 511u)
                        : ivec3(e & 1023u, (e >> 10) & 1023u, (e >> 20) & 1023u);
    int k = ATLASES > 1 ? s.z / H.slot_layers : 0;
    s.z -= k * H.slot_layers;
    return ivec4(s, k);
}

// Texel origin (xyz) of the slot a page-table word names, in its atlas (w).
ivec4 word_slot(uint e) {
    ivec4 s = word_slot_index(e);
    return ivec4(s.xyz * SLOT, s.w);
}

// Where dense texture coordinate `uvw` lies among the volume's texels: clamped to the outermost
// texel centres (where a clamp-to-edge filter returns the edge texels already).
vec3 texel_position(vec3 uvw) {
    return clamp(uvw * H.dims, vec3(0.5), H.dims - 0.5);
}

// The brick of texel position `x`: the one holding its lower filter texel, so the footprint is
// that brick and its apron. x − 0.5 ≤ dims − 1 keeps it inside the page table without a clamp.
// `brick_at` gives it as floats (whole numbers), which `atlas_at` uses without a conversion.
vec3 brick_at(vec3 x) {
    return floor(x * (1.0 / float(BRICK)) - 0.5 / float(BRICK));
}
ivec3 brick_of(vec3 x) {
    return ivec3(brick_at(x));
}

// Atlas texel position (xyz, in texels, not normalized; the atlas in w) of level-0 texel position
// `x` in level-0 brick `b` (floats) whose word `e` names a brick of level L (LOD_WORDS). Level-L
// voxel j covers level-0 voxels 2^L j ..< 2^L (j + 1), so the level-L position is x / 2^L, clamped
// to level L's texel centres. Near the region's lower faces its lower filter texel lies in the
// level-L brick before, whose slot holds it: that brick's word (read at its first level-0 brick)
// serves when it shows level L too, so a region of one level filters as level L's own volume
// across bricks; next to another level the position is clamped into the region's brick (its slot
// has no lower apron), within half a level-L voxel of the seam.
vec4 lod_texel(vec3 x, vec3 b, uint e) {
    uint level = word_level(e);
    float s = float(1u << level);
    vec3 xl = clamp(x / s, vec3(0.5), ceil(H.dims / s) - 0.5);
    vec3 own = floor(b / s);
    vec3 lower = brick_at(xl);
    uint e2 = page_word(ivec3(lower * s));
    bool same = word_level(e2) == level;
    vec3 brick = same ? lower : own;
    xl = same ? xl : max(xl, own * float(BRICK) + 0.5);
    ivec4 slot = word_slot_index(same ? e2 : e);
    return vec4(vec3(slot.xyz * SLOT) + (xl - brick * float(BRICK)), float(slot.w));
}

// Atlas texture coordinates (xyz; the atlas in w) of texel position `x` in brick `b` (as
// floats), whose page-table word is `e`: the slot's origin plus the offset in the brick, which
// is exact (x and the brick's corner are within 8.5 texels), so the sum rounds once at atlas scale.
vec4 atlas_at(vec3 x, vec3 b, uint e) {
    if (LOD_WORDS) {
        vec4 t = lod_texel(x, b, e);
        return vec4(t.xyz * H.atlas, t.w);
    }
    ivec4 s = word_slot_index(e);
    return vec4(fma(vec3(s.xyz), H.slot_atlas, (x - b * float(BRICK)) * H.atlas), float(s.w));
}

// Segment words (the Monte Carlo trackers' majorant-grid walk, `tracking.glsl`): where the
// majorant grid's cells are the sparse layout's bricks, each cell also carries its brick's
// page-table word, and the walk's cells are shifted by half a voxel to be the bricks' sample
// regions (points whose lower filter texel is in the brick). A tentative collision then finds its
// slot in the walk's segment, fetched with the segment's majorant, instead of by a page lookup:
// llvmpipe runs the segment's fetch at every step anyway (both sides of a branch), so this takes
// one fetch a step away. A constant (sparse, cells of one brick, hardware filtering).
layout(constant_id = 6) const bool SEGMENT_WORDS = false;

// Atlas coordinates of dense texture coordinate `uvw` in brick `b` (floats), whose word is `e`:
// the position clamped into the brick's sample region, which rounding may leave by a hair at a
// segment's ends (the clamp keeps the filter footprint in the brick's slot).
vec4 atlas_in(vec3 uvw, vec3 b, uint e) {
    vec3 lo = b * float(BRICK) + 0.5;
    return atlas_at(clamp(texel_position(uvw), lo, lo + float(BRICK)), b, e);
}

// Where dense texture coordinate `uvw` lies in the atlases: texture coordinates, atlas in w.
vec4 atlas_uvw(vec3 uvw) {
    vec3 x = texel_position(uvw);
    vec3 b = brick_at(x);
    return atlas_at(x, b, page_word(ivec3(b)));
}

// Atlas `at.w`'s filtered value at its texture coordinates `at.xyz`.
float atlas_value(vec4 at) {
    if (ATLASES > 1 && at.w >= 1.0) {
        if (ATLASES > 2 && at.w >= 2.0) {
            if (ATLASES > 3 && at.w >= 3.0) return textureLod(volume_atlas3, at.xyz, 0.0).r;
            return textureLod(volume_atlas2, at.xyz, 0.0).r;
        }
        return textureLod(volume_atlas1, at.xyz, 0.0).r;
    }
    return texture(volume_tex, at.xyz).r;
}

// Texel `p` of atlas `k` (of the dense image when there is one).
float atlas_texel(int k, ivec3 p) {
    if (ATLASES > 1 && k >= 1) {
        if (ATLASES > 2 && k >= 2) {
            if (ATLASES > 3 && k >= 3) return texelFetch(volume_atlas3, p, 0).r;
            return texelFetch(volume_atlas2, p, 0).r;
        }
        return texelFetch(volume_atlas1, p, 0).r;
    }
    return texelFetch(volume_tex, p, 0).r;
}

float trilinear_exact(vec3 uvw) {
    ivec3 size = H.volume_size;
    vec3 x = clamp(uvw * vec3(size) - 0.5, vec3(0.0), vec3(size - 1));
    ivec3 a = ivec3(x);
    ivec3 b = min(a + 1, size - 1);
    vec3 f = x - vec3(a);
    int k = 0;
    if (SPARSE && LOD_WORDS) {
        // The footprint in the slot of the level-L brick the position maps to (`lod_texel`).
        vec3 xp = texel_position(uvw);
        vec3 bf = brick_at(xp);
        vec4 t = lod_texel(xp, bf, page_word(ivec3(bf)));
        vec3 p = t.xyz - 0.5;
        a = ivec3(floor(p));
        b = a + 1;
        f = p - vec3(a);
        k = int(t.w);
    } else if (SPARSE) {
        // Brick of the lower texel; the upper one is its neighbour or the apron (b - a ≤ 1).
        ivec4 o = word_slot(page_word(a / BRICK));
        ivec3 shift = o.xyz - (a / BRICK) * BRICK;
        a += shift;
        b += shift;
        k = o.w;
    }
    float c00 = mix(atlas_texel(k, a), atlas_texel(k, ivec3(b.x, a.y, a.z)), f.x);
    float c10 = mix(atlas_texel(k, ivec3(a.x, b.y, a.z)), atlas_texel(k, ivec3(b.x, b.y, a.z)), f.x);
    float c01 = mix(atlas_texel(k, ivec3(a.x, a.y, b.z)), atlas_texel(k, ivec3(b.x, a.y, b.z)), f.x);
    float c11 = mix(atlas_texel(k, ivec3(a.x, b.y, b.z)), atlas_texel(k, b), f.x);
    return mix(mix(c00, c10, f.y), mix(c01, c11, f.y), f.z);
}

// The value lookup at dense texture coordinate `uvw` whose atlas coordinates `at` (sparse
// layout; ignored in the dense one) the caller already has.
float sample_volume_at(vec3 uvw, vec4 at) {
    if (EXACT_FILTER) return trilinear_exact(uvw);
    return SPARSE ? atlas_value(at) : texture(volume_tex, uvw).r;
}

// Every volume renderer's value lookup, in either layout and either filter.
float sample_volume(vec3 uvw) {
    return sample_volume_at(uvw, SPARSE && !EXACT_FILTER ? atlas_uvw(uvw) : vec4(uvw, 0.0));
}

// Every renderer's gradient-magnitude lookup: macros because each shader declares
// `gradient_tex` at its own binding (after this file); the same atlas position as the value's.
#define GRADIENT_ATLAS(at) (ATLASES > 1 && (at).w >= 1.0 \
    ? (ATLASES > 2 && (at).w >= 2.0 \
        ? (ATLASES > 3 && (at).w >= 3.0 ? textureLod(gradient_atlas3, (at).xyz, 0.0).r : textureLod(gradient_atlas2, (at).xyz, 0.0).r) \
        : textureLod(gradient_atlas1, (at).xyz, 0.0).r) \
    : texture(gradient_tex, (at).xyz).r)
#define sample_gradient_at(uvw, at) (SPARSE ? GRADIENT_ATLAS(at) : texture(gradient_tex, (uvw)).r)
#define sample_gradient(uvw) sample_gradient_at(uvw, (SPARSE ? atlas_uvw(uvw) : vec4(0.0)))

// Where `sample_volume_at` reads at `uvw`: one page lookup a caller shares with the gradient's
// (`sample_gradient_from`), where value and gradient are both needed.
vec4 lookup_at(vec3 uvw) {
    return SPARSE && !EXACT_FILTER ? atlas_uvw(uvw) : vec4(uvw, 0.0);
}
// The gradient magnitude at `uvw` from `lookup_at(uvw)` (exact filtering looks up its own: the
// value is then fetched texel by texel, the gradient still filtered in the atlas).
#define sample_gradient_from(uvw, at) sample_gradient_at(uvw, (SPARSE && EXACT_FILTER ? atlas_uvw(uvw) : (at)))

// Central differences, in value change per voxel along each axis.
vec3 gradient(vec3 uvw) {
    vec3 h = H.voxel;
    return 0.5 * vec3(
        sample_volume(uvw + vec3(h.x, 0, 0)) - sample_volume(uvw - vec3(h.x, 0, 0)),
        sample_volume(uvw + vec3(0, h.y, 0)) - sample_volume(uvw - vec3(0, h.y, 0)),
        sample_volume(uvw + vec3(0, 0, h.z)) - sample_volume(uvw - vec3(0, 0, h.z)));
}

// Transfer function: (rgb emission, extinction). Table texel i sits at value i/(N-1).
vec4 transfer(float v, float grad_mag) {
    ivec2 isize = H.tf_size;
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

// Label maps (`engine/volume/render/labels.rs`, docs/labels.md): per voxel its label's colour and
// opacity scale, premultiplied (`[a·rgb, a]`, a = 0 for a hidden label), rebuilt on the host when
// the table, the mode or the hidden labels change; in `replace` mode `label_keep` holds label 0's
// opacity (where the medium keeps its own colour). A constant: without a label map every renderer
// folds the label code away and samples as before (the bindings then hold 1-texel placeholders).
// The mode is a constant too: llvmpipe would fetch `label_keep` in tint mode behind a uniform
// branch.
layout(constant_id = 7) const uint LABEL_MODE = 0u;  // 0 none, 1 tint, 2 replace
const bool LABELS = LABEL_MODE != 0u;
layout(set = 0, binding = 25) uniform sampler3D label_colour;
layout(set = 0, binding = 26) uniform sampler3D label_keep;

// The medium `tf` (colour, extinction) at dense texture coordinate `uvw` under the label map. One
// trilinear fetch weighs the 8 neighbouring labels' premultiplied entries as a linear filter
// does, so each label's one-hot mask is interpolated trilinearly and a boundary blends over one
// voxel instead of stepping. Colour: the opacity-weighted mean of the labels' colours (tint: each
// times tf's); extinction: tf's times the weighted opacity scale, at most tf's (scales are ≤ 1),
// so occupancy and majorant grids stay bounds. Where the 8 texels agree, the label's own values.
vec4 label_medium(vec4 tf, vec3 uvw) {
    if (!LABELS) return tf;
    vec4 q = textureLod(label_colour, uvw, 0.0);
    vec3 c = LABEL_MODE == 2u ? q.rgb + textureLod(label_keep, uvw, 0.0).r * tf.rgb : tf.rgb * q.rgb;
    return vec4(q.a > 0.0 ? c / q.a : tf.rgb, tf.a * q.a);
}

// The value at `uvw` scaled by the labels' weighted opacity (ISO, MIP: a hidden label holds no
// surface and no maximum).
float labelled_value(vec3 uvw) {
    float v = sample_volume(uvw);
    return LABELS ? v * label_medium(vec4(1.0), uvw).a : v;
}

// Reads `H` (above): every volume shader's main calls it first.
void load_params() {
    // 0: the workgroup's z is below the dispatch's, but no compiler can know it.
    if (OPAQUE_BLOCKS) g_block = gl_WorkGroupID.z / max(gl_NumWorkGroups.z, 1u);
    H.box_min = P.box_min.xyz;
    H.box_extent = P.box_max.xyz - P.box_min.xyz;
    H.voxel = P.voxel.xyz;
    H.dims = vec3(P.dims.xyz);
    H.atlas = P.atlas.xyz;
    H.slot_atlas = float(SLOT) * P.atlas.xyz;
    H.slot_layers = int(P.dims.w);
    H.cell_bricks = float(P.flags.z / uint(BRICK));
    H.cells = 1.0 / (P.voxel.xyz * float(P.flags.z));
    H.grid = vec3(P.grid.xyz);
    H.volume_size = SPARSE ? ivec3(P.dims.xyz) : textureSize(volume_tex, 0);
    H.tf_size = textureSize(tf_tex, 0);
}
#endif
