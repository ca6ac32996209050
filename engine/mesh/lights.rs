//! A mesh frame's lights before any pass: shadow tiles (sun cascades, then one per spot) and
//! their atlas, the reflective shadow map's light and the flux bound that sets the LPV's
//! fixed-point scale, the LPV cascades around the camera and the sky light's top-down view.

use super::camera::View;
use super::frame::{FrameData, SpotData, MAX_SHADOW_TILES, MAX_SPOTS};
use super::gpu_scene::GpuScene;
use super::settings::MeshSettings;
use super::shadow::{self, ShadowView};
use crate::lpv::grid::Cascade;
use crate::{Error, Result};
use glam::{Mat4, Vec3};

/// Largest soft-shadow filter radius in texels: bounds the penumbra (and the blocker search)
/// so a pixel never costs more than 7² + 12² shadow-map taps.
pub const MAX_PENUMBRA_TEXELS: f32 = 16.0;

/// Everything [`frame_lights`] derives.
pub(crate) struct FrameLights {
    /// The frame uniform block's light fields.
    pub frame: FrameData,
    /// Shadow atlas size in texels.
    pub atlas_size: [u32; 2],
    /// Each tile's rectangle in the atlas (uv).
    pub rects: Vec<[f32; 4]>,
    /// The RSM's light view, when there is an RSM and a light.
    pub rsm_view: Option<ShadowView>,
    /// The RSM light's position (spot) or direction (sun).
    pub rsm_light_pos: [f32; 3],
    /// Upper bound on the flux per channel one LPV cell can receive.
    pub flux_bound: f32,
    /// LPV cascades (empty with the LPV off).
    pub cascades: Vec<Cascade>,
    /// Whether the subsurface LPV runs.
    pub sslpv_on: bool,
    /// The sky light's height-map view, when the sky light is on.
    pub sky_vp: Option<Mat4>,
}

/// The lights of one frame seen from `view`; `rsm_edge` is the RSM's size when there is one,
/// `previous` the cascades of the cached LPV the frame may keep (`lpv_follow`; none without reuse).
pub(crate) fn frame_lights(
    scene: &GpuScene,
    view: &View,
    aspect: f32,
    s: &MeshSettings,
    rsm_edge: Option<u32>,
    previous: &[crate::lpv::grid::Cascade],
) -> Result<FrameLights> {
    let mut frame = FrameData {
        view_proj: view.view_proj(aspect),
        camera_pos: view.position,
        camera_forward: view.forward,
        ambient: s.ambient,
        sky: s.sky,
        pcf_radius: s.pcf_radius,
        ..Default::default()
    };
    // Shadow tiles: the sun's cascades first, then one per spot light.
    let mut tiles: Vec<ShadowView> = Vec::new();
    if let Some(sun) = scene.sun {
        frame.sun = Some((sun.to_sun, sun.irradiance));
        let dir = -Vec3::from(sun.to_sun);
        let far = s.shadow_distance.min(view.far);
        let splits = shadow::cascade_splits(view.near, far, s.cascades, s.cascade_lambda);
        let mut near = view.near;
        for (i, &split) in splits.iter().enumerate() {
            tiles.push(shadow::fit_cascade(view, aspect, near, split, dir, scene.bounds, s.shadow_tile));
            frame.cascade_far[i] = split;
            near = split;
        }
        frame.cascades = splits.len() as u32;
    }
    for spot in scene.spots.iter().take(MAX_SPOTS) {
        let tile = tiles.len() as u32;
        tiles.push(shadow::spot_view(
            spot.position.into(),
            spot.direction.into(),
            spot.angles[1],
            spot.range,
            s.shadow_tile,
        ));
        frame.spots.push(SpotData {
            position: spot.position,
            direction: spot.direction,
            intensity: spot.intensity,
            cos_outer: spot.angles[1].cos(),
            cos_inner: spot.angles[0].cos(),
            tile,
        });
    }
    debug_assert!(tiles.len() <= MAX_SHADOW_TILES);
    let (atlas_size, rects) =
        if tiles.is_empty() { ([1, 1], vec![]) } else { shadow::atlas_layout(tiles.len() as u32, s.shadow_tile) };
    frame.atlas_size = atlas_size;
    frame.tiles = tiles
        .iter()
        .zip(&rects)
        .map(|(t, r)| {
            let [near, far] = t.depth_range;
            let depth = if t.perspective { [near, far] } else { [far - near, 0.0] };
            (t.view_proj, *r, [t.texel, t.bias, depth[0], depth[1]])
        })
        .collect();
    frame.soft_shadow = [(0.5 * s.sun_angle).to_radians().tan(), s.spot_radius, MAX_PENUMBRA_TEXELS, 0.0];

    // The RSM sees the scene from the sun (whole scene box) or else from the first spot.
    // Also: the light's position or direction, and a bound on the flux per channel that can
    // land in one LPV cell (at most the RSM's total: every texel lit, albedo 1), which sets
    // the LPV's fixed-point scale.
    let mut rsm_light_pos = [0.0f32; 3];
    let mut flux_bound = 0.0f32;
    let rsm_view = match (rsm_edge, scene.sun, scene.spots.first()) {
        (Some(n), Some(sun), _) => {
            let v = shadow::fit_scene(-Vec3::from(sun.to_sun), scene.bounds, n);
            frame.rsm_light = [0.0, v.texel * v.texel, n as f32, 0.0];
            rsm_light_pos = (-Vec3::from(sun.to_sun)).into();
            flux_bound = sun.irradiance.iter().fold(0.0f32, |a, &b| a.max(b)) * (v.texel * n as f32).powi(2);
            Some(v)
        }
        (Some(n), None, Some(spot)) => {
            let v = shadow::spot_view(spot.position.into(), spot.direction.into(), spot.angles[1], spot.range, n);
            frame.rsm_light = [1.0, spot.angles[1].clamp(0.01, 1.5).tan(), n as f32, 0.0];
            rsm_light_pos = spot.position;
            let cone = 2.0 * std::f32::consts::PI * (1.0 - spot.angles[1].clamp(0.01, 1.5).cos());
            flux_bound = spot.intensity.iter().fold(0.0f32, |a, &b| a.max(b)) * cone;
            Some(v)
        }
        _ => None,
    };
    let cascades = if s.lpv.enabled {
        if rsm_view.is_none() {
            return Err(Error::Input(
                "LPV needs a reflective shadow map (set rsm=N, e.g. 256) and a sun or spot light".into(),
            ));
        }
        crate::lpv::grid::place_following(
            view.position.into(),
            view.forward.into(),
            scene.bounds,
            [s.lpv.size, s.lpv.cascades],
            s.lpv.extent,
            s.lpv.follow_slack,
            previous,
        )
    } else {
        Vec::new()
    };
    if let (Some(sun), Some(coarsest)) = (scene.sun, cascades.last()) {
        // Sun light reaching one cell (grown by the VPL offset on each side) is at most E
        // times the cube's largest shadow, √3·a²: a far tighter bound than the whole RSM,
        // so the fixed-point scale keeps more bits for dim light.
        let a = coarsest.cell * (1.0 + 2.0 * s.lpv.vpl_offset);
        let per_cell = sun.irradiance.iter().fold(0.0f32, |m, &b| m.max(b)) * 3f32.sqrt() * a * a;
        flux_bound = flux_bound.min(per_cell);
    }
    frame.lpv = cascades.clone();
    // The subsurface LPV is built only when some surface lets light in.
    let sslpv_on = s.lpv.enabled && s.lpv.subsurface && scene.translucent;
    // Damping and the subsurface LPV reach the lighting pass as specialization constants.
    frame.lpv_params = [s.lpv.intensity, s.lpv.sample_offset, 0.0, 0.0];
    // LPV sky light: an orthographic view straight down over the coarsest cascade, from above
    // everything, so its depth map is the height of the topmost surface.
    let sky_vp = match (s.lpv.sky > 0.0, cascades.last()) {
        (true, Some(c)) => {
            let (lo, hi) = (Vec3::from(c.origin), c.max());
            let top = hi.y.max(scene.bounds[1].y) + c.cell;
            let bottom = lo.y.min(scene.bounds[0].y) - c.cell;
            let (centre, half) = ((lo + hi) * 0.5, (hi.x - lo.x) * 0.5);
            let eye = Vec3::new(centre.x, top, centre.z);
            let look = Mat4::look_at_rh(eye, eye - Vec3::Y, -Vec3::Z);
            Some(Mat4::orthographic_rh(-half, half, -half, half, 0.0, top - bottom) * look)
        }
        _ => None,
    };
    frame.sky_vp = sky_vp.unwrap_or(Mat4::IDENTITY);
    if let Some(v) = rsm_view {
        frame.rsm_vp = v.view_proj;
    }
    Ok(FrameLights { frame, atlas_size, rects, rsm_view, rsm_light_pos, flux_bound, cascades, sslpv_on, sky_vp })
}
