//! Sun rays: a radial blur of the camera depth's sky toward the sun's screen position, added
//! into the HDR image.

use super::camera::View;
use super::frame::FrameData;
use super::gpu_scene::GpuScene;
use super::settings::MeshSettings;
use crate::graph::{GraphBuilder, ImageId, Work};
use crate::shaders;
use crate::vk::Sampling;
use crate::Result;
use glam::{Vec3, Vec4Swizzles};

/// The sun-rays pass, where it is on and the sun is in front of the camera.
#[allow(clippy::too_many_arguments)]
pub(super) fn sun_rays(
    g: &mut GraphBuilder<'_>,
    scene: &GpuScene,
    view: &View,
    frame: &FrameData,
    s: &MeshSettings,
    depth: ImageId,
    hdr: ImageId,
    [w, h]: [u32; 2],
) -> Result<()> {
    let Some(push) = sun_rays_constants(scene, view, frame, s) else { return Ok(()) };
    // Reads only the camera depth and each pixel's own HDR value, so it can add in place.
    let pixels = u64::from(w) * u64::from(h);
    g.compute("sun rays", &shaders::MESH_SUN_RAYS_COMP)
        .work(Work::bytes(pixels * (u64::from(s.sun_rays_samples) * 4 + 32)))
        .sampled(depth, Sampling::Nearest)
        .read_write(hdr)
        .push_bytes(push)
        .dispatch([w.div_ceil(8), h.div_ceil(8), 1])?;
    Ok(())
}

/// Push constants of the sun-rays pass, or `None` when it is off or the sun is absent or behind
/// the camera. Behind the camera the sun projects through the camera's centre to the wrong side
/// of the screen, so a blur toward that point would streak away from the real sun: no pass is
/// added rather than one that adds garbage (or zero at the cost of a full-screen dispatch).
fn sun_rays_constants(scene: &GpuScene, view: &View, frame: &FrameData, s: &MeshSettings) -> Option<Vec<u8>> {
    let sun = scene.sun.filter(|_| s.sun_rays)?;
    let to_sun = Vec3::from(sun.to_sun).normalize_or_zero();
    // Fade out over the last ~12° before the sun leaves the front hemisphere, so the rays do
    // not pop off as the pass stops being added.
    let fade = (to_sun.dot(Vec3::from(view.forward)) / 0.2).clamp(0.0, 1.0);
    if fade <= 0.0 {
        return None;
    }
    let clip = frame.view_proj * to_sun.extend(0.0);
    let uv = clip.xy() / clip.w * 0.5 + 0.5;
    let k = s.sun_rays_intensity * fade / s.sun_rays_samples as f32;
    // The `Rays` block: two vec4 and the sample count, 36 bytes.
    let words: [u32; 9] = [
        uv.x.to_bits(),
        uv.y.to_bits(),
        0,
        0,
        (sun.irradiance[0] * k).to_bits(),
        (sun.irradiance[1] * k).to_bits(),
        (sun.irradiance[2] * k).to_bits(),
        s.sun_rays_decay.to_bits(),
        s.sun_rays_samples,
    ];
    Some(words.iter().flat_map(|x| x.to_le_bytes()).collect())
}
