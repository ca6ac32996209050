//! Temperature-driven emission: a second grid of temperatures (kelvin) beside the volume, and
//! the blackbody table the Monte Carlo shaders turn them into radiance with
//! (`shaders_glsl/volume/mc_common.glsl`'s `emitted`).

use super::renderer::{VolumeRenderer, READ_ONLY};
use crate::error::{Error, Result};
use crate::graph::execute::Imports;
use crate::graph::{GraphBuilder, ImageId};
use crate::vk::{vk, Context, Image, ImageInfo};
use crate::volume::data::Volume;
use crate::volume::device::layout::upload_ro;
use crate::volume::optics::blackbody;

/// Binding of the temperature grid in the Monte Carlo shaders.
pub const TEMPERATURE_BINDING: u32 = 27;
/// Binding of the blackbody table in the Monte Carlo shaders.
pub const PLANCK_BINDING: u32 = 28;

/// The temperature grid and its blackbody table on the device.
pub struct TemperatureGrid {
    /// Kelvin per voxel, R32_SFLOAT, on the volume's grid.
    pub(super) grid: Image,
    /// [`blackbody::table`] over `range`.
    pub(super) planck: Image,
    /// Temperatures (kelvin) the table spans: colder emits nothing, hotter is clamped.
    pub(super) range: [f32; 2],
}

/// Checks a temperature grid against the volume's dims and a range: one message naming what
/// is wrong (`what` names the grid for it: a file and grid name, or an argument).
pub fn check(what: &str, dims: [u32; 3], grid: &Volume, range: [f32; 2]) -> Result<()> {
    if !(range[0].is_finite() && range[1].is_finite() && range[0] > 0.0 && range[1] > range[0]) {
        return Err(Error::Input(format!(
            "temperature_range {},{}: expected 0 < LO < HI kelvin, finite",
            range[0], range[1]
        )));
    }
    if grid.dims != dims {
        return Err(Error::Input(format!(
            "{what}: the temperature grid is {:?} voxels, the volume {dims:?} (they must share one grid; resampling is not supported)",
            grid.dims
        )));
    }
    if grid.data.len() != dims.iter().map(|&d| d as usize).product::<usize>() {
        return Err(Error::Input(format!("{what}: the temperature grid must be dense (f32 values)")));
    }
    if let Some(i) = grid.data.iter().position(|v| !v.is_finite()) {
        return Err(Error::Input(format!(
            "{what}: temperature {} at voxel {i} (temperatures must be finite)",
            grid.data[i]
        )));
    }
    Ok(())
}

/// Checks that a temperature grid loaded from a file (`what` names it) can drive `density`'s
/// emission: the same box (OpenVDB index origin, dims, voxel size; there is no resampling) and no
/// NaN temperature (which the loader replaced, with a warning).
pub fn check_same_box(what: &str, density: &Volume, temperature: &Volume) -> Result<()> {
    if let Some(w) = temperature.warnings.iter().find(|w| w.contains("NaN")) {
        return Err(Error::Input(format!("{what}: temperatures must be finite ({w})")));
    }
    let (t, d) = (temperature, density);
    if t.index_origin != d.index_origin || t.dims != d.dims || t.spacing != d.spacing {
        return Err(Error::Input(format!(
            "{what}: its box ({:?} voxels of {:?} from index {:?}) differs from the density grid's ({:?} of {:?} from {:?}); resampling is not supported",
            t.dims, t.spacing, t.index_origin, d.dims, d.spacing, d.index_origin
        )));
    }
    Ok(())
}

impl VolumeRenderer {
    /// Sets (or with `None` removes) the temperature grid: with it, the Monte Carlo renderers'
    /// emission (`emission=S`) is S × blackbody radiance at each point's temperature, normalised
    /// to luminance 1 at `range[1]` kelvin, instead of S × the transfer function's colour.
    pub fn set_temperature(&mut self, ctx: &Context, grid: Option<(&Volume, [f32; 2])>) -> Result<()> {
        let Some((vol, range)) = grid else {
            self.temperature = None;
            return Ok(());
        };
        check(&vol.source, self.dims, vol, range)?;
        let usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST;
        let img = Image::new(ctx, "temperature", ImageInfo::d3(vk::Format::R32_SFLOAT, vol.dims, usage))?;
        upload_ro(ctx, &img, bytemuck::cast_slice(&vol.data))?;
        let table = blackbody::table(range);
        let planck = Image::new(
            ctx,
            "blackbody table",
            ImageInfo::d2(vk::Format::R32G32B32A32_SFLOAT, blackbody::TABLE_SIZE as u32, 1, usage),
        )?;
        upload_ro(ctx, &planck, bytemuck::cast_slice(&table))?;
        self.temperature = Some(TemperatureGrid { grid: img, planck, range });
        Ok(())
    }

    /// The temperature grid and its blackbody table imported for a frame, or placeholders
    /// without a grid (the shaders read them only with one).
    pub(super) fn import_temperature(&self, g: &mut GraphBuilder<'_>, imports: &mut Imports) -> [ImageId; 2] {
        let (temp, planck) = match &self.temperature {
            Some(t) => (&t.grid, &t.planck),
            None => (&self.atlas_placeholder, &self.tf),
        };
        [
            imports.image_readonly(g, "temperature", temp, READ_ONLY),
            imports.image_readonly(g, "blackbody table", planck, READ_ONLY),
        ]
    }
}
