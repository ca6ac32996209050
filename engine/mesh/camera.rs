//! Perspective views for mesh scenes: a look-at view (from a scene file or a camera path) and a
//! fly camera for the window.

use glam::{Mat4, Vec3};

/// A perspective camera in world space (right-handed, y up).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct View {
    /// Eye position.
    pub position: [f32; 3],
    /// Unit view direction.
    pub forward: [f32; 3],
    /// Up hint.
    pub up: [f32; 3],
    /// Vertical field of view in radians.
    pub fov_y: f32,
    /// Near plane distance.
    pub near: f32,
    /// Far plane distance.
    pub far: f32,
}

impl View {
    /// Looks from `position` at `target`; the up hint is replaced when it is parallel to the view.
    pub fn look_at(position: Vec3, target: Vec3, up: Vec3, fov_y_deg: f32, near: f32, far: f32) -> Self {
        let forward = (target - position).try_normalize().unwrap_or(Vec3::NEG_Z);
        let up = if forward.cross(up).length_squared() < 1e-8 { Vec3::Z } else { up };
        Self {
            position: position.into(),
            forward: forward.into(),
            up: up.into(),
            fov_y: fov_y_deg.to_radians(),
            near,
            far,
        }
    }

    /// World → view matrix.
    pub fn view(&self) -> Mat4 {
        Mat4::look_to_rh(self.position.into(), self.forward.into(), self.up.into())
    }

    /// View → clip with Vulkan's conventions: depth in [0, 1] and the framebuffer's y pointing
    /// down, so images come out upright.
    pub fn proj(&self, aspect: f32) -> Mat4 {
        let mut p = Mat4::perspective_rh(self.fov_y, aspect, self.near, self.far);
        p.y_axis.y = -p.y_axis.y;
        p
    }

    /// World → clip.
    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        self.proj(aspect) * self.view()
    }

    /// World-space corners of the view frustum between view depths `near` and `far`.
    pub fn frustum_corners(&self, aspect: f32, near: f32, far: f32) -> [Vec3; 8] {
        let (p, f) = (Vec3::from(self.position), Vec3::from(self.forward));
        let right = f.cross(Vec3::from(self.up)).normalize();
        let up = right.cross(f);
        let ty = (self.fov_y * 0.5).tan();
        let tx = ty * aspect;
        let mut out = [Vec3::ZERO; 8];
        for (i, d) in [near, far].into_iter().enumerate() {
            for (j, (sx, sy)) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)].into_iter().enumerate() {
                out[i * 4 + j] = p + f * d + right * (sx * tx * d) + up * (sy * ty * d);
            }
        }
        out
    }
}

/// Mouse-look and WASD fly camera.
#[derive(Clone, Copy, Debug)]
pub struct FlyCamera {
    /// Eye position.
    pub position: Vec3,
    /// Rotation about +y (radians; 0 looks along -z).
    pub yaw: f32,
    /// Elevation (radians), kept inside (-89°, 89°).
    pub pitch: f32,
}

impl FlyCamera {
    /// The fly camera that sees what `view` sees.
    pub fn from_view(view: &View) -> Self {
        let f = Vec3::from(view.forward);
        Self { position: view.position.into(), yaw: (-f.x).atan2(-f.z), pitch: f.y.clamp(-1.0, 1.0).asin() }
    }

    /// Unit view direction.
    pub fn forward(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        Vec3::new(-sy * cp, sp, -cy * cp)
    }

    /// Turns by mouse deltas (radians).
    pub fn turn(&mut self, dyaw: f32, dpitch: f32) {
        self.yaw += dyaw;
        self.pitch = (self.pitch + dpitch).clamp(-1.55, 1.55);
    }

    /// Moves along the view (`forward`), sideways (`right`) and world up, in metres.
    pub fn translate(&mut self, forward: f32, right: f32, up: f32) {
        let f = self.forward();
        let r = f.cross(Vec3::Y).normalize_or_zero();
        self.position += f * forward + r * right + Vec3::Y * up;
    }

    /// The view with the given lens.
    pub fn view(&self, fov_y: f32, near: f32, far: f32) -> View {
        View { position: self.position.into(), forward: self.forward().into(), up: [0.0, 1.0, 0.0], fov_y, near, far }
    }
}
