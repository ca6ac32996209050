//! A volume frame end to end: the persistent targets (each owns its state) and the one frame
//! driver shared by headless rendering and the window: declare the renderer's passes, the UI
//! overlay and the present pass, compile, record.

use super::renderer::{RenderSettings, RendererKind, VolumeRenderer};
use crate::graph::execute::Imports;
use crate::graph::{Access, GraphBuilder, PersistentImage};
use crate::vk::{vk, Context, Image, ImageInfo};
use crate::volume::camera::Camera;
use crate::{Error, Result};

/// Persistent HDR + LDR targets of a given size (each owns its state).
pub struct Targets {
    /// Linear HDR (RGBA32F).
    pub hdr: PersistentImage,
    /// Tone-mapped (RGBA8).
    pub ldr: PersistentImage,
    /// Frames averaged into `hdr` so far (an integer: a float counter stalls at 2^24).
    pub samples: u32,
    /// What those frames rendered; a different key restarts the mean.
    pub(crate) key: String,
    /// Depth output (RGBA32F), created by `enable_depth` or by `render_frame` on demand.
    pub depth: Option<PersistentImage>,
    /// Bounded-work Monte Carlo: every pixel's path in flight and its completed paths' sum
    /// (`mc_bounded.comp`), created on demand.
    pub paths: Option<crate::vk::Buffer>,
    /// Monte Carlo: each pixel's second moment and the per-tile error sums (`super::variance`),
    /// created on demand.
    pub moments: Option<super::variance::Moments>,
    /// `denoise=on`: the feature buffers, temporal history and denoised image (`super::denoise`).
    pub denoise: Option<super::denoise::DenoiseTargets>,
}

impl Targets {
    /// Creates both targets.
    pub fn new(ctx: &Context, [w, h]: [u32; 2]) -> Result<Self> {
        let u = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
        Ok(Self {
            hdr: PersistentImage::new(Image::new(ctx, "hdr", ImageInfo::d2(vk::Format::R32G32B32A32_SFLOAT, w, h, u))?),
            // Colour-attachment use lets the window's UI overlay draw onto it.
            ldr: PersistentImage::new(Image::new(
                ctx,
                "ldr",
                ImageInfo::d2(vk::Format::R8G8B8A8_UNORM, w, h, u | vk::ImageUsageFlags::COLOR_ATTACHMENT),
            )?),
            samples: 0,
            key: String::new(),
            depth: None,
            paths: None,
            moments: None,
            denoise: None,
        })
    }

    /// Adds the depth target (a no-op if it exists); only needed with `depth_threshold`.
    pub fn enable_depth(&mut self, ctx: &Context) -> Result<()> {
        if self.depth.is_none() {
            let u = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
            let [w, h] = [self.hdr.info.extent[0], self.hdr.info.extent[1]];
            let info = ImageInfo::d2(vk::Format::R32G32B32A32_SFLOAT, w, h, u);
            self.depth = Some(PersistentImage::new(Image::new(ctx, "depth", info)?));
        }
        Ok(())
    }

    /// Adds the path-state buffer of bounded-work Monte Carlo (a no-op if it exists).
    pub fn enable_paths(&mut self, ctx: &Context) -> Result<()> {
        if self.paths.is_none() {
            let [w, h] = [self.hdr.info.extent[0], self.hdr.info.extent[1]];
            let bytes = PATH_STATE_BYTES * u64::from(w) * u64::from(h);
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
            self.paths =
                Some(crate::vk::Buffer::new(ctx, "mc paths", bytes, usage, crate::vk::MemoryLocation::GpuOnly)?);
        }
        Ok(())
    }

    /// Reads the depth target back: (ray distance, NDC depth, hit, 0) per pixel.
    pub fn read_depth(&self, ctx: &Context) -> Result<Vec<[f32; 4]>> {
        let img = self.depth.as_ref().ok_or_else(|| Error::Input("no depth target (depth_threshold unset)".into()))?;
        img.read_rgba32f(ctx)
    }
}

/// Bytes of one pixel's path state (`PathState` in `mc_bounded.comp`, its largest variant).
pub const PATH_STATE_BYTES: u64 = 8 * 16;

/// `settings` with `mc_budget=auto` resolved for this device and the targets' size (and the label
/// images built for its label settings).
fn resolve(
    ctx: &Context,
    renderer: &VolumeRenderer,
    targets: &Targets,
    settings: &RenderSettings,
) -> Result<RenderSettings> {
    renderer.sync_labels(ctx, &settings.labels)?;
    let size = [targets.hdr.info.extent[0], targets.hdr.info.extent[1]];
    renderer.resolve_auto(ctx, settings, size)
}

/// Creates the targets a frame with these settings needs and does not have yet.
fn enable_targets(ctx: &Context, targets: &mut Targets, settings: &RenderSettings) -> Result<()> {
    if settings.occlusion.depth_threshold.is_some() {
        targets.enable_depth(ctx)?;
    }
    if matches!(settings.renderer, RendererKind::Mcs | RendererKind::Mcm) {
        targets.enable_moments(ctx)?;
        if settings.denoise.on {
            targets.enable_denoise(ctx)?;
        }
    }
    if settings.mc_bounded() {
        if !ctx.info.bounded_mc() {
            return Err(crate::Error::Input(format!(
                "mc_budget={}: bounded work needs subgroup ballots, votes and arithmetic in compute shaders, which {} lacks; use mc_budget=0",
                settings.mc.budget, ctx.info.name
            )));
        }
        targets.enable_paths(ctx)?;
    }
    Ok(())
}

/// Builds and compiles one frame: the renderer's passes, then the UI overlay and the present
/// pass when given; HDR, LDR (and depth) are exported for readback.
fn compile_frame<'a>(
    renderer: &'a VolumeRenderer,
    targets: &mut Targets,
    camera: &Camera,
    settings: &RenderSettings,
    frame: u64,
    overlay: Option<&'a dyn crate::graph::FrameOverlay>,
    present: Option<crate::graph::PresentTarget>,
) -> Result<(crate::graph::CompiledGraph<'a>, Imports)> {
    let mut g = GraphBuilder::new();
    let mut imports = Imports::default();
    let out = renderer.add_passes(&mut g, &mut imports, targets, camera, settings, frame)?;
    crate::graph::add_window_passes(&mut g, &mut imports, out.ldr, overlay, present)?;
    g.export_image(out.hdr, Some(Access::TransferSrc))?;
    g.export_image(out.ldr, Some(Access::TransferSrc))?;
    if let Some(d) = out.depth {
        g.export_image(d, Some(Access::TransferSrc))?;
    }
    if let Some(m) = out.moments {
        g.export_image(m.moments, Some(Access::TransferSrc))?;
        // The host reads the tiles' sums after the frame (`Targets::error_estimate`).
        g.export_buffer(m.tiles, Some(Access::HostRead))?;
    }
    Ok((g.compile()?, imports))
}

/// Records one frame into `cmd` for a window, ending in the present pass onto `target`, with
/// `overlay` (the UI) drawn over the tone-mapped image first.
#[allow(clippy::too_many_arguments)] // each is a separate input of the frame
pub fn record_frame(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    renderer: &VolumeRenderer,
    targets: &mut Targets,
    camera: &Camera,
    settings: &RenderSettings,
    frame: u64,
    overlay: Option<&dyn crate::graph::FrameOverlay>,
    target: crate::graph::PresentTarget,
) -> Result<crate::graph::execute::RecordedGraph> {
    let settings = &resolve(ctx, renderer, targets, settings)?;
    enable_targets(ctx, targets, settings)?;
    let (compiled, imports) = compile_frame(renderer, targets, camera, settings, frame, overlay, Some(target))?;
    crate::graph::execute::record_graph(ctx, cmd, compiled, &imports, Default::default())
}

/// Renders one frame synchronously into `targets` (headless rendering and tests).
pub fn render_frame(
    ctx: &Context,
    renderer: &VolumeRenderer,
    targets: &mut Targets,
    camera: &Camera,
    settings: &RenderSettings,
    frame: u64,
) -> Result<crate::graph::execute::GraphRun> {
    let settings = &resolve(ctx, renderer, targets, settings)?;
    enable_targets(ctx, targets, settings)?;
    let (compiled, imports) = compile_frame(renderer, targets, camera, settings, frame, None, None)?;
    let fetches_before = renderer.fetch_counter();
    let mut run = crate::graph::execute::run_graph(ctx, compiled, &imports, Default::default())?;
    if matches!(settings.renderer, RendererKind::Mcs | RendererKind::Mcm) {
        // The shader counted its filtered fetches: the pass's work, measured rather than guessed.
        let fetches = u64::from(renderer.fetch_counter().wrapping_sub(fetches_before));
        for t in run.timings.iter_mut().filter(|t| t.name == settings.renderer.name()) {
            t.work = crate::graph::Work { texel_fetches: fetches, declared: true, ..t.work };
            renderer.note_mc_frame(fetches, t.gpu_ms());
        }
    }
    Ok(run)
}

impl Targets {
    /// Reads the HDR target back as RGBA f32 texels.
    pub fn read_hdr(&self, ctx: &Context) -> Result<Vec<[f32; 4]>> {
        self.hdr.read_rgba32f(ctx)
    }

    /// Reads the tone-mapped target back as RGBA8.
    pub fn read_ldr(&self, ctx: &Context) -> Result<Vec<u8>> {
        self.ldr.read(ctx)
    }
}
