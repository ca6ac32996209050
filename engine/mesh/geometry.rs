//! The scene's geometry as raster passes draw it: the depth and G-buffer pipelines, what every
//! raster pass binds (frame buffer, vertices, indices, material textures), per-view culling and
//! the draw loops.

use super::cull::{add_cull_pass, CullView, CulledDraws, DRAW_STRIDE};
use super::formats::{ALBEDO_FORMAT, DEPTH_FORMAT, NORMAL_FORMAT, RSM_FORMAT, SPECULAR_FORMAT};
use super::frame::{draw_constants, VIEW_CAMERA};
use super::gpu_scene::{GpuMaterial, GpuScene, FLAG_ALPHA_MASK, FLAG_NORMAL_MAP, POSITION_BYTES, WHITE};
use crate::graph::execute::PassContext;
use crate::graph::{Access, BufferId, GraphBuilder, ImageId, ShaderStage};
use crate::shaders;
use crate::vk::{vk, Binding, Context, Descriptor, GraphicsDesc, Pipeline, Sampling};
use crate::Result;

const DRAW_PUSH: u32 = 48;

/// The two pipelines of a depth-only pass (`Geometry::draw_depth`).
pub(super) struct DepthPipelines {
    /// Position only, no fragment stage.
    pub opaque: Pipeline,
    /// mesh.vert and shadow.frag, which discards below the alpha cutoff.
    pub masked: Pipeline,
}

/// The two pipelines of the G-buffer pass (`Geometry::draw_gbuffer`).
pub(super) struct GbufferPipelines {
    /// gbuffer.frag with its normal- and specular-map lookups.
    pub maps: Pipeline,
    /// Its NO_MAPS variant, for materials with neither map.
    pub no_maps: Pipeline,
}

fn vertex_layout(desc: &mut GraphicsDesc) {
    desc.vertex_bindings = vec![vk::VertexInputBindingDescription {
        binding: 0,
        stride: (super::gpu_scene::VERTEX_FLOATS * 4) as u32,
        input_rate: vk::VertexInputRate::VERTEX,
    }];
    let attr = |location, format, offset| vk::VertexInputAttributeDescription { location, binding: 0, format, offset };
    desc.vertex_attributes = vec![
        attr(0, vk::Format::R32G32B32_SFLOAT, 0),
        attr(1, vk::Format::R32G32B32_SFLOAT, 12),
        attr(2, vk::Format::R32G32_SFLOAT, 24),
        attr(3, vk::Format::R32G32B32A32_SFLOAT, 32),
    ];
}

/// The mesh renderer's raster pipelines.
pub(super) struct RasterPipelines {
    pub gbuffer: GbufferPipelines,
    pub depth: DepthPipelines,
    pub rsm: Pipeline,
}

impl RasterPipelines {
    /// Creates every raster pipeline of the mesh frame.
    pub fn new(ctx: &Context) -> Result<Self> {
        let (vs, fs) = (vk::ShaderStageFlags::VERTEX, vk::ShaderStageFlags::FRAGMENT);
        let sampler = vk::DescriptorType::COMBINED_IMAGE_SAMPLER;
        let raster_bindings = [
            Binding::new(0, vk::DescriptorType::UNIFORM_BUFFER, vs | fs),
            Binding::new(1, sampler, fs),
            Binding::new(2, sampler, fs),
            Binding::new(3, sampler, fs),
        ];
        let desc = |colors: Vec<vk::Format>| GraphicsDesc {
            color_formats: colors,
            depth_format: Some(DEPTH_FORMAT),
            depth_test: true,
            depth_write: true,
            dynamic_cull: true,
            ..Default::default()
        };
        let raster = |frag, colors: Vec<vk::Format>| -> Result<Pipeline> {
            let mut d = desc(colors);
            vertex_layout(&mut d);
            Pipeline::graphics(ctx, &[&shaders::MESH_MESH_VERT, frag], &raster_bindings, DRAW_PUSH, &d)
        };
        // Opaque depth draws read the scene's compact positions (16 bytes a vertex, as culling
        // does) rather than the interleaved vertices' 48: a third of the cache lines, in passes
        // that start the frame with caches the previous frame's LPV and lighting have emptied.
        let mut position_only = desc(vec![]);
        vertex_layout(&mut position_only);
        position_only.vertex_attributes.truncate(1);
        position_only.vertex_bindings[0].stride = POSITION_BYTES;
        let opaque =
            Pipeline::graphics(ctx, &[&shaders::MESH_DEPTH_VERT], &raster_bindings, DRAW_PUSH, &position_only)?;
        Ok(Self {
            gbuffer: GbufferPipelines {
                maps: raster(&shaders::MESH_GBUFFER_FRAG, vec![ALBEDO_FORMAT, NORMAL_FORMAT, SPECULAR_FORMAT])?,
                no_maps: raster(
                    &shaders::MESH_GBUFFER_FRAG__NO_MAPS,
                    vec![ALBEDO_FORMAT, NORMAL_FORMAT, SPECULAR_FORMAT],
                )?,
            },
            depth: DepthPipelines { opaque, masked: raster(&shaders::MESH_SHADOW_FRAG, vec![])? },
            rsm: raster(&shaders::MESH_RSM_FRAG, vec![RSM_FORMAT; 3])?,
        })
    }
}

/// Sets the viewport and scissor to the texel rectangle `[x, y, width, height]` (a plain
/// viewport, so texel (u, v) is NDC (2u − 1, 2v − 1) as the passes sampling the map expect).
pub(super) fn set_viewport(pc: &PassContext<'_>, [x, y, width, height]: [u32; 4]) {
    let vp = vk::Viewport {
        x: x as f32,
        y: y as f32,
        width: width as f32,
        height: height as f32,
        min_depth: 0.0,
        max_depth: 1.0,
    };
    let sc = vk::Rect2D { offset: vk::Offset2D { x: x as i32, y: y as i32 }, extent: vk::Extent2D { width, height } };
    // SAFETY: called inside a raster pass's rendering scope; the rectangle lies in its target.
    unsafe {
        pc.device().cmd_set_viewport(pc.cmd, 0, &[vp]);
        pc.device().cmd_set_scissor(pc.cmd, 0, &[sc]);
    }
}

/// What every raster pass binds: the frame buffer, vertices, indices and material textures.
#[derive(Clone)]
pub(super) struct Geometry<'a> {
    pub scene: &'a GpuScene,
    pub ubo: BufferId,
    pub vb: BufferId,
    /// The scene's compact positions ([`GpuScene::positions`]), which opaque depth draws read.
    pub positions: BufferId,
    pub ib: BufferId,
    pub textures: Vec<ImageId>,
    /// Cull the back faces of single-sided materials.
    pub cull: bool,
    /// The scene's culling chunks and the counters of kept triangles, when each view's
    /// triangles are culled before it draws.
    pub culling: Option<[BufferId; 2]>,
    /// The device draws a mesh's chunks in one indirect call.
    pub multi_draw: bool,
    /// The device's least subgroup size (the culling passes' workgroup).
    pub subgroup: u32,
}

impl<'a> Geometry<'a> {
    pub(super) fn declare_reads(&self, p: &mut crate::graph::PassBuilder<'_, 'a>) -> Result<()> {
        p.read_buffer(self.ubo, Access::UniformRead(ShaderStage::AllGraphics))?;
        p.read_buffer(self.vb, Access::VertexBuffer)?;
        p.read_buffer(self.positions, Access::VertexBuffer)?;
        p.read_buffer(self.ib, Access::IndexBuffer)?;
        for &t in &self.textures {
            p.read_image(t, Access::Sampled(ShaderStage::Fragment))?;
        }
        Ok(())
    }

    /// [`Geometry::declare_reads`] plus a view's culled draws.
    pub(super) fn declare_reads_culled(
        &self,
        p: &mut crate::graph::PassBuilder<'_, 'a>,
        culled: Option<CulledDraws>,
    ) -> Result<()> {
        self.declare_reads(p)?;
        culled.map_or(Ok(()), |c| c.declare_reads(p))
    }

    /// The faces `view`'s pipelines cull on single-sided materials. The camera's projection flips
    /// y so images come out upright; the light views' do not. A reflection swaps the framebuffer
    /// winding, so the same world-space back face is clockwise in one and counter-clockwise in
    /// the other.
    pub(super) fn culled_faces(&self, view: u32) -> vk::CullModeFlags {
        match (self.cull, view == VIEW_CAMERA) {
            (false, _) => vk::CullModeFlags::NONE,
            (true, true) => vk::CullModeFlags::BACK,
            (true, false) => vk::CullModeFlags::FRONT,
        }
    }

    /// Adds `view`'s culling pass (named `{name} cull`) when views are culled.
    pub(super) fn cull_view(
        &self,
        g: &mut GraphBuilder<'a>,
        name: String,
        view: u32,
        viewport: [u32; 4],
    ) -> Result<Option<CulledDraws>> {
        let Some([chunks, stats]) = self.culling else { return Ok(None) };
        // With the pipelines' counter-clockwise front face, back faces have negative area.
        let facing = match self.culled_faces(view) {
            vk::CullModeFlags::BACK => 1.0,
            vk::CullModeFlags::FRONT => -1.0,
            _ => 0.0,
        };
        let v = CullView { view, viewport, facing };
        let buffers = [self.positions, self.ib, chunks, stats];
        add_cull_pass(g, format!("{name} cull"), self.subgroup, self.scene, self.ubo, buffers, v).map(Some)
    }

    /// Draws every mesh from `view` with its material's textures and constants.
    pub(super) fn draw_all(
        &self,
        pc: &PassContext<'_>,
        pipe: &Pipeline,
        view: u32,
        culled: Option<CulledDraws>,
    ) -> Result<()> {
        self.draw_with(pc, |_| (pipe, false), view, culled)
    }

    /// Draws every mesh's depth from `view`: a fragment stage only where an alpha mask needs it.
    pub(super) fn draw_depth(
        &self,
        pc: &PassContext<'_>,
        pipes: &DepthPipelines,
        view: u32,
        culled: Option<CulledDraws>,
    ) -> Result<()> {
        let pick = |m: &GpuMaterial| {
            if m.flags & FLAG_ALPHA_MASK != 0 {
                (&pipes.masked, false)
            } else {
                (&pipes.opaque, true)
            }
        };
        self.draw_with(pc, pick, view, culled)
    }

    /// Draws every mesh's G-buffer from `view`: the map lookups only where a material has a map.
    pub(super) fn draw_gbuffer(
        &self,
        pc: &PassContext<'_>,
        pipes: &GbufferPipelines,
        view: u32,
        culled: Option<CulledDraws>,
    ) -> Result<()> {
        let has_maps = |m: &GpuMaterial| m.flags & FLAG_NORMAL_MAP != 0 || m.specular_tex != WHITE;
        self.draw_with(pc, |m| (if has_maps(m) { &pipes.maps } else { &pipes.no_maps }, false), view, culled)
    }

    /// Draws every mesh from `view` with the pipeline `pick` gives its material (and whether
    /// that pipeline reads the compact positions instead of the interleaved vertices): all its
    /// triangles, or the survivors of `view`'s culling.
    pub(super) fn draw_with<'p>(
        &self,
        pc: &PassContext<'_>,
        pick: impl Fn(&GpuMaterial) -> (&'p Pipeline, bool),
        view: u32,
        culled: Option<CulledDraws>,
    ) -> Result<()> {
        let dev = pc.device();
        let ib = culled.map_or(self.ib, |c| c.indices);
        // SAFETY: inside a rendering scope; the buffer was declared as read by this pass.
        unsafe { dev.cmd_bind_index_buffer(pc.cmd, pc.buffer(ib).raw, 0, vk::IndexType::UINT32) };
        let mut bound = None;
        // Material textures repeat and are mipmapped.
        let sampler = pc.ctx.pipelines().sampler(pc.ctx, Sampling::Repeat)?;
        let ubo = pc.buffer(self.ubo).raw;
        let faces = self.culled_faces(view);
        for d in &self.scene.draws {
            let m = &self.scene.materials[d.material];
            let cull = if m.double_sided { vk::CullModeFlags::NONE } else { faces };
            // SAFETY: every mesh pipeline has dynamic cull mode (`raster` in `MeshRenderer::new`).
            unsafe { dev.cmd_set_cull_mode(pc.cmd, cull) };
            let tex = |slot: usize| Descriptor::CombinedImageSampler(pc.image(self.textures[slot]).view, sampler);
            let ds = [Descriptor::UniformBuffer(ubo), tex(m.base_color_tex), tex(m.normal_tex), tex(m.specular_tex)];
            let push = draw_constants(m.base_color, m.specular, view, m.flags, m.cutoff, m.translucency);
            let (pipe, positions_only) = pick(m);
            let vertices = if positions_only { self.positions } else { self.vb };
            if bound != Some(vertices) {
                // SAFETY: inside the rendering scope; both vertex buffers are declared read.
                unsafe { dev.cmd_bind_vertex_buffers(pc.cmd, 0, &[pc.buffer(vertices).raw], &[0]) };
                bound = Some(vertices);
            }
            pipe.bind(pc.cmd, &ds, &push)?;
            match culled {
                // SAFETY: pipeline, descriptors and buffers bound above.
                None => unsafe { dev.cmd_draw_indexed(pc.cmd, d.index_count, 1, d.first_index, 0, 0) },
                Some(c) => {
                    let (buf, first) = (pc.buffer(c.draws).raw, u64::from(d.first_chunk) * u64::from(DRAW_STRIDE));
                    if self.multi_draw {
                        // SAFETY: as above; the mesh's chunks are its commands, declared IndirectArgs.
                        unsafe { dev.cmd_draw_indexed_indirect(pc.cmd, buf, first, d.chunk_count, DRAW_STRIDE) };
                    } else {
                        for k in 0..u64::from(d.chunk_count) {
                            // SAFETY: as above, one chunk's command at a time.
                            unsafe {
                                dev.cmd_draw_indexed_indirect(
                                    pc.cmd,
                                    buf,
                                    first + k * u64::from(DRAW_STRIDE),
                                    1,
                                    DRAW_STRIDE,
                                )
                            };
                        }
                    }
                }
            }
        }
        Ok(())
    }
}
