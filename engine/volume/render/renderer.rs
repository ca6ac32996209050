//! The volume renderers as frame-graph passes, plus the GPU state one volume carries: its
//! images in either layout (`layout`), the transfer-function table and the occupancy and
//! majorant grids. The uniform blocks are filled in `uniforms`, the marchers' bounds are in
//! `march_bounds`, the frame driver is in `frame`.

use super::march_bounds::MarchKey;
use super::occlusion::MarchInputs;
use crate::error::{Error, Result};
use crate::graph::execute::Imports;
use crate::graph::{Access, BufferDesc, BufferId, GraphBuilder, ImageDesc, ImageId, ResourceState};
use crate::shaders;
use crate::vk::{vk, Context, Image, ImageInfo};
use crate::volume::camera::Camera;
use crate::volume::data::bricks::MAX_ATLASES;
use crate::volume::data::stats::BLOCK;
use crate::volume::data::Volume;
use crate::volume::device::layout::{upload_ro, LayoutReport, VolumeImages, VolumeLayout};
use crate::volume::device::page_images::DevicePages;
use crate::volume::optics::tf::{TransferFunction, TF_GRADIENTS, TF_VALUES};
use glam::Vec3;

pub use super::settings::{McSettings, RenderSettings, RendererKind, TransmittanceEstimator};
pub use crate::post::ToneMap;

/// GPU state of one volume: texture, transfer-function table, occupancy grid, pipelines.
pub struct VolumeRenderer {
    volume: Image,
    pub(super) tf: Image,
    occupancy: Image,
    gradients: Image,
    /// The sparse layout's page table (1³ placeholders in the dense one).
    pages: DevicePages,
    /// Value and gradient atlases past the first (sparse, past one allocation).
    more_atlases: Vec<(Image, Image)>,
    /// Bound where a volume has fewer atlases than `volume/common.glsl` declares.
    pub(super) atlas_placeholder: Image,
    /// The label map: its host copy and the premultiplied colour images built from it (1-texel
    /// placeholders until [`Self::set_labels`] binds a label map).
    pub(super) labels: std::sync::Mutex<super::labels::LabelState>,
    /// A label map is bound (`volume/common.glsl`'s LABELS).
    pub(super) has_labels: bool,
    pub(super) majorants: Image,
    /// The majorant grid's cells are bricks of the sparse layout and carry their page words.
    pub(super) segment_words: bool,
    /// The shaders read their uniform blocks at an opaque index (`volume/common.glsl`'s
    /// `OPAQUE_BLOCKS`): on llvmpipe, whose lavapipe would otherwise recompile them every dispatch.
    pub(super) opaque_blocks: bool,
    pub(crate) global_majorant: [f32; 2],
    pub(super) stats: crate::vk::Buffer,
    pub(crate) dims: [u32; 3],
    pub(crate) grid: [u32; 3],
    /// Voxels per occupancy/majorant cell edge (`crate::volume::data::bricks::cells`).
    pub(crate) cell: u32,
    /// Min/max normalized value per block, dilated by one voxel (trilinear footprint).
    block_ranges: Vec<[f32; 2]>,
    pub(crate) box_half: Vec3,
    /// Image-based lighting: the environment map on the GPU, if one is set.
    pub(crate) env: Option<crate::volume::optics::envmap::EnvLight>,
    env_generation: u64,
    /// Temperature-driven emission: the temperature grid and its blackbody table, if one is set.
    pub(super) temperature: Option<super::temperature::TemperatureGrid>,
    /// Largest |∇v| of the volume (hybrid scattering normalizes by it).
    pub(crate) max_gradient: f32,
    /// Voxel counts per transfer-function table cell (value along x, normalized gradient
    /// magnitude along y, `TF_VALUES × TF_GRADIENTS`): what the TF editor draws behind its widgets.
    pub histogram: Vec<u32>,
    pub(super) tf_generation: u64,
    /// The transfer function's table differs between gradient rows: the Monte Carlo medium
    /// lookup must fetch the gradient magnitude (otherwise a specialization leaves it out).
    pub(super) tf_gradient: bool,
    /// `march_samples` of the last (view-projection bits, size, step): a still camera, as in
    /// headless and progressive runs, pays for the per-pixel sum once.
    pub(crate) march_cache: std::sync::Mutex<Option<(MarchKey, u64)>>,
    /// Tracking steps per second measured on this device by Monte Carlo frames (f64 bits; 0:
    /// none yet), for `mc_budget=auto` (`super::mc_mode`).
    pub(crate) measured_steps_per_s: std::sync::atomic::AtomicU64,
    /// Fraction of occupancy blocks that are empty under the current transfer function.
    pub empty_fraction: f32,
    /// The layout the volume was stored in and what it takes on the device.
    pub layout: LayoutReport,
    /// View-dependent residency ([`Self::with_residency`]): the pyramid, the streamer and the
    /// atlas's slots.
    residency: Option<Box<crate::volume::device::resident::Residency>>,
    /// The transfer function's baked table as last uploaded (residency rebuilds the grids from it
    /// when the cut changes).
    tf_table: Vec<[f32; 4]>,
}

/// The images one frame produced.
#[derive(Clone, Copy, Debug)]
pub struct FrameImages {
    /// Linear HDR radiance: the progressive mean of this and earlier unchanged frames.
    pub hdr: ImageId,
    /// Tone-mapped sRGB.
    pub ldr: ImageId,
    /// ISO only: hit position (texture space, xyz) and ray distance (w, < 0 for a miss).
    pub iso_hit: Option<ImageId>,
    /// With `depth_threshold` set (EAM, LAO, DOS): (ray distance, NDC depth, hit 1/0, 0) per pixel.
    pub depth: Option<ImageId>,
    /// Monte Carlo: each pixel's second moment and the per-tile error sums (`super::variance`).
    pub moments: Option<super::variance::MomentImages>,
    /// `denoise=on` (Monte Carlo): the denoised image that was tone-mapped (`super::denoise`).
    pub shown: Option<ImageId>,
}

pub(super) const READ_ONLY: ResourceState = ResourceState {
    layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
    stage: vk::PipelineStageFlags2::COMPUTE_SHADER,
    access: vk::AccessFlags2::NONE,
};

/// Where the page table stays: a storage image the marchers read.
const PAGE_TABLE_STATE: ResourceState = ResourceState {
    layout: vk::ImageLayout::GENERAL,
    stage: vk::PipelineStageFlags2::COMPUTE_SHADER,
    access: vk::AccessFlags2::NONE,
};

/// Binding of `volume/common.glsl`'s page table (past every shader's own bindings).
pub const PAGE_TABLE_BINDING: u32 = 15;
/// Binding of `volume/common.glsl`'s page directory (two-level page tables).
pub const PAGE_DIRECTORY_BINDING: u32 = 22;

impl VolumeRenderer {
    /// Uploads `volume` (normalized to [0,1] by its value range, R16_UNORM) and `tf`, in the
    /// layout `volume_layout=auto` chooses.
    pub fn new(ctx: &Context, volume: &Volume, tf: &TransferFunction) -> Result<Self> {
        Self::with_layout(ctx, volume, tf, VolumeLayout::Auto)
    }

    /// [`Self::new`] in `layout`.
    pub fn with_layout(ctx: &Context, volume: &Volume, tf: &TransferFunction, layout: VolumeLayout) -> Result<Self> {
        let images = VolumeImages::new(ctx, volume, layout)?;
        Self::from_images(ctx, volume, tf, images, None)
    }

    /// [`Self::new`] with view-dependent residency: the volume's brick pyramid kept on the host,
    /// at most `budget` bytes of its bricks (values and gradients) on the device, chosen by
    /// [`Self::stream`] for each view and uploaded at most `upload_budget` bytes per frame. Until
    /// the first call every region shows the coarsest brick.
    pub fn with_residency(
        ctx: &Context,
        volume: &Volume,
        tf: &TransferFunction,
        budget: u64,
        upload_budget: u64,
    ) -> Result<Self> {
        let (residency, images) = crate::volume::device::resident::Residency::new(ctx, volume, budget, upload_budget)?;
        Self::from_images(ctx, volume, tf, images, Some(Box::new(residency)))
    }

    fn from_images(
        ctx: &Context,
        volume: &Volume,
        tf: &TransferFunction,
        images: VolumeImages,
        residency: Option<Box<crate::volume::device::resident::Residency>>,
    ) -> Result<Self> {
        let dims = volume.dims;
        let usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST;
        let grid = crate::volume::data::bricks::cells::cell_grid(dims, images.cell_bricks);
        let occupancy = Image::new(ctx, "occupancy", ImageInfo::d3(vk::Format::R8_UINT, grid, usage))?;
        let atlas_placeholder =
            Image::new(ctx, "atlas placeholder", ImageInfo::d3(vk::Format::R16_UNORM, [1; 3], usage))?;
        upload_ro(ctx, &atlas_placeholder, &[0; 2])?;
        let labels = std::sync::Mutex::new(super::labels::LabelState::none(ctx)?);
        // Cells that are bricks in the sparse layout also carry their page-table word (segment
        // words: `volume/common.glsl`'s SEGMENT_WORDS); otherwise (min, max) only.
        let segment_words =
            images.report.layout == VolumeLayout::Sparse && images.cell_bricks == 1 && residency.is_none();
        let majorant_format = match segment_words {
            true => vk::Format::R32G32B32A32_UINT,
            false => vk::Format::R32G32_UINT,
        };
        let majorants = Image::new(ctx, "majorant grid", ImageInfo::d3(majorant_format, grid, usage))?;
        let mut stats = crate::vk::Buffer::new(
            ctx,
            "volume stats",
            8,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            crate::vk::MemoryLocation::GpuToCpu,
        )?;
        stats.write_bytes(&[0; 8])?;
        let tf_img = Image::new(
            ctx,
            "transfer function",
            ImageInfo::d2(vk::Format::R32G32B32A32_SFLOAT, TF_VALUES as u32, TF_GRADIENTS as u32, usage),
        )?;
        let ext = volume.extent();
        let largest = ext.iter().cloned().fold(f32::MIN, f32::max).max(f32::MIN_POSITIVE);
        let box_half = Vec3::from(ext) / largest * 0.5;
        let grid_bytes = occupancy.memory_bytes() + majorants.memory_bytes();
        let mut me = Self {
            tf_generation: 0,
            tf_gradient: true,
            env: None,
            env_generation: 0,
            temperature: None,
            max_gradient: images.max_gradient,
            histogram: images.histogram,
            volume: images.volume,
            tf: tf_img,
            occupancy,
            gradients: images.gradients,
            pages: images.pages,
            more_atlases: images.more_atlases,
            atlas_placeholder,
            labels,
            has_labels: false,
            majorants,
            segment_words,
            opaque_blocks: ctx.info.llvmpipe(),
            global_majorant: [0.0; 2],
            stats,
            dims,
            grid,
            cell: images.report.grid_cell,
            block_ranges: images.block_ranges,
            box_half,
            empty_fraction: 0.0,
            march_cache: std::sync::Mutex::new(None),
            measured_steps_per_s: std::sync::atomic::AtomicU64::new(0),
            layout: LayoutReport { grid_bytes, ..images.report },
            residency,
            tf_table: Vec::new(),
        };
        me.set_transfer_function(ctx, tf)?;
        Ok(me)
    }

    /// Replaces the transfer function: re-uploads its table and rebuilds the occupancy grid.
    pub fn set_transfer_function(&mut self, ctx: &Context, tf: &TransferFunction) -> Result<()> {
        tf.validate().map_err(|e| Error::Input(format!("transfer function: {e}")))?;
        self.tf_table = tf.bake();
        let bytes: Vec<u8> = self.tf_table.iter().flatten().flat_map(|f| f.to_le_bytes()).collect();
        upload_ro(ctx, &self.tf, &bytes)?;
        self.rebuild_grids(ctx).map(|_| ())
    }

    /// Rebuilds the occupancy and majorant grids and the page words' occupancy bits from the
    /// block ranges and the transfer function's table; returns the bytes of page words written.
    fn rebuild_grids(&mut self, ctx: &Context) -> Result<u64> {
        let table = &self.tf_table;
        let max_ext = crate::volume::optics::tf::max_extinction_per_value(table);
        let n = (TF_VALUES - 1) as f32;
        let occ: Vec<u8> = self
            .block_ranges
            .iter()
            .map(|&[lo, hi]| {
                let (a, b) = ((lo * n).floor() as usize, ((hi * n).ceil() as usize).min(TF_VALUES - 1));
                u8::from(max_ext[a..=b].iter().any(|&e| e > 0.0))
            })
            .collect();
        self.tf_gradient = table.chunks(TF_VALUES).any(|row| row != &table[..TF_VALUES]);
        // Majorant grid: per cell (min, max) extinction over every table texel the cell's
        // dilated value range touches, across all gradient rows — conservative for trilinear
        // interpolation of both the volume and the table.
        let (mut gmax, mut gmin) = (0.0f32, f32::MAX);
        // Segment words: each cell's page-table word after its (min, max), as the slot lookup
        // of the samples in its (half-voxel shifted) cell.
        let words = match self.segment_words {
            true => Some(self.pages.flat_words().map_err(Error::Input)?),
            false => None,
        };
        let mut maj = Vec::with_capacity(self.block_ranges.len() * 16);
        for (i, &[lo, hi]) in self.block_ranges.iter().enumerate() {
            let (a, b) = ((lo * n).floor() as usize, ((hi * n).ceil() as usize).min(TF_VALUES - 1));
            let (mut mn, mut mx) = (f32::MAX, 0.0f32);
            for row in 0..TF_GRADIENTS {
                for texel in &table[row * TF_VALUES + a..=row * TF_VALUES + b] {
                    mn = mn.min(texel[3]);
                    mx = mx.max(texel[3]);
                }
            }
            gmax = gmax.max(mx);
            gmin = gmin.min(mn);
            maj.extend(mn.to_le_bytes());
            maj.extend(mx.to_le_bytes());
            if let Some(w) = &words {
                maj.extend(w[i].to_le_bytes());
                maj.extend(0u32.to_le_bytes());
            }
        }
        upload_ro(ctx, &self.majorants, &maj)?;
        self.global_majorant = [gmax, gmin.min(gmax)];
        self.tf_generation += 1;
        self.empty_fraction = occ.iter().filter(|&&o| o == 0).count() as f32 / occ.len().max(1) as f32;
        // The sparse layout's marchers read occupancy with the slot, one lookup per sample:
        // each brick gets the bit of the occupancy cell holding it.
        let k = self.cell / BLOCK;
        let words = self.pages.mark(ctx, |b| occ[crate::volume::data::bricks::cells::cell_of(b, k, self.grid)] != 0)?;
        upload_ro(ctx, &self.occupancy, &occ)?;
        Ok(words)
    }

    /// Whether the volume is kept resident by the view ([`Self::with_residency`]).
    pub fn residency(&self) -> bool {
        self.residency.is_some()
    }

    /// With residency, the level each level-0 brick shows (x fastest over the brick grid).
    pub fn shown_levels(&self) -> Option<Vec<u32>> {
        let r = self.residency.as_deref()?;
        let p = &r.levels.pyramid;
        let g = p.grid(0);
        let mut out = Vec::with_capacity(g.iter().map(|&c| c as usize).product());
        for z in 0..g[2] {
            for y in 0..g[1] {
                for x in 0..g[0] {
                    out.push(r.streamer.level_of(p, [x, y, z]));
                }
            }
        }
        Some(out)
    }

    /// With residency, bytes of bricks' own slots resident (at most the budget).
    pub fn resident_bytes(&self) -> Option<u64> {
        self.residency.as_deref().map(|r| r.streamer.resident_bytes())
    }

    /// View-dependent residency, once per frame before rendering it: chooses the cut for
    /// `camera` (at `aspect` = width / height), moves the device toward it within the per-frame
    /// upload budget (only arrived bricks and changed page words are written) and, when what is
    /// shown changed, rebuilds the occupancy and majorant grids from the bounds of what each
    /// brick now shows. `None` without residency. When the report's `upload.changed` is set the
    /// progressive mean restarts (the grids' generation is part of what a mean is kept for), so
    /// it converges on the final residency.
    pub fn stream(
        &mut self,
        ctx: &Context,
        camera: &Camera,
        aspect: f32,
    ) -> Result<Option<crate::volume::device::resident::ResidencyReport>> {
        use crate::volume::data::bricks::residency::{choose, View};
        let Some(r) = self.residency.as_mut() else { return Ok(None) };
        let dims = Vec3::from(self.dims.map(|d| d as f32));
        let to_world =
            glam::Mat4::from_translation(-self.box_half) * glam::Mat4::from_scale(2.0 * self.box_half / dims);
        let clip = camera.projection(aspect) * camera.view() * to_world;
        let (eye, _) = camera.eye_forward();
        let eye = (eye + self.box_half) / (2.0 * self.box_half) * dims;
        let view = View::from_view_projection(clip.to_cols_array_2d(), eye.to_array());
        let p = &r.levels.pyramid;
        let cut = choose(p, &view, r.budget);
        let upload = r.streamer.frame(p, &view, &cut);
        r.last = upload;
        let mut written = 0;
        if upload.uploaded > 0 || upload.evicted > 0 {
            let (words, bytes) = r.atlas.apply(ctx, &r.levels, &r.streamer, (&self.volume, &self.gradients))?;
            written += bytes;
            if upload.changed {
                self.block_ranges = crate::volume::data::bricks::levels::cut_ranges(&r.levels, &r.streamer);
                self.pages.set_entries(words);
            }
        }
        let (shown_levels, resident_levels) =
            (r.streamer.shown_counts(&r.levels.pyramid), r.streamer.resident_counts(&r.levels.pyramid));
        if upload.changed {
            // New grids and page words (the table is unchanged); the grids' generation restarts
            // progressive means.
            written += self.rebuild_grids(ctx)?;
        }
        Ok(Some(crate::volume::device::resident::ResidencyReport {
            upload,
            written_bytes: written,
            shown_levels,
            resident_levels,
        }))
    }

    /// Sets (or with `None` removes) the environment map the MC renderers use when
    /// `McSettings::env_map` is on: uploads it with its sampling distribution.
    pub fn set_environment(
        &mut self,
        ctx: &Context,
        map: Option<&crate::volume::optics::envmap::EnvMap>,
    ) -> Result<()> {
        self.env = map.map(|m| crate::volume::optics::envmap::EnvLight::new(ctx, m)).transpose()?;
        self.env_generation += 1;
        Ok(())
    }

    /// Half-extent of the volume's box in world units (largest axis spans 1).
    pub fn box_half(&self) -> Vec3 {
        self.box_half
    }

    /// Majorant violations counted by the Monte Carlo renderers so far (0 unless the grid is wrong).
    pub fn majorant_violations(&self) -> u32 {
        self.stats.mapped().map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])).unwrap_or(0)
    }

    /// Filtered texel fetches the Monte Carlo renderers have counted so far (wrapping).
    pub(crate) fn fetch_counter(&self) -> u32 {
        self.stats.mapped().map(|b| u32::from_le_bytes([b[4], b[5], b[6], b[7]])).unwrap_or(0)
    }

    /// Whether the Monte Carlo trackers read slots from the majorant grid's segment words
    /// (sparse layout, cells of one brick; `volume/common.glsl`), with hardware filtering.
    pub fn segment_words(&self) -> bool {
        self.segment_words
    }

    /// Global (max, min) extinction of the current transfer function over the volume.
    pub fn global_majorant(&self) -> [f32; 2] {
        self.global_majorant
    }

    /// Declares this frame's passes: parameter upload, the renderer, and tone mapping into the
    /// imported `ldr` (and `hdr`, persistent so it can be read back as linear HDR).
    pub fn add_passes<'a>(
        &'a self,
        g: &mut GraphBuilder<'a>,
        imports: &mut Imports,
        targets: &mut Targets,
        camera: &Camera,
        s: &RenderSettings,
        frame: u64,
    ) -> Result<FrameImages> {
        s.validate()?;
        if s.mc.budget == super::settings::BUDGET_AUTO && matches!(s.renderer, RendererKind::Mcs | RendererKind::Mcm) {
            // One whole path per frame would be unbounded; render_frame and record_frame resolve.
            return Err(Error::Input(
                "mc_budget=auto must be resolved (VolumeRenderer::resolve_mc) before a frame is built".into(),
            ));
        }
        let size = [targets.hdr.info.extent[0], targets.hdr.info.extent[1]];
        // Any change of what is rendered restarts the progressive mean. Bounded work's budget,
        // path cap and interleaving change only how much work a frame does, not the image the
        // paths converge to: a frame-time knob turned mid-run keeps the mean (switching bounded
        // work on or off does not, as the two keep different state).
        let what = match s.mc_bounded() {
            true => RenderSettings {
                mc: McSettings { budget: 1, paths_per_frame: 1, frame_ms: 0.0, interleave: 1, ..s.mc },
                ..*s
            },
            false => *s,
        };
        // Adaptive sampling and the error target decide which pixels get paths, not what a path
        // estimates: toggling them keeps the mean (each pixel divides by its own path count).
        // The denoiser only filters what the mean holds.
        let what = RenderSettings {
            mc: McSettings { convergence: Default::default(), ..what.mc },
            denoise: Default::default(),
            ..what
        };
        let key = format!("{camera:?}{what:?}{}{size:?}{}", self.tf_generation, self.env_generation);
        if key != targets.key {
            targets.key = key;
            targets.samples = 0;
        }
        targets.samples = targets.samples.saturating_add(1);
        let n = targets.samples;
        let groups = [size[0].div_ceil(8), size[1].div_ceil(8), 1];
        let is_mc = matches!(s.renderer, RendererKind::Mcs | RendererKind::Mcm);
        let moments = match is_mc {
            true => Some(targets.import_moments(g, imports, s.mc.convergence.adaptive && n > 1).ok_or_else(|| {
                Error::Input("Monte Carlo: the targets have no moments image (Targets::enable_moments)".into())
            })?),
            false => None,
        };
        let mc = self.mc_params(s);
        let (params, mc_params) = upload_params(g, &self.params(camera, s, size, frame), is_mc.then_some(&mc))?;
        let vol = imports.image_readonly(g, "volume", &self.volume, READ_ONLY);
        let tf = imports.image_readonly(g, "transfer function", &self.tf, READ_ONLY);
        let occ = imports.image_readonly(g, "occupancy", &self.occupancy, READ_ONLY);
        let majorants = imports.image_readonly(g, "majorant grid", &self.majorants, READ_ONLY);
        let grads = imports.image_readonly(g, "gradient magnitude", &self.gradients, READ_ONLY);
        let page_table = imports.image_readonly(g, "page table", &self.pages.table, PAGE_TABLE_STATE);
        let page_directory = imports.image_readonly(g, "page directory", &self.pages.directory, PAGE_TABLE_STATE);
        let placeholder = imports.image_readonly(g, "atlas placeholder", &self.atlas_placeholder, READ_ONLY);
        let mut more_atlases = [placeholder; 2 * (MAX_ATLASES as usize - 1)];
        for (k, (v, gr)) in self.more_atlases.iter().enumerate() {
            more_atlases[k] = imports.image_readonly(g, "volume atlas", v, READ_ONLY);
            more_atlases[MAX_ATLASES as usize - 1 + k] = imports.image_readonly(g, "gradient atlas", gr, READ_ONLY);
        }
        let accum = targets.hdr.import(g, imports, "accumulation");
        let ldr = targets.ldr.import(g, imports, "ldr");
        // Bounded-work Monte Carlo keeps its own mean (of completed paths) and writes it straight
        // into the accumulation: a copy pass would cost 3 ms a frame at 512².
        let bounded_mean = is_mc && s.mc_bounded();
        let hdr = match bounded_mean {
            true => accum,
            false => g.create_image("frame", ImageDesc::d2(vk::Format::R32G32B32A32_SFLOAT, size[0], size[1])),
        };
        let depth = depth_target(g, imports, targets, s)?;
        let march = MarchInputs {
            params,
            volume: vol,
            tf,
            gradients: grads,
            occupancy: occ,
            majorants,
            hdr,
            size,
            exact_filter: s.exact_filter,
            page_table,
            page_directory,
            page_levels: self.pages.levels,
            sparse: self.layout.layout == VolumeLayout::Sparse,
            segment_words: self.segment_words,
            opaque_blocks: self.opaque_blocks,
            more_atlases,
            atlases: self.layout.atlases,
            label_images: self.import_labels(g, imports, &s.labels)?,
            labels: super::labels::label_constant(self.has_labels, &s.labels),
            clipping: s.clip.active(),
            tf_gradient: self.tf_gradient,
            lod_words: self.residency.is_some(),
            temperature: self.import_temperature(g, imports),
            temperature_emission: self.temperature.is_some() && s.mc.emission > 0.0,
        };
        let iso_hit = match moments {
            Some(m) => {
                self.add_mc_pass(g, imports, targets, s, &march, (&mc, mc_params), m, n, groups)?;
                None
            }
            None => self.add_march_passes(g, camera, s, march, depth, groups)?,
        };
        match moments {
            Some(m) => super::variance::add_moment_passes(g, m, (!bounded_mean).then_some(hdr), accum, s, n, size)?,
            None => g
                .compute("accumulate", &shaders::POST_ACCUMULATE_COMP)
                .read(hdr)
                .read_write(accum)
                .constants(&n)
                .dispatch(groups)?,
        }
        let denoise_in = moments.map(|m| super::denoise::DenoiseInputs { mean: accum, moments: m });
        let shown = self.add_denoise_passes(g, imports, targets, camera, s, &march, denoise_in, ldr)?;
        if shown.is_none() {
            crate::post::add_tonemap_pass(g, accum, ldr, s.tonemap.params(s.exposure), groups)?;
        }
        Ok(FrameImages { hdr: accum, ldr, iso_hit, depth, moments, shown })
    }
}

/// The frame's uniform blocks (the Monte Carlo one where given), uploaded by one transfer pass.
fn upload_params(
    g: &mut GraphBuilder<'_>,
    params: &super::uniforms::VolumeParams,
    mc: Option<&super::uniforms::McParams>,
) -> Result<(BufferId, BufferId)> {
    let params_bytes = bytemuck::bytes_of(params).to_vec();
    let mc_bytes = mc.map_or(Vec::new(), |m| bytemuck::bytes_of(m).to_vec());
    let ids = (
        g.create_buffer("volume params", BufferDesc::new(params_bytes.len() as u64)),
        g.create_buffer("mc params", BufferDesc::new(mc_bytes.len().max(4) as u64)),
    );
    let (params, mc_params) = ids;
    let is_mc = mc.is_some();
    let mut up = g.add_transfer_pass("upload params");
    up.write_buffer(params, Access::TransferDst)?;
    if is_mc {
        up.write_buffer(mc_params, Access::TransferDst)?;
    }
    up.record(move |pc| {
        // SAFETY: transfer pass outside rendering; each buffer is exactly as large as its data.
        unsafe {
            pc.device().cmd_update_buffer(pc.cmd, pc.buffer(params).raw, 0, &params_bytes);
            if is_mc {
                pc.device().cmd_update_buffer(pc.cmd, pc.buffer(mc_params).raw, 0, &mc_bytes);
            }
        }
        Ok(())
    });
    Ok(ids)
}

/// The depth image a renderer writes with `depth_threshold` set (EAM with precomputed
/// gradients, LAO, DOS), or the error naming why it cannot.
fn depth_target(
    g: &mut GraphBuilder<'_>,
    imports: &mut Imports,
    targets: &mut Targets,
    s: &RenderSettings,
) -> Result<Option<ImageId>> {
    match (s.occlusion.depth_threshold, s.renderer) {
        (None, _) => Ok(None),
        (Some(_), RendererKind::Eam) if !s.precomputed_gradients => {
            Err(Error::Input("--set depth_threshold: eam writes depth only with precomputed gradients".into()))
        }
        (Some(_), RendererKind::Eam | RendererKind::Lao | RendererKind::Dos) => {
            s.occlusion.validate()?;
            let img = targets.depth.as_ref().ok_or_else(|| {
                Error::Input("depth_threshold: the targets have no depth image (Targets::enable_depth)".into())
            })?;
            Ok(Some(img.import(g, imports, "depth")))
        }
        (Some(_), r) => Err(Error::Input(format!(
            "--set depth_threshold: only the eam, lao and dos renderers write depth, not {}",
            r.name()
        ))),
    }
}

pub use super::frame::{record_frame, render_frame, Targets};
pub use super::mc_loops::{mc_loop_iterations, LOOP_LIMIT};
pub use super::uniforms::{McParams, VolumeParams};
