//! Occlusion-shaded volume renderers and the ray marchers' depth output, as frame-graph passes:
//! local ambient occlusion (LAO, Hernell et al. 2010), directional occlusion shading (DOS,
//! Schott et al. 2009), and the depth where accumulated opacity first reaches a threshold.

use super::camera::{Camera, Projection};
use crate::error::{Error, Result};
use crate::graph::{Access, GraphBuilder, GraphError, ImageDesc, ImageId, ShaderStage};
use crate::shaders;
use crate::vk::{pipeline::push_words, vk, Binding, Context, Descriptor, Pipeline};
use glam::Vec3;

pub use super::settings::OcclusionSettings;

/// llvmpipe (lavapipe) ends every loop of a shader invocation once all its loops together have
/// run this many iterations (gallivm's `LP_MAX_TGSI_LOOP_ITERATIONS`, "shared between every loop
/// in a shader"); past it the image is silently wrong, by workgroup. Real GPUs have no such cap.
pub const LLVMPIPE_LOOP_LIMIT: u64 = 65535;

/// Published defaults of terier/vpt's `src/js/renderers/LAORenderer.js`: `lightRadious` 0.19 and
/// `numShadowSamples` 10 (its volume is the unit cube, as our box's largest axis). Its
/// `lightPosition` [2, 12, 3] is not adopted: vpt multiplies it by the inverse MVP matrix (as if it
/// were a clip-space point, without the divide), so it names no fixed place in the scene.
pub const VPT_LIGHT_RADIUS: f32 = 0.19;
/// See [`VPT_LIGHT_RADIUS`].
pub const VPT_LIGHT_SAMPLES: u32 = 10;

impl OcclusionSettings {
    /// Worst-case loop iterations of one LAO pixel whose camera ray takes `march_steps` samples:
    /// per sample its ambient rays × steps, and its shadow rays × up to `march_steps` segments.
    pub fn lao_loop_iterations(&self, march_steps: u64) -> u64 {
        let ambient =
            if self.lao_ambient > 0.0 { u64::from(self.lao_samples) * u64::from(self.lao_steps + 1) } else { 0 };
        let light = if self.lao_light > 0.0 { u64::from(self.lao_light_samples) * (march_steps + 1) } else { 0 };
        march_steps * (1 + ambient + light)
    }

    /// Whether LAO needs its light variant: a light is on or the ambient weight is not 1. With
    /// the defaults the plain shader runs, so images are unchanged.
    pub fn lao_light_variant(&self) -> bool {
        self.lao_light > 0.0 || self.lao_ambient != 1.0
    }
}

/// The pipelines of this module's passes.
pub struct OcclusionPipelines {
    eam_depth: Pipeline,
    lao: Pipeline,
    lao_depth: Pipeline,
    lao_light: Pipeline,
    lao_light_depth: Pipeline,
    dos_init: Pipeline,
    dos: Pipeline,
    dos_init_depth: Pipeline,
    dos_depth: Pipeline,
}

impl OcclusionPipelines {
    /// Builds every pipeline (layouts share bindings 0–3 with the other volume renderers).
    pub fn new(ctx: &Context) -> Result<Self> {
        let c = vk::ShaderStageFlags::COMPUTE;
        let (ub, cis, si) = (
            vk::DescriptorType::UNIFORM_BUFFER,
            vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
            vk::DescriptorType::STORAGE_IMAGE,
        );
        let b = |i, t| Binding::new(i, t, c);
        let base = [b(0, ub), b(1, cis), b(2, cis), b(3, si)];
        let occupancy_grad_depth = [base[0], base[1], base[2], base[3], b(4, cis), b(5, cis), b(6, si)];
        let lao = [base[0], base[1], base[2], base[3], b(4, cis)];
        let lao_depth = [base[0], base[1], base[2], base[3], b(4, cis), b(5, si)];
        let dos = [base[0], base[1], base[2], base[3], b(4, cis), b(5, cis), b(6, si)];
        let dos_depth = [base[0], base[1], base[2], base[3], b(4, cis), b(5, cis), b(6, si), b(7, si)];
        Ok(Self {
            eam_depth: Pipeline::compute(ctx, &shaders::VOLUME_EAM_COMP__DEPTH, &occupancy_grad_depth, 4)?,
            lao: Pipeline::compute(ctx, &shaders::VOLUME_LAO_COMP, &lao, 16)?,
            lao_depth: Pipeline::compute(ctx, &shaders::VOLUME_LAO_COMP__DEPTH, &lao_depth, 16)?,
            lao_light: Pipeline::compute(ctx, &shaders::VOLUME_LAO_COMP__LIGHT, &lao, 48)?,
            lao_light_depth: Pipeline::compute(ctx, &shaders::VOLUME_LAO_COMP__LIGHT_DEPTH, &lao_depth, 48)?,
            dos_init: Pipeline::compute(ctx, &shaders::VOLUME_DOS_COMP__INIT, &[b(0, si), b(1, si)], 0)?,
            dos: Pipeline::compute(ctx, &shaders::VOLUME_DOS_COMP, &dos, 48)?,
            dos_init_depth: Pipeline::compute(
                ctx,
                &shaders::VOLUME_DOS_COMP__INIT_DEPTH,
                &[b(0, si), b(1, si), b(2, si)],
                0,
            )?,
            dos_depth: Pipeline::compute(ctx, &shaders::VOLUME_DOS_COMP__DEPTH, &dos_depth, 48)?,
        })
    }
}

/// What the volume renderer hands to these passes: its per-frame graph resources.
#[derive(Clone, Copy)]
pub struct MarchInputs {
    /// The `Params` uniform buffer.
    pub params: crate::graph::BufferId,
    /// Volume texture.
    pub volume: ImageId,
    /// Transfer-function table.
    pub tf: ImageId,
    /// Gradient-magnitude texture.
    pub gradients: ImageId,
    /// Occupancy grid (EAM's empty-space skipping).
    pub occupancy: ImageId,
    /// The frame's HDR output.
    pub hdr: ImageId,
    /// Linear and nearest samplers.
    pub samplers: (vk::Sampler, vk::Sampler),
    /// Output size.
    pub size: [u32; 2],
}

fn ge(e: GraphError) -> Error {
    Error::Input(format!("frame graph: {e}"))
}

const CS: ShaderStage = ShaderStage::Compute;

fn groups(size: [u32; 2]) -> [u32; 2] {
    [size[0].div_ceil(8), size[1].div_ceil(8)]
}

fn reads(p: &mut crate::graph::PassBuilder<'_, '_>, m: &MarchInputs) -> Result<()> {
    p.read_buffer(m.params, Access::UniformRead(CS)).map_err(ge)?;
    p.read_image(m.volume, Access::Sampled(CS)).map_err(ge)?;
    p.read_image(m.tf, Access::Sampled(CS)).map_err(ge)?;
    p.read_image(m.gradients, Access::Sampled(CS)).map_err(ge)?;
    Ok(())
}

fn base_descriptors(pc: &crate::graph::PassContext<'_>, m: &MarchInputs, out: ImageId) -> [Descriptor; 5] {
    let lin = m.samplers.0;
    [
        Descriptor::UniformBuffer(pc.buffer(m.params).raw),
        Descriptor::CombinedImageSampler(pc.image(m.volume).view, lin),
        Descriptor::CombinedImageSampler(pc.image(m.tf).view, lin),
        Descriptor::StorageImage(pc.image(out).view),
        Descriptor::CombinedImageSampler(pc.image(m.gradients).view, lin),
    ]
}

fn dispatch(pc: &crate::graph::PassContext<'_>, g: [u32; 2]) {
    // SAFETY: the pass bound its pipeline and descriptors just before.
    unsafe { pc.device().cmd_dispatch(pc.cmd, g[0], g[1], 1) };
}

/// EAM (precomputed gradients) that also writes `depth`: (ray distance, NDC depth, hit, 0).
pub fn add_eam_depth_pass<'a>(
    g: &mut GraphBuilder<'a>,
    pipes: &'a OcclusionPipelines,
    m: MarchInputs,
    depth: ImageId,
    threshold: f32,
    work: crate::graph::Work,
) -> Result<()> {
    let pipe = &pipes.eam_depth;
    let mut p = g.add_compute_pass("eam");
    p.work(work);
    reads(&mut p, &m)?;
    p.read_image(m.occupancy, Access::Sampled(CS)).map_err(ge)?;
    p.write_image(m.hdr, Access::StorageWrite(CS)).map_err(ge)?;
    p.write_image(depth, Access::StorageWrite(CS)).map_err(ge)?;
    let push = push_words(&[(1.0 - threshold).to_bits()]);
    p.record(move |pc| {
        let [a, b, c, d, grad] = base_descriptors(pc, &m, m.hdr);
        let occ = Descriptor::CombinedImageSampler(pc.image(m.occupancy).view, m.samplers.1);
        let ds = [a, b, c, d, occ, grad, Descriptor::StorageImage(pc.image(depth).view)];
        if pipe.bind(pc.cmd, &ds, &push).is_ok() {
            dispatch(pc, groups(m.size));
        }
    });
    Ok(())
}

/// LAO ray marching into `m.hdr` (and `depth` if given).
pub fn add_lao_pass<'a>(
    g: &mut GraphBuilder<'a>,
    pipes: &'a OcclusionPipelines,
    m: MarchInputs,
    s: &OcclusionSettings,
    depth: Option<ImageId>,
    work: crate::graph::Work,
) -> Result<()> {
    s.validate()?;
    let target = 1.0 - s.depth_threshold.unwrap_or(0.5);
    let mut words = vec![s.lao_radius.to_bits(), s.lao_samples, s.lao_steps, target.to_bits()];
    let light = s.lao_light_variant();
    if light {
        let [x, y, z] = s.lao_light_pos;
        words.extend([x, y, z, s.lao_light_radius, s.lao_light].map(f32::to_bits));
        words.extend([s.lao_light_samples, s.lao_ambient.to_bits(), 0]);
    }
    let push = push_words(&words);
    let (plain, with_depth) =
        if light { (&pipes.lao_light, &pipes.lao_light_depth) } else { (&pipes.lao, &pipes.lao_depth) };
    let mut p = g.add_compute_pass("lao");
    p.work(work);
    reads(&mut p, &m)?;
    p.write_image(m.hdr, Access::StorageWrite(CS)).map_err(ge)?;
    if let Some(d) = depth {
        p.write_image(d, Access::StorageWrite(CS)).map_err(ge)?;
    }
    p.record(move |pc| {
        let base = base_descriptors(pc, &m, m.hdr);
        let ok = match depth {
            Some(d) => {
                let [a, b, c, e, f] = base;
                with_depth.bind(pc.cmd, &[a, b, c, e, f, Descriptor::StorageImage(pc.image(d).view)], &push)
            }
            None => plain.bind(pc.cmd, &base, &push),
        };
        if ok.is_ok() {
            dispatch(pc, groups(m.size));
        }
    });
    Ok(())
}

/// Slab of view-axis planes covering the box: (first plane coordinate, Δz) for `slices`.
fn slab(camera: &Camera, box_half: Vec3, slices: u32) -> (Vec3, f32, f32) {
    let (_, fwd) = camera.eye_forward();
    // Plane coordinate along `fwd` of the box's nearest and farthest corners.
    let extent = fwd.abs().dot(box_half);
    (fwd, -extent, 2.0 * extent / slices as f32)
}

/// DOS: an init pass and one compute pass per slice, compositing into `m.hdr` (and writing
/// `depth` in the slice where the threshold is crossed, if given). The occlusion buffer
/// ping-pongs between two R32F images because each slice reads its neighbours' values from the
/// previous slice.
pub fn add_dos_passes<'a>(
    g: &mut GraphBuilder<'a>,
    pipes: &'a OcclusionPipelines,
    m: MarchInputs,
    s: &OcclusionSettings,
    camera: &Camera,
    box_half: Vec3,
    depth: Option<ImageId>,
) -> Result<()> {
    s.validate()?;
    let [w, h] = m.size;
    let occ = [
        g.create_image("dos occlusion 0", ImageDesc::d2(vk::Format::R32_SFLOAT, w, h)),
        g.create_image("dos occlusion 1", ImageDesc::d2(vk::Format::R32_SFLOAT, w, h)),
    ];
    let init = if depth.is_some() { &pipes.dos_init_depth } else { &pipes.dos_init };
    let mut p = g.add_compute_pass("dos init");
    p.write_image(m.hdr, Access::StorageWrite(CS)).map_err(ge)?;
    p.write_image(occ[0], Access::StorageWrite(CS)).map_err(ge)?;
    if let Some(d) = depth {
        p.write_image(d, Access::StorageWrite(CS)).map_err(ge)?;
    }
    p.record(move |pc| {
        let mut ds =
            vec![Descriptor::StorageImage(pc.image(m.hdr).view), Descriptor::StorageImage(pc.image(occ[0]).view)];
        if let Some(d) = depth {
            ds.push(Descriptor::StorageImage(pc.image(d).view));
        }
        if init.bind(pc.cmd, &ds, &[]).is_ok() {
            dispatch(pc, groups(m.size));
        }
    });
    let target = 1.0 - s.depth_threshold.unwrap_or(0.5);
    let (fwd, z0, dz) = slab(camera, box_half, s.dos_slices);
    let (eye, _) = camera.eye_forward();
    // World size of one pixel at view depth z: s0 + s1·z.
    let (s0, s1) = match camera.projection {
        Projection::Orthographic { height } => (height / h as f32, 0.0),
        Projection::Perspective { fov_y } => (0.0, 2.0 * (0.5 * fov_y).tan() / h as f32),
    };
    let tan = s.dos_angle.to_radians().tan();
    let pipe = if depth.is_some() { &pipes.dos_depth } else { &pipes.dos };
    for k in 0..s.dos_slices {
        let (src, dst) = (occ[(k % 2) as usize], occ[((k + 1) % 2) as usize]);
        let last = if k + 1 == s.dos_slices { 1.0 } else { 0.0 };
        let push: Vec<u8> = [z0, dz, s0, s1, fwd.x, fwd.y, fwd.z, tan, eye.dot(fwd), k as f32, last, target]
            .iter()
            .flat_map(|f| f.to_le_bytes())
            .collect();
        let mut p = g.add_compute_pass("dos slice");
        reads(&mut p, &m)?;
        p.read_image(src, Access::Sampled(CS)).map_err(ge)?;
        p.write_image(dst, Access::StorageWrite(CS)).map_err(ge)?;
        p.write_image(m.hdr, Access::StorageReadWrite(CS)).map_err(ge)?;
        if let Some(d) = depth {
            // Read-write: slices that do not cross the threshold leave earlier slices' texels.
            p.write_image(d, Access::StorageReadWrite(CS)).map_err(ge)?;
        }
        p.record(move |pc| {
            let [a, b, c, d, grad] = base_descriptors(pc, &m, m.hdr);
            let o_in = Descriptor::CombinedImageSampler(pc.image(src).view, m.samplers.0);
            let mut ds = vec![a, b, c, d, grad, o_in, Descriptor::StorageImage(pc.image(dst).view)];
            if let Some(di) = depth {
                ds.push(Descriptor::StorageImage(pc.image(di).view));
            }
            if pipe.bind(pc.cmd, &ds, &push).is_ok() {
                dispatch(pc, groups(m.size));
            }
        });
    }
    Ok(())
}
