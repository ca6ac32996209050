//! Cameras: orbit and free-flying, perspective and orthographic (Vulkan depth 0..1).

use glam::{Mat4, Vec3};

/// Projection model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Perspective with vertical field of view in radians.
    Perspective {
        /// Vertical field of view (radians).
        fov_y: f32,
    },
    /// Orthographic with this visible height in world units.
    Orthographic {
        /// Visible height.
        height: f32,
    },
}

/// How the camera is placed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rig {
    /// Orbits `target` at `distance`; yaw/pitch in radians.
    Orbit {
        /// Point looked at.
        target: Vec3,
        /// Distance from the target.
        distance: f32,
        /// Rotation about +Y.
        yaw: f32,
        /// Elevation.
        pitch: f32,
    },
    /// Free camera at `position` looking along yaw/pitch.
    Free {
        /// Eye position.
        position: Vec3,
        /// Rotation about +Y.
        yaw: f32,
        /// Elevation.
        pitch: f32,
    },
}

/// A camera: rig + projection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Placement.
    pub rig: Rig,
    /// Projection.
    pub projection: Projection,
}

fn dir(yaw: f32, pitch: f32) -> Vec3 {
    Vec3::new(yaw.sin() * pitch.cos(), pitch.sin(), yaw.cos() * pitch.cos())
}

impl Camera {
    /// Orbit camera looking at the origin from +Z (yaw 0, pitch 0).
    pub fn orbit(distance: f32, yaw: f32, pitch: f32, projection: Projection) -> Self {
        Self { rig: Rig::Orbit { target: Vec3::ZERO, distance, yaw, pitch }, projection }
    }

    /// The orbit camera (looking at the origin from `yaw`, `pitch`) at which the box
    /// `[-half, half]` fills `fill` of the view of `aspect` (the tighter of width and height).
    /// Each corner at view-space `(x, y)` and depth `d − z` (`z` towards the eye) is inside when
    /// `max(|x| / aspect, |y|) ≤ fill · tan(fov/2) · (d − z)`, which gives `d` in closed form;
    /// an orthographic view keeps `d` outside the box and sets its height instead.
    pub fn framing(half: Vec3, yaw: f32, pitch: f32, projection: Projection, aspect: f32, fill: f32) -> Self {
        let (_, fwd) = Self::orbit(1.0, yaw, pitch, projection).eye_forward();
        let up = if fwd.cross(Vec3::Y).length_squared() < 1e-8 { Vec3::Z } else { Vec3::Y };
        let rotate = Mat4::look_to_rh(Vec3::ZERO, fwd, up);
        let corners = (0..8).map(|i| {
            let c = Vec3::new(
                if i & 1 == 0 { -half.x } else { half.x },
                if i & 2 == 0 { -half.y } else { half.y },
                if i & 4 == 0 { -half.z } else { half.z },
            );
            rotate.transform_point3(c)
        });
        let aspect = aspect.max(1e-3);
        let fill = fill.clamp(0.05, 1.0);
        // Never inside the box, whatever the projection.
        let outside = half.length() * 1.05 + 0.02;
        match projection {
            Projection::Perspective { fov_y } => {
                let t = (fov_y * 0.5).tan() * fill;
                let d = corners.map(|v| v.z + (v.x.abs() / aspect).max(v.y.abs()) / t).fold(outside, f32::max);
                Self::orbit(d, yaw, pitch, projection)
            }
            Projection::Orthographic { .. } => {
                let h = corners.map(|v| (v.x.abs() / aspect).max(v.y.abs())).fold(0.0, f32::max) * 2.0 / fill;
                Self::orbit(outside, yaw, pitch, Projection::Orthographic { height: h.max(1e-3) })
            }
        }
    }

    /// Eye position and forward direction.
    pub fn eye_forward(&self) -> (Vec3, Vec3) {
        match self.rig {
            Rig::Orbit { target, distance, yaw, pitch } => {
                let eye = target + dir(yaw, pitch) * distance;
                (eye, (target - eye).normalize_or(Vec3::NEG_Z))
            }
            Rig::Free { position, yaw, pitch } => (position, -dir(yaw, pitch)),
        }
    }

    /// World → view matrix (right-handed, +Y up).
    pub fn view(&self) -> Mat4 {
        let (eye, fwd) = self.eye_forward();
        let up = if fwd.cross(Vec3::Y).length_squared() < 1e-8 { Vec3::Z } else { Vec3::Y };
        Mat4::look_to_rh(eye, fwd, up)
    }

    /// View → clip matrix, depth in [0,1], for `aspect` = width / height.
    pub fn projection(&self, aspect: f32) -> Mat4 {
        match self.projection {
            Projection::Perspective { fov_y } => Mat4::perspective_rh(fov_y, aspect, 0.01, 100.0),
            Projection::Orthographic { height } => {
                let (h, w) = (height * 0.5, height * 0.5 * aspect);
                Mat4::orthographic_rh(-w, w, -h, h, 0.01, 100.0)
            }
        }
    }

    /// Clip → world: what the ray-generation shaders use.
    pub fn inverse_view_projection(&self, aspect: f32) -> Mat4 {
        (self.projection(aspect) * self.view()).inverse()
    }

    /// Orbit by mouse deltas (radians); free camera turns in place.
    pub fn rotate(&mut self, d_yaw: f32, d_pitch: f32) {
        let limit = 1.55;
        match &mut self.rig {
            Rig::Orbit { yaw, pitch, .. } | Rig::Free { yaw, pitch, .. } => {
                *yaw += d_yaw;
                *pitch = (*pitch + d_pitch).clamp(-limit, limit);
            }
        }
    }

    /// Dolly (orbit) or zoom (orthographic height) by a factor.
    pub fn zoom(&mut self, factor: f32) {
        if let Projection::Orthographic { height } = &mut self.projection {
            *height = (*height * factor).clamp(0.01, 100.0);
        }
        if let Rig::Orbit { distance, .. } = &mut self.rig {
            *distance = (*distance * factor).clamp(0.05, 100.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unproject(m: Mat4, x: f32, y: f32, z: f32) -> Vec3 {
        let p = m * glam::Vec4::new(x, y, z, 1.0);
        p.truncate() / p.w
    }

    #[test]
    fn centre_ray_hits_target_for_both_projections() {
        for projection in [Projection::Perspective { fov_y: 0.8 }, Projection::Orthographic { height: 2.0 }] {
            let cam = Camera::orbit(3.0, 0.3, 0.2, projection);
            let inv = cam.inverse_view_projection(1.5);
            let (near, far) = (unproject(inv, 0.0, 0.0, 0.0), unproject(inv, 0.0, 0.0, 1.0));
            let d = (far - near).normalize();
            // Distance from the origin (target) to the centre ray.
            let closest = near - d * near.dot(d);
            assert!(closest.length() < 1e-4, "{projection:?}: centre ray misses target by {}", closest.length());
        }
    }

    #[test]
    fn framing_puts_the_outermost_corner_at_the_requested_fill() {
        // Project every corner with the real view-projection matrix: the largest |ndc| must be
        // the fill fraction, for both projections, a flat box and an oblique view.
        let half = Vec3::new(0.5, 0.2, 0.35);
        for projection in [Projection::Perspective { fov_y: 0.8 }, Projection::Orthographic { height: 1.0 }] {
            for (yaw, pitch, aspect) in [(0.0, 0.0, 1.0), (0.7, 0.4, 1.6), (2.5, -0.9, 0.5)] {
                let cam = Camera::framing(half, yaw, pitch, projection, aspect, 0.9);
                let m = cam.projection(aspect) * cam.view();
                let mut worst: f32 = 0.0;
                for i in 0..8 {
                    let c = Vec3::new(
                        if i & 1 == 0 { -half.x } else { half.x },
                        if i & 2 == 0 { -half.y } else { half.y },
                        if i & 4 == 0 { -half.z } else { half.z },
                    );
                    let p = m * c.extend(1.0);
                    assert!(p.w > 0.0, "{projection:?}: corner {c} behind the camera");
                    worst = worst.max((p.x / p.w).abs()).max((p.y / p.w).abs());
                }
                assert!((worst - 0.9).abs() < 1e-4, "{projection:?} yaw {yaw}: outermost corner at {worst}");
            }
        }
    }

    #[test]
    fn orthographic_rays_are_parallel_and_span_height() {
        let cam = Camera::orbit(3.0, 0.0, 0.0, Projection::Orthographic { height: 2.0 });
        let inv = cam.inverse_view_projection(1.0);
        let top = unproject(inv, 0.0, 1.0, 0.0);
        let bottom = unproject(inv, 0.0, -1.0, 0.0);
        assert!(((top - bottom).length() - 2.0).abs() < 1e-4);
        let d1 = unproject(inv, 1.0, 1.0, 1.0) - unproject(inv, 1.0, 1.0, 0.0);
        let d2 = unproject(inv, -1.0, 0.0, 1.0) - unproject(inv, -1.0, 0.0, 0.0);
        assert!(d1.normalize().dot(d2.normalize()) > 0.99999);
    }
}
