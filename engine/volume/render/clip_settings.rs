//! Clipping: a crop box and up to six clip planes (`--set crop=… clip=… clip2=…`), declared once
//! in the schema, and their planes as the shaders' `Params.clip` (`shaders_glsl/volume/common.glsl`).

use super::settings::VolumeSetup;
use crate::settings::{Key, Sliders, Type};

/// Clip planes a setting may name (`clip`, `clip2` … `clip6`).
pub const MAX_PLANES: usize = 6;
/// Planes the shaders read: the crop box's six, then the clip planes.
pub const MAX_GPU_PLANES: usize = 6 + MAX_PLANES;

/// What is kept of the volume: the box, cut to the crop box and the kept side of each plane.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct ClipSettings {
    /// Axis-aligned box kept, `[x0, y0, z0, x1, y1, z1]` in world units (the volume's box is
    /// centred on the origin, largest axis 1); `None` keeps everything.
    pub crop: Option<[f32; 6]>,
    /// Rotation of the crop box about its centre, degrees about x, then y, then z (world axes);
    /// `None` keeps it axis-aligned.
    pub crop_rotation: Option<[f32; 3]>,
    /// Monte Carlo only: paths after the camera segment see the unclipped volume, so the removed
    /// part still shadows and scatters onto the cut face. Off (vacuum) by default.
    pub shadows: bool,
    /// Planes `[px, py, pz, nx, ny, nz]` (a point and a normal): the side the normal points away
    /// from is kept.
    pub planes: [Option<[f32; 6]>; MAX_PLANES],
}

impl ClipSettings {
    /// Whether anything is clipped.
    pub fn active(&self) -> bool {
        self.crop.is_some() || self.planes.iter().any(Option::is_some)
    }

    /// The planes `(n, d)`, kept where `n·x <= d`, and how many: the crop box's faces, then the
    /// clip planes with unit normals. Zero planes when nothing is clipped.
    pub fn gpu_planes(&self) -> ([[f32; 4]; MAX_GPU_PLANES], u32) {
        let mut out = [[0.0; 4]; MAX_GPU_PLANES];
        let mut n = 0;
        let mut push = |p: [f32; 4]| {
            out[n] = p;
            n += 1;
        };
        if let (Some(c), Some(r)) = (self.crop, self.crop_rotation) {
            for p in oriented_box_planes(c, r) {
                push(p);
            }
        } else if let Some([x0, y0, z0, x1, y1, z1]) = self.crop {
            for (axis, (lo, hi)) in [(x0, x1), (y0, y1), (z0, z1)].into_iter().enumerate() {
                let mut e = [0.0; 4];
                e[axis] = -1.0;
                e[3] = -lo;
                push(e);
                e[axis] = 1.0;
                e[3] = hi;
                push(e);
            }
        }
        for [px, py, pz, nx, ny, nz] in self.planes.iter().flatten().copied() {
            let len = (nx * nx + ny * ny + nz * nz).sqrt();
            let [ux, uy, uz] = [nx / len, ny / len, nz / len];
            push([ux, uy, uz, ux * px + uy * py + uz * pz]);
        }
        (out, n as u32)
    }
}

/// Rotation matrix (columns are the box's axes in world space) for rotations by `deg` degrees
/// about x, then y, then z: `R = Rz · Ry · Rx`, in f64 so the six planes agree to f32 rounding.
pub fn crop_rotation_matrix(deg: [f32; 3]) -> [[f64; 3]; 3] {
    let [a, b, c] = deg.map(|d| f64::from(d).to_radians());
    let (sa, ca, sb, cb, sc, cc) = (a.sin(), a.cos(), b.sin(), b.cos(), c.sin(), c.cos());
    // Rows of Rz·Ry·Rx.
    [
        [cc * cb, cc * sb * sa - sc * ca, cc * sb * ca + sc * sa],
        [sc * cb, sc * sb * sa + cc * ca, sc * sb * ca - cc * sa],
        [-sb, cb * sa, cb * ca],
    ]
}

/// The six faces `(n, d)` of the crop box `c` rotated by `deg` about its centre: a face of the
/// axis-aligned box with outward normal `e` and half-extent `h` keeps `e·Rᵀ(x − m) <= h`, that is
/// `(R e)·x <= h + (R e)·m` with `m` the centre.
fn oriented_box_planes(c: [f32; 6], deg: [f32; 3]) -> [[f32; 4]; 6] {
    let r = crop_rotation_matrix(deg);
    let mut out = [[0.0; 4]; 6];
    for axis in 0..3 {
        let (lo, hi) = (f64::from(c[axis]), f64::from(c[axis + 3]));
        let h = 0.5 * (hi - lo);
        let m = [0, 1, 2].map(|i| 0.5 * (f64::from(c[i]) + f64::from(c[i + 3])));
        let col = [r[0][axis], r[1][axis], r[2][axis]];
        for (k, sign) in [-1.0f64, 1.0].into_iter().enumerate() {
            let n = col.map(|v| sign * v);
            let d = h + n[0] * m[0] + n[1] * m[1] + n[2] * m[2];
            out[2 * axis + k] = [n[0] as f32, n[1] as f32, n[2] as f32, d as f32];
        }
    }
    out
}

/// Three angles in degrees, finite and within ±360.
fn angles(t: &str) -> std::result::Result<Option<[f32; 3]>, String> {
    if matches!(t.trim(), "" | "none") {
        return Ok(None);
    }
    let parts: Vec<&str> = t.split(',').collect();
    let v: Vec<f32> = parts.iter().filter_map(|p| p.trim().parse().ok()).collect();
    match v[..] {
        [a, b, c] if parts.len() == 3 && v.iter().all(|c| c.is_finite() && c.abs() <= 360.0) => Ok(Some([a, b, c])),
        _ => Err("expected three angles AX,AY,AZ in degrees within ±360, or `none`".into()),
    }
}

/// Six numbers, finite and within ±1e4.
fn six(t: &str) -> std::result::Result<[f32; 6], String> {
    let parts: Vec<&str> = t.split(',').collect();
    let v: Vec<f32> = parts.iter().filter_map(|p| p.trim().parse().ok()).collect();
    match v[..] {
        [a, b, c, d, e, f] if parts.len() == 6 && v.iter().all(|c| c.is_finite() && c.abs() <= 1e4) => {
            Ok([a, b, c, d, e, f])
        }
        _ => Err("expected six numbers within ±1e4, or `none`".into()),
    }
}

// Callers have the six numbers finite already (`six`).
fn check_crop(c: [f32; 6]) -> std::result::Result<(), String> {
    if (0..3).any(|i| c[i] >= c[i + 3]) {
        return Err("the box is empty or inverted: expected X0,Y0,Z0,X1,Y1,Z1 with X0 < X1, Y0 < Y1, Z0 < Z1".into());
    }
    Ok(())
}

fn check_plane(p: [f32; 6]) -> std::result::Result<(), String> {
    let [nx, ny, nz] = [p[3], p[4], p[5]];
    if (nx * nx + ny * ny + nz * nz).sqrt() <= 1e-6 {
        return Err("the normal NX,NY,NZ is zero".into());
    }
    Ok(())
}

/// `none` (or nothing) clears the setting; anything else must pass `check`.
fn parse(
    t: &str,
    check: fn([f32; 6]) -> std::result::Result<(), String>,
) -> std::result::Result<Option<[f32; 6]>, String> {
    if matches!(t.trim(), "" | "none") {
        return Ok(None);
    }
    let v = six(t)?;
    check(v)?;
    Ok(Some(v))
}

/// The text of a value, `none` when unset (the window's choice shows it).
fn show(v: Option<[f32; 6]>) -> Option<String> {
    Some(v.map_or_else(|| "none".into(), |v| v.map(|c| c.to_string()).join(",")))
}

const GROUP: &str = "Clipping";
const PLANE_HINT: &str = "PX,PY,PZ,NX,NY,NZ | none";
/// The window's sliders: points within the volume's box (largest axis 1), unit-range normals.
static PLANE_SLIDERS: Sliders = Sliders {
    spans: &[
        ("px", -0.5, 0.5),
        ("py", -0.5, 0.5),
        ("pz", -0.5, 0.5),
        ("nx", -1.0, 1.0),
        ("ny", -1.0, 1.0),
        ("nz", -1.0, 1.0),
    ],
    initial: "0,0,0,1,0,0",
};
static CROP_SLIDERS: Sliders = Sliders {
    spans: &[
        ("x0", -0.5, 0.5),
        ("y0", -0.5, 0.5),
        ("z0", -0.5, 0.5),
        ("x1", -0.5, 0.5),
        ("y1", -0.5, 0.5),
        ("z1", -0.5, 0.5),
    ],
    initial: "-0.5,-0.5,-0.5,0.5,0.5,0.5",
};
static ROTATION_SLIDERS: Sliders =
    Sliders { spans: &[("ax", -180.0, 180.0), ("ay", -180.0, 180.0), ("az", -180.0, 180.0)], initial: "0,0,0" };

macro_rules! plane {
    ($i:literal, $key:literal, $doc:literal) => {
        Key {
            key: $key,
            group: GROUP,
            doc: $doc,
            ui: true,
            ty: Type::Text {
                hint: PLANE_HINT,
                presets: &[],
                sliders: Some(&PLANE_SLIDERS),
                get: |s| show(s.render.clip.planes[$i]),
                set: |s, t| {
                    s.render.clip.planes[$i] = parse(t, check_plane)?;
                    Ok(())
                },
            },
        }
    };
}

/// The clipping keys (part of the volume renderers' schema).
pub(super) static CLIPPING: [Key<VolumeSetup>; 3 + MAX_PLANES] = [
    Key {
        key: "crop",
        group: GROUP,
        doc: "keep only this axis-aligned box, in world units (the volume's box is centred on the origin, largest axis 1); every renderer, vacuum to Monte Carlo paths",
        ui: true,
        ty: Type::Text {
            hint: "X0,Y0,Z0,X1,Y1,Z1 | none",
            presets: &[],
            sliders: Some(&CROP_SLIDERS),
            get: |s| show(s.render.clip.crop),
            set: |s, t| {
                s.render.clip.crop = parse(t, check_crop)?;
                Ok(())
            },
        },
    },
    Key {
        key: "crop_rotation",
        group: GROUP,
        doc: "rotate the crop box about its centre by AX, AY, AZ degrees about the world's x, then y, then z axis (an oriented crop box, exact in every renderer like the axis-aligned one); no effect without `crop`",
        ui: true,
        ty: Type::Text {
            hint: "AX,AY,AZ | none",
            presets: &[],
            sliders: Some(&ROTATION_SLIDERS),
            get: |s| Some(s.render.clip.crop_rotation.map_or_else(|| "none".into(), |v| v.map(|c| c.to_string()).join(","))),
            set: |s, t| {
                s.render.clip.crop_rotation = angles(t)?;
                Ok(())
            },
        },
    },
    Key {
        key: "clip_shadows",
        group: GROUP,
        doc: "MCS and MCM: `on` lets the clipped part still cast shadows and scatter light (only the camera's segment is clipped; every later path segment sees the whole volume), `off` makes it vacuum",
        ui: true,
        ty: Type::Choice {
            names: &["off", "on"],
            get: |s| if s.render.clip.shadows { "on" } else { "off" },
            set: |s, t| s.render.clip.shadows = t == "on",
        },
    },
    plane!(0, "clip", "clip plane through point P with normal N: the side N points away from is kept; every renderer, vacuum to Monte Carlo paths"),
    plane!(1, "clip2", "second clip plane (as `clip`)"),
    plane!(2, "clip3", "third clip plane (as `clip`)"),
    plane!(3, "clip4", "fourth clip plane (as `clip`)"),
    plane!(4, "clip5", "fifth clip plane (as `clip`)"),
    plane!(5, "clip6", "sixth clip plane (as `clip`)"),
];
