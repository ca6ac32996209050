//! Scene description files (TOML) and [`load_scene`], the entry point for `--scene FILE`.
//!
//! ```toml
//! model = "sponza/sponza.obj"      # relative to this file; or: builtin = "cornell" | "atrium"
//! [camera]
//! position = [0.0, 1.5, 4.0]
//! target = [0.0, 1.0, 0.0]
//! fov = 45.0                       # vertical, degrees; also optional up, near, far
//! [[camera_path]]                  # optional, two or more keys for an animation
//! time = 0.0
//! position = [0.0, 1.5, 4.0]
//! target = [0.0, 1.0, 0.0]
//! [[lights]]                       # replaces the model's/builtin's lights when present
//! type = "directional"             # direction the light travels
//! direction = [-0.3, -1.0, -0.2]
//! intensity = 3.0
//! [[lights]]
//! type = "spot"                    # angles are half-angles in degrees
//! position = [0.0, 3.0, 0.0]
//! direction = [0.0, -1.0, 0.0]
//! intensity = 10.0
//! inner_angle_deg = 30.0
//! outer_angle_deg = 45.0
//! [settings]                       # renderer settings; strings, numbers or booleans
//! cascades = 3
//! ```

use std::collections::BTreeMap;
use std::path::Path;

use serde::Deserialize;

use super::{procedural, Camera, CameraKey, CameraPath, Light, Scene};
use crate::{Error, Result};

/// The file extensions [`load_scene`] accepts, for messages.
pub const ACCEPTED_EXTENSIONS: &str = ".toml (scene description), .gltf, .glb, .obj";

/// Loads a scene description (`.toml`) or a bare model (`.gltf`, `.glb`, `.obj`, framed with a default
/// camera and sun).
pub fn load_scene(path: &Path) -> Result<Scene> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
    match ext.as_str() {
        "toml" => load_description(path),
        "gltf" | "glb" => super::gltf_load::load_gltf(path),
        "obj" => super::obj_load::load_obj(path),
        _ => Err(Error::Input(format!(
            "{}: unsupported scene file extension `{ext}`; accepted: {ACCEPTED_EXTENSIONS}",
            path.display()
        ))),
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Description {
    model: Option<String>,
    builtin: Option<String>,
    camera: Option<CameraDesc>,
    #[serde(default)]
    camera_path: Vec<KeyDesc>,
    #[serde(default)]
    lights: Vec<LightDesc>,
    #[serde(default)]
    settings: BTreeMap<String, toml::Value>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraDesc {
    position: [f32; 3],
    target: [f32; 3],
    up: Option<[f32; 3]>,
    fov: Option<f32>,
    near: Option<f32>,
    far: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct KeyDesc {
    time: f32,
    position: [f32; 3],
    target: [f32; 3],
}

#[derive(Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
enum LightDesc {
    Directional {
        direction: [f32; 3],
        color: Option<[f32; 3]>,
        intensity: f32,
    },
    Spot {
        position: [f32; 3],
        direction: [f32; 3],
        color: Option<[f32; 3]>,
        intensity: f32,
        inner_angle_deg: f32,
        outer_angle_deg: f32,
        range: Option<f32>,
    },
    Point {
        position: [f32; 3],
        color: Option<[f32; 3]>,
        intensity: f32,
        range: Option<f32>,
    },
}

fn load_description(path: &Path) -> Result<Scene> {
    let f = path.display().to_string();
    let bytes = super::read_file(path)?;
    let text = String::from_utf8(bytes).map_err(|_| Error::Input(format!("{f}: not UTF-8 text")))?;
    let desc: Description = toml::from_str(&text).map_err(|e| {
        let line = e.span().and_then(|s| text.get(..s.start)).map(|t| t.matches('\n').count() + 1);
        let at = line.map(|l| format!(":{l}")).unwrap_or_default();
        Error::Input(format!("{f}{at}: {}", e.message().trim()))
    })?;
    let bad = |what: String| Error::Input(format!("{f}: {what}"));

    let mut scene = match (&desc.model, &desc.builtin) {
        (Some(_), Some(_)) => return Err(bad("give either `model` or `builtin`, not both".into())),
        (None, None) => return Err(bad("missing `model = \"path\"` or `builtin = \"cornell\" | \"atrium\"`".into())),
        (Some(model), None) => {
            let model_path = path.parent().unwrap_or(Path::new(".")).join(model);
            match model_path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
                Some("gltf" | "glb" | "obj") => load_scene(&model_path)?,
                _ => return Err(bad(format!("model `{model}` must be a .gltf, .glb or .obj file"))),
            }
        }
        (None, Some(b)) => match procedural::builtin(b) {
            Some(scene) => scene,
            None => return Err(bad(format!("unknown builtin `{b}`; expected \"cornell\" or \"atrium\""))),
        },
    };

    if let Some(c) = desc.camera {
        let fov = c.fov.unwrap_or(scene.camera.fov_y_deg);
        if !(fov > 0.0 && fov < 180.0) {
            return Err(bad(format!("camera fov {fov} must be between 0 and 180 degrees")));
        }
        let near = c.near.unwrap_or(scene.camera.near);
        let far = c.far.unwrap_or(scene.camera.far.max(near * 2.0));
        if !(near > 0.0 && far > near) {
            return Err(bad(format!("camera near {near} / far {far}: need 0 < near < far")));
        }
        let finite = c.position.iter().chain(&c.target).chain(c.up.iter().flatten()).all(|v| v.is_finite());
        if !finite || c.position == c.target {
            return Err(bad("camera position and target must be finite and distinct".into()));
        }
        scene.camera = Camera {
            position: c.position,
            target: c.target,
            up: c.up.unwrap_or([0.0, 1.0, 0.0]),
            fov_y_deg: fov,
            near,
            far,
        };
    }
    if !desc.camera_path.is_empty() {
        let keys = desc.camera_path.iter().map(|k| CameraKey { time: k.time, position: k.position, target: k.target });
        scene.camera_path = Some(CameraPath::new(keys.collect()).map_err(bad)?);
    }
    if !desc.lights.is_empty() {
        scene.lights = desc
            .lights
            .into_iter()
            .enumerate()
            .map(|(i, l)| light(l).map_err(|e| bad(format!("lights[{i}]: {e}"))))
            .collect::<Result<_>>()?;
    }
    for (k, v) in desc.settings {
        let s = crate::settings::toml_text(&v)
            .ok_or_else(|| bad(format!("settings.{k}: must be a string, number or boolean")))?;
        scene.settings.insert(k, s);
    }
    Ok(scene)
}

fn unit(v: [f32; 3], what: &str) -> Result<[f32; 3], String> {
    glam::Vec3::from(v).try_normalize().map(Into::into).ok_or(format!("{what} must be a non-zero finite vector"))
}

fn light(l: LightDesc) -> Result<Light, String> {
    let white = [1.0; 3];
    let check = |intensity: f32| {
        if intensity.is_finite() && intensity >= 0.0 {
            Ok(())
        } else {
            Err(format!("intensity {intensity} must be finite and >= 0"))
        }
    };
    Ok(match l {
        LightDesc::Directional { direction, color, intensity } => {
            check(intensity)?;
            Light::Directional { direction: unit(direction, "direction")?, color: color.unwrap_or(white), intensity }
        }
        LightDesc::Spot { position, direction, color, intensity, inner_angle_deg, outer_angle_deg, range } => {
            check(intensity)?;
            if !(0.0 <= inner_angle_deg && inner_angle_deg <= outer_angle_deg && outer_angle_deg <= 90.0) {
                return Err(format!(
                    "need 0 <= inner_angle_deg ({inner_angle_deg}) <= outer_angle_deg ({outer_angle_deg}) <= 90"
                ));
            }
            Light::Spot {
                position,
                direction: unit(direction, "direction")?,
                color: color.unwrap_or(white),
                intensity,
                inner_angle: inner_angle_deg.to_radians(),
                outer_angle: outer_angle_deg.to_radians(),
                range: range.unwrap_or(f32::INFINITY),
            }
        }
        LightDesc::Point { position, color, intensity, range } => {
            check(intensity)?;
            Light::Point { position, color: color.unwrap_or(white), intensity, range: range.unwrap_or(f32::INFINITY) }
        }
    })
}
