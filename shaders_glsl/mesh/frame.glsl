#ifndef MESH_FRAME_GLSL
#define MESH_FRAME_GLSL
// Per-frame data of the mesh renderer (engine/mesh/frame.rs packs it; std140). One buffer for
// every pass, so a view is chosen by index instead of re-uploading matrices per pass.
const uint MAX_SHADOW_TILES = 8u;
const uint MAX_SPOTS = 4u;
const uint VIEW_CAMERA = 0u;       // views 1..8: shadow tiles; 9: the RSM light
const uint VIEW_RSM = 9u;
const uint VIEW_SKY = 10u;         // the LPV sky light's top-down height map

layout(set = 0, binding = 0, std140) uniform Frame {
    mat4 view_proj;
    mat4 inv_view_proj;
    vec4 camera_pos;        // xyz
    vec4 camera_forward;    // xyz unit view direction (cascades split along it)
    vec4 sun_dir;           // xyz towards the sun; w: 1 = on
    vec4 sun_irradiance;    // rgb, W/m² on a surface facing the sun
    vec4 ambient;           // rgb radiance of a uniform ambient term (0 = none)
    uvec4 counts;           // x: cascades, y: spots, z: shadow tiles, w: PCF radius in texels
    vec4 cascade_far;       // view-space far distance of each cascade
    vec4 atlas_size;        // xy: shadow atlas texels, zw: 1 / xy
    vec4 sky;               // rgb: background radiance
    mat4 shadow_vp[MAX_SHADOW_TILES];
    vec4 shadow_rect[MAX_SHADOW_TILES];   // xy: tile origin, zw: tile size (atlas UV)
    vec4 shadow_texel[MAX_SHADOW_TILES];  // x: world size of one texel at the receiver, y: depth bias,
                                          // zw: orthographic: (far − near, 0); perspective: (near, far)
    vec4 spot_pos[MAX_SPOTS];             // xyz; w: shadow tile index
    vec4 spot_dir[MAX_SPOTS];             // xyz direction the light travels; w: cos(outer)
    vec4 spot_intensity[MAX_SPOTS];       // rgb W/sr; a: cos(inner)
    mat4 rsm_vp;
    vec4 rsm_light;  // x: 0 sun, 1 spot; y: sun: texel area (m²), spot: tan(half angle); z: RSM size; w: spot index
    vec4 lpv_cascade[4];  // xyz: minimum corner, w: cell edge
    uvec4 lpv_dims;       // x: cells per edge, y: cascades
    vec4 lpv_params;      // x: intensity, y: normal offset (cells); z, w: unused (damping and the
                          //   subsurface LPV are the lighting pass's specialization constants)
    mat4 sky_vp;          // world → clip of the LPV sky's top-down height map
    vec4 soft_shadow;     // x: tan(sun's angular radius), y: spot radius (m), z: largest penumbra (texels)
} F;

mat4 view_matrix(uint view) {
    if (view == VIEW_CAMERA) return F.view_proj;
    if (view == VIEW_RSM) return F.rsm_vp;
    if (view == VIEW_SKY) return F.sky_vp;
    return F.shadow_vp[min(view - 1u, MAX_SHADOW_TILES - 1u)];
}

// Spot cone: 1 inside the inner angle, 0 outside the outer, smooth between (a hard edge when
// the angles coincide, where smoothstep would be undefined).
float cone_falloff(float cos_axis, float cos_outer, float cos_inner) {
    return cos_inner > cos_outer ? smoothstep(cos_outer, cos_inner, cos_axis) : step(cos_outer, cos_axis);
}

// Per-draw constants: the view to render from and the material. A compute pass with push
// constants of its own, or none, defines MESH_FRAME_NO_DRAW (a stage has room for one push
// block, and the pipeline layout follows the reflected one).
#ifndef MESH_FRAME_NO_DRAW
layout(push_constant) uniform Draw {
    vec4 base_color;  // linear rgb, a: alpha
    vec4 specular;    // rgb: Blinn–Phong specular colour, a: shininess
    uint view;
    uint flags;       // bit0: alpha mask, bit1: normal map
    float cutoff;     // alpha-mask threshold
    float translucency;  // fraction of incident light entering the surface (subsurface LPV)
} D;
#endif
#endif
