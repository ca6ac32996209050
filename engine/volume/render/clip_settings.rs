//! Clipping: a crop box and up to six clip planes (`--set crop=… clip=… clip2=…`), declared once
//! in the schema, and their planes as the shaders' `Params.clip` (`shaders_glsl/volume/common.glsl`).

use super::settings::VolumeSetup;
use crate::settings::{Key, Type};

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
        if let Some([x0, y0, z0, x1, y1, z1]) = self.crop {
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

macro_rules! plane {
    ($i:literal, $key:literal, $doc:literal, $ui:literal, $presets:expr) => {
        Key {
            key: $key,
            group: GROUP,
            doc: $doc,
            ui: $ui,
            ty: Type::Text {
                hint: PLANE_HINT,
                presets: $presets,
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
pub(super) static CLIPPING: [Key<VolumeSetup>; 1 + MAX_PLANES] = [
    Key {
        key: "crop",
        group: GROUP,
        doc: "keep only this axis-aligned box, in world units (the volume's box is centred on the origin, largest axis 1); every renderer, vacuum to Monte Carlo paths",
        ui: false,
        ty: Type::Text {
            hint: "X0,Y0,Z0,X1,Y1,Z1 | none",
            presets: &[],
            get: |s| show(s.render.clip.crop),
            set: |s, t| {
                s.render.clip.crop = parse(t, check_crop)?;
                Ok(())
            },
        },
    },
    plane!(0, "clip", "clip plane through point P with normal N: the side N points away from is kept; every renderer, vacuum to Monte Carlo paths", true,
        &["none", "0,0,0,1,0,0", "0,0,0,-1,0,0", "0,0,0,0,1,0", "0,0,0,0,-1,0", "0,0,0,0,0,1", "0,0,0,0,0,-1"]),
    plane!(1, "clip2", "second clip plane (as `clip`)", false, &[]),
    plane!(2, "clip3", "third clip plane (as `clip`)", false, &[]),
    plane!(3, "clip4", "fourth clip plane (as `clip`)", false, &[]),
    plane!(4, "clip5", "fifth clip plane (as `clip`)", false, &[]),
    plane!(5, "clip6", "sixth clip plane (as `clip`)", false, &[]),
];
