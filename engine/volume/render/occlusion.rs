//! Occlusion-shaded volume renderers and the ray marchers' depth output, as frame-graph passes:
//! local ambient occlusion (LAO, Hernell et al. 2010), directional occlusion shading (DOS,
//! Schott et al. 2009), and the depth where accumulated opacity first reaches a threshold.

use crate::error::{Error, Result};
use crate::graph::{ComputePass, GraphBuilder, ImageDesc, ImageId};
use crate::shaders::{self, Shader};
use crate::vk::{vk, Sampling};
use crate::volume::camera::{Camera, Projection};
use crate::volume::data::bricks::MAX_ATLASES;
use glam::Vec3;

pub use super::settings::OcclusionSettings;

/// llvmpipe's loop limit (the frame graph's, which refuses passes declared over it).
pub use crate::graph::work::LLVMPIPE_LOOP_LIMIT;

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
        march_steps * self.lao_sample_iterations(march_steps)
    }

    /// Worst-case loop iterations of one camera-ray sample (its own iteration, its ambient
    /// rays × steps and its shadow rays × up to `march_steps` segments, each loop's exit included).
    pub fn lao_sample_iterations(&self, march_steps: u64) -> u64 {
        let ambient =
            if self.lao_ambient > 0.0 { u64::from(self.lao_samples) * u64::from(self.lao_steps + 1) + 1 } else { 0 };
        let light = if self.lao_light > 0.0 { u64::from(self.lao_light_samples) * (march_steps + 1) + 1 } else { 0 };
        1 + ambient + light
    }

    /// Whether LAO needs its light variant: a light is on or the ambient weight is not 1. With
    /// the defaults the plain shader runs, so images are unchanged.
    pub fn lao_light_variant(&self) -> bool {
        self.lao_light > 0.0 || self.lao_ambient != 1.0
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
    /// Majorant grid: per cell the (min, max) extinction as float bits (the Monte Carlo trackers'
    /// and the feature march's steps).
    pub majorants: ImageId,
    /// The frame's HDR output.
    pub hdr: ImageId,
    /// Output size.
    pub size: [u32; 2],
    /// `filter=exact`: specialization constant 2 of `volume/common.glsl`.
    pub exact_filter: bool,
    /// The sparse layout's page table (a placeholder in the dense one).
    pub page_table: ImageId,
    /// The two-level page table's directory (a placeholder otherwise).
    pub page_directory: ImageId,
    /// Page-table levels: specialization constant 5 of `volume/common.glsl`.
    pub page_levels: u32,
    /// `volume_layout` resolved to sparse: specialization constant 3 of `volume/common.glsl`.
    pub sparse: bool,
    /// Value atlases 1–3, then gradient atlases 1–3 (placeholders past the volume's).
    pub more_atlases: [ImageId; 2 * (MAX_ATLASES as usize - 1)],
    /// The majorant grid carries page words (a sparse volume whose cells are bricks): without
    /// `exact_filter`, specialization constant 6 of `volume/common.glsl`.
    pub segment_words: bool,
    /// Atlases per quantity: specialization constant 4 of `volume/common.glsl`.
    pub atlases: u32,
    /// The label colour and keep images (1-texel placeholders without a label map).
    pub label_images: [ImageId; 2],
    /// The label map, specialization constant 7 of `volume/common.glsl`: 0 none, 1 tint, 2
    /// replace ([`super::labels::label_constant`]).
    pub labels: u32,
    /// Whether anything is clipped: specialization constant 8 of `volume/common.glsl`.
    pub clipping: bool,
    /// The transfer function reads the gradient magnitude: specialization constant 0 of
    /// `volume/common.glsl` (otherwise no medium lookup fetches it).
    pub tf_gradient: bool,
    /// Page words name bricks of any pyramid level (view-dependent residency): specialization
    /// constant 9 of `volume/common.glsl`.
    pub lod_words: bool,
    /// Read the uniform blocks at an opaque index (`volume/common.glsl`'s `OPAQUE_BLOCKS`).
    pub opaque_blocks: bool,
    /// The temperature grid and its blackbody table (placeholders without a grid).
    pub temperature: [ImageId; 2],
    /// A temperature grid with `emission` > 0: EAM's colour is its blackbody radiance
    /// (specialization constant 1 of `volume/eam.comp`).
    pub temperature_emission: bool,
}

fn groups([w, h]: [u32; 2]) -> [u32; 3] {
    [w.div_ceil(8), h.div_ceil(8), 1]
}

/// Bindings 0–2 every ray marcher shares (`volume/common.glsl`): parameters, volume, table, and
/// its page table at [`PAGE_TABLE_BINDING`](super::renderer::PAGE_TABLE_BINDING).
pub(crate) fn march_pass<'g, 'a>(
    g: &'g mut GraphBuilder<'a>,
    name: &str,
    shader: &'static Shader,
    m: &MarchInputs,
) -> ComputePass<'g, 'a> {
    g.compute(name, shader)
        .uniform(m.params)
        .sampled(m.volume, Sampling::Linear)
        .sampled(m.tf, Sampling::Linear)
        .read_at(super::renderer::PAGE_TABLE_BINDING, m.page_table)
        .each((0..).zip(m.more_atlases), |p, (i, a)| p.sampled_at(MORE_ATLASES_BINDING + i, a, Sampling::Linear))
        .read_at(super::renderer::PAGE_DIRECTORY_BINDING, m.page_directory)
        .sampled_at(LABEL_BINDING, m.label_images[0], Sampling::Linear)
        .sampled_at(LABEL_BINDING + 1, m.label_images[1], Sampling::Linear)
        .specialize(&m.specialization(u32::from(m.tf_gradient), 0))
}

/// An EAM pass: [`march_pass`] with the temperature grid and its blackbody table, and EAM's own
/// constant (`volume/eam.comp`'s `TEMPERATURE`).
pub(crate) fn eam_pass<'g, 'a>(
    g: &'g mut GraphBuilder<'a>,
    name: &str,
    shader: &'static Shader,
    m: &MarchInputs,
) -> ComputePass<'g, 'a> {
    march_pass(g, name, shader, m)
        .sampled_at(super::temperature::TEMPERATURE_BINDING, m.temperature[0], Sampling::Linear)
        .sampled_at(super::temperature::PLANCK_BINDING, m.temperature[1], Sampling::Linear)
        .specialize(&m.specialization(u32::from(m.tf_gradient), u32::from(m.temperature_emission)))
}

/// First binding of `volume/common.glsl`'s further atlases (values 1–3, then gradients 1–3).
pub const MORE_ATLASES_BINDING: u32 = 16;
/// Binding of `volume/common.glsl`'s label map (its colour table is the next).
pub const LABEL_BINDING: u32 = 25;

impl MarchInputs {
    /// Specialization constants 0–10 of the shaders including `volume/common.glsl`: 0 is
    /// `TF_GRADIENT` (the marchers pass [`Self::tf_gradient`]), 1 the shader's own.
    pub fn specialization(&self, c0: u32, c1: u32) -> [u32; 11] {
        let segment_words = self.segment_words && !self.exact_filter;
        [
            c0,
            c1,
            u32::from(self.exact_filter),
            u32::from(self.sparse),
            self.atlases,
            self.page_levels.max(1),
            u32::from(segment_words),
            self.labels,
            u32::from(self.clipping),
            u32::from(self.lod_words),
            u32::from(self.opaque_blocks),
        ]
    }
}

/// EAM (precomputed gradients) that also writes `depth`: (ray distance, NDC depth, hit, 0).
pub fn add_eam_depth_pass(
    g: &mut GraphBuilder<'_>,
    m: MarchInputs,
    depth: ImageId,
    threshold: f32,
    work: crate::graph::Work,
) -> Result<()> {
    eam_pass(g, "eam", &shaders::VOLUME_EAM_COMP__DEPTH, &m)
        .work(work)
        .write(m.hdr)
        .sampled(m.occupancy, Sampling::Nearest)
        .sampled(m.gradients, Sampling::Linear)
        .write(depth)
        .constants(&(1.0 - threshold))
        .dispatch(groups(m.size))?;
    Ok(())
}

/// LAO ray marching into `m.hdr` (and `depth` if given), camera rays of up to `march_steps`
/// samples split over as many dispatches as keep each under llvmpipe's loop limit
/// ([`LLVMPIPE_LOOP_LIMIT`]; `lao_chunk` forces smaller ones).
pub fn add_lao_pass(
    g: &mut GraphBuilder<'_>,
    m: MarchInputs,
    s: &OcclusionSettings,
    depth: Option<ImageId>,
    work: crate::graph::Work,
    march_steps: u64,
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
    let shader = match (light, depth.is_some()) {
        (false, false) => &shaders::VOLUME_LAO_COMP,
        (false, true) => &shaders::VOLUME_LAO_COMP__DEPTH,
        (true, false) => &shaders::VOLUME_LAO_COMP__LIGHT,
        (true, true) => &shaders::VOLUME_LAO_COMP__LIGHT_DEPTH,
    };
    let per_sample = s.lao_sample_iterations(march_steps);
    // The chunk's own loop exit and the early-out test cost one iteration more.
    let fits = (LLVMPIPE_LOOP_LIMIT - 1) / per_sample;
    if fits == 0 {
        return Err(Error::Input(format!(
            "lao: one sample's occlusion and shadow rays alone can take {per_sample} loop iterations, over llvmpipe's \
             {LLVMPIPE_LOOP_LIMIT}; lower lao_light_samples, lao_samples or lao_steps, or raise step"
        )));
    }
    let chunk = if s.lao_chunk > 0 { u64::from(s.lao_chunk).min(fits) } else { fits };
    let steps = march_steps.max(1);
    let chunks = steps.div_ceil(chunk);
    for c in 0..chunks {
        let (first, last) = (c * chunk, c + 1 == chunks);
        let mut push = vec![first as u32, chunk as u32, u32::from(last), 0];
        push.extend(&words);
        let name = if chunks == 1 { "lao".to_string() } else { format!("lao {}/{chunks}", c + 1) };
        // The first dispatch starts every ray; later ones carry its state in the texels.
        let first_pass = c == 0;
        march_pass(g, &name, shader, &m)
            .work(crate::graph::Work { loop_iterations: chunk * per_sample + 1, ..work })
            .each(Some(m.hdr).filter(|_| first_pass), |p, h| p.write(h))
            .each(Some(m.hdr).filter(|_| !first_pass), |p, h| p.read_write(h))
            .sampled(m.gradients, Sampling::Linear)
            .each(depth.filter(|_| first_pass), |p, d| p.write(d))
            .each(depth.filter(|_| !first_pass), |p, d| p.read_write(d))
            .push_bytes(bytemuck::cast_slice(&push).to_vec())
            .dispatch(groups(m.size))?;
    }
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
pub fn add_dos_passes(
    g: &mut GraphBuilder<'_>,
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
    let (init, slice) = match depth {
        Some(_) => (&shaders::VOLUME_DOS_COMP__INIT_DEPTH, &shaders::VOLUME_DOS_COMP__DEPTH),
        None => (&shaders::VOLUME_DOS_COMP__INIT, &shaders::VOLUME_DOS_COMP),
    };
    g.compute("dos init", init).write(m.hdr).write(occ[0]).each(depth, |p, d| p.write(d)).dispatch(groups(m.size))?;
    let target = 1.0 - s.depth_threshold.unwrap_or(0.5);
    let (fwd, z0, dz) = slab(camera, box_half, s.dos_slices);
    let (eye, _) = camera.eye_forward();
    // World size of one pixel at view depth z: s0 + s1·z.
    let (s0, s1) = match camera.projection {
        Projection::Orthographic { height } => (height / h as f32, 0.0),
        Projection::Perspective { fov_y } => (0.0, 2.0 * (0.5 * fov_y).tan() / h as f32),
    };
    let tan = s.dos_angle.to_radians().tan();
    for k in 0..s.dos_slices {
        let (src, dst) = (occ[(k % 2) as usize], occ[((k + 1) % 2) as usize]);
        let last = if k + 1 == s.dos_slices { 1.0 } else { 0.0 };
        let push: [f32; 12] = [z0, dz, s0, s1, fwd.x, fwd.y, fwd.z, tan, eye.dot(fwd), k as f32, last, target];
        march_pass(g, "dos slice", slice, &m)
            .read_write(m.hdr)
            .sampled(m.gradients, Sampling::Linear)
            .sampled(src, Sampling::Linear)
            .write(dst)
            // Read-write: slices that do not cross the threshold leave earlier slices' texels.
            .each(depth, |p, d| p.read_write(d))
            .constants(&push)
            // One loop: the 13-tap occlusion blur (dos.comp's TAPS) and its exit.
            .loop_bound(14)
            .dispatch(groups(m.size))?;
    }
    Ok(())
}
