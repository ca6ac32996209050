//! Draws egui's tessellated output as frame-graph passes: a transfer pass uploads changed
//! textures, a raster pass blends the meshes over the display image. The graph orders both and
//! issues every barrier; the painter only declares what it reads and writes.

use crate::error::{Error, Result};
use crate::graph::execute::Imports;
use crate::graph::{Access, BufferId, GraphBuilder, ImageId, LoadOp, PersistentImage, ShaderStage};
use crate::vk::{vk, Binding, Blend, Buffer, Context, Descriptor, GraphicsDesc, Image, ImageInfo};
use crate::vk::{Pipeline, Sampling};
use egui::epaint::{ClippedPrimitive, ImageDelta, Primitive, Vertex};
use egui::TextureId;
use std::collections::HashMap;

struct Texture {
    image: PersistentImage,
    /// Nearest filtering (egui asks for it for pixel-exact images).
    nearest: bool,
}

/// A texture region to copy in this frame's upload pass.
struct Upload {
    id: TextureId,
    staging: Buffer,
    offset: [u32; 2],
    size: [u32; 2],
}

/// One draw: a mesh's index range and scissor.
struct Draw {
    texture: TextureId,
    first_index: u32,
    index_count: u32,
    vertex_offset: i32,
    scissor: vk::Rect2D,
}

/// GPU side of the UI: pipeline, textures, and the current frame's geometry.
pub struct Painter {
    pipeline: Pipeline,
    textures: HashMap<TextureId, Texture>,
    uploads: Vec<Upload>,
    /// Freed after this frame is recorded: egui may still draw with them this frame.
    to_free: Vec<TextureId>,
    vertices: Option<Buffer>,
    indices: Option<Buffer>,
    draws: Vec<Draw>,
    screen_points: [f32; 2],
}

fn bytes_of<T: bytemuck::Pod>(v: &[T]) -> &[u8] {
    bytemuck::cast_slice(v)
}

impl Painter {
    /// Creates the pipeline for drawing into `R8G8B8A8_UNORM` display images.
    pub fn new(ctx: &Context) -> Result<Self> {
        let binding = [Binding::new(0, vk::DescriptorType::COMBINED_IMAGE_SAMPLER, vk::ShaderStageFlags::FRAGMENT)];
        let stride = std::mem::size_of::<Vertex>() as u32;
        let attr =
            |location, format, offset| vk::VertexInputAttributeDescription { location, binding: 0, format, offset };
        let desc = GraphicsDesc {
            color_formats: vec![vk::Format::R8G8B8A8_UNORM],
            blend: Blend::PremultipliedAlpha,
            vertex_bindings: vec![vk::VertexInputBindingDescription {
                binding: 0,
                stride,
                input_rate: vk::VertexInputRate::VERTEX,
            }],
            vertex_attributes: vec![
                attr(0, vk::Format::R32G32_SFLOAT, 0),
                attr(1, vk::Format::R32G32_SFLOAT, 8),
                attr(2, vk::Format::R8G8B8A8_UNORM, 16),
            ],
            ..Default::default()
        };
        let shaders = [&crate::shaders::UI_OVERLAY_VERT, &crate::shaders::UI_OVERLAY_FRAG];
        Ok(Self {
            pipeline: Pipeline::graphics(ctx, &shaders, &binding, 8, &desc)?,
            textures: HashMap::new(),
            uploads: Vec::new(),
            to_free: Vec::new(),
            vertices: None,
            indices: None,
            draws: Vec::new(),
            screen_points: [1.0; 2],
        })
    }

    /// Applies egui's texture changes: new textures are created, changed regions staged for
    /// this frame's upload pass, and freed ones dropped after this frame.
    pub fn update_textures(&mut self, ctx: &Context, delta: &egui::TexturesDelta) -> Result<()> {
        for t in self.to_free.drain(..) {
            // Dropping defers destruction until the GPU is done with the frames that used it.
            self.textures.remove(&t);
        }
        for (id, d) in &delta.set {
            self.stage(ctx, *id, d)?;
        }
        self.to_free.extend(delta.free.iter().copied());
        Ok(())
    }

    fn stage(&mut self, ctx: &Context, id: TextureId, d: &ImageDelta) -> Result<()> {
        let egui::ImageData::Color(img) = &d.image;
        let [w, h] = img.size.map(|v| v as u32);
        if w == 0 || h == 0 {
            return Ok(());
        }
        let nearest = d.options.magnification == egui::TextureFilter::Nearest;
        let offset = match d.pos {
            Some([x, y]) => {
                if !self.textures.contains_key(&id) {
                    return Err(Error::Input(format!("ui: partial update of unknown texture {id:?}")));
                }
                [x as u32, y as u32]
            }
            None => {
                let usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST;
                let image = Image::new(ctx, "ui texture", ImageInfo::d2(vk::Format::R8G8B8A8_UNORM, w, h, usage))?;
                self.textures.insert(id, Texture { image: PersistentImage::new(image), nearest });
                [0, 0]
            }
        };
        let pixels: Vec<u8> = img.pixels.iter().flat_map(|c| c.to_array()).collect();
        let staging = Buffer::with_data(ctx, "ui texture staging", &pixels, vk::BufferUsageFlags::TRANSFER_SRC)?;
        self.uploads.push(Upload { id, staging, offset, size: [w, h] });
        Ok(())
    }

    /// Copies this frame's meshes into host-visible vertex and index buffers.
    pub fn set_meshes(
        &mut self,
        ctx: &Context,
        prims: &[ClippedPrimitive],
        pixels_per_point: f32,
        extent: [u32; 2],
    ) -> Result<()> {
        self.screen_points = [extent[0] as f32 / pixels_per_point, extent[1] as f32 / pixels_per_point];
        self.draws.clear();
        let (mut vertices, mut indices) = (Vec::<Vertex>::new(), Vec::<u32>::new());
        for p in prims {
            let Primitive::Mesh(mesh) = &p.primitive else { continue };
            if mesh.indices.is_empty() || !self.textures.contains_key(&mesh.texture_id) {
                continue;
            }
            // Clip rectangle in pixels, clamped to the target (egui may hand out off-screen rects).
            let r = p.clip_rect;
            let clamp = |v: f32, hi: u32| (v * pixels_per_point).round().clamp(0.0, hi as f32) as u32;
            let (x0, y0) = (clamp(r.min.x, extent[0]), clamp(r.min.y, extent[1]));
            let (x1, y1) = (clamp(r.max.x, extent[0]), clamp(r.max.y, extent[1]));
            if x1 <= x0 || y1 <= y0 {
                continue;
            }
            self.draws.push(Draw {
                texture: mesh.texture_id,
                first_index: indices.len() as u32,
                index_count: mesh.indices.len() as u32,
                vertex_offset: vertices.len() as i32,
                scissor: vk::Rect2D {
                    offset: vk::Offset2D { x: x0 as i32, y: y0 as i32 },
                    extent: vk::Extent2D { width: x1 - x0, height: y1 - y0 },
                },
            });
            vertices.extend_from_slice(&mesh.vertices);
            indices.extend_from_slice(&mesh.indices);
        }
        // New buffers each frame: the previous ones may still be read by the frame in flight and
        // are destroyed once it completes.
        self.vertices = None;
        self.indices = None;
        if !self.draws.is_empty() {
            let (v, i) = (bytes_of(&vertices), bytes_of(&indices));
            self.vertices = Some(Buffer::with_data(ctx, "ui vertices", v, vk::BufferUsageFlags::VERTEX_BUFFER)?);
            self.indices = Some(Buffer::with_data(ctx, "ui indices", i, vk::BufferUsageFlags::INDEX_BUFFER)?);
        }
        Ok(())
    }

    /// Declares the upload and overlay passes drawing onto `target` (loaded, then blended over).
    /// The textures are persistent images: recording the graph records their states.
    pub fn add_passes<'a>(&'a self, g: &mut GraphBuilder<'a>, imports: &mut Imports, target: ImageId) -> Result<()> {
        let mut ids: HashMap<TextureId, ImageId> = HashMap::new();
        let mut import = |g: &mut GraphBuilder<'a>, imports: &mut Imports, id: TextureId| -> Option<ImageId> {
            let t = self.textures.get(&id)?;
            Some(*ids.entry(id).or_insert_with(|| t.image.import(g, imports, "ui texture")))
        };
        if !self.uploads.is_empty() {
            let targets: Vec<(ImageId, &Upload)> =
                self.uploads.iter().filter_map(|u| Some((import(g, imports, u.id)?, u))).collect();
            let mut p = g.add_transfer_pass("ui upload");
            // Runs even when nothing draws this frame (egui's first, sizing frame): the staged
            // texels are dropped after the frame and egui never sends them again.
            p.side_effect();
            for (img, _) in &targets {
                p.write_image(*img, Access::TransferDst)?;
            }
            p.record(move |pc| {
                for (img, u) in &targets {
                    let region = vk::BufferImageCopy {
                        image_subresource: vk::ImageSubresourceLayers {
                            aspect_mask: vk::ImageAspectFlags::COLOR,
                            mip_level: 0,
                            base_array_layer: 0,
                            layer_count: 1,
                        },
                        image_offset: vk::Offset3D { x: u.offset[0] as i32, y: u.offset[1] as i32, z: 0 },
                        image_extent: vk::Extent3D { width: u.size[0], height: u.size[1], depth: 1 },
                        ..Default::default()
                    };
                    // SAFETY: transfer pass; the graph moved the image to TRANSFER_DST_OPTIMAL and
                    // the staging buffer holds exactly the region's texels.
                    unsafe {
                        pc.device().cmd_copy_buffer_to_image(
                            pc.cmd,
                            u.staging.raw,
                            pc.image(*img).raw,
                            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                            &[region],
                        )
                    };
                }
                Ok(())
            });
        }
        let (Some(vb), Some(ib)) = (&self.vertices, &self.indices) else { return Ok(()) };
        let vbuf: BufferId = imports.buffer_readonly(g, "ui vertices", vb);
        let ibuf: BufferId = imports.buffer_readonly(g, "ui indices", ib);
        let mut sampled = Vec::new();
        for d in &self.draws {
            if let Some(img) = import(g, imports, d.texture) {
                sampled.push((d.texture, img));
            }
        }
        let mut p = g.add_raster_pass("ui overlay");
        p.color_attachment(target, LoadOp::Load, [0.0; 4])?;
        p.read_buffer(vbuf, Access::VertexBuffer)?;
        p.read_buffer(ibuf, Access::IndexBuffer)?;
        let mut declared = Vec::new();
        for (_, img) in &sampled {
            if !declared.contains(img) {
                p.read_image(*img, Access::Sampled(ShaderStage::Fragment))?;
                declared.push(*img);
            }
        }
        let push: Vec<u8> = self.screen_points.iter().flat_map(|f| f.to_le_bytes()).collect();
        p.record(move |pc| {
            let d = pc.device();
            // SAFETY: inside the pass's dynamic rendering; both buffers were declared above.
            unsafe {
                d.cmd_bind_vertex_buffers(pc.cmd, 0, &[pc.buffer(vbuf).raw], &[0]);
                d.cmd_bind_index_buffer(pc.cmd, pc.buffer(ibuf).raw, 0, vk::IndexType::UINT32);
            }
            for draw in &self.draws {
                let (Some(t), Some(&(_, img))) =
                    (self.textures.get(&draw.texture), sampled.iter().find(|(id, _)| *id == draw.texture))
                else {
                    continue;
                };
                let sampling = if t.nearest { Sampling::Nearest } else { Sampling::Linear };
                let sampler = pc.ctx.pipelines().sampler(pc.ctx, sampling)?;
                let desc = [Descriptor::CombinedImageSampler(pc.image(img).view, sampler)];
                self.pipeline.bind(pc.cmd, &desc, &push)?;
                // SAFETY: pipeline bound above; the index range lies inside this frame's buffers.
                unsafe {
                    d.cmd_set_scissor(pc.cmd, 0, &[draw.scissor]);
                    d.cmd_draw_indexed(pc.cmd, draw.index_count, 1, draw.first_index, draw.vertex_offset, 0);
                }
            }
            Ok(())
        });
        Ok(())
    }

    /// Drops the staged uploads once the frame that copies them is recorded.
    pub fn finish_frame(&mut self) {
        self.uploads.clear();
    }
}
