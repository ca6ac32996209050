#ifndef LPV_IMAGES_GLSL
#define LPV_IMAGES_GLSL
// Light-grid image bindings shared by the passes that read or write whole grids (common.glsl
// explains the layout). Define SRC_BINDING and/or DST_BINDING (first of three consecutive
// bindings: R, G, B), DST_BUFFER_BINDING or ACC_BINDING (one flat buffer) before including.
#ifdef SRC_BINDING
layout(set = 0, binding = SRC_BINDING, rgba32f) readonly uniform image3D src_r;
layout(set = 0, binding = SRC_BINDING + 1, rgba32f) readonly uniform image3D src_g;
layout(set = 0, binding = SRC_BINDING + 2, rgba32f) readonly uniform image3D src_b;
void load_src(ivec3 t, out vec4 v[3]) {
    v[0] = imageLoad(src_r, t);
    v[1] = imageLoad(src_g, t);
    v[2] = imageLoad(src_b, t);
}
#endif
#ifdef SRC_TEXELS_BINDING
// A flat light buffer (channel blocks of `stride` texels, the store_dst / accumulate layouts below)
// read as a storage texel buffer: llvmpipe gathers a texel per lane in one vector operation, where
// a storage-buffer load loops over the lanes per component, and the 3D image it replaces needed
// a copy pass after every step.
layout(set = 0, binding = SRC_TEXELS_BINDING, rgba32f) readonly uniform imageBuffer src_t;
void load_src_texels(int base, int stride, out vec4 v[3]) {
    v[0] = imageLoad(src_t, base);
    v[1] = imageLoad(src_t, base + stride);
    v[2] = imageLoad(src_t, base + 2 * stride);
}
#endif
#ifdef DST_BINDING
layout(set = 0, binding = DST_BINDING, rgba32f) writeonly uniform image3D dst_r;
layout(set = 0, binding = DST_BINDING + 1, rgba32f) writeonly uniform image3D dst_g;
layout(set = 0, binding = DST_BINDING + 2, rgba32f) writeonly uniform image3D dst_b;
void store_dst(ivec3 t, vec4 v[3]) {
    imageStore(dst_r, t, v[0]);
    imageStore(dst_g, t, v[1]);
    imageStore(dst_b, t, v[2]);
}
#endif
#ifdef DST_BUFFER_BINDING
// The step's light as a flat buffer in the images' texel order, one channel after another (a copy
// pass turns it into the step's images): llvmpipe stores a vec4 to a storage buffer about 2.4×
// faster than an RGBA32F texel to a storage image (device_limits), and stores bound a step.
layout(set = 0, binding = DST_BUFFER_BINDING, std430) writeonly buffer StepOut { vec4 v[]; } D;
// A cascade's grid from texel `base` on, channels `stride` texels apart.
void store_dst(uint base, uint stride, ivec3 t, vec4 v[3]) {
    uint i = base + cell_linear(t);
    D.v[i] = v[0];
    D.v[stride + i] = v[1];
    D.v[2u * stride + i] = v[2];
}
#endif
#ifdef STACKED_BINDING
// A light grid of all cascades as a flat buffer in the stacked images' texel order, one channel
// after another (the accumulated grid's layout below), written without reading.
layout(set = 0, binding = STACKED_BINDING, std430) writeonly buffer Stacked { vec4 v[]; } S;
void store_stacked(ivec3 t, vec4 v[3]) {
    uint texels = flat_channel();
    uint i = cell_linear(t);
    S.v[i] = v[0];
    S.v[texels + i] = v[1];
    S.v[2u * texels + i] = v[2];
}
#endif
#ifdef ACC_BINDING
// The accumulated grid as a flat buffer in the stacked images' texel order (all cascades along z),
// one channel after another; a copy after the last step makes the images shading reads. Same
// reason as the step's buffer: the read-modify-write of three RGBA32F storage-image texels was
// a third of an accumulating step on llvmpipe, and buffer stores are the cheaper path.
layout(set = 0, binding = ACC_BINDING, std430) buffer Accumulated { vec4 v[]; } A;
// The accumulated grid += v at stacked texel t (each texel is owned by one invocation: no race).
void accumulate(ivec3 t, vec4 v[3]) {
    uint texels = flat_channel();
    uint i = cell_linear(t);  // z runs over all cascades: the stacked images' texel order
    A.v[i] += v[0];
    A.v[texels + i] += v[1];
    A.v[2u * texels + i] += v[2];
}
#endif
#endif
