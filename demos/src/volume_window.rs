//! The volume demo's window: orbit camera (drag, scroll) plus the UI — every renderer setting,
//! camera, transfer-function editor, live profiler, screenshots and "Save scene".

use crate::cli::{setting, DemoArgs};
use crate::shell::Shell;
use crate::volume_scene::{camera, env_map, load_labels, load_scene, volume_setup};
use crate::volume_session::VolumeSession;
use std::path::PathBuf;
use vkengine::graph::execute::RecordedGraph;
use vkengine::ui::controls;
use vkengine::ui::script::Action;
use vkengine::ui::tf_editor::{TfEditor, TfEvent};
use vkengine::vk::{vk, Context};
use vkengine::volume::camera::{Camera, Projection, Rig};
use vkengine::volume::data::labels::LabelVolume;
use vkengine::volume::optics::label_table::LabelTable;
use vkengine::volume::render::renderer::{
    record_frame, McSettings, RenderSettings, RendererKind, Targets, VolumeRenderer,
};
use vkengine::volume::render::settings::{VolumeSetup, BUDGET_AUTO, SCHEMA};
use vkengine::window::{PresentTarget, WindowApp};
use vkengine::{Error, Result};
use winit::event::{MouseScrollDelta, WindowEvent};
use winit::window::Window;

/// The parsed settings next to the `key=value` list they came from.
pub struct Live {
    /// Parsed.
    pub s: VolumeSetup,
    /// The list (`--set` plus UI edits).
    pub sets: Vec<(String, String)>,
}

/// The volume window.
pub struct VolumeWindow {
    args: DemoArgs,
    renderer: VolumeRenderer,
    targets: Option<Targets>,
    camera: Camera,
    live: Live,
    tf: TfEditor,
    shell: Shell,
    in_flight: Option<RecordedGraph>,
    pending: Vec<(String, String)>,
    tf_changed: bool,
    tf_open: bool,
    save_scene: bool,
    /// Monte Carlo pacing toward `mc_frame_ms`.
    pacing: Pacing,
    /// The label map's segments present in it, for the Segments panel (empty without one).
    segments: Vec<SegmentRow>,
}

/// One label of the loaded label map as the Segments panel lists it.
struct SegmentRow {
    label: u32,
    name: String,
    colour: [f32; 3],
    /// The colour table's opacity scale (`label_opacity` overrides it).
    opacity: f32,
}

/// The labels that occur in `labels`, with their table names and colours.
fn segment_rows(labels: Option<&(LabelVolume, LabelTable)>) -> Vec<SegmentRow> {
    let Some((l, t)) = labels else { return Vec::new() };
    let present = vkengine::volume::optics::label_table::present(l);
    (0u32..)
        .zip(present)
        .filter(|(_, p)| *p)
        .map(|(label, _)| {
            let e = t.entries[label as usize];
            let name = t.names.get(&label).cloned().unwrap_or_else(|| {
                if label == 0 {
                    "unlabelled".into()
                } else {
                    String::new()
                }
            });
            SegmentRow { label, name, colour: [e[0], e[1], e[2]], opacity: e[3] }
        })
        .collect()
}

/// Per label of the map: its colour, a visibility box and an opacity slider; they edit
/// `label_hide` and `label_opacity` (so a saved session keeps them). Returns the edit.
fn segments_ui(
    ui: &mut egui::Ui,
    rows: &[SegmentRow],
    s: &vkengine::volume::render::label_settings::LabelSettings,
) -> Option<(String, String)> {
    let mut edit = None;
    for r in rows {
        ui.horizontal(|ui| {
            let c = r.colour.map(|x| (x.clamp(0.0, 1.0) * 255.0).round() as u8);
            let (rect, _) = ui.allocate_exact_size(egui::vec2(12.0, 12.0), egui::Sense::hover());
            ui.painter().rect_filled(rect, 2.0, egui::Color32::from_rgb(c[0], c[1], c[2]));
            let mut visible = !s.is_hidden(r.label);
            let text = if r.name.is_empty() { r.label.to_string() } else { format!("{} {}", r.label, r.name) };
            let resp = ui.checkbox(&mut visible, text);
            vkengine::ui::track(&resp, &format!("segment:{}", r.label));
            if resp.changed() {
                edit = Some(("label_hide".to_string(), s.hide_toggled(r.label)));
            }
        });
        let set = s.opacity[r.label as usize];
        let mut a = if set >= 0.0 { set } else { r.opacity };
        ui.horizontal(|ui| {
            // The slider alone is the tracked widget (scripts click its middle), its value beside.
            let resp = ui.add(egui::Slider::new(&mut a, 0.0..=1.0).show_value(false));
            vkengine::ui::track(&resp, &format!("segment-opacity:{}", r.label));
            ui.label(format!("opacity {a:.3}"));
            if resp.changed() {
                edit = Some(("label_opacity".to_string(), s.opacity_set(r.label, a)));
            }
        });
    }
    edit
}

/// Interactive Monte Carlo, unless the command line says otherwise: `mc_budget=auto` (one whole
/// path per frame where it fits the device and the device did not measure bounded work faster:
/// on llvmpipe it starts with bounded work) with at most 4 paths a pixel per bounded frame and
/// frames paced toward 50 ms GPU time ([`Pacing`]): a frame that misses it switches to bounded
/// work, whose budget is then steered, and only a budget already at its floor that still misses
/// interleaves tiles. On an H200 the old fixed default (bounded 512, interleave 16) took 8× one
/// whole path per frame's time to vpt's error; on llvmpipe pacing reaches that default's shape.
// The window shows the denoised image unless `--set denoise=off` (headless runs default to off).
const WINDOW_MC: [(&str, &str); 3] = [("mc_paths", "4"), ("mc_frame_ms", "50"), ("denoise", "on")];

/// The window's Monte Carlo pacing state, measured frame by frame (never by driver name).
#[derive(Clone, Copy, Debug, Default)]
struct Pacing {
    /// The budget `mc_frame_ms` steers toward its frame time (0: not steering yet).
    steered_budget: u32,
    /// A whole-path frame missed the frame time: render bounded work from now on.
    bounded: bool,
    /// Interleaving forced by a budget at its floor that still missed the frame time (0: none).
    interleave: u32,
}

impl Pacing {
    /// Applies pacing to `render` (already resolved for the device) after a frame of `last_ms`;
    /// `auto`: the user left mc_budget=auto, so the pacing may switch to bounded work.
    fn apply(&mut self, render: &mut RenderSettings, auto: bool, last_ms: f64) {
        let target = f64::from(render.mc.frame_ms);
        if target <= 0.0 || !matches!(render.renderer, RendererKind::Mcs | RendererKind::Mcm) {
            return;
        }
        let missed = last_ms.is_finite() && last_ms > 1.5 * target;
        if auto && render.mc.budget == 0 && !render.mc.debug_transmittance && (self.bounded || missed) {
            self.bounded = true;
            render.mc.budget = vkengine::volume::render::mc_mode::AUTO_BUDGET;
        }
        if !render.mc_bounded() {
            return;
        }
        let start = if self.steered_budget == 0 { render.mc.budget } else { self.steered_budget };
        self.steered_budget = render.mc.steer_budget(start, last_ms);
        render.mc.budget = self.steered_budget;
        if self.steered_budget == 8 && missed {
            self.interleave = (self.interleave.max(1) * 2).min(16);
        }
        render.mc.interleave = render.mc.interleave.max(self.interleave);
    }
}

/// Whether `key`'s last value in `set` is a number (a fixed budget), not `auto`.
fn value_is_number(set: &[(String, String)], key: &str) -> bool {
    set.iter().rev().find(|(k, _)| k == key).is_some_and(|(_, v)| v.trim().parse::<u32>().is_ok())
}

/// Window settings: jittered accumulation, no depth output (a headless feature), and
/// [`WINDOW_MC`] for the keys not given.
fn window_settings(args: &DemoArgs) -> Result<VolumeSetup> {
    let mut args = args.clone();
    let budget_given = args.set.iter().any(|(key, _)| key == "mc_budget" && value_is_number(&args.set, key));
    for (k, v) in WINDOW_MC {
        // A budget on the command line is meant to stay fixed.
        let steer_over_given_budget = k == "mc_frame_ms" && budget_given;
        if !steer_over_given_budget && !args.set.iter().any(|(key, _)| key == k) {
            args.set.insert(0, (k.to_string(), v.to_string()));
        }
    }
    let mut s = volume_setup(&args)?;
    s.render.jitter = true;
    s.render.occlusion.depth_threshold = None;
    Ok(s)
}

impl VolumeWindow {
    /// Loads the volume and builds the renderer for `args`.
    pub fn new(ctx: &Context, args: &DemoArgs) -> Result<Self> {
        let setup = window_settings(args)?;
        let (volume, tf) = load_scene(args, &setup, ctx)?;
        let labels = load_labels(args, &setup, &volume)?;
        let segments = segment_rows(labels.as_ref());
        let mut renderer = crate::volume_scene::renderer(ctx, &volume, &tf, &setup)?;
        renderer.set_labels(ctx, labels.as_ref().map(|(l, t)| (l, t)))?;
        renderer.set_environment(ctx, env_map(&setup)?.as_ref())?;
        crate::volume_scene::set_temperature(ctx, &mut renderer, &setup, args, &volume)?;
        let shell = Shell::new("volume", args)?;
        let tf_path = match &args.out {
            Some(p) => p.with_extension("tf.json"),
            None => PathBuf::from("screenshots/volume-tf.json"),
        };
        let camera = camera(&setup, &volume, renderer.box_half(), args.size[0] as f32 / args.size[1] as f32);
        let tf = TfEditor::new(tf, renderer.histogram.clone(), tf_path.display().to_string());
        let mut sets = args.set.clone();
        if let Some(r) = &args.renderer {
            controls::upsert(&mut sets, "renderer", r);
        }
        Ok(Self {
            args: args.clone(),
            camera,
            live: Live { s: setup, sets },
            renderer,
            tf,
            shell,
            targets: None,
            in_flight: None,
            pending: Vec::new(),
            tf_changed: false,
            tf_open: false,
            save_scene: false,
            pacing: Pacing::default(),
            segments,
        })
    }

    /// The parse input: the CLI arguments with the live setting list.
    fn parse_args(&self, sets: &[(String, String)]) -> DemoArgs {
        let mut a = self.args.clone();
        a.renderer = setting::<String>(sets, "renderer").ok().flatten();
        a.set = sets.iter().filter(|(k, _)| k != "renderer").cloned().collect();
        a
    }

    /// Applies UI edits through the CLI's parser; a rejected edit is reverted and reported.
    fn apply(&mut self, ctx: &Context) -> Result<()> {
        if self.pending.is_empty() {
            return Ok(());
        }
        let mut sets = self.live.sets.clone();
        let edits = std::mem::take(&mut self.pending);
        for (k, v) in &edits {
            if k == "env_map" && v == "off" {
                sets.retain(|(key, _)| key != "env_map");
            } else {
                controls::upsert(&mut sets, k, v);
            }
        }
        let args = self.parse_args(&sets);
        let parsed = window_settings(&args);
        let s = match parsed {
            Ok(s) => s,
            Err(e) => {
                self.shell.status = e.to_string();
                return Ok(());
            }
        };
        // The temperature grid is checked against the density as loaded: both reload.
        let reload = ["scene", "volume_layout", "residency", "upload_budget"];
        if edits.iter().any(|(k, _)| reload.contains(&k.as_str()) || k.starts_with("temperature_")) {
            let (volume, tf) = load_scene(&args, &s, ctx)?;
            let labels = load_labels(&args, &s, &volume)?;
            self.renderer = crate::volume_scene::renderer(ctx, &volume, &tf, &s)?;
            self.renderer.set_labels(ctx, labels.as_ref().map(|(l, t)| (l, t)))?;
            self.segments = segment_rows(labels.as_ref());
            self.renderer.set_environment(ctx, env_map(&s)?.as_ref())?;
            crate::volume_scene::set_temperature(ctx, &mut self.renderer, &s, &args, &volume)?;
            let path = self.tf.path.clone();
            self.tf = TfEditor::new(tf, self.renderer.histogram.clone(), path);
        } else if edits.iter().any(|(k, _)| k == "env_map") {
            self.renderer.set_environment(ctx, env_map(&s)?.as_ref())?;
        }
        // Accepted: an earlier refusal no longer applies (a new one is shown by the next frame).
        self.shell.status.clear();
        self.live = Live { s, sets };
        Ok(())
    }

    fn build_ui(&mut self, ectx: &egui::Context) {
        egui::Window::new("Volume").default_pos([8.0, 8.0]).default_width(260.0).show(ectx, |ui| {
            egui::ScrollArea::vertical().max_height(ectx.content_rect().height() * 0.8).show(ui, |ui| {
                self.save_scene |= self.shell.actions(ui);
                let r = ui.checkbox(&mut self.tf_open, "Transfer-function editor");
                vkengine::ui::track(&r, "tf:open");
                // A label map's segments first: with one loaded they are what is edited most.
                if !self.segments.is_empty() {
                    let r = egui::CollapsingHeader::new("Segments")
                        .show(ui, |ui| segments_ui(ui, &self.segments, &self.live.s.render.labels));
                    vkengine::ui::track(&r.header_response, "Segments");
                    self.pending.extend(r.body_returned.flatten());
                }
                self.pending.extend(controls::panel(ui, &SCHEMA, &self.live.s, &["Renderer", "Display"]));
                egui::CollapsingHeader::new("Camera").show(ui, |ui| camera_ui(ui, &mut self.camera));
            });
        });
        let right = ectx.content_rect().width() - 268.0;
        egui::Window::new("Transfer function")
            .open(&mut self.tf_open)
            .pivot(egui::Align2::RIGHT_BOTTOM)
            .default_pos(ectx.content_rect().right_bottom() - egui::vec2(8.0, 8.0))
            .default_width(320.0)
            .show(ectx, |ui| {
                self.tf_changed |= self.tf.show(ui) == TfEvent::Changed;
            });
        egui::Window::new("Profiler")
            .default_pos([right, 8.0])
            .default_width(260.0)
            .show(ectx, |ui| self.shell.profiler.show(ui));
    }

    /// Writes the session (settings, camera, transfer function) beside the screenshots.
    fn save(&mut self) -> Result<()> {
        let base = match &self.args.out {
            Some(p) => p.with_extension(""),
            None => PathBuf::from("screenshots/volume"),
        };
        let tf_path = PathBuf::from(format!("{}-scene-tf.json", base.display()));
        if let Some(dir) = tf_path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.display().to_string(), source })?;
        }
        self.tf.save(&tf_path)?;
        let mut settings: std::collections::BTreeMap<String, String> =
            self.live.sets.iter().filter(|(k, _)| k != "renderer").cloned().collect();
        if let Rig::Orbit { target, distance, yaw, pitch } = self.camera.rig {
            settings.insert("yaw".into(), yaw.to_string());
            settings.insert("pitch".into(), pitch.to_string());
            settings.insert("distance".into(), distance.to_string());
            settings.insert("target".into(), target.to_array().map(|c| c.to_string()).join(","));
        }
        if let Projection::Orthographic { height } = self.camera.projection {
            settings.insert("camera".into(), "ortho".into());
            settings.insert("height".into(), height.to_string());
        }
        settings.insert("tf".into(), tf_path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default());
        let session_path = PathBuf::from(format!("{}-scene.toml", base.display()));
        let abs = |p: &PathBuf| std::fs::canonicalize(p).unwrap_or_else(|_| p.clone());
        let session = VolumeSession {
            renderer: Some(self.live.s.render.renderer.name().into()),
            volume: self.args.volume.as_ref().map(abs),
            dims: self.args.dims,
            voxel_type: self.args.voxel_type.clone(),
            endian: self.args.endian.clone(),
            spacing: self.args.spacing,
            series: self.args.series.clone(),
            frame: self.args.frame,
            grid: self.args.grid.clone(),
            settings,
        };
        session.save(&session_path)?;
        self.shell.status = format!("saved {}", session_path.display());
        eprintln!("{}", self.shell.status);
        Ok(())
    }

    /// Reads back what the previous frame rendered for a screenshot or the error measurement.
    fn readbacks(&mut self, ctx: &Context) -> Result<()> {
        let Some(t) = self.targets.as_ref() else { return Ok(()) };
        let size = [t.hdr.info.extent[0], t.hdr.info.extent[1]];
        self.shell.write_due_shot(size, || t.read_ldr(ctx), || t.read_shown(ctx))?;
        self.shell.profiler.samples = t.samples;
        self.shell.measure(size, t.samples.into(), || t.read_hdr(ctx))?;
        Ok(())
    }
}

fn camera_ui(ui: &mut egui::Ui, camera: &mut Camera) {
    if let Rig::Orbit { distance, yaw, pitch, .. } = &mut camera.rig {
        ui.add(egui::Slider::new(yaw, -std::f32::consts::PI..=std::f32::consts::PI).text("yaw"));
        ui.add(egui::Slider::new(pitch, -1.5..=1.5).text("pitch"));
        ui.add(egui::Slider::new(distance, 0.2..=10.0).logarithmic(true).text("distance"));
    }
    let ortho = matches!(camera.projection, Projection::Orthographic { .. });
    let mut o = ortho;
    ui.checkbox(&mut o, "orthographic");
    if o != ortho {
        camera.projection =
            if o { Projection::Orthographic { height: 1.6 } } else { Projection::Perspective { fov_y: 0.8 } };
    }
}

impl WindowApp for VolumeWindow {
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
        self.readbacks(ctx)?;
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
        self.apply(ctx)?;
        if std::mem::take(&mut self.tf_changed) {
            self.renderer.set_transfer_function(ctx, &self.tf.tf)?;
        }
        if std::mem::take(&mut self.save_scene) {
            if let Err(e) = self.save() {
                self.shell.status = e.to_string();
            }
        }
        if self.targets.as_ref().is_none_or(|t| t.hdr.info.extent[..2] != extent) {
            self.targets = Some(Targets::new(ctx, extent)?);
        }
        // Bounded work with `mc_frame_ms`: the budget follows the last measured frame time (the
        // budget does not restart the mean; the panel keeps showing the user's starting value).
        let mut render = self.live.s.render;
        render.mc.seed = self.args.seed as u32;
        let mut auto = render.mc.budget == BUDGET_AUTO;
        // An explicit mc_budget=0 this device cannot bound at this size is refused: the status
        // line says why and the frame renders with auto instead of closing the window.
        render = match self.renderer.resolve_auto(ctx, &render, extent) {
            Ok(r) => r,
            Err(e) => {
                self.shell.status = e.to_string();
                auto = true;
                self.renderer.resolve_auto(
                    ctx,
                    &RenderSettings { mc: McSettings { budget: BUDGET_AUTO, ..render.mc }, ..render },
                    extent,
                )?
            }
        };
        self.pacing.apply(&mut render, auto, self.shell.profiler.last_frame_ms());
        // residency=view follows the camera: the bricks it needs arrive within the frame's budget.
        if let Some(r) = self.renderer.stream(ctx, &self.camera, extent[0] as f32 / extent[1].max(1) as f32)? {
            if r.upload.pending > 0 {
                self.shell.status = format!("residency: {} bricks to upload", r.upload.pending);
            }
        }
        let t = self.targets.as_mut().ok_or_else(|| Error::Input("no targets".into()))?;
        let overlay = self.shell.frame_overlay();
        let rec = record_frame(ctx, cmd, &self.renderer, t, &self.camera, &render, frame, overlay, target)?;
        self.in_flight = Some(rec);
        self.shell.frame_recorded();
        Ok(())
    }

    fn input(&mut self, window: &Window, event: &WindowEvent) {
        if self.shell.input(window, event) {
            return;
        }
        if let Some((dx, dy)) = self.shell.drag(event) {
            self.camera.rotate(-dx * 0.01, dy * 0.01);
        }
        if let WindowEvent::MouseWheel { delta, .. } = event {
            let d = match delta {
                MouseScrollDelta::LineDelta(_, y) => *y,
                MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
            };
            self.camera.zoom(0.9f32.powf(d));
        }
    }

    fn title(&self) -> Option<String> {
        // Monte Carlo: the image's own estimate of its relative error (foreground).
        let error = self.targets.as_ref().and_then(|t| t.error_estimate()).and_then(|e| e.relative);
        Some(format!(
            "vkengine volume — {} — {:.2} ms GPU — {} spp{}",
            self.live.s.render.renderer.name().to_uppercase(),
            self.shell.profiler.last_frame_ms(),
            self.shell.profiler.samples,
            error.map_or(String::new(), |e| format!(" — est. relative error {e:.3}"))
        ))
    }

    fn wants_exit(&self) -> bool {
        self.shell.wants_exit()
    }
}

/// Opens the volume window and runs it until closed; validation messages fail the run.
pub fn run(args: &DemoArgs) -> Result<()> {
    crate::runner::run_window("vkengine volume".into(), args, |ctx| VolumeWindow::new(ctx, args))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pacing_keeps_whole_paths_until_a_frame_misses_and_interleaves_only_at_the_budget_floor() {
        let mut render = window_settings(&<DemoArgs as clap::Parser>::parse_from(["volume"])).expect("defaults").render;
        render.renderer = RendererKind::Mcm;
        assert_eq!(render.mc.budget, BUDGET_AUTO, "the window leaves mc_budget to auto");
        render.mc.budget = 0; // what auto resolved to on a device where whole paths fit
        let mut p = Pacing::default();
        // Frames on time: one whole path per frame, no interleaving (a GPU keeps the fast path).
        for _ in 0..3 {
            let mut r = render;
            p.apply(&mut r, true, 30.0);
            assert_eq!((r.mc.budget, r.mc.interleave), (0, 1));
        }
        // One frame misses 1.5× the 50 ms target: bounded work from then on, steered down.
        let mut r = render;
        p.apply(&mut r, true, 400.0);
        assert!(
            r.mc_bounded() && r.mc.budget < vkengine::volume::render::mc_mode::AUTO_BUDGET,
            "budget {}",
            r.mc.budget
        );
        assert_eq!(r.mc.interleave, 1, "interleaving before the budget reached its floor");
        let mut last = r.mc.budget;
        for _ in 0..20 {
            let mut r = render;
            p.apply(&mut r, true, 400.0);
            assert!(r.mc_bounded() && r.mc.budget <= last);
            last = r.mc.budget;
        }
        // At the floor and still missing: interleave, doubling up to 16.
        let mut r = render;
        p.apply(&mut r, true, 400.0);
        assert_eq!(r.mc.budget, 8);
        assert_eq!(r.mc.interleave, 16);
        // An explicit mc_budget=0 (not auto) is never switched to bounded work.
        let (mut q, mut r) = (Pacing::default(), render);
        q.apply(&mut r, false, 400.0);
        assert_eq!(r.mc.budget, 0);
    }

    #[test]
    fn every_control_writes_a_key_the_parser_reads() {
        // Each control moved to a value different from its current one must read back as that
        // value after the CLI's parser: the panel and the parser agree on keys, names and units.
        let args = <DemoArgs as clap::Parser>::parse_from(["volume"]);
        let live = window_settings(&args).expect("defaults parse");
        for (c, kind) in controls::controls(&SCHEMA) {
            let moved = controls::moved(c.key, kind, &c.value(&live));
            let mut a = args.clone();
            match c.key {
                "renderer" => a.renderer = Some(controls::format_value(&moved)),
                "env_map" | "scene" => continue, // they load files / rebuild the volume
                k => a.set.push((k.into(), controls::format_value(&moved))),
            }
            let s = window_settings(&a).unwrap_or_else(|e| panic!("{}: {e}", c.key));
            assert_eq!(c.value(&s), moved, "{}", c.key);
        }
    }
}
