//! What the LPV passes exchange with the rest of a frame: the uniform block and push constants
//! (as `Pod` structs the shader-layout test checks), the inputs a mesh frame hands in, the grids
//! it gets back, and the host-visible counters.

use crate::graph::ImageId;
use crate::vk::{vk, Buffer, Context, MemoryLocation};
use crate::Result;
use glam::Mat4;

/// The LPV uniform block (`shaders_glsl/lpv/common.glsl`, `Lpv`); a test checks every offset
/// against the block reflected from the SPIR-V.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LpvParams {
    /// Per cascade: world origin (xyz) and cell edge (w).
    pub cascade: [[f32; 4]; 4],
    /// Grid edge, cascade count, RSM edge, flags (occlusion, thesis fixed point, swapped face
    /// weights, subsurface).
    pub dims: [u32; 4],
    /// VPL offset, fixed-point scale, its inverse, geometry-volume scale.
    pub params: [f32; 4],
    /// The RSM light's world → clip.
    pub rsm_vp: [f32; 16],
    /// `[kind, sun texel area or spot tan(half angle), RSM edge, 0]`.
    pub rsm_light: [f32; 4],
    /// Sun direction or spot position.
    pub light: [f32; 4],
    /// Camera clip → world (camera geometry volume).
    pub inv_view_proj: [f32; 16],
    /// Camera position and one pixel's angle.
    pub camera: [f32; 4],
    /// G-buffer size, surfel stride, camera source on.
    pub gbuffer: [u32; 4],
}

/// The sky-light pass's push constants (`shaders_glsl/lpv/sky.comp`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SkyPush {
    /// Height map world → clip.
    pub view_proj: [f32; 16],
    /// Sky radiance (rgb) and the coarsest cell edge (w).
    pub radiance: [f32; 4],
}

/// The host-visible counters an LPV frame leaves behind.
pub struct LpvStats {
    pub(crate) buffer: Buffer,
}

impl LpvStats {
    /// Allocates the counters.
    pub fn new(ctx: &Context) -> Result<Self> {
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST;
        Ok(Self { buffer: Buffer::new(ctx, "lpv stats", 8, usage, MemoryLocation::GpuToCpu)? })
    }

    /// Fixed-point additions that overflowed in the last frame (0 unless the scale is wrong).
    pub fn overflows(&self) -> u32 {
        self.buffer.mapped_u32(0)
    }

    /// VPLs injected into the finest cascade in the last frame (scatter injection only).
    pub fn injected(&self) -> u32 {
        self.buffer.mapped_u32(1)
    }
}

/// What the passes read: the RSM and its light.
#[derive(Clone, Copy, Debug)]
pub struct LpvInputs {
    /// RSM position, normal, flux.
    pub rsm: [ImageId; 3],
    /// RSM edge in texels.
    pub rsm_size: u32,
    /// The RSM light's world → clip.
    pub rsm_vp: Mat4,
    /// `[kind (0 sun, 1 spot), sun texel area or spot tan(half angle), RSM edge, 0]`.
    pub rsm_light: [f32; 4],
    /// Sun: direction the light travels; spot: position.
    pub light: [f32; 3],
    /// Upper bound of the flux per channel that can land in one cell (sets the fixed-point scale).
    pub flux_bound: f32,
    /// The camera's depth and normal buffers, for the geometry volume's second source.
    pub camera: Option<CameraSurfels>,
    /// Sky light, when on.
    pub sky: Option<SkyInput>,
    /// Build the subsurface LPV (the thesis' SSLPV): only translucent RSM texels, normals turned
    /// into the object, no geometry volume; its passes are named `sslpv …`.
    pub subsurface: bool,
}

/// What the sky-light pass reads.
#[derive(Clone, Copy, Debug)]
pub struct SkyInput {
    /// Depth of the scene seen from straight above (the height map).
    pub height: ImageId,
    /// The height map's world → clip.
    pub view_proj: Mat4,
    /// Sky radiance (RGB).
    pub radiance: [f32; 3],
    /// The coarsest cascade's cell edge in metres (the reduced map's texel).
    pub cell: f32,
}

/// What the camera-depth geometry volume reads.
#[derive(Clone, Copy, Debug)]
pub struct CameraSurfels {
    /// Depth (D32) and world normal images of the G-buffer.
    pub depth: ImageId,
    /// World normals.
    pub normal: ImageId,
    /// Camera clip → world.
    pub inv_view_proj: Mat4,
    /// Camera position.
    pub position: [f32; 3],
    /// One pixel's angle: 2·tan(fov/2)/height.
    pub pixel_angle: f32,
    /// G-buffer size.
    pub size: [u32; 2],
}

/// Every this-many pixels (per axis) of the depth buffer is a camera surfel.
pub const CAMERA_SURFEL_STRIDE: u32 = 2;

/// Persistent images that hold every cascade's accumulated light (stacked along z), and the
/// slot each computed cascade fills: a frame whose camera moved only some cascades computes
/// just those and keeps the others' slots.
#[derive(Clone, Debug)]
pub struct PackedGrids {
    /// R, G, B SH images of all cascades.
    pub images: [ImageId; 3],
    /// For each cascade passed to the LPV passes, its slot (cascade index) in `images`.
    pub slots: Vec<u32>,
}

/// The light grids the passes leave: R, G, B SH images (RGBA32F 3D, cascades stacked along z).
#[derive(Clone, Debug)]
pub struct LpvOutput {
    /// The accumulated grid, which shading samples.
    pub images: [ImageId; 3],
    /// The injected grid before propagation (tests and tools).
    pub injected: [ImageId; 3],
    /// The fixed-point scale used (1 for float variants).
    pub scale: f32,
}
