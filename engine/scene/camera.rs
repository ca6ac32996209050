//! Cameras and Catmull–Rom camera paths.

use super::Aabb;

/// A pinhole camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub position: [f32; 3],
    /// Point looked at.
    pub target: [f32; 3],
    /// Up hint.
    pub up: [f32; 3],
    /// Vertical field of view, degrees.
    pub fov_y_deg: f32,
    /// Near clip distance.
    pub near: f32,
    /// Far clip distance.
    pub far: f32,
}

impl Camera {
    /// A camera looking at the centre of `bounds` from the +z side (slightly above), far enough away that
    /// the bounding sphere fits in the vertical field of view.
    pub fn framing(bounds: &Aabb, fov_y_deg: f32) -> Camera {
        let c = bounds.center();
        let s = bounds.size();
        let radius = (0.5 * (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt()).max(1e-3);
        let half = (0.5 * fov_y_deg.to_radians()).clamp(0.01, 1.5);
        let dist = radius / half.sin();
        let dir = glam::Vec3::new(0.0, 0.25, 1.0).normalize();
        let pos = glam::Vec3::from(c) + dir * dist;
        Camera {
            position: pos.into(),
            target: c,
            up: [0.0, 1.0, 0.0],
            fov_y_deg,
            near: (dist - radius).max(radius * 1e-3),
            far: dist + 2.0 * radius,
        }
    }
}

/// One key of a camera path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraKey {
    /// Time in seconds; keys are strictly increasing.
    pub time: f32,
    /// Eye position at `time`.
    pub position: [f32; 3],
    /// Look-at point at `time`.
    pub target: [f32; 3],
}

/// A camera animation through keys, interpolated by Catmull–Rom splines.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraPath {
    /// Keys sorted by strictly increasing time.
    pub keys: Vec<CameraKey>,
}

impl CameraPath {
    /// Checks the keys are non-empty, finite and strictly increasing in time; the error says which key.
    pub fn new(keys: Vec<CameraKey>) -> Result<CameraPath, String> {
        if keys.is_empty() {
            return Err("camera path has no keys".into());
        }
        for (i, k) in keys.iter().enumerate() {
            let finite = k.time.is_finite() && k.position.iter().chain(&k.target).all(|v| v.is_finite());
            if !finite {
                return Err(format!("camera path key {i} has a non-finite value"));
            }
            if i > 0 && k.time <= keys[i - 1].time {
                return Err(format!("camera path key {i}: time {} is not after the previous key's", k.time));
            }
        }
        Ok(CameraPath { keys })
    }

    /// The camera at time `t`, clamped to the first/last key; lens and up vector come from `lens`.
    ///
    /// Non-uniform Catmull–Rom: cubic Hermite segments with finite-difference tangents over key *times*
    /// (`m_i = (p_{i+1} − p_{i−1}) / (t_{i+1} − t_{i−1})`, one-sided at the ends), so the path passes
    /// through every key and its velocity is continuous in `t` even with unevenly spaced keys.
    pub fn at(&self, t: f32, lens: &Camera) -> Camera {
        let mut cam = *lens;
        let (Some(first), Some(last)) = (self.keys.first(), self.keys.last()) else {
            return cam;
        };
        let (pos, tgt) = if self.keys.len() == 1 || t.is_nan() || t <= first.time {
            (first.position, first.target)
        } else if t >= last.time {
            (last.position, last.target)
        } else {
            let i = self.keys.partition_point(|k| k.time <= t).saturating_sub(1).min(self.keys.len() - 2);
            (self.hermite(i, t, |k| k.position), self.hermite(i, t, |k| k.target))
        };
        cam.position = pos;
        cam.target = tgt;
        cam
    }

    fn tangent(&self, i: usize, f: impl Fn(&CameraKey) -> [f32; 3]) -> [f32; 3] {
        let n = self.keys.len();
        let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
        let dt = self.keys[b].time - self.keys[a].time;
        let (pa, pb) = (f(&self.keys[a]), f(&self.keys[b]));
        [0, 1, 2].map(|k| (pb[k] - pa[k]) / dt)
    }

    fn hermite(&self, i: usize, t: f32, f: impl Fn(&CameraKey) -> [f32; 3] + Copy) -> [f32; 3] {
        let (k0, k1) = (&self.keys[i], &self.keys[i + 1]);
        let h = k1.time - k0.time;
        let s = (t - k0.time) / h;
        let (s2, s3) = (s * s, s * s * s);
        let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
        let h10 = s3 - 2.0 * s2 + s;
        let h01 = -2.0 * s3 + 3.0 * s2;
        let h11 = s3 - s2;
        let (p0, p1) = (f(k0), f(k1));
        let (m0, m1) = (self.tangent(i, f), self.tangent(i + 1, f));
        [0, 1, 2].map(|k| h00 * p0[k] + h10 * h * m0[k] + h01 * p1[k] + h11 * h * m1[k])
    }
}
