//! Cameras: orbit and free-flying, perspective and orthographic (Vulkan depth 0..1), and the
//! framing of a volume's visible part (`framing`). Uses `data` and `optics` (which values are
//! visible); used by `render`, the demos and the Python module.

pub mod framing;

use glam::{Mat3, Mat4, Vec3};

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
    /// The rig's frame in world space: columns are the world directions of its x, up (y) and
    /// z axes (yaw 0, pitch 0 looks from +z). Identity for world-aligned volumes.
    pub basis: Mat3,
}

/// The eight corners of the box `±half`.
pub fn box_corners(half: Vec3) -> [Vec3; 8] {
    std::array::from_fn(|i| {
        Vec3::new(
            if i & 1 == 0 { -half.x } else { half.x },
            if i & 2 == 0 { -half.y } else { half.y },
            if i & 4 == 0 { -half.z } else { half.z },
        )
    })
}

fn dir(yaw: f32, pitch: f32) -> Vec3 {
    Vec3::new(yaw.sin() * pitch.cos(), pitch.sin(), yaw.cos() * pitch.cos())
}

impl Camera {
    /// Orbit camera looking at the origin from +Z (yaw 0, pitch 0).
    pub fn orbit(distance: f32, yaw: f32, pitch: f32, projection: Projection) -> Self {
        Self { rig: Rig::Orbit { target: Vec3::ZERO, distance, yaw, pitch }, projection, basis: Mat3::IDENTITY }
    }

    /// The rig frame of a volume in patient axes (x → left, y → posterior, z → superior): up is
    /// superior and yaw 0 looks at the face from anterior, the patient's left on the right of
    /// the image, as an anatomical front view shows it.
    pub const PATIENT: Mat3 = Mat3::from_cols(Vec3::X, Vec3::Z, Vec3::NEG_Y);

    /// This camera turned into an orbit around `center`, at the distance from which the box
    /// `center ± half` fills `fill` of the view of `aspect` (the tighter of width and height).
    /// Each corner at view-space `(x, y)` and depth `d − z` (`z` towards the eye) is inside when
    /// `max(|x| / aspect, |y|) ≤ fill · tan(fov/2) · (d − z)`, which gives `d` in closed form;
    /// an orthographic view keeps `d` outside the box and sets its height instead.
    pub fn framed(self, center: Vec3, half: Vec3, aspect: f32, fill: f32) -> Self {
        let (yaw, pitch) = match self.rig {
            Rig::Orbit { yaw, pitch, .. } | Rig::Free { yaw, pitch, .. } => (yaw, pitch),
        };
        let mut cam = Self { rig: Rig::Orbit { target: center, distance: 1.0, yaw, pitch }, ..self };
        // Directions only: the view's rotation.
        let rotate = cam.view();
        let corners = box_corners(half).into_iter().map(|c| rotate.transform_vector3(c));
        let aspect = aspect.max(1e-3);
        let fill = fill.clamp(0.05, 1.0);
        // Never inside the box, whatever the projection.
        let outside = half.length() * 1.05 + 0.02;
        let distance = match self.projection {
            Projection::Perspective { fov_y } => {
                let t = (fov_y * 0.5).tan() * fill;
                corners.map(|v| v.z + (v.x.abs() / aspect).max(v.y.abs()) / t).fold(outside, f32::max)
            }
            Projection::Orthographic { .. } => {
                let h = corners.map(|v| (v.x.abs() / aspect).max(v.y.abs())).fold(0.0, f32::max) * 2.0 / fill;
                cam.projection = Projection::Orthographic { height: h.max(1e-3) };
                outside
            }
        };
        cam.rig = Rig::Orbit { target: center, distance, yaw, pitch };
        cam
    }

    /// Eye position and forward direction.
    pub fn eye_forward(&self) -> (Vec3, Vec3) {
        match self.rig {
            Rig::Orbit { target, distance, yaw, pitch } => {
                let eye = target + self.basis * dir(yaw, pitch) * distance;
                (eye, (target - eye).normalize_or(self.basis * Vec3::NEG_Z))
            }
            Rig::Free { position, yaw, pitch } => (position, -(self.basis * dir(yaw, pitch))),
        }
    }

    /// World → view matrix (right-handed, +Y up).
    pub fn view(&self) -> Mat4 {
        let (eye, fwd) = self.eye_forward();
        let (y, z) = (self.basis * Vec3::Y, self.basis * Vec3::Z);
        let up = if fwd.cross(y).length_squared() < 1e-8 { z } else { y };
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
        // the fill fraction, for both projections and rig frames, a flat off-centre box and
        // oblique views.
        let (half, centre) = (Vec3::new(0.5, 0.2, 0.35), Vec3::new(0.1, -0.2, 0.3));
        for basis in [Mat3::IDENTITY, Camera::PATIENT] {
            for projection in [Projection::Perspective { fov_y: 0.8 }, Projection::Orthographic { height: 1.0 }] {
                for (yaw, pitch, aspect) in [(0.0, 0.0, 1.0), (0.7, 0.4, 1.6), (2.5, -0.9, 0.5)] {
                    let cam = Camera { basis, ..Camera::orbit(1.0, yaw, pitch, projection) }
                        .framed(centre, half, aspect, 0.9);
                    let m = cam.projection(aspect) * cam.view();
                    let mut worst: f32 = 0.0;
                    for c in box_corners(half).map(|c| centre + c) {
                        let p = m * c.extend(1.0);
                        assert!(p.w > 0.0, "{projection:?}: corner {c} behind the camera");
                        worst = worst.max((p.x / p.w).abs()).max((p.y / p.w).abs());
                    }
                    assert!((worst - 0.9).abs() < 1e-4, "{projection:?} yaw {yaw}: outermost corner at {worst}");
                }
            }
        }
    }

    #[test]
    fn a_patient_frame_shows_superior_up_and_the_face_towards_the_camera() {
        let cam =
            Camera { basis: Camera::PATIENT, ..Camera::orbit(2.0, 0.0, 0.0, Projection::Perspective { fov_y: 0.8 }) };
        let (eye, fwd) = cam.eye_forward();
        assert!((eye - Vec3::new(0.0, -2.0, 0.0)).length() < 1e-5, "eye {eye} should be anterior (−y)");
        assert!((fwd - Vec3::Y).length() < 1e-5);
        // View space: +y is the image's up, +x its right.
        let v = cam.view();
        assert!((v.transform_vector3(Vec3::Z) - Vec3::Y).length() < 1e-5, "superior is up");
        assert!((v.transform_vector3(Vec3::X) - Vec3::X).length() < 1e-5, "the patient's left is on the right");
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
