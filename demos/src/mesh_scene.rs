//! What the mesh demos' headless run and window share: loading the scene (built-in, a scene
//! description or a bare model), its settings layered under `--set`, and the camera path.

use crate::cli::DemoArgs;
use std::collections::BTreeMap;
use std::time::Instant;
use vkengine::mesh::camera::View;
use vkengine::mesh::renderer::MeshSettings;
use vkengine::mesh::settings::{MeshSetup, SCHEMA};
use vkengine::scene::{self, Scene};
use vkengine::settings::{self, Origin};
use vkengine::{Error, Result};

/// Settings keys the mesh renderer understands (scene file `[settings]` or `--set`), from its schema.
pub fn keys() -> Vec<&'static str> {
    SCHEMA.names()
}

/// Renderer settings: defaults, then the scene file's `[settings]` (`origin` names the file in
/// errors), then `--set` (which wins).
pub fn mesh_setup(origin: &str, file: &BTreeMap<String, String>, sets: &[(String, String)]) -> Result<MeshSetup> {
    MeshSetup::parse(&settings::layered(file, &Origin::File(origin.to_string()), sets))
}

/// [`mesh_setup`] for a file named only "scene file": the settings and the RSM edge.
pub fn mesh_settings(file: &BTreeMap<String, String>, sets: &[(String, String)]) -> Result<(MeshSettings, u32)> {
    let s = mesh_setup("scene file", file, sets)?;
    Ok((s.settings, s.rsm_size()))
}

/// How errors name the scene's `[settings]`: its file, or the built-in scene.
pub fn settings_origin(args: &DemoArgs, builtin: &str) -> String {
    args.scene.as_ref().map_or_else(|| format!("built-in scene {builtin}"), |p| p.display().to_string())
}

/// Loads `--scene FILE` or the demo's built-in scene.
pub fn load(args: &DemoArgs, builtin: &str) -> Result<(Scene, f64)> {
    let start = Instant::now();
    let scene = match &args.scene {
        Some(path) => scene::load_scene(path)?,
        None => builtin_scene(builtin)?,
    };
    Ok((scene, start.elapsed().as_secs_f64() * 1e3))
}

pub use scene::procedural::BUILTIN;

/// A built-in scene by name; an unknown name is bad input.
pub fn builtin_scene(name: &str) -> Result<Scene> {
    scene::procedural::builtin(name)
        .ok_or_else(|| Error::Input(format!("unknown built-in scene `{name}` (expected {})", BUILTIN.join(" or "))))
}

/// The view at `frame` of `frames`: along the scene's camera path if it has one.
pub fn view_at(scene: &Scene, frame: u64, frames: u64) -> View {
    let cam = match &scene.camera_path {
        Some(path) if frames > 1 => {
            let t0 = path.keys.first().map_or(0.0, |k| k.time);
            let t1 = path.keys.last().map_or(0.0, |k| k.time);
            path.at(t0 + (t1 - t0) * frame as f32 / (frames - 1) as f32, &scene.camera)
        }
        _ => scene.camera,
    };
    View::look_at(cam.position.into(), cam.target.into(), cam.up.into(), cam.fov_y_deg, cam.near, cam.far)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_overrides_the_scene_file_which_overrides_the_default() {
        let file: BTreeMap<String, String> = [("lpv_steps", "6"), ("pcf", "3"), ("lpv", "1")]
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        let sets = vec![("lpv_steps".to_string(), "2".to_string()), ("lpv".to_string(), "0".to_string())];
        let (from_file, _) = mesh_settings(&file, &[]).expect("file");
        assert_eq!((from_file.lpv.steps, from_file.pcf_radius, from_file.lpv.enabled), (6, 3, true));
        let (overridden, _) = mesh_settings(&file, &sets).expect("file + --set");
        assert_eq!((overridden.lpv.steps, overridden.pcf_radius, overridden.lpv.enabled), (2, 3, false));
        // Repeated --set: the last one wins.
        let twice = vec![("pcf".to_string(), "1".to_string()), ("pcf".to_string(), "2".to_string())];
        assert_eq!(mesh_settings(&file, &twice).expect("twice").0.pcf_radius, 2);
    }
}
