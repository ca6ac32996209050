//! The mesh demos' window: fly camera (drag to look, WASD/QE to move) plus the UI — every
//! renderer and LPV setting, camera and lights, live profiler, screenshots and "Save scene".

use crate::cli::DemoArgs;
use crate::mesh_scene::{load, mesh_setup, settings_origin, view_at};
use crate::shell::Shell;
use glam::Vec3;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use vkengine::graph::execute::RecordedGraph;
use vkengine::mesh::camera::{FlyCamera, View};
use vkengine::mesh::gpu_scene::GpuScene;
use vkengine::mesh::renderer::{record_frame, MeshRenderer, MeshTargets};
use vkengine::mesh::settings::{MeshSetup, SCHEMA};
use vkengine::ui::controls;
use vkengine::ui::script::Action;
use vkengine::vk::{vk, Context};
use vkengine::window::{PresentTarget, WindowApp};
use vkengine::{Error, Result};
use winit::event::{ElementState, WindowEvent};
use winit::keyboard::Key;
use winit::window::Window;

/// Parsed settings and the `--set` list (with UI edits) they came from.
pub struct Live {
    /// Parsed.
    pub s: MeshSetup,
    /// `--set` plus UI edits (the scene file's `[settings]` sit under them).
    pub sets: Vec<(String, String)>,
}

/// The mesh window.
pub struct MeshWindow {
    args: DemoArgs,
    /// The scene file's `[settings]` (under `--set` and UI edits).
    file_settings: BTreeMap<String, String>,
    /// How errors name the scene file.
    origin: String,
    /// `builtin = NAME` or `model = PATH` for a saved scene file.
    source: (String, String),
    scene: GpuScene,
    renderer: MeshRenderer,
    live: Live,
    targets: Option<MeshTargets>,
    camera: FlyCamera,
    lens: View,
    step: f32,
    shell: Shell,
    in_flight: Option<RecordedGraph>,
    pending: Vec<(String, String)>,
    save_scene: bool,
    title: String,
}

/// What a saved scene file should load: the original scene file's model or builtin, a bare
/// model's path, or the demo's builtin.
fn scene_source(args: &DemoArgs, builtin: &str) -> (String, String) {
    let abs = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf()).display().to_string();
    let Some(path) = &args.scene else { return ("builtin".into(), builtin.into()) };
    if !path.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml")) {
        return ("model".into(), abs(path));
    }
    let table: Option<toml::Table> = std::fs::read_to_string(path).ok().and_then(|t| t.parse().ok());
    let get = |k: &str| table.as_ref().and_then(|t| t.get(k)).and_then(|v| v.as_str()).map(str::to_string);
    match (get("builtin"), get("model")) {
        (Some(b), _) => ("builtin".into(), b),
        (None, Some(m)) => ("model".into(), abs(&path.parent().unwrap_or(Path::new("")).join(m))),
        _ => ("builtin".into(), builtin.into()),
    }
}

impl MeshWindow {
    /// Loads the scene and builds the renderer.
    pub fn new(ctx: &Context, args: &DemoArgs, demo: &str, builtin: &str) -> Result<Self> {
        let (scene, _) = load(args, builtin)?;
        let origin = settings_origin(args, builtin);
        let s = mesh_setup(&origin, &scene.settings, &args.set)?;
        let lens = view_at(&scene, 0, 1);
        let size = scene.bounds.size();
        Ok(Self {
            args: args.clone(),
            file_settings: scene.settings.clone(),
            origin,
            source: scene_source(args, builtin),
            scene: GpuScene::upload(ctx, &scene)?,
            renderer: MeshRenderer::new(ctx)?,
            live: Live { s, sets: args.set.clone() },
            targets: None,
            camera: FlyCamera::from_view(&lens),
            lens,
            step: size.iter().fold(0.0f32, |a, &b| a.max(b)) * 0.02,
            shell: Shell::new(demo, args)?,
            in_flight: None,
            pending: Vec::new(),
            save_scene: false,
            title: format!("vkengine {demo}"),
        })
    }

    fn apply(&mut self) {
        if self.pending.is_empty() {
            return;
        }
        let mut sets = self.live.sets.clone();
        for (k, v) in std::mem::take(&mut self.pending) {
            controls::upsert(&mut sets, &k, &v);
        }
        match mesh_setup(&self.origin, &self.file_settings, &sets) {
            Ok(s) => {
                self.live = Live { s, sets };
                self.shell.status.clear();
            }
            Err(e) => self.shell.status = e.to_string(),
        }
    }

    fn build_ui(&mut self, ectx: &egui::Context) {
        egui::Window::new("Scene").default_pos([8.0, 8.0]).default_width(270.0).show(ectx, |ui| {
            egui::ScrollArea::vertical().max_height(ectx.content_rect().height() * 0.8).show(ui, |ui| {
                self.save_scene |= self.shell.actions(ui);
                self.pending.extend(controls::panel(ui, &SCHEMA, &self.live.s, &["LPV"]));
                egui::CollapsingHeader::new("Camera").show(ui, |ui| {
                    let p = &mut self.camera.position;
                    ui.horizontal(|ui| {
                        ui.label("position");
                        for c in [&mut p.x, &mut p.y, &mut p.z] {
                            ui.add(egui::DragValue::new(c).speed(self.step));
                        }
                    });
                    ui.add(
                        egui::Slider::new(&mut self.camera.yaw, -std::f32::consts::PI..=std::f32::consts::PI)
                            .text("yaw"),
                    );
                    ui.add(egui::Slider::new(&mut self.camera.pitch, -1.55..=1.55).text("pitch"));
                    let mut fov = self.lens.fov_y.to_degrees();
                    if ui.add(egui::Slider::new(&mut fov, 10.0..=120.0).text("fov°")).changed() {
                        self.lens.fov_y = fov.to_radians();
                    }
                    ui.add(egui::Slider::new(&mut self.step, 1e-3..=10.0).logarithmic(true).text("move step"));
                });
                egui::CollapsingHeader::new("Lights").show(ui, |ui| lights_ui(ui, &mut self.scene));
            });
        });
        let right = ectx.content_rect().width() - 268.0;
        egui::Window::new("Profiler")
            .default_pos([right, 8.0])
            .default_width(260.0)
            .show(ectx, |ui| self.shell.profiler.show(ui));
    }

    /// Writes a scene description reproducing this view: source, camera, lights, settings.
    fn save(&mut self) -> Result<()> {
        let base = match &self.args.out {
            Some(p) => p.with_extension(""),
            None => PathBuf::from(format!("screenshots/{}", self.title.trim_start_matches("vkengine "))),
        };
        let path = PathBuf::from(format!("{}-scene.toml", base.display()));
        let arr = |v: [f32; 3]| toml::Value::Array(v.iter().map(|&x| toml::Value::Float(f64::from(x))).collect());
        let mut t = toml::Table::new();
        t.insert(self.source.0.clone(), toml::Value::String(self.source.1.clone()));
        let pos = self.camera.position;
        let mut cam = toml::Table::new();
        cam.insert("position".into(), arr(pos.into()));
        cam.insert("target".into(), arr((pos + self.camera.forward()).into()));
        cam.insert("up".into(), arr(self.lens.up));
        cam.insert("fov".into(), toml::Value::Float(f64::from(self.lens.fov_y.to_degrees())));
        cam.insert("near".into(), toml::Value::Float(f64::from(self.lens.near)));
        cam.insert("far".into(), toml::Value::Float(f64::from(self.lens.far)));
        t.insert("camera".into(), toml::Value::Table(cam));
        let mut lights = Vec::new();
        let split = |rgb: [f32; 3]| {
            let m = rgb.iter().fold(0.0f32, |a, &b| a.max(b));
            (if m > 0.0 { rgb.map(|c| c / m) } else { [1.0; 3] }, m)
        };
        if let Some(sun) = self.scene.sun {
            let (color, intensity) = split(sun.irradiance);
            let mut l = toml::Table::new();
            l.insert("type".into(), "directional".into());
            l.insert("direction".into(), arr((-Vec3::from(sun.to_sun)).into()));
            l.insert("color".into(), arr(color));
            l.insert("intensity".into(), toml::Value::Float(f64::from(intensity)));
            lights.push(toml::Value::Table(l));
        }
        for s in &self.scene.spots {
            let (color, intensity) = split(s.intensity);
            let mut l = toml::Table::new();
            l.insert("type".into(), "spot".into());
            l.insert("position".into(), arr(s.position));
            l.insert("direction".into(), arr(s.direction));
            l.insert("color".into(), arr(color));
            l.insert("intensity".into(), toml::Value::Float(f64::from(intensity)));
            l.insert("inner_angle_deg".into(), toml::Value::Float(f64::from(s.angles[0].to_degrees())));
            l.insert("outer_angle_deg".into(), toml::Value::Float(f64::from(s.angles[1].to_degrees())));
            l.insert("range".into(), toml::Value::Float(f64::from(s.range)));
            lights.push(toml::Value::Table(l));
        }
        if !lights.is_empty() {
            t.insert("lights".into(), toml::Value::Array(lights));
        }
        let mut settings: toml::Table =
            self.file_settings.iter().map(|(k, v)| (k.clone(), toml::Value::String(v.clone()))).collect();
        for (k, v) in &self.live.sets {
            settings.insert(k.clone(), toml::Value::String(v.clone()));
        }
        t.insert("settings".into(), toml::Value::Table(settings));
        let text = format!(
            "# vkengine scene saved from the window — replay with: scene --scene {}\n{}",
            path.display(),
            toml::to_string(&t).map_err(|e| Error::Input(e.to_string()))?
        );
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.display().to_string(), source })?;
        }
        std::fs::write(&path, text).map_err(|source| Error::Io { path: path.display().to_string(), source })?;
        self.shell.status = format!("saved {}", path.display());
        eprintln!("{}", self.shell.status);
        Ok(())
    }
}

/// The sun's direction (azimuth, elevation) and strength, and each spot's strength.
fn lights_ui(ui: &mut egui::Ui, scene: &mut GpuScene) {
    if let Some(sun) = &mut scene.sun {
        let d = Vec3::from(sun.to_sun);
        let (mut az, mut el) = (d.x.atan2(d.z).to_degrees(), d.y.clamp(-1.0, 1.0).asin().to_degrees());
        let m = sun.irradiance.iter().fold(0.0f32, |a, &b| a.max(b));
        let mut strength = m;
        let a = ui.add(egui::Slider::new(&mut az, -180.0..=180.0).text("sun azimuth°"));
        let e = ui.add(egui::Slider::new(&mut el, 1.0..=90.0).text("sun elevation°"));
        let s = ui.add(egui::Slider::new(&mut strength, 0.0..=50.0).text("sun irradiance"));
        if a.changed() || e.changed() {
            let (az, el) = (az.to_radians(), el.to_radians());
            sun.to_sun = [el.cos() * az.sin(), el.sin(), el.cos() * az.cos()];
        }
        if s.changed() && m > 0.0 {
            sun.irradiance = sun.irradiance.map(|c| c * strength / m);
        }
    } else {
        ui.label("no sun");
    }
    for (n, spot) in scene.spots.iter_mut().enumerate() {
        let m = spot.intensity.iter().fold(0.0f32, |a, &b| a.max(b));
        let mut strength = m;
        if ui
            .add(egui::Slider::new(&mut strength, 0.0..=1000.0).logarithmic(true).text(format!("spot {n} W/sr")))
            .changed()
            && m > 0.0
        {
            spot.intensity = spot.intensity.map(|c| c * strength / m);
        }
    }
}

impl WindowApp for MeshWindow {
    fn render(
        &mut self,
        ctx: &Context,
        window: &Window,
        cmd: vk::CommandBuffer,
        frame: u64,
        target: PresentTarget,
    ) -> Result<()> {
        let extent = target.extent;
        self.shell.frame_done(self.in_flight.take());
        if let Some(t) = self.targets.as_ref() {
            self.shell.write_due_shot(t.size(), || t.read_ldr(ctx), || t.read_hdr(ctx))?;
            // No accumulation here: the error is re-measured as frames go by.
            self.shell.measure(t.size(), frame, || t.read_hdr(ctx))?;
        }
        for action in self.shell.begin_frame(ctx, window, frame)? {
            if action == Action::SaveScene {
                self.save_scene = true;
            }
        }
        if let Some(mut overlay) = self.shell.overlay.take() {
            let built = overlay.run(ctx, window, extent, |c| self.build_ui(c));
            self.shell.overlay = Some(overlay);
            built?;
        }
        self.apply();
        if std::mem::take(&mut self.save_scene) {
            if let Err(e) = self.save() {
                self.shell.status = e.to_string();
            }
        }
        let rsm_now = self.targets.as_ref().map(|t| t.rsm.as_ref().map_or(0, |r| r.flux.info.extent[0]));
        if self.targets.as_ref().is_none_or(|t| t.size() != extent) || rsm_now != Some(self.live.s.rsm_size()) {
            self.targets = Some(MeshTargets::new(ctx, extent, self.live.s.rsm_size())?);
        }
        let t = self.targets.as_mut().ok_or_else(|| Error::Input("no targets".into()))?;
        let view = self.camera.view(self.lens.fov_y, self.lens.near, self.lens.far);
        let overlay = self.shell.frame_overlay();
        let rec =
            record_frame(ctx, cmd, &self.renderer, &self.scene, t, &view, &self.live.s.settings, overlay, target)?;
        self.in_flight = Some(rec);
        self.shell.frame_recorded();
        Ok(())
    }

    fn input(&mut self, window: &Window, event: &WindowEvent) {
        if self.shell.input(window, event) {
            return;
        }
        if let Some((dx, dy)) = self.shell.drag(event) {
            self.camera.turn(-dx * 0.005, -dy * 0.005);
        }
        match event {
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                let s = self.step;
                if let Key::Character(c) = &event.logical_key {
                    match c.as_str() {
                        "w" => self.camera.translate(s, 0.0, 0.0),
                        "s" => self.camera.translate(-s, 0.0, 0.0),
                        "a" => self.camera.translate(0.0, -s, 0.0),
                        "d" => self.camera.translate(0.0, s, 0.0),
                        "e" => self.camera.translate(0.0, 0.0, s),
                        "q" => self.camera.translate(0.0, 0.0, -s),
                        _ => {}
                    }
                }
            }
            _ => {}
        }
    }

    fn title(&self) -> Option<String> {
        Some(format!("{} — {:.2} ms GPU", self.title, self.shell.profiler.last_frame_ms()))
    }

    fn wants_exit(&self) -> bool {
        self.shell.wants_exit()
    }
}

/// Opens the mesh window and runs it until closed; validation messages fail the run.
pub fn run(args: &DemoArgs, demo: &str, builtin: &str) -> Result<()> {
    crate::runner::run_window(format!("vkengine {demo}"), args, |ctx| MeshWindow::new(ctx, args, demo, builtin))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_control_writes_a_key_the_parser_reads() {
        let empty = BTreeMap::new();
        let defaults = mesh_setup("test", &empty, &[]).expect("defaults");
        for (c, kind) in controls::controls(&SCHEMA) {
            let moved = controls::moved(c.key, kind, &c.value(&defaults));
            // Keys that only make sense with the LPV (and its RSM) on are tested with it on.
            let mut sets = vec![("lpv".to_string(), "1".to_string())];
            if c.key == "lpv" {
                sets.clear();
            }
            sets.push((c.key.to_string(), controls::format_value(&moved)));
            let s = mesh_setup("test", &empty, &sets).unwrap_or_else(|e| panic!("{}: {e}", c.key));
            assert_eq!(c.value(&s), moved, "{}", c.key);
        }
    }
}
