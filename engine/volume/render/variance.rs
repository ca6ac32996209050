//! Each Monte Carlo pixel's error where it is made. Beside the progressive mean (`Targets::hdr`)
//! the `moments` image holds per pixel (M2.r, M2.g, M2.b, n): n its completed paths, M2 their
//! Σ (x − mean)² per channel (Welford's update, written by `mc_accumulate.comp` for one path per
//! frame and by `mc_bounded.comp` as each path completes), so the variance of the pixel's mean is
//! M2 / (n (n − 1)). A pass per frame sums it per 8×8 tile (`mc_tiles.comp`), the host reads the
//! sums back as the image's estimated relative error ([`ErrorEstimate`]), and adaptive sampling
//! decides from them which tiles go on (`mc_adapt.comp`).

use super::convergence::ConvergenceSettings;
use super::frame::Targets;
use super::settings::RenderSettings;
use crate::graph::execute::Imports;
use crate::graph::{BufferId, GraphBuilder, ImageId, PersistentBuffer, PersistentImage};
use crate::shaders;
use crate::vk::{vk, Context, Image, ImageInfo};
use crate::{Error, Result};

/// Pixels along a tile's edge (adaptive sampling's unit; `mc_tiles.glsl`).
pub const TILE: u32 = 8;
/// `mc_tiles.glsl`'s header: Σ weights, tiles along x and y, padding.
const HEADER_BYTES: usize = 16;
/// `mc_tiles.glsl`'s `Tile`: two halves of (var, pvar, sq, n_min, fg), then their two weights.
const TILE_BYTES: usize = 48;

/// A Monte Carlo target's error state, created with the first Monte Carlo frame.
pub struct Moments {
    /// RGBA32F per pixel: the Σ (x − mean)² of its completed paths per channel (rgb), their count (a).
    pub image: PersistentImage,
    /// Per tile (`mc_tiles.glsl`), host-visible: the error sums and adaptive sampling's weights.
    pub tiles: PersistentBuffer,
    /// The last frame decided with adaptive sampling (its tiles' weights are meaningful).
    adaptive: bool,
}

/// One frame's handles of the error state in the frame graph.
#[derive(Clone, Copy, Debug)]
pub struct MomentImages {
    /// The `moments` image (see the module's documentation).
    pub moments: ImageId,
    /// The per-tile buffer.
    pub tiles: BufferId,
}

/// The image's estimated error after the last frame, from the tiles' sums.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct ErrorEstimate {
    /// sqrt(Σ variance of the mean / Σ mean²) over the foreground's pixels and RGB: the expected
    /// relative RMSE (foreground) against the exact image, as `volume_bench` measures it against
    /// a reference. `None` until every pixel has two paths, or while no pixel is foreground.
    pub relative: Option<f64>,
    /// Pixels whose paths have not all returned the same radiance.
    pub foreground_pixels: u64,
    /// Fewest completed paths of any pixel.
    pub min_paths: u32,
    /// Tiles of the image.
    pub tiles: u32,
    /// Tiles adaptive sampling has stopped, both halves (0 without it).
    pub stopped_tiles: u32,
}

/// One tile's figures after the last frame (both halves of `mc_tiles.glsl` together).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TileStats {
    /// Σ over the foreground pixels and RGB of the variance of the pixel's mean.
    pub var: f64,
    /// Σ over the same of the mean².
    pub sq: f64,
    /// Fewest paths of any pixel of each half.
    pub n_min: [u32; 2],
    /// Foreground pixels.
    pub foreground: u32,
    /// Adaptive sampling stopped each half (pixels of even, odd x + y) for the next frame.
    pub stopped: [bool; 2],
}

impl ErrorEstimate {
    /// Whether a run with `c` may stop here: `until_error` set, every pixel has
    /// `adaptive_min_paths` paths (a dark image whose first paths all missed the light looks
    /// converged), and the estimate is at most the target.
    pub fn reached(&self, c: &ConvergenceSettings) -> bool {
        c.until_error > 0.0
            && self.min_paths >= c.adaptive_min_paths
            && self.relative.is_some_and(|e| e <= f64::from(c.until_error))
    }
}

/// Push constants of `mc_accumulate.comp`.
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct AccumulatePush {
    n: u32,
    adaptive: u32,
}

/// Push constants of `mc_adapt.comp`.
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct AdaptPush {
    target2: f32,
    min_paths: u32,
}

/// Tiles of an image of `size` pixels.
pub fn tile_grid(size: [u32; 2]) -> [u32; 2] {
    size.map(|s| s.div_ceil(TILE))
}

impl Targets {
    /// Adds the Monte Carlo error state (a no-op if it exists).
    pub fn enable_moments(&mut self, ctx: &Context) -> Result<()> {
        if self.moments.is_none() {
            let [w, h] = [self.hdr.info.extent[0], self.hdr.info.extent[1]];
            let u = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
            let image = Image::new(ctx, "moments", ImageInfo::d2(vk::Format::R32G32B32A32_SFLOAT, w, h, u))?;
            let [tx, ty] = tile_grid([w, h]);
            let bytes = (HEADER_BYTES + TILE_BYTES * tx as usize * ty as usize) as u64;
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
            let tiles = crate::vk::Buffer::new(ctx, "mc tiles", bytes, usage, crate::vk::MemoryLocation::GpuToCpu)?;
            self.moments = Some(Moments {
                image: PersistentImage::new(image),
                tiles: PersistentBuffer::new(tiles),
                adaptive: false,
            });
        }
        Ok(())
    }

    /// Declares the error state in `g` (Monte Carlo frames; `None` before `enable_moments`).
    pub(super) fn import_moments(
        &mut self,
        g: &mut GraphBuilder<'_>,
        imports: &mut Imports,
        adaptive: bool,
    ) -> Option<MomentImages> {
        let m = self.moments.as_mut()?;
        m.adaptive = adaptive;
        Some(MomentImages {
            moments: m.image.import(g, imports, "moments"),
            tiles: m.tiles.import(g, imports, "mc tiles"),
        })
    }

    /// Reads the moments image back: (M2.r, M2.g, M2.b, paths) per pixel (see the module).
    pub fn read_moments(&self, ctx: &Context) -> Result<Vec<[f32; 4]>> {
        let m = self.moments.as_ref().ok_or_else(|| Error::Input("no Monte Carlo frame rendered yet".into()))?;
        m.image.read_rgba32f(ctx)
    }

    /// The image's estimated error after the last frame (`None` before a Monte Carlo frame).
    pub fn error_estimate(&self) -> Option<ErrorEstimate> {
        let tiles = self.tile_stats()?;
        let (mut var, mut sq) = (0.0f64, 0.0f64);
        let mut e = ErrorEstimate { tiles: tiles.len() as u32, min_paths: u32::MAX, ..Default::default() };
        for t in &tiles {
            var += t.var;
            sq += t.sq;
            e.min_paths = e.min_paths.min(t.n_min[0]).min(t.n_min[1]);
            e.foreground_pixels += u64::from(t.foreground);
            e.stopped_tiles += u32::from(t.stopped == [true; 2]);
        }
        e.relative = (e.min_paths >= 2 && e.foreground_pixels > 0 && sq > 0.0).then(|| (var / sq).sqrt());
        Some(e)
    }

    /// Each tile's figures after the last frame, row by row (`None` before a Monte Carlo frame).
    pub fn tile_stats(&self) -> Option<Vec<TileStats>> {
        let m = self.moments.as_ref()?;
        let bytes = m.tiles.buffer().mapped()?;
        let [tx, ty] = tile_grid([self.hdr.info.extent[0], self.hdr.info.extent[1]]);
        let word = |b: &[u8], i: usize| [b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]];
        let float = |b: &[u8], i: usize| f64::from(f32::from_le_bytes(word(b, i)));
        let uint = |b: &[u8], i: usize| u32::from_le_bytes(word(b, i));
        let tiles = bytes.get(HEADER_BYTES..)?.chunks_exact(TILE_BYTES).take((tx * ty) as usize);
        Some(
            tiles
                .map(|t| TileStats {
                    var: float(t, 0) + float(t, 5),
                    sq: float(t, 2) + float(t, 7),
                    n_min: [uint(t, 3), uint(t, 8)],
                    foreground: uint(t, 4) + uint(t, 9),
                    stopped: [m.adaptive && float(t, 10) <= 0.0, m.adaptive && float(t, 11) <= 0.0],
                })
                .collect(),
        )
    }
}

/// The passes after a Monte Carlo frame's renderer: with one path per frame (`frame`, its
/// radiance) the mean and second moment into `accum` and the moments (bounded work wrote both
/// itself), then the tiles' sums, then adaptive sampling's decision for the next frame (the
/// `n`-th of the mean).
pub(super) fn add_moment_passes(
    g: &mut GraphBuilder<'_>,
    m: MomentImages,
    frame: Option<ImageId>,
    accum: ImageId,
    s: &RenderSettings,
    n: u32,
    size: [u32; 2],
) -> Result<()> {
    let c = &s.mc.convergence;
    let [tx, ty] = tile_grid(size);
    if let Some(frame) = frame {
        let push = AccumulatePush { n, adaptive: u32::from(c.adaptive && n > 1) };
        g.compute("mc accumulate", &shaders::VOLUME_MC_ACCUMULATE_COMP)
            .read(frame)
            .read_write(accum)
            .read_write(m.moments)
            .read(m.tiles)
            .constants(&push)
            .dispatch([tx, ty, 1])?;
    }
    g.compute("mc tiles", &shaders::VOLUME_MC_TILES_COMP)
        .read(accum)
        .read(m.moments)
        .read_write(m.tiles)
        .constants(&[tx, ty])
        .dispatch([(tx * ty).div_ceil(64), 1, 1])?;
    if c.adaptive {
        let t = c.tile_target();
        let push = AdaptPush { target2: t * t, min_paths: c.adaptive_min_paths };
        g.compute("mc adapt", &shaders::VOLUME_MC_ADAPT_COMP).read_write(m.tiles).constants(&push).dispatch([
            (tx * ty).div_ceil(64),
            1,
            1,
        ])?;
    }
    Ok(())
}
