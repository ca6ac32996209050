//! A label map on the device: the label volume as an R8_UINT 3D image beside the scan (dense in
//! either of the scan's layouts) and its colour table as a 256×1 RGBA32F image, read by
//! `volume/common.glsl`'s `label_medium` in every renderer.

use super::renderer::VolumeRenderer;
use crate::error::{Error, Result};
use crate::vk::{vk, Context, Image, ImageInfo};
use crate::volume::data::labels::LabelVolume;
use crate::volume::device::layout::upload_ro;
use crate::volume::optics::label_table::{LabelTable, LABELS};

fn usage() -> vk::ImageUsageFlags {
    vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST
}

/// The 1-texel label map and colour table bound where no label map is set.
pub(super) fn placeholders(ctx: &Context) -> Result<[Image; 2]> {
    let map = Image::new(ctx, "label map placeholder", ImageInfo::d3(vk::Format::R8_UINT, [1; 3], usage()))?;
    upload_ro(ctx, &map, &[0])?;
    let table =
        Image::new(ctx, "label table placeholder", ImageInfo::d2(vk::Format::R32G32B32A32_SFLOAT, 1, 1, usage()))?;
    upload_ro(ctx, &table, &[0; 16])?;
    Ok([map, table])
}

impl VolumeRenderer {
    /// Binds `labels` (a label volume on this volume's grid) with its colour table, or with
    /// `None` removes the label map: every renderer then samples exactly as without one.
    pub fn set_labels(&mut self, ctx: &Context, labels: Option<(&LabelVolume, &LabelTable)>) -> Result<()> {
        let Some((l, table)) = labels else {
            self.label_images = placeholders(ctx)?;
            self.has_labels = false;
            self.tf_generation += 1;
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
        let map = Image::new(ctx, "label map", ImageInfo::d3(vk::Format::R8_UINT, l.dims, usage()))?;
        upload_ro(ctx, &map, &l.labels)?;
        let info = ImageInfo::d2(vk::Format::R32G32B32A32_SFLOAT, LABELS as u32, 1, usage());
        let lut = Image::new(ctx, "label table", info)?;
        let bytes: Vec<u8> = table.entries.iter().flatten().flat_map(|f| f.to_le_bytes()).collect();
        upload_ro(ctx, &lut, &bytes)?;
        self.label_images = [map, lut];
        self.has_labels = true;
        // A new label map restarts the progressive mean, as a new transfer function does.
        self.tf_generation += 1;
        Ok(())
    }

    /// Whether a label map is bound.
    pub fn has_labels(&self) -> bool {
        self.has_labels
    }
}
