//! A label map on the device: per voxel its label's colour and opacity scale, premultiplied, as an
//! RGBA16F 3D image (and in `replace` mode an R16F keep weight) beside the scan, read with one
//! trilinear fetch by `volume/common.glsl`'s `label_medium` in every renderer. The label volume
//! and its table stay on the host: the images are rebuilt when the mode or the hidden labels
//! change ([`VolumeRenderer::sync_labels`]).

use super::label_settings::{LabelMode, LabelSettings};
use super::label_texture::{build, COLOUR_BYTES};
use super::renderer::{VolumeRenderer, READ_ONLY};
use crate::error::{Error, Result};
use crate::graph::execute::Imports;
use crate::graph::{GraphBuilder, ImageId};
use crate::vk::{vk, Context, Image, ImageInfo};
use crate::volume::data::labels::LabelVolume;
use crate::volume::device::layout::{device_budget, upload_ro};
use crate::volume::optics::label_table::{LabelTable, LABELS};

fn usage() -> vk::ImageUsageFlags {
    vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST
}

const COLOUR: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
const KEEP: vk::Format = vk::Format::R16_SFLOAT;

/// The label map the renderer holds: the host copy and the images built from it.
pub(super) struct LabelState {
    /// The label volume and its table (`None`: no label map).
    host: Option<(LabelVolume, LabelTable)>,
    /// Per label value, whether the map holds it (empty without a map): found once, as the
    /// settings checked against it (`label_opacity`) change every slider step.
    present: Vec<bool>,
    /// The settings the images were built for.
    built: Option<LabelSettings>,
    /// The colour and keep images (1-texel placeholders where unused).
    pub(super) images: [Image; 2],
}

impl LabelState {
    /// No label map: 1-texel placeholders bound.
    pub(super) fn none(ctx: &Context) -> Result<Self> {
        Ok(LabelState {
            host: None,
            present: Vec::new(),
            built: None,
            images: [placeholder(ctx, COLOUR, 8)?, placeholder(ctx, KEEP, 2)?],
        })
    }

    /// Whether the images hold `s` (always, without a label map).
    pub(super) fn current(&self, s: &LabelSettings) -> bool {
        self.host.is_none() || self.built == Some(*s)
    }
}

fn placeholder(ctx: &Context, format: vk::Format, bytes: usize) -> Result<Image> {
    let i = Image::new(ctx, "label placeholder", ImageInfo::d3(format, [1; 3], usage()))?;
    upload_ro(ctx, &i, &vec![0; bytes])?;
    Ok(i)
}

impl VolumeRenderer {
    /// Binds `labels` (a label volume on this volume's grid) with its colour table, or with
    /// `None` removes the label map: every renderer then samples exactly as without one. The
    /// device images are built at the next frame for its settings ([`Self::sync_labels`]).
    pub fn set_labels(&mut self, ctx: &Context, labels: Option<(&LabelVolume, &LabelTable)>) -> Result<()> {
        // A new label map restarts the progressive mean, as a new transfer function does.
        self.tf_generation += 1;
        let Some((l, table)) = labels else {
            *self.labels.get_mut().map_err(|_| poisoned())? = LabelState::none(ctx)?;
            self.has_labels = false;
            return Ok(());
        };
        if l.dims != self.dims {
            return Err(Error::Input(format!(
                "{}: label volume dims {:?} differ from the volume's {:?}",
                l.source, l.dims, self.dims
            )));
        }
        let max = ctx.info.limits.max_image_dimension3_d;
        if l.dims.iter().any(|&d| d > max) {
            return Err(Error::Input(format!(
                "{}: label volume dims {:?} exceed this device's 3D image limit {max}",
                l.source, l.dims
            )));
        }
        if l.labels.len() != l.dims.iter().map(|&d| d as usize).product::<usize>() || table.entries.len() != LABELS {
            return Err(Error::Input(format!("{}: label volume or table has the wrong size", l.source)));
        }
        // The colour texture is the largest label image (the keep texture of `replace` is a
        // quarter of it): refused up front rather than at the first frame.
        let bytes = l.labels.len() as u64 * COLOUR_BYTES;
        let budget = device_budget(ctx);
        let limit = budget.max_allocation.min(budget.heap_bytes);
        if bytes > limit {
            return Err(Error::Input(format!(
                "{}: the label colour texture needs {bytes} bytes ({COLOUR_BYTES} per voxel) but this device allows {limit} in one image; crop or downsample the label map",
                l.source
            )));
        }
        let host = Some((l.clone(), table.clone()));
        let present = crate::volume::optics::label_table::present(l);
        *self.labels.get_mut().map_err(|_| poisoned())? = LabelState { host, present, ..LabelState::none(ctx)? };
        self.has_labels = true;
        Ok(())
    }

    /// Builds the label images for `s` (mode and hidden labels) where they hold other settings:
    /// the frame drivers call it before declaring a frame.
    pub fn sync_labels(&self, ctx: &Context, s: &LabelSettings) -> Result<()> {
        let mut state = self.labels.lock().map_err(|_| poisoned())?;
        if state.current(s) {
            return Ok(());
        }
        let Some((l, table)) = &state.host else { return Ok(()) };
        if let Some(v) = (0..state.present.len()).find(|&v| s.opacity[v] >= 0.0 && !state.present[v]) {
            return Err(Error::Input(format!("label_opacity: label {v} does not occur in the label map {}", l.source)));
        }
        let (colour, keep) = build(&l.labels, table, s);
        let map = Image::new(ctx, "label colours", ImageInfo::d3(COLOUR, l.dims, usage()))?;
        upload_ro(ctx, &map, &colour)?;
        let keep = match keep {
            Some(k) => {
                let i = Image::new(ctx, "label keep", ImageInfo::d3(KEEP, l.dims, usage()))?;
                upload_ro(ctx, &i, &k)?;
                i
            }
            None => placeholder(ctx, KEEP, 2)?,
        };
        state.images = [map, keep];
        state.built = Some(*s);
        Ok(())
    }

    /// Imports the label images into the frame graph; they must hold `s` ([`Self::sync_labels`]).
    pub(super) fn import_labels(
        &self,
        g: &mut GraphBuilder<'_>,
        imports: &mut Imports,
        s: &LabelSettings,
    ) -> Result<[ImageId; 2]> {
        let state = self.labels.lock().map_err(|_| poisoned())?;
        if !state.current(s) {
            return Err(Error::Input(
                "label map: the label images were built for other label settings; call VolumeRenderer::sync_labels before a frame is built".into(),
            ));
        }
        Ok(state.images.each_ref().map(|i| imports.image_readonly(g, "label colours", i, READ_ONLY)))
    }

    /// Whether a label map is bound.
    pub fn has_labels(&self) -> bool {
        self.has_labels
    }
}

/// Specialization constant 7 of `volume/common.glsl` for a label map (`bound`) under `s`: 0 none,
/// 1 tint, 2 replace.
pub(super) fn label_constant(bound: bool, s: &LabelSettings) -> u32 {
    match (bound, s.mode) {
        (false, _) => 0,
        (true, LabelMode::Tint) => 1,
        (true, LabelMode::Replace) => 2,
    }
}

fn poisoned() -> Error {
    Error::Graph("label map: a frame failed while rebuilding the label images".into())
}
