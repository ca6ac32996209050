//! The denoised image of the Monte Carlo renderers (`denoise=on`): the view's unbiased mean, with
//! a prior reprojected from earlier views blended in by sample count (`super::temporal`), through
//! a few iterations of an edge-avoiding à-trous filter (`post/atrous.comp`) guided by the volume's
//! feature buffers (`super::features`) and by each pixel's variance of the mean (the moments
//! image, `super::variance`), so the filter weakens as paths accumulate, then shrunk toward the
//! mean where its deviation outgrows the mean's noise (`post/denoise_shrink.comp`), so the shown
//! image converges to the mean. The mean itself (`Targets::hdr`) is never touched.
//!
//! Memory per pixel: two feature images (current and previous view, 2 words each), the prior
//! and the integrated image, one transient ping-pong image and the shown image (RGBA16F each):
//! 12 floats. The filtered images hold their difference from the mean (`post/atrous.comp`), so
//! half floats suffice: where the filter changes nothing the shown image is the mean exactly.

use super::frame::Targets;
use super::occlusion::MarchInputs;
use super::renderer::VolumeRenderer;
use super::settings::{RenderSettings, VolumeSetup};
use super::variance::MomentImages;
use crate::field;
use crate::graph::execute::Imports;
use crate::graph::{Access, GraphBuilder, ImageDesc, ImageId, PersistentImage};
use crate::settings::Key;
use crate::shaders;
use crate::vk::{vk, Context, Image, ImageInfo};
use crate::volume::camera::Camera;
use crate::{Error, Result};
use glam::Mat4;

/// The denoiser's settings.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct DenoiseSettings {
    /// Monte Carlo renderers: show and write the denoised image instead of the raw mean (the
    /// mean is still computed, unchanged, and can be read beside it).
    pub on: bool,
    /// Test switches (`post/atrous.comp` bit 0: ignore the variance, bit 1: ignore the features;
    /// `post/denoise_shrink.comp` bit 3: no shrink toward the mean;
    /// `post/reproject.comp` bit 2: keep every reprojected tap, unclamped), only for tests that show their checks can fail; not a setting.
    #[serde(skip)]
    pub debug_flags: u32,
}

pub(super) static DENOISE: [Key<VolumeSetup>; 1] = [field!(pair "denoise", "Denoise",
    "Monte Carlo: show and write the denoised image (an edge-avoiding filter guided by the volume's features and each pixel's variance, with history reprojected while the camera moves); the unbiased mean is kept beside it",
    ["off", "on"], |s| s.render.denoise.on)];

/// À-trous iterations: 5×5 taps 1, 2, 4, 8 and 16 pixels apart (SVGF's five).
pub const ITERATIONS: u32 = 5;
// The iterations must end in the transient, which the shrink reads to write the shown image.
const _: () = assert!(ITERATIONS % 2 == 1);
/// The luminance edge-stopping scale in standard deviations (SVGF's σ_l is 4; 2 keeps taps whose
/// true difference would outweigh the noise they remove from pulling the image off the mean).
pub const SIGMA_L: f32 = 2.0;
/// Samples a reprojected history may stand for at most: older views fade as new ones add theirs.
pub const AGE_CAP: f32 = 16.0;

/// The denoiser's persistent images and what they were made for.
pub struct DenoiseTargets {
    /// Feature buffers (`post/features.glsl`) of the current view and the one before.
    pub(super) features: [PersistentImage; 2],
    /// Which of `features` is the current view's.
    pub(super) cur: usize,
    /// This view's prior: the previous views' integrated image reprojected (rgb, age in samples).
    pub(super) prior: PersistentImage,
    /// The last frame's mean blended with its prior (rgb, age): the next view's history.
    pub(super) integrated: PersistentImage,
    /// The denoised image as its difference from the mean (RGBA16F; `post/atrous.comp`), what is
    /// shown, tone-mapped with the mean added.
    pub(super) shown: PersistentImage,
    /// The mean's key (`Targets::key`) the current features were made for ("" before any).
    pub(super) view_key: String,
    /// The current view's inverse view-projection and, when a history exists, the previous one's.
    pub(super) inv_view_proj: Mat4,
    pub(super) prev_inv_view_proj: Option<Mat4>,
    /// `integrated` holds an earlier frame's output.
    pub(super) history: bool,
    /// This view's prior was reprojected (otherwise the blend ignores it).
    pub(super) prior_valid: bool,
    /// The last frame showed the denoised image.
    shown_last: bool,
}

impl Targets {
    /// Adds the denoiser's images (a no-op if they exist).
    pub fn enable_denoise(&mut self, ctx: &Context) -> Result<()> {
        if self.denoise.is_none() {
            let [w, h] = [self.hdr.info.extent[0], self.hdr.info.extent[1]];
            let u = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
            let img = |name: &str, f| -> Result<PersistentImage> {
                Ok(PersistentImage::new(Image::new(ctx, name, ImageInfo::d2(f, w, h, u))?))
            };
            self.denoise = Some(DenoiseTargets {
                features: [img("features 0", vk::Format::R32G32_UINT)?, img("features 1", vk::Format::R32G32_UINT)?],
                cur: 0,
                prior: img("denoise prior", vk::Format::R16G16B16A16_SFLOAT)?,
                integrated: img("denoise integrated", vk::Format::R16G16B16A16_SFLOAT)?,
                shown: img("denoised", vk::Format::R16G16B16A16_SFLOAT)?,
                view_key: String::new(),
                inv_view_proj: Mat4::IDENTITY,
                prev_inv_view_proj: None,
                history: false,
                prior_valid: false,
                shown_last: false,
            });
        }
        Ok(())
    }

    /// Whether the last frame showed (tone-mapped) the denoised image rather than the mean.
    pub fn shows_denoised(&self) -> bool {
        self.denoise.as_ref().is_some_and(|d| d.shown_last)
    }

    /// The image the last frame showed, as RGBA f32 texels: the denoised one with `denoise=on`
    /// (the mean plus the filter's difference, alpha the mean's), otherwise the mean
    /// ([`Targets::read_hdr`]).
    pub fn read_shown(&self, ctx: &Context) -> Result<Vec<[f32; 4]>> {
        let mut mean = self.read_hdr(ctx)?;
        if let Some(d) = self.denoise.as_ref().filter(|d| d.shown_last) {
            let delta = d.shown.read(ctx)?;
            for (m, t) in mean.iter_mut().zip(delta.chunks_exact(8)) {
                for (c, h) in m[..3].iter_mut().zip(t.chunks_exact(2)) {
                    // f32 + f16 → f32, as the tone map adds them.
                    *c += crate::volume::data::half_to_f32(u16::from_le_bytes([h[0], h[1]]));
                }
            }
        }
        Ok(mean)
    }

    /// Reads the current view's feature buffers back (`post/features.glsl`): per pixel the
    /// feature depth (< 0: background), normal, albedo and transmittance to the background.
    pub fn read_features(&self, ctx: &Context) -> Result<Vec<Feature>> {
        let d = self.denoise.as_ref().ok_or_else(|| Error::Input("no denoised frame rendered yet".into()))?;
        Ok(d.features[d.cur].read(ctx)?.chunks_exact(8).map(Feature::unpack).collect())
    }
}

/// One pixel's features as the host reads them (`post/features.glsl`'s `Feature`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Feature {
    /// Ray distance of the feature point (< 0: background).
    pub depth: f32,
    /// Albedo (5 bits a channel).
    pub albedo: [f32; 3],
    /// Transmittance to the background (5 bits).
    pub transmittance: f32,
}

impl Feature {
    fn unpack(b: &[u8]) -> Self {
        let word = |i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
        let w = word(4);
        let channel = |shift: u32| ((w >> shift) & 31) as f32 / 31.0;
        Self {
            depth: f32::from_bits(word(0)),
            albedo: [channel(12), channel(17), channel(22)],
            transmittance: channel(27),
        }
    }
}

/// Push constants of `post/denoise_blend.comp`.
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct BlendPush {
    age_cap: f32,
    use_prior: u32,
}

/// Push constants of `post/atrous.comp`.
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct AtrousPush {
    step: i32,
    sigma_l: f32,
    last: u32,
    flags: u32,
}

/// The mean and its moments: what the denoiser starts from.
#[derive(Clone, Copy)]
pub(super) struct DenoiseInputs {
    /// The progressive mean (`Targets::hdr`).
    pub mean: ImageId,
    /// Its moments.
    pub moments: MomentImages,
}

impl VolumeRenderer {
    /// With `denoise=on` on a Monte Carlo frame: the feature buffers (a new view only), the
    /// temporal prior (a new view with a history), the blend and the à-trous iterations, then
    /// the tone map of the denoised image into `ldr`. Returns the denoised image, or `None` when
    /// the denoiser is off (the caller tone-maps the mean).
    #[allow(clippy::too_many_arguments)] // each is a separate input of the frame
    pub(super) fn add_denoise_passes(
        &self,
        g: &mut GraphBuilder<'_>,
        imports: &mut Imports,
        targets: &mut Targets,
        camera: &Camera,
        s: &RenderSettings,
        march: &MarchInputs,
        inputs: Option<DenoiseInputs>,
        ldr: ImageId,
    ) -> Result<Option<ImageId>> {
        let key = targets.key.clone();
        let (inputs, d) = match (s.denoise.on, inputs, targets.denoise.as_mut()) {
            (true, Some(i), Some(d)) => (i, d),
            (true, Some(_), None) => {
                return Err(Error::Input(
                    "denoise: the targets have no denoiser images (Targets::enable_denoise)".into(),
                ))
            }
            (_, _, d) => {
                if let Some(d) = d {
                    d.shown_last = false;
                }
                return Ok(None);
            }
        };
        let size = march.size;
        let groups = [size[0].div_ceil(8), size[1].div_ceil(8), 1];
        let new_view = d.view_key != key;
        if new_view {
            let first = d.view_key.is_empty();
            if !first {
                d.cur ^= 1;
            }
            d.prev_inv_view_proj = d.history.then_some(d.inv_view_proj);
            d.inv_view_proj = camera.inverse_view_projection(size[0] as f32 / size[1] as f32);
            d.view_key = key;
        }
        let feats = d.features[d.cur].import(g, imports, "features");
        if new_view {
            self.add_features_pass(g, march, s, feats)?;
        }
        let prior = d.prior.import(g, imports, "denoise prior");
        let integrated = d.integrated.import(g, imports, "denoise integrated");
        if new_view {
            d.prior_valid = false;
            if let Some(prev) = d.prev_inv_view_proj {
                let feats_prev = d.features[d.cur ^ 1].import(g, imports, "features (previous view)");
                super::temporal::add_reproject_pass(
                    g,
                    march.params,
                    inputs.mean,
                    [feats, feats_prev],
                    integrated,
                    prior,
                    prev,
                    s.denoise.debug_flags,
                    groups,
                )?;
                d.prior_valid = true;
            }
        }
        // The blend writes the shown image, the à-trous iterations ping-pong between it and a
        // transient, ending in the transient (five: an odd count), and the shrink writes the
        // shown image from there.
        let shown = d.shown.import(g, imports, "denoised");
        let ping =
            g.create_image("denoise ping-pong", ImageDesc::d2(vk::Format::R16G16B16A16_SFLOAT, size[0], size[1]));
        let push = BlendPush { age_cap: AGE_CAP, use_prior: u32::from(d.prior_valid) };
        g.compute("denoise blend", &shaders::POST_DENOISE_BLEND_COMP)
            .read(inputs.mean)
            .read(inputs.moments.moments)
            .read(prior)
            .write(integrated)
            .write(shown)
            .constants(&push)
            .loop_bound(10)
            .dispatch(groups)?;
        let (mut src, mut dst) = (shown, ping);
        for i in 0..ITERATIONS {
            let last = i + 1 == ITERATIONS;
            let push =
                AtrousPush { step: 1 << i, sigma_l: SIGMA_L, last: u32::from(last), flags: s.denoise.debug_flags };
            g.compute("denoise a-trous", &shaders::POST_ATROUS_COMP)
                .read(inputs.mean)
                .read(src)
                .write(dst)
                .read(feats)
                .constants(&push)
                .loop_bound(26)
                .dispatch(groups)?;
            (src, dst) = (dst, src);
        }
        g.compute("denoise shrink", &shaders::POST_DENOISE_SHRINK_COMP)
            .read(inputs.moments.moments)
            .read(src)
            .write(shown)
            .constants(&s.denoise.debug_flags)
            .loop_bound(26)
            .dispatch(groups)?;
        d.history = true;
        d.shown_last = true;
        let params = s.tonemap.params(s.exposure);
        crate::post::add_tonemap_sum_pass(g, [inputs.mean, shown], ldr, params, groups)?;
        g.export_image(shown, Some(Access::TransferSrc))?;
        Ok(Some(shown))
    }
}
