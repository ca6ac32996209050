//! Shadow-map views: cascade splits, cascades fitted to view-frustum slices (stable: bounding
//! spheres and texel-snapped origins), spot-light frusta, and the atlas tiles they render into.

use super::camera::View;
use glam::{Mat4, Vec3, Vec4Swizzles};

/// One rendered shadow (or RSM) view.
#[derive(Clone, Copy, Debug)]
pub struct ShadowView {
    /// World → clip (depth in [0, 1]).
    pub view_proj: Mat4,
    /// World size of one texel (orthographic), or per unit distance along the axis (perspective).
    pub texel: f32,
    /// Depth bias in clip depth units.
    pub bias: f32,
    /// Perspective (spot) rather than orthographic (sun).
    pub perspective: bool,
    /// Distances of the near and far planes along the light (soft shadows turn depths back into
    /// distances with them).
    pub depth_range: [f32; 2],
}

/// Far view depth of each of `count` cascades between `near` and `far`: the practical split
/// scheme, `lambda` blending logarithmic (1) and uniform (0) splits.
pub fn cascade_splits(near: f32, far: f32, count: u32, lambda: f32) -> Vec<f32> {
    (1..=count)
        .map(|i| {
            let t = i as f32 / count as f32;
            let log = near * (far / near).powf(t);
            let uni = near + (far - near) * t;
            lambda * log + (1.0 - lambda) * uni
        })
        .collect()
}

/// Light-space rotation for light travelling along `dir` (an up vector that is never parallel).
fn light_rotation(dir: Vec3) -> Mat4 {
    let up = if dir.cross(Vec3::Y).length_squared() < 1e-6 { Vec3::Z } else { Vec3::Y };
    Mat4::look_to_rh(Vec3::ZERO, dir, up)
}

/// Orthographic view of a sphere (`centre`, `radius`) for light travelling along `dir`, its depth
/// range widened to the whole scene box so that occluders outside the sphere still cast shadows,
/// its origin snapped to whole texels so the shadow does not shimmer as the camera moves.
pub fn fit_sphere(centre: Vec3, radius: f32, dir: Vec3, scene: [Vec3; 2], resolution: u32) -> ShadowView {
    let rot = light_rotation(dir.normalize());
    let texel = 2.0 * radius / resolution.max(1) as f32;
    let mut c = rot.transform_point3(centre);
    c.x = (c.x / texel).floor() * texel;
    c.y = (c.y / texel).floor() * texel;
    let view = Mat4::from_translation(-glam::Vec3::new(c.x, c.y, 0.0)) * rot;
    let (mut zmin, mut zmax) = (f32::MAX, f32::MIN);
    for i in 0..8 {
        let p = Vec3::new(
            if i & 1 == 0 { scene[0].x } else { scene[1].x },
            if i & 2 == 0 { scene[0].y } else { scene[1].y },
            if i & 4 == 0 { scene[0].z } else { scene[1].z },
        );
        let z = view.transform_point3(p).z;
        zmin = zmin.min(z);
        zmax = zmax.max(z);
    }
    let cz = view.transform_point3(centre).z;
    let (zmin, zmax) = (zmin.min(cz - radius), zmax.max(cz + radius));
    // Right-handed view space looks down -z: near = -zmax, far = -zmin.
    let (near, far) = (-zmax - texel, -zmin + texel);
    let proj = Mat4::orthographic_rh(-radius, radius, -radius, radius, near, far);
    ShadowView {
        view_proj: proj * view,
        texel,
        bias: 1.5 * texel / (far - near),
        perspective: false,
        depth_range: [near, far],
    }
}

/// Cascade covering view depths `[near, far]` of `view`.
pub fn fit_cascade(
    view: &View,
    aspect: f32,
    near: f32,
    far: f32,
    dir: Vec3,
    scene: [Vec3; 2],
    resolution: u32,
) -> ShadowView {
    let corners = view.frustum_corners(aspect, near, far);
    let centre = corners.iter().fold(Vec3::ZERO, |a, &c| a + c) / 8.0;
    // The radius depends only on the slice's shape, not on the camera's rotation: stable size.
    let radius = corners.iter().map(|&c| (c - centre).length()).fold(0.0, f32::max);
    fit_sphere(centre, radius, dir, scene, resolution)
}

/// The whole scene box seen by light travelling along `dir` (the sun's RSM).
pub fn fit_scene(dir: Vec3, scene: [Vec3; 2], resolution: u32) -> ShadowView {
    let centre = (scene[0] + scene[1]) * 0.5;
    let radius = ((scene[1] - scene[0]) * 0.5).length().max(1e-3);
    fit_sphere(centre, radius, dir, scene, resolution)
}

/// Perspective view of a spot light whose cone half-angle is `outer` (radians).
pub fn spot_view(position: Vec3, dir: Vec3, outer: f32, range: f32, resolution: u32) -> ShadowView {
    let half = outer.clamp(0.01, 1.5);
    let near = (range * 1e-3).max(0.01);
    let view = light_rotation(dir.normalize()) * Mat4::from_translation(-position);
    let far = range.max(near * 2.0);
    let proj = Mat4::perspective_rh(2.0 * half, 1.0, near, far);
    ShadowView {
        view_proj: proj * view,
        texel: 2.0 * half.tan() / resolution.max(1) as f32,
        bias: 2e-5,
        perspective: true,
        depth_range: [near, far],
    }
}

/// Where tile `i` of `tiles` sits in the atlas: (origin, size) in atlas UV, and the atlas extent.
pub fn atlas_layout(tiles: u32, tile: u32) -> ([u32; 2], Vec<[f32; 4]>) {
    let cols = tiles.clamp(1, 4);
    let rows = tiles.max(1).div_ceil(cols);
    let rects = (0..tiles)
        .map(|i| {
            let (c, r) = ((i % cols) as f32, (i / cols) as f32);
            [c / cols as f32, r / rows as f32, 1.0 / cols as f32, 1.0 / rows as f32]
        })
        .collect();
    ([cols * tile, rows * tile], rects)
}

/// Projects a world point with `vp` to (uv in [0,1]², depth): the lookup a shader performs.
pub fn project(vp: &Mat4, p: Vec3) -> (glam::Vec2, f32) {
    let c = *vp * p.extend(1.0);
    let ndc = c.xyz() / c.w;
    (glam::Vec2::new(ndc.x * 0.5 + 0.5, ndc.y * 0.5 + 0.5), ndc.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_are_increasing_and_end_at_far() {
        let s = cascade_splits(0.1, 100.0, 4, 0.7);
        assert!(s.windows(2).all(|w| w[0] < w[1]));
        assert!((s[3] - 100.0).abs() < 1e-3);
        // Uniform at lambda 0.
        let u = cascade_splits(0.0 + 1.0, 5.0, 4, 0.0);
        assert!((u[0] - 2.0).abs() < 1e-5);
    }

    #[test]
    fn cascade_contains_its_slice_and_snaps_to_texels() {
        let view = View::look_at(Vec3::new(0.0, 2.0, 5.0), Vec3::ZERO, Vec3::Y, 60.0, 0.1, 50.0);
        let dir = Vec3::new(-0.3, -1.0, -0.2).normalize();
        let scene = [Vec3::splat(-10.0), Vec3::splat(10.0)];
        let sv = fit_cascade(&view, 1.5, 0.1, 8.0, dir, scene, 512);
        for c in view.frustum_corners(1.5, 0.1, 8.0) {
            let (uv, z) = project(&sv.view_proj, c);
            assert!(uv.min_element() >= -1e-4 && uv.max_element() <= 1.0 + 1e-4, "{uv}");
            assert!((0.0..=1.0).contains(&z), "{z}");
        }
        // Moving the camera by less than a texel sideways keeps the projection grid aligned.
        let mut moved = view;
        moved.position[0] += sv.texel * 0.3;
        let sv2 = fit_cascade(&moved, 1.5, 0.1, 8.0, dir, scene, 512);
        let (a, _) = project(&sv.view_proj, Vec3::ZERO);
        let (b, _) = project(&sv2.view_proj, Vec3::ZERO);
        let shift = (a - b) * 512.0;
        assert!((shift.x - shift.x.round()).abs() < 1e-2 && (shift.y - shift.y.round()).abs() < 1e-2, "{shift}");
    }

    #[test]
    fn atlas_tiles_do_not_overlap() {
        let (size, rects) = atlas_layout(6, 256);
        assert_eq!(size, [1024, 512]);
        assert_eq!(rects.len(), 6);
        assert_eq!(rects[5], [0.25, 0.5, 0.25, 0.5]);
    }
}
