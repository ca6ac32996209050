//! The per-frame uniform buffer of the mesh renderer (`shaders_glsl/mesh/frame.glsl`, std140).

use glam::Mat4;

/// Shadow tiles the frame buffer has room for (cascades + spot lights).
pub const MAX_SHADOW_TILES: usize = 8;
/// Spot lights the frame buffer has room for.
pub const MAX_SPOTS: usize = 4;
/// Draw view index of the camera; shadow tile `k` is `1 + k`; the RSM light is [`VIEW_RSM`], the
/// LPV sky's top-down height map [`VIEW_SKY`].
pub const VIEW_CAMERA: u32 = 0;
/// Draw view index of the RSM light.
pub const VIEW_RSM: u32 = 9;
/// Draw view index of the LPV sky light's top-down height map.
pub const VIEW_SKY: u32 = 10;

/// A spot light as the shaders see it.
#[derive(Clone, Copy, Debug, Default)]
pub struct SpotData {
    /// Position.
    pub position: [f32; 3],
    /// Direction the light travels (unit).
    pub direction: [f32; 3],
    /// Radiant intensity, W/sr.
    pub intensity: [f32; 3],
    /// Cosines of the outer and inner cone half-angles.
    pub cos_outer: f32,
    /// Cosine of the inner half-angle (full intensity inside).
    pub cos_inner: f32,
    /// Shadow tile index.
    pub tile: u32,
}

/// Everything `frame.glsl`'s `Frame` block holds.
#[derive(Clone, Debug, Default)]
pub struct FrameData {
    /// Camera world → clip.
    pub view_proj: Mat4,
    /// Camera position.
    pub camera_pos: [f32; 3],
    /// Camera forward (unit).
    pub camera_forward: [f32; 3],
    /// Direction towards the sun (unit) and irradiance; `None`: no sun.
    pub sun: Option<([f32; 3], [f32; 3])>,
    /// Uniform ambient radiance.
    pub ambient: [f32; 3],
    /// Background radiance.
    pub sky: [f32; 3],
    /// Number of sun cascades (tiles `0..cascades`).
    pub cascades: u32,
    /// PCF radius in texels.
    pub pcf_radius: u32,
    /// Far view depth per cascade.
    pub cascade_far: [f32; 4],
    /// Shadow atlas extent in texels.
    pub atlas_size: [u32; 2],
    /// Shadow tiles: world → clip, atlas rect, (texel, bias, depth range: orthographic
    /// far − near and 0, or perspective near and far).
    pub tiles: Vec<(Mat4, [f32; 4], [f32; 4])>,
    /// Spot lights.
    pub spots: Vec<SpotData>,
    /// RSM light world → clip.
    pub rsm_vp: Mat4,
    /// RSM light: [kind (0 sun, 1 spot), sun texel area or spot tan(half angle), size, spot index].
    pub rsm_light: [f32; 4],
    /// LPV cascades (empty: no LPV).
    pub lpv: Vec<crate::lpv::grid::Cascade>,
    /// LPV shading: [intensity, normal offset in cells, 0, 0].
    pub lpv_params: [f32; 4],
    /// World → clip of the LPV sky light's top-down height map.
    pub sky_vp: Mat4,
    /// Soft shadows: [tan(sun's angular radius), spot radius (m), largest penumbra (texels), 0].
    pub soft_shadow: [f32; 4],
}

impl FrameData {
    /// std140 bytes of the uniform block.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut w: Vec<u32> = Vec::with_capacity(512);
        let f = |w: &mut Vec<u32>, v: &[f32]| w.extend(v.iter().map(|x| x.to_bits()));
        let v4 = |w: &mut Vec<u32>, v: [f32; 3], a: f32| w.extend([v[0], v[1], v[2], a].map(f32::to_bits));
        f(&mut w, &self.view_proj.to_cols_array());
        f(&mut w, &self.view_proj.inverse().to_cols_array());
        v4(&mut w, self.camera_pos, 1.0);
        v4(&mut w, self.camera_forward, 0.0);
        let (dir, e, on) = match self.sun {
            Some((d, e)) => (d, e, 1.0),
            None => ([0.0, 1.0, 0.0], [0.0; 3], 0.0),
        };
        v4(&mut w, dir, on);
        v4(&mut w, e, 0.0);
        v4(&mut w, self.ambient, 0.0);
        w.extend([self.cascades, self.spots.len().min(MAX_SPOTS) as u32, self.tiles.len() as u32, self.pcf_radius]);
        f(&mut w, &self.cascade_far);
        let [ax, ay] = self.atlas_size.map(|x| x.max(1) as f32);
        f(&mut w, &[ax, ay, 1.0 / ax, 1.0 / ay]);
        v4(&mut w, self.sky, 0.0);
        let tile = |i: usize| self.tiles.get(i).copied().unwrap_or((Mat4::IDENTITY, [0.0; 4], [0.0; 4]));
        for i in 0..MAX_SHADOW_TILES {
            f(&mut w, &tile(i).0.to_cols_array());
        }
        for i in 0..MAX_SHADOW_TILES {
            f(&mut w, &tile(i).1);
        }
        for i in 0..MAX_SHADOW_TILES {
            f(&mut w, &tile(i).2);
        }
        let spot = |i: usize| self.spots.get(i).copied().unwrap_or_default();
        for i in 0..MAX_SPOTS {
            v4(&mut w, spot(i).position, spot(i).tile as f32);
        }
        for i in 0..MAX_SPOTS {
            v4(&mut w, spot(i).direction, spot(i).cos_outer);
        }
        for i in 0..MAX_SPOTS {
            v4(&mut w, spot(i).intensity, spot(i).cos_inner);
        }
        f(&mut w, &self.rsm_vp.to_cols_array());
        f(&mut w, &self.rsm_light);
        for i in 0..4 {
            match self.lpv.get(i) {
                Some(c) => v4(&mut w, c.origin, c.cell),
                None => v4(&mut w, [0.0; 3], 1.0),
            }
        }
        let n = self.lpv.first().map_or(0, |c| c.n);
        w.extend([n, self.lpv.len().min(4) as u32, 0, 0]);
        f(&mut w, &self.lpv_params);
        f(&mut w, &self.sky_vp.to_cols_array());
        f(&mut w, &self.soft_shadow);
        w.iter().flat_map(|x| x.to_le_bytes()).collect()
    }
}

/// Push constants of one draw (`Draw` in frame.glsl): 48 bytes.
pub fn draw_constants(
    base_color: [f32; 4],
    specular: [f32; 4],
    view: u32,
    flags: u32,
    cutoff: f32,
    translucency: f32,
) -> Vec<u8> {
    let mut w: Vec<u32> = base_color.iter().chain(specular.iter()).map(|x| x.to_bits()).collect();
    w.extend([view, flags, cutoff.to_bits(), translucency.to_bits()]);
    w.iter().flat_map(|x| x.to_le_bytes()).collect()
}
